"""Bounded readers for hostile input: a JSON file and image headers, checked before decoding.

:func:`load_json_bounded` refuses a file above :data:`~hdrfringe.core.limits.MAX_MANIFEST_BYTES`
before reading it, nesting beyond :data:`~hdrfringe.core.limits.MAX_JSON_DEPTH` before parsing it
(the standard parser would recurse until :class:`RecursionError`), and number literals longer than
:data:`~hdrfringe.core.limits.MAX_NUMBER_DIGITS` (which would raise ``ValueError`` from the integer
digit limit, or ``OverflowError`` when converted to float), naming the field that holds one.
:func:`probe_image` reads an image's shape and pixel type from its header only and refuses one
above :data:`~hdrfringe.core.limits.MAX_IMAGE_PIXELS`, so a small file declaring a huge image costs
nothing. Every failure is one :class:`~hdrfringe.errors.CaptureFormatError` line.
:func:`load_toml_bounded` reads the small TOML files users write (import descriptions, rig
configurations) within a size limit, refusing deep nesting and huge integers in one
:class:`~hdrfringe.errors.InputError` line.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core._validation import check_regular_file
from hdrfringe.core.limits import (
    MAX_IMAGE_PIXELS,
    MAX_JSON_DEPTH,
    MAX_MANIFEST_BYTES,
    MAX_NUMBER_DIGITS,
)
from hdrfringe.errors import CaptureFormatError, InputError

__all__ = [
    "ImageHeader",
    "available_memory",
    "check_memory",
    "load_json_bounded",
    "load_toml_bounded",
    "probe_image",
    "reason_of",
]

#: A JSON string literal (unrolled loop: linear time, no backtracking).
_JSON_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"')
_BRACKETS = re.compile(r"[\[\]{}]")


class _LongNumber:
    """A number literal longer than MAX_NUMBER_DIGITS, kept as text until its field is known."""

    def __init__(self, text: str) -> None:
        self.text = text


def _number_hook(text: str, convert: type) -> Any:
    if len(text) > MAX_NUMBER_DIGITS:
        return _LongNumber(text)
    return convert(text)


def reason_of(exc: BaseException) -> str:
    """The first line of an exception's message, or its type name when it has none.

    Parameters
    ----------
    exc : BaseException
        Any exception, e.g. from a decoder.

    Returns
    -------
    str
        One line, to quote inside a one-line error.

    Examples
    --------
    >>> reason_of(ValueError("bad\\nmore"))
    'bad'
    >>> reason_of(KeyError())
    'KeyError'
    """
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _check_depth(text: str, where: str) -> None:
    depth = 0
    for m in _BRACKETS.finditer(_JSON_STRING.sub("", text)):
        depth += 1 if m.group() in "[{" else -1
        if depth > MAX_JSON_DEPTH:
            raise CaptureFormatError(
                f"{where}: arrays and objects nested more than {MAX_JSON_DEPTH} deep, the limit; "
                "fix or regenerate the file"
            )


def _check_numbers(value: Any, where: str) -> None:
    stack: list[tuple[Any, str]] = [(value, "")]
    while stack:
        v, path = stack.pop()
        if isinstance(v, _LongNumber):
            field = path.lstrip(".") or "the top level"
            raise CaptureFormatError(
                f"{where}: field '{field}' holds a number of {len(v.text)} characters, more than "
                f"the limit of {MAX_NUMBER_DIGITS}; write it with fewer digits"
            )
        if isinstance(v, dict):  # reversed: the first in the file is reported
            stack.extend((item, f"{path}.{key}") for key, item in reversed(v.items()))
        elif isinstance(v, list):
            stack.extend((item, f"{path}[{i}]") for i, item in reversed(list(enumerate(v))))


def load_json_bounded(path: str | Path) -> Any:
    """Parse a JSON file within the manifest limits, refusing hostile content in one line.

    Parameters
    ----------
    path : str or Path
        The JSON file (a capture folder's ``manifest.json``).

    Returns
    -------
    Any
        The parsed value; numbers are int or float (``NaN``/``Infinity`` literals are kept
        as float: the fields that must be finite refuse them).

    Raises
    ------
    CaptureFormatError
        A file above :data:`~hdrfringe.core.limits.MAX_MANIFEST_BYTES`, not UTF-8, not JSON, nested
        beyond :data:`~hdrfringe.core.limits.MAX_JSON_DEPTH`, or with a number literal longer than
        :data:`~hdrfringe.core.limits.MAX_NUMBER_DIGITS` (the message names its field).

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "m.json"
    >>> _ = path.write_text('{"frames": [{"pitch": 8.5}]}')
    >>> load_json_bounded(path)
    {'frames': [{'pitch': 8.5}]}
    >>> _ = path.write_text('{"frames": [{"pitch": 1' + "0" * 400 + '}]}')
    >>> load_json_bounded(path)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: ...: field 'frames[0].pitch' holds a number of 401 ...
    """
    path = Path(path)
    where = str(path)
    try:
        size = path.stat().st_size
        if size > MAX_MANIFEST_BYTES:
            raise CaptureFormatError(
                f"{where}: {size} bytes, more than the limit of {MAX_MANIFEST_BYTES}; a manifest "
                "lists frames, it holds no image data"
            )
        with path.open("rb") as fh:  # read at most the limit, even if the file grew meanwhile
            raw = fh.read(MAX_MANIFEST_BYTES + 1)
    except OSError as exc:  # no permission, an I/O error: the file, not its contents
        import errno

        code = errno.errorcode.get(exc.errno or 0)
        raise CaptureFormatError(
            f"{where}: cannot read the file ({exc.strerror or reason_of(exc)}"
            f"{f', errno {code}' if code else ''}); check its permissions (chmod u+r) or copy "
            "the folder again"
        ) from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise CaptureFormatError(f"{where}: not UTF-8 text ({exc}); fix or regenerate it") from None
    _check_depth(text, where)
    try:
        value = json.loads(
            text,
            parse_int=lambda t: _number_hook(t, int),
            parse_float=lambda t: _number_hook(t, float),
        )
    except json.JSONDecodeError as exc:
        raise CaptureFormatError(f"{where}: not valid JSON ({exc}); fix or regenerate it") from None
    except (ValueError, RecursionError) as exc:  # not expected after the checks above
        raise CaptureFormatError(
            f"{where}: cannot parse ({reason_of(exc)}); fix or regenerate it"
        ) from None
    _check_numbers(value, where)
    return value


#: Deepest nesting of tables and arrays accepted in a user's TOML file (a rig configuration or
#: an import description nests three levels at most).
MAX_TOML_DEPTH = 32


def _nesting_depth(value: Any) -> int:
    """Deepest nesting of dicts and lists in ``value``, counted without recursion."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(value, 0)]
    while stack:
        item, depth = stack.pop()
        deepest = max(deepest, depth)
        if deepest > MAX_TOML_DEPTH:
            break
        if isinstance(item, dict):
            stack.extend((v, depth + 1) for v in item.values())
        elif isinstance(item, list):
            stack.extend((v, depth + 1) for v in item)
    return deepest


def load_toml_bounded(
    path: str | Path,
    *,
    what: str,
    max_bytes: int,
    holds: str,
    doc: str,
    missing: str,
    on_bytes: Callable[[bytes], object] | None = None,
) -> dict[str, Any]:
    """Parse a small TOML file a user wrote, refusing hostile content in one line.

    At most ``max_bytes + 1`` bytes are read (a larger file is refused, even one that grows
    while it is read); an integer of more digits than Python converts, and arrays or tables
    nested deeper than the parser's recursion (a "TOML bomb"), are refused with one line
    instead of a traceback.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.
    what : str
        What the file is, for messages (``"description"``, ``"rig configuration"``).
    max_bytes : int
        Largest file read.
    holds : str
        What such a file holds, for the size message (``"lists frame groups and holds no
        data"``).
    doc : str
        The document that describes the file (``"docs/import.md"``).
    missing : str
        How to fix a missing file (``"give the TOML description"``).
    on_bytes : callable, optional
        Called with the bytes read (all of them, once) before parsing, e.g. a hash's
        ``update``: a caller that records the file's digest hashes exactly what was parsed,
        not a second read that the file may have changed in between.

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    InputError
        A missing file (or not a regular file), one above ``max_bytes``, not UTF-8, not TOML,
        with a huge integer or nested too deep.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "rig.toml"
    >>> _ = p.write_text('name = "bench"\\n[sync]\\ndiscard = 2\\n')
    >>> kw = dict(what="rig configuration", max_bytes=20000, holds="holds settings only",
    ...           doc="docs/hardware.md", missing="give the file")
    >>> load_toml_bounded(p, **kw)
    {'name': 'bench', 'sync': {'discard': 2}}
    >>> _ = p.write_text("a = " + "[" * 5000 + "]" * 5000)
    >>> load_toml_bounded(p, **kw)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: ...: a number with too many digits or arrays nested too deep; ...
    """
    import tomllib  # here: reading a capture folder (json) does not pay for it

    path = Path(path)
    if not path.is_file():
        if path.exists():  # a folder, a FIFO (which would block the read), a device
            check_regular_file(path, what, missing)
        raise InputError(f"{path}: {what} file does not exist; {missing}")
    with path.open("rb") as fh:  # at most the limit, even if the file grew meanwhile
        raw = fh.read(max_bytes + 1)
    if len(raw) > max_bytes:
        raise InputError(f"{path}: {what} larger than {max_bytes} bytes; a {what} {holds}")
    if on_bytes is not None:
        on_bytes(raw)
    try:
        text = raw.decode("utf-8").replace("\r\n", "\n").replace("\r", "\n")  # as read_text
        parsed = tomllib.loads(text)
        # The parser's own RecursionError depends on the interpreter's recursion limit (which a
        # host program may raise): count the nesting explicitly, without recursing.
        if _nesting_depth(parsed) > MAX_TOML_DEPTH:
            raise RecursionError
        return parsed
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(f"{path}: not a valid TOML {what} ({exc}); see {doc}") from None
    except (ValueError, RecursionError):  # an integer of > 4300 digits, arrays nested too deep
        raise InputError(
            f"{path}: a number with too many digits or arrays nested too deep; a {what} "
            f"holds short numbers and flat lists ({doc})"
        ) from None


def available_memory() -> int | None:
    """Bytes this process can still allocate, as far as the system says; None when unknown.

    The least of: the memory the kernel reports available (``MemAvailable`` of
    ``/proc/meminfo``, else ``sysconf`` free pages), what the address-space limit leaves
    (``ulimit -v``, RLIMIT_AS, minus the process's current size) and what a cgroup v2 memory
    limit leaves (a container's ``memory.max`` minus ``memory.current``).

    Returns
    -------
    int or None

    Examples
    --------
    >>> free = available_memory()
    >>> free is None or free > 0
    True
    """
    import os
    import resource

    found: list[int] = []
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError):
        try:
            found.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (OSError, ValueError, AttributeError):
            pass
    soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    if soft != resource.RLIM_INFINITY:
        try:
            with open("/proc/self/statm", encoding="ascii") as fh:
                used = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        except (OSError, ValueError, IndexError):
            used = 0
        found.append(max(0, soft - used))
    try:
        cgroup = Path("/sys/fs/cgroup")
        limit = (cgroup / "memory.max").read_text().strip()
        if limit != "max":
            found.append(max(0, int(limit) - int((cgroup / "memory.current").read_text())))
    except (OSError, ValueError):
        pass
    return min(found) if found else None


