"""How a task reports progress and says things without printing: callbacks the front end gives.

- ``say(line)``: a line for the user while the work runs (the rig is open, a pose is written).
- ``progress(label, total)``: a context manager around a long stage; it yields ``advance()``,
  called once per unit of work (``total`` units, or an unknown number when None).

:func:`quiet` and :func:`silent` are the defaults: a Python caller sees nothing.

Examples
--------
>>> with quiet("decoding", 3) as advance:
...     for _ in range(3):
...         advance()
>>> silent("nothing is printed")
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["Progress", "Say", "quiet", "silent"]

#: A line for the user, said while the work runs.
Say = Callable[[str], Any]
#: A long stage: ``with progress(label, total) as advance: ...``.
Progress = Callable[[str, "int | None"], contextlib.AbstractContextManager[Callable[[], Any]]]


def silent(line: str) -> None:
    """Say nothing (the default :data:`Say`).

    Parameters
    ----------
    line : str
        The line not said.
    """


@contextlib.contextmanager
def quiet(label: str, total: int | None = None) -> Iterator[Callable[[], Any]]:
    """Show no progress (the default :data:`Progress`).

    Parameters
    ----------
    label : str
        What the stage does.
    total : int or None
        Units of work.

    Yields
    ------
    callable
        ``advance()``, which does nothing.
    """
    yield lambda: None
