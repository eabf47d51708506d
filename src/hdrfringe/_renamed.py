"""Old spellings of renamed keywords and fields (issue 29), kept working with a warning.

A user-facing name that changed keeps its old spelling as a deprecated alias: a keyword of a
function (:func:`renamed_keyword`) or a field of a dataclass, in its constructor and as an
attribute (:func:`renamed_fields`). Each use emits a :class:`DeprecationWarning` that names the
new spelling; giving both spellings with different values is an error.

Examples
--------
>>> import warnings
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     renamed_keyword("measure", "strategy", None, "method", "lpa")
'lpa'
>>> str(caught[0].message)
'measure: method= is deprecated; use strategy='
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from typing import Any, TypeVar

from hdrfringe.errors import InputError

__all__ = ["renamed_fields", "renamed_keyword"]

T = TypeVar("T", bound=type)


def renamed_keyword(
    where: str, new: str, value: Any, old: str, old_value: Any, *, stacklevel: int = 3
) -> Any:
    """The value of keyword ``new``, or of its deprecated spelling ``old`` (with a warning).

    Parameters
    ----------
    where : str
        The function, as the warning names it (``"measure"``).
    new, old : str
        The keyword's name and its deprecated spelling.
    value, old_value : object
        What each was given; None: not given.
    stacklevel : int
        Passed to :func:`warnings.warn` (3: the caller of the function taking the keyword).

    Returns
    -------
    object
        ``value``, or ``old_value`` when only the old spelling was given.

    Raises
    ------
    InputError
        Both spellings given, with different values.

    Examples
    --------
    >>> renamed_keyword("measure", "strategy", "dpa", "method", None)
    'dpa'
    """
    if old_value is None:
        return value
    warnings.warn(f"{where}: {old}= is deprecated; use {new}=", DeprecationWarning, stacklevel)
    if value is not None and value != old_value:
        raise InputError(
            f"{where}: {new}={value!r} and the deprecated {old}={old_value!r} disagree; give "
            f"{new}= only"
        )
    return old_value


def renamed_fields(**renames: str) -> Callable[[T], T]:
    """Class decorator: a dataclass's renamed fields keep their old names, deprecated.

    The constructor takes ``old=`` for the field ``new`` and the attribute ``old`` reads
    ``new``, both with a :class:`DeprecationWarning` naming the new spelling.

    Parameters
    ----------
    **renames : str
        Old name -> new field name.

    Returns
    -------
    callable
        The decorator; it returns the class itself, changed.

    Examples
    --------
    >>> import warnings
    >>> from dataclasses import dataclass
    >>> @renamed_fields(method="strategy")
    ... @dataclass
    ... class Row:
    ...     strategy: str
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     row = Row(method="lpa")
    ...     old = row.method
    >>> row, old
    (Row(strategy='lpa'), 'lpa')
    """

    def decorate(cls: T) -> T:
        init = cls.__init__  # type: ignore[misc]

        @functools.wraps(init)
        def __init__(self: Any, *args: Any, **kwargs: Any) -> None:
            for old, new in renames.items():
                if old in kwargs:
                    value = renamed_keyword(
                        cls.__name__, new, kwargs.pop(new, None), old, kwargs.pop(old)
                    )
                    kwargs[new] = value
            init(self, *args, **kwargs)

        cls.__init__ = __init__  # type: ignore[misc]
        for old, new in renames.items():
            setattr(cls, old, _deprecated_attribute(cls.__name__, old, new))
        return cls

    return decorate


def _deprecated_attribute(owner: str, old: str, new: str) -> property:
    """A read-only attribute ``old`` that returns ``new``, with a warning."""

    def read(self: Any) -> Any:
        warnings.warn(
            f"{owner}.{old} is deprecated; read .{new}", DeprecationWarning, stacklevel=2
        )
        return getattr(self, new)

    return property(read, doc=f"Deprecated alias of ``{new}``.")