def check_memory(needed: int, where: str, what: str, fix: str) -> None:
    """Refuse work that needs more memory than :func:`available_memory` reports.

    Parameters
    ----------
    needed : int
        Bytes the work needs at least.
    where : str
        What is read (a folder), for the message.
    what : str
        What needs the memory (``"4 images of 11585x11585"``).
    fix : str
        How to need less.

    Raises
    ------
    CaptureFormatError
        ``needed`` is above the available memory (nothing is refused when it is unknown).

    Examples
    --------
    >>> check_memory(1, "caps", "1 byte", "nothing")
    """
    free = available_memory()
    if free is not None and needed > free:

        def size(n: int) -> str:
            return f"{n / (1 << 30):.1f} GiB" if n >= 1 << 30 else f"{n / (1 << 20):.0f} MiB"

        raise CaptureFormatError(
            f"{where}: {what} need at least {size(needed)} of memory to decode, {size(free)} "
            f"is available; {fix}"
        )


class ImageHeader:
    """Shape and pixel type of an image, read from its header without decoding pixels.

    Parameters
    ----------
    shape : tuple of int
        What decoding would return: (H, W), (H, W, channels), or (pages, H, W) for a
        multi-page TIFF.
    dtype : numpy.dtype
        The decoded pixel type.

    Examples
    --------
    >>> ImageHeader((4, 5), np.dtype(np.uint8)).pixels
    20
    """

    def __init__(self, shape: tuple[int, ...], dtype: np.dtype) -> None:
        self.shape = tuple(int(n) for n in shape)
        self.dtype = np.dtype(dtype)

    @property
    def pixels(self) -> int:
        """Height x width (x pages); colour channels (a last axis of 3 or 4) not counted."""
        shape = self.shape
        if len(shape) == 3 and shape[-1] in (3, 4):
            shape = shape[:-1]
        return math.prod(shape)


