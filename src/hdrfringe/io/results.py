"""Result folders and map files: staged writing, float32 TIFF maps, PNG previews.

Outputs are written into a hidden staging folder beside the target and moved into place only
when complete, so a failure never leaves a half-written result, and an existing result is
replaced only with ``force``.
"""

from __future__ import annotations

import contextlib
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from hdrfringe.errors import OutputExistsError

__all__ = [
    "check_output_dir",
    "read_map_tiff",
    "staged_output_dir",
    "write_map_tiff",
    "write_preview_png",
]


def check_output_dir(path: str | Path, force: bool) -> Path:
    """Refuse an existing non-empty output folder unless ``force``; refuse a file in the way.

    Nothing is created or removed: this is the check a command makes before any work, so that
    a run that would be refused at the end is refused at once.

    Parameters
    ----------
    path : str or Path
        The output folder a command is about to write.
    force : bool
        Accept an existing non-empty folder (it will be replaced).

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    OutputExistsError
        If ``path`` is a file, or a non-empty folder and ``force`` is false.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> check_output_dir(root / "new", force=False).name
    'new'
    >>> (root / "new").mkdir()
    >>> (root / "new" / "old.txt").write_text("x")
    1
    >>> check_output_dir(root / "new", force=False)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    hdrfringe.errors.OutputExistsError: ...new: output folder exists and is not empty; ...
    >>> check_output_dir(root / "new", force=True).name
    'new'
    """
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise OutputExistsError(f"{out}: exists and is not a folder; choose another output path")
    if out.is_dir() and any(out.iterdir()) and not force:
        raise OutputExistsError(
            f"{out}: output folder exists and is not empty; pass --force to replace it "
            "or choose another path"
        )
    return out


@contextlib.contextmanager
def staged_output_dir(path: str | Path, force: bool = False) -> Iterator[Path]:
    """Write a folder atomically: yield a staging folder, then move it to ``path``.

    The staging folder is a hidden sibling of ``path`` (same file system, so the final move is
    a rename). On any exception the staging folder is removed and ``path`` is left untouched;
    on success an existing ``path`` (allowed by ``force``) is replaced by the new folder.

    Parameters
    ----------
    path : str or Path
        The output folder to create (its parents are created too).
    force : bool
        Replace an existing non-empty folder; without it one is refused
        (:func:`check_output_dir`) before anything is written.

    Yields
    ------
    Path
        The empty staging folder to write into.

    Raises
    ------
    OutputExistsError
        As :func:`check_output_dir`.

    Examples
    --------
    >>> import tempfile
    >>> root = Path(tempfile.mkdtemp())
    >>> with staged_output_dir(root / "result") as tmp:
    ...     _ = (tmp / "a.txt").write_text("done")
    ...     (root / "result").exists()
    False
    >>> (root / "result" / "a.txt").read_text()
    'done'
    >>> with staged_output_dir(root / "failed") as tmp:
    ...     raise RuntimeError("stopped half-way")
    Traceback (most recent call last):
    ...
    RuntimeError: stopped half-way
    >>> sorted(p.name for p in root.iterdir())
    ['result']
    """
    out = check_output_dir(path, force)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.staging-", dir=out.parent))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if out.exists():
        backup = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        backup.rmdir()
        out.rename(backup)
        tmp.rename(out)
        shutil.rmtree(backup, ignore_errors=True)
    else:
        tmp.rename(out)


def write_map_tiff(path: str | Path, data: ArrayLike) -> None:
    """Write a map as float32 TIFF (NaN = invalid), or an integer map in its own dtype.

    Float and bool maps are stored as float32 (bool as 0/1); integer maps keep their dtype.
    The file is zlib-compressed.

    Parameters
    ----------
    path : str or Path
        TIFF file to write.
    data : array_like
        The map, usually (H, W).

    See Also
    --------
    read_map_tiff : Read it back.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "height.tiff"
    >>> write_map_tiff(path, np.array([[1.5, np.nan], [0.25, 2.0]]))
    >>> m = read_map_tiff(path)
    >>> m.dtype, m.tolist()
    (dtype('float32'), [[1.5, nan], [0.25, 2.0]])
    """
    import tifffile

    arr = np.asarray(data)
    if arr.dtype.kind == "f" or arr.dtype == bool:
        arr = arr.astype(np.float32)
    tifffile.imwrite(path, arr, compression="zlib")


def read_map_tiff(path: str | Path) -> np.ndarray:
    """Read a map written by :func:`write_map_tiff`, its size checked from the header first.

    Parameters
    ----------
    path : str or Path
        TIFF file.

    Returns
    -------
    ndarray
        The map in its stored dtype (float32 for float and bool maps).

    Raises
    ------
    CaptureFormatError
        A truncated, corrupt or non-TIFF file, or a header declaring more than
        :data:`hdrfringe.limits.MAX_IMAGE_PIXELS` pixels (refused before decoding), in one line
        naming the file.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "count.tiff"
    >>> write_map_tiff(path, np.array([[0, 3], [1, 2]], dtype=np.uint8))
    >>> m = read_map_tiff(path)
    >>> m.dtype, m.tolist()
    (dtype('uint8'), [[0, 3], [1, 2]])
    """
    import tifffile

    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.io._read_limits import probe_image, reason_of

    probe_image(path, "the map")
    try:
        return tifffile.imread(path)
    except Exception as exc:  # any decoder failure: truncated, corrupt data
        raise CaptureFormatError(
            f"{path}: cannot read the map ({reason_of(exc)}); the file is corrupt or "
            "truncated: regenerate it"
        ) from None


def write_preview_png(
    path: str | Path,
    data: ArrayLike,
    *,
    title: str = "",
    cmap: str = "viridis",
    label: str = "",
    vmin: float | None = None,
    vmax: float | None = None,
) -> None:
    """A PNG preview of a map with a colour bar; NaN (invalid) shown in gray.

    Drawn with matplotlib's Agg backend (no display needed). Without ``vmin``/``vmax`` the
    colour range spans the 0.5 and 99.5 percentiles of the finite values, so a few outliers do
    not flatten the picture.

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    data : array_like
        The map, (H, W); non-finite values are invalid.
    title : str
        Title above the map.
    cmap : str
        Name of a matplotlib colour map.
    label : str
        Label of the colour bar (e.g. the unit).
    vmin, vmax : float, optional
        Colour range; default the percentiles above.

    Examples
    --------
    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "height.png"
    >>> write_preview_png(path, [[0.0, 1.0], [np.nan, 2.0]], title="height", label="mm")
    >>> path.read_bytes()[1:4]
    b'PNG'
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    arr = np.asarray(data, dtype=np.float64)
    finite = np.isfinite(arr)
    if vmin is None and finite.any():
        vmin = float(np.percentile(arr[finite], 0.5))
    if vmax is None and finite.any():
        vmax = float(np.percentile(arr[finite], 99.5))
    h, w = arr.shape
    fig, ax = plt.subplots(figsize=(6.4, 6.4 * h / w + 0.6), dpi=100)
    cm = matplotlib.colormaps[cmap].with_extremes(bad="0.5")
    im = ax.imshow(
        np.ma.masked_invalid(arr), cmap=cm, vmin=vmin, vmax=vmax, interpolation="nearest"
    )
    ax.set_title(title)
    ax.set_axis_off()
    fig.colorbar(im, ax=ax, label=label, fraction=0.046, pad=0.04)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
