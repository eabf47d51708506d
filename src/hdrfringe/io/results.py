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


def check_output_dir(path: str | Path, force: bool) -> Path:
    """Refuse an existing non-empty output folder unless ``force``; refuse a file in the way."""
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

    On any exception the staging folder is removed and ``path`` is left untouched.
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
    """Write a map as float32 TIFF (NaN = invalid), or an integer map in its own dtype."""
    import tifffile

    arr = np.asarray(data)
    if arr.dtype.kind == "f" or arr.dtype == bool:
        arr = arr.astype(np.float32)
    tifffile.imwrite(path, arr, compression="zlib")


def read_map_tiff(path: str | Path) -> np.ndarray:
    """Read a map written by :func:`write_map_tiff`."""
    import tifffile

    return tifffile.imread(path)


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
    """A PNG preview of a map with a colour bar; NaN (invalid) shown in gray."""
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