_PIL_DTYPES = {
    "1": np.bool_,
    "L": np.uint8,
    "P": np.uint8,
    "LA": np.uint8,
    "RGB": np.uint8,
    "RGBA": np.uint8,
    "I;16": np.uint16,
    "I;16B": np.uint16,
    "I;16L": np.uint16,
    "I": np.int32,
    "F": np.float32,
}


def probe_image(path: str | Path, what: str = "the image") -> ImageHeader:
    """Read a PNG or TIFF's shape and pixel type from its header and check the pixel limit.

    TIFF (``.tif``, ``.tiff``) headers are read with tifffile (the first series, as
    ``tifffile.imread`` decodes it), others with Pillow; Pillow's decompression-bomb warning is
    silenced here, as :data:`~hdrfringe.core.limits.MAX_IMAGE_PIXELS` is the bound that applies.

    Parameters
    ----------
    path : str or Path
        The image file.
    what : str
        What the file is, for messages (``"the image"``, ``"map 'truth_height_mm'"``).

    Returns
    -------
    ImageHeader
        Shape and dtype decoding would give.

    Raises
    ------
    CaptureFormatError
        An unreadable header (truncated, corrupt, not that format), or more pixels than
        :data:`~hdrfringe.core.limits.MAX_IMAGE_PIXELS`.

    Examples
    --------
    >>> import tempfile, tifffile
    >>> path = Path(tempfile.mkdtemp()) / "m.tiff"
    >>> tifffile.imwrite(path, np.zeros((3, 4), np.float32))
    >>> h = probe_image(path, "the map")
    >>> h.shape, h.dtype
    ((3, 4), dtype('float32'))
    """
    path = Path(path)
    try:
        if path.suffix.lower() in (".tif", ".tiff"):
            import tifffile

            with tifffile.TiffFile(path) as tif:
                series = tif.series[0]
                header = ImageHeader(series.shape, series.dtype)
        else:
            from PIL import Image

            with warnings.catch_warnings():
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                with Image.open(path) as im:
                    width, height = im.size
                    bands = len(im.getbands())
                    dtype = _PIL_DTYPES.get(im.mode, np.uint8)
            shape = (height, width) if bands == 1 else (height, width, bands)
            header = ImageHeader(shape, np.dtype(dtype))
    except Exception as exc:  # any header parser failure: truncated, corrupt, not an image
        if type(exc).__name__ == "DecompressionBombError":  # Pillow: above 2 x 89 Mpx
            raise CaptureFormatError(
                f"{path}: {what} declares more than {MAX_IMAGE_PIXELS} pixels, the limit "
                f"({reason_of(exc)}); store images of at most that size"
            ) from None
        raise CaptureFormatError(
            f"{path}: cannot read {what} ({reason_of(exc)}); the file is corrupt, truncated "
            "or not a PNG/TIFF: regenerate it"
        ) from None
    if header.pixels > MAX_IMAGE_PIXELS:
        raise CaptureFormatError(
            f"{path}: {what} declares {'x'.join(map(str, header.shape))} = {header.pixels} "
            f"pixels, more than the limit of {MAX_IMAGE_PIXELS}; store images of at most that "
            "size"
        )
    return header
