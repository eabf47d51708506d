"""Resource limits checked before any work is allocated (issue 11, item 4).

A request beyond one of these bounds is refused up front with a one-line
:class:`~hdrfringe.errors.InputError`, instead of running for hours, exhausting memory, or writing
a folder that a later step refuses:

* :data:`MAX_STEPS`: phase shifts N of one fringe set (the capture-folder contract's bound, so
  every folder hdrfringe writes can be read back).
* :data:`MAX_PROGRAM_FRAMES`: frames of one projector program (a pattern folder, or one capture
  folder of the virtual rig), and values of one ``start:stop:step`` list.
* :data:`MAX_SERIES_FOLDERS`: capture folders of one simulated series (depths).
* :data:`MAX_PROJECTOR_PIXELS`: projector width x height (twice an 8K projector).

Reading a capture folder is bounded the same way, before any pixel is decoded or any array
allocated (a bound exceeded there is a :class:`~hdrfringe.errors.CaptureFormatError`):

* :data:`MAX_MANIFEST_BYTES`: size of ``manifest.json``, checked before it is read.
* :data:`MAX_JSON_DEPTH`: nesting of arrays and objects in the manifest, checked before parsing.
* :data:`MAX_NUMBER_DIGITS`: characters of one number literal in the manifest.
* :data:`MAX_PROGRAM_FRAMES`: frames listed in one manifest.
* :data:`MAX_IMAGE_PIXELS`: height x width of one image or map, read from its header.
* :data:`MAX_FOLDER_PIXELS`: pixels of all images of one folder, summed from their headers.

docs/capture_format.md ("Limits") lists them with what happens when one is exceeded.

Examples
--------
>>> check_count(12, MAX_PROGRAM_FRAMES, "frames in the program")
12
>>> check_count(10**9, MAX_PROGRAM_FRAMES, "frames in the program", fix="use fewer pitches")
Traceback (most recent call last):
...
hdrfringe.errors.InputError: 1000000000 frames in the program: more than the limit of 10000; \
use fewer pitches
"""

from __future__ import annotations

import math

from hdrfringe.errors import InputError

__all__ = [
    "MAX_FOLDER_PIXELS",
    "MAX_IMAGE_PIXELS",
    "MAX_JSON_DEPTH",
    "MAX_MANIFEST_BYTES",
    "MAX_NUMBER_DIGITS",
    "MAX_PROGRAM_FRAMES",
    "MAX_PROJECTOR_PIXELS",
    "MAX_SERIES_FOLDERS",
    "MAX_STEPS",
    "check_count",
]

#: Phase shifts N of one set (the capture-folder contract reads at most this many).
MAX_STEPS = 1000
#: Frames of one projector program, and values of one parsed ``start:stop:step`` range.
MAX_PROGRAM_FRAMES = 10_000
#: Capture folders of one simulated series.
MAX_SERIES_FOLDERS = 1000
#: Projector pixels (width x height): 2^26, twice an 8K projector.
MAX_PROJECTOR_PIXELS = 1 << 26
#: Pixels (height x width) of one capture image or map: 2^27, 134 Mpx. Below Pillow's
#: decompression-bomb refusal (2 x 89 Mpx), so this bound is the one a PNG meets first.
MAX_IMAGE_PIXELS = 1 << 27
#: Pixels of all images of one capture folder together: 2^31 (4 GiB as 16-bit counts).
MAX_FOLDER_PIXELS = 1 << 31
#: Bytes of one ``manifest.json``: 16 MiB (a 10 000-frame manifest takes about 2 MiB).
MAX_MANIFEST_BYTES = 16 << 20
#: Nesting depth of arrays and objects in a manifest (the contract's own reaches 4).
MAX_JSON_DEPTH = 64
#: Characters of one number literal in a manifest (a float64 needs at most 24).
MAX_NUMBER_DIGITS = 40


def check_count(count: float, limit: int, what: str, *, fix: str = "") -> int:
    """Refuse a count above its limit (or not finite) before anything of that size is made.

    Parameters
    ----------
    count : float
        The number requested (an int, or a float computed from a range, possibly huge or inf).
    limit : int
        The largest count allowed.
    what : str
        What is counted, e.g. ``"frames in the program"``; starts the message.
    fix : str, optional
        How to stay within the limit, appended to the message.

    Returns
    -------
    int
        ``count`` as an int, when within the limit.

    Raises
    ------
    InputError
        ``count`` is not finite or above ``limit``.

    Examples
    --------
    >>> check_count(4.0, MAX_STEPS, "steps")
    4
    """
    if not math.isfinite(count) or count > limit:
        exact = not isinstance(count, float) or (math.isfinite(count) and count < 1e15)
        shown = str(int(count)) if exact else f"{count:.3g}"
        raise InputError(
            f"{shown} {what}: more than the limit of {limit}" + (f"; {fix}" if fix else "")
        )
    return int(count)
