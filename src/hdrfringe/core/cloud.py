"""Organised point clouds (one point per camera pixel): outlier removal and the grid mesh.

A structured-light cloud keeps the camera's pixel grid, so its surface mesh needs no
reconstruction: neighbouring valid pixels are neighbours on the surface, except across a depth
step, where a triangle would span empty space. :func:`grid_mesh` triangulates the grid and
drops such triangles; :func:`statistical_outliers` is the statistical outlier rule of PCL's
``StatisticalOutlierRemoval`` and Open3D's ``remove_statistical_outlier`` (scipy's k-d tree).
Points are ordered as :func:`hdrfringe.io.point_cloud.write_ply` writes them: the valid pixels
in row-major order.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError

__all__ = [
    "MESH_EDGE_FACTOR",
    "OUTLIER_NEIGHBOURS",
    "OUTLIER_STD_RATIO",
    "grid_mesh",
    "statistical_outliers",
]

#: Neighbours whose mean distance rates a point (:func:`statistical_outliers`; Open3D's usual
#: ``nb_neighbors=20``).
OUTLIER_NEIGHBOURS = 20
#: A point is an outlier when its mean neighbour distance exceeds the mean over all points by
#: this many standard deviations (Open3D's usual ``std_ratio=2.0``).
OUTLIER_STD_RATIO = 2.0
#: Default longest edge of a mesh triangle, in multiples of the median distance between
#: row and column neighbours (:func:`grid_mesh`): a step of more than about 4 pixel pitches is
#: left open, a surface tilted by up to ``arccos(1/4)`` (75.5 deg) from the image plane is meshed.
MESH_EDGE_FACTOR = 4.0


def statistical_outliers(
    points: ArrayLike, k: int = OUTLIER_NEIGHBOURS, std_ratio: float = OUTLIER_STD_RATIO
) -> NDArray[np.bool_]:
    """Statistical outliers of a point set: the mean-k-nearest-neighbour-distance rule.

    For every point the mean distance ``d_i`` to its ``k`` nearest neighbours is computed
    (:class:`scipy.spatial.cKDTree`); a point is an outlier when
    ``d_i > mean(d) + std_ratio * std(d)``. Isolated points (spikes of a wrong fringe order,
    stray points at an edge) have far-away neighbours; points on the surface do not.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Finite points, mm.
    k : int
        Neighbours per point (>= 1); fewer when the set has fewer than ``k + 1`` points.
    std_ratio : float
        Threshold in standard deviations of ``d`` (> 0); smaller removes more.

    Returns
    -------
    ndarray of bool, shape (N,)
        True for an outlier; none for fewer than 2 points.

    Raises
    ------
    InputError
        Points that are not (N, 3) or not finite, ``k < 1``, ``std_ratio <= 0``.

    References
    ----------
    R. B. Rusu et al., "Towards 3D point cloud based object maps for household environments",
    Robotics and Autonomous Systems 56 (2008), Sec. 4 (the rule PCL and Open3D implement).

    Examples
    --------
    >>> rows, cols = np.mgrid[0:10, 0:10].astype(float)
    >>> pts = np.c_[cols.ravel(), rows.ravel(), np.zeros(100)]
    >>> pts[37, 2] = 25.0  # a spike
    >>> np.flatnonzero(statistical_outliers(pts, k=8)).tolist()
    [37]
    """
    pts = np.asarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3 or not np.isfinite(pts).all():
        raise InputError(f"outlier removal needs finite points of shape (N, 3), got {pts.shape}")
    if isinstance(k, bool) or int(k) != k or k < 1:
        raise InputError(f"outlier removal: k must be an integer >= 1, got {k}")
    if not (np.isfinite(std_ratio) and std_ratio > 0):
        raise InputError(f"outlier removal: std_ratio must be > 0, got {std_ratio}")
    n = pts.shape[0]
    if n < 2:
        return np.zeros(n, dtype=bool)
    from scipy.spatial import cKDTree

    kk = min(int(k), n - 1)
    dist, _ = cKDTree(pts).query(pts, k=kk + 1)  # the first neighbour is the point itself
    mean = dist[:, 1:].mean(axis=1)
    return np.asarray(mean > mean.mean() + std_ratio * mean.std())


def grid_mesh(
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    *,
    max_edge: float | None = None,
    edge_factor: float = MESH_EDGE_FACTOR,
) -> NDArray[np.int64]:
    """Triangles of an organised point grid: two per 2x2 block of valid pixels, none across
    a depth step.

    The block with corners ``a = (r, c)``, ``b = (r, c+1)``, ``c = (r+1, c)``,
    ``d = (r+1, c+1)``, all four valid, gives the triangles ``(a, c, b)`` and ``(b, c, d)``
    (split along ``b-c``), each ordered so that its normal is ``dP/dr x dP/dc``, as
    :func:`hdrfringe.io.point_cloud.grid_normals`' (toward the camera). A triangle with an edge
    longer than ``max_edge`` (3-D distance) is dropped, so no skin spans a step edge.

    Parameters
    ----------
    x, y, z : array_like, shape (H, W)
        The points' coordinates on the pixel grid; a pixel with a non-finite coordinate is
        invalid.
    max_edge : float, optional
        Longest edge kept, in the points' unit (mm). Default: ``edge_factor`` times the median
        distance between valid row and column neighbours.
    edge_factor : float
        See ``max_edge``.

    Returns
    -------
    ndarray of int64, shape (M, 3)
        Vertex indices of the triangles into the valid points in row-major order (the order
        of :func:`hdrfringe.io.point_cloud.write_ply`); M may be 0.

    Raises
    ------
    InputError
        Maps that are not (H, W) of one shape, or a threshold that is not > 0.

    Examples
    --------
    A 2x3 grid: two blocks, four triangles; a step of 10 between the columns 1 and 2 leaves
    the right block out.

    >>> x, y = np.meshgrid([0.0, 1.0, 2.0], [0.0, -1.0])
    >>> grid_mesh(x, y, np.zeros((2, 3))).tolist()
    [[0, 3, 1], [1, 3, 4], [1, 4, 2], [2, 4, 5]]
    >>> grid_mesh(x, y, np.array([[0.0, 0.0, 10.0], [0.0, 0.0, 10.0]])).tolist()
    [[0, 3, 1], [1, 3, 4]]
    """
    p = np.stack([np.asarray(a, dtype=np.float64) for a in (x, y, z)], axis=-1)
    if p.ndim != 3:
        raise InputError(f"a grid mesh needs (H, W) maps of one shape, got {p.shape[:-1]}")
    valid: NDArray[np.bool_] = np.asarray(np.isfinite(p).all(axis=-1))
    index = np.cumsum(valid).reshape(valid.shape) - 1  # vertex index of a valid pixel
    a, b = (slice(None, -1), slice(None, -1)), (slice(None, -1), slice(1, None))
    c, d = (slice(1, None), slice(None, -1)), (slice(1, None), slice(1, None))
    block = valid[a] & valid[b] & valid[c] & valid[d]
    if max_edge is None:
        if not (np.isfinite(edge_factor) and edge_factor > 0):
            raise InputError(f"grid mesh: edge_factor must be > 0, got {edge_factor}")
        steps = [
            np.linalg.norm(p[:, 1:] - p[:, :-1], axis=-1)[valid[:, 1:] & valid[:, :-1]],
            np.linalg.norm(p[1:] - p[:-1], axis=-1)[valid[1:] & valid[:-1]],
        ]
        step = np.concatenate(steps)
        max_edge = edge_factor * float(np.median(step)) if step.size else np.inf
    elif not max_edge > 0:
        raise InputError(f"grid mesh: max_edge must be > 0, got {max_edge}")

    def length(u: tuple[slice, slice], v: tuple[slice, slice]) -> NDArray[np.float64]:
        return np.asarray(np.linalg.norm(p[u] - p[v], axis=-1))

    diagonal = length(b, c)
    keep1 = block & (np.maximum(np.maximum(length(a, c), length(a, b)), diagonal) <= max_edge)
    keep2 = block & (np.maximum(np.maximum(length(b, d), length(c, d)), diagonal) <= max_edge)
    first = np.stack([index[a][keep1], index[c][keep1], index[b][keep1]], axis=-1)
    second = np.stack([index[b][keep2], index[c][keep2], index[d][keep2]], axis=-1)
    # both triangles of a block next to each other, blocks in row-major order
    order = np.argsort(np.r_[2 * np.flatnonzero(keep1), 2 * np.flatnonzero(keep2) + 1])
    return np.asarray(np.concatenate([first, second])[order], dtype=np.int64).reshape(-1, 3)
