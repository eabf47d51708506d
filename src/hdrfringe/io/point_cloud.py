"""Point clouds as PLY files (written with plyfile).

The points come from :func:`hdrfringe.core.reconstruct.points_from_height` (thesis Eq. 2.11's
height with the camera's pinhole geometry); this module only writes them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["write_ply"]


def write_ply(
    path: str | Path,
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    *,
    intensity: ArrayLike | None = None,
) -> int:
    """Write the finite points as a binary little-endian PLY (vertex x, y, z [, intensity]).

    Parameters
    ----------
    path : str or Path
        PLY file to write.
    x, y, z : array_like
        Coordinates of the points (any shape, flattened), e.g. the maps of
        :func:`~hdrfringe.core.reconstruct.points_from_height` in mm. A point with a non-finite
        coordinate is left out.
    intensity : array_like, optional
        A value per point (same size), stored as the vertex property ``intensity``.

    Returns
    -------
    int
        Number of points written.

    References
    ----------
    Thesis Sec. 2.4 (height, Eq. 2.11), the source of ``z``.

    Examples
    --------
    >>> import tempfile
    >>> from plyfile import PlyData
    >>> path = Path(tempfile.mkdtemp()) / "points.ply"
    >>> write_ply(path, [0.0, 1.0, 2.0], [0.0, 0.0, 1.0], [5.0, np.nan, 6.0])
    2
    >>> PlyData.read(str(path))["vertex"]["z"].tolist()
    [5.0, 6.0]
    """
    from plyfile import PlyData, PlyElement

    xa, ya, za = (np.asarray(a, dtype=np.float64).ravel() for a in (x, y, z))
    ok = np.isfinite(xa) & np.isfinite(ya) & np.isfinite(za)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if intensity is not None:
        fields.append(("intensity", "<f4"))
    vert = np.empty(int(ok.sum()), dtype=fields)
    vert["x"], vert["y"], vert["z"] = xa[ok], ya[ok], za[ok]
    if intensity is not None:
        vert["intensity"] = np.asarray(intensity, dtype=np.float64).ravel()[ok]
    PlyData([PlyElement.describe(vert, "vertex")], byte_order="<").write(str(path))
    return int(ok.sum())
