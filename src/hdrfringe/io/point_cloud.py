"""Point clouds as PLY files (written with plyfile) and their meshes as PLY or STL.

The points come from :func:`hdrfringe.core.reconstruct.points_from_height` (thesis Eq. 2.11's
height with the camera's pinhole geometry); this module only writes them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "MESH_FORMATS",
    "OUTLIERS_MAP",
    "grid_normals",
    "intensity_colour",
    "read_result_points",
    "write_mesh",
    "write_ply",
]


def _grid_derivative(p: np.ndarray, axis: int) -> np.ndarray:
    """Derivative of an organised point grid, its coordinates as planes (3, H, W), along the
    image ``axis`` (0: rows, 1: columns), per pixel: the central difference where both
    neighbours are finite, else the one-sided difference to the finite neighbour, else NaN."""
    d = np.full_like(p, np.nan)
    n = p.shape[axis + 1]

    def part(a: np.ndarray, lo: int, hi: int) -> np.ndarray:  # a slice along the image axis
        index = [slice(None)] * a.ndim
        index[a.ndim - 2 + axis] = slice(lo, hi)
        return a[tuple(index)]

    if n < 2:
        return d
    step = part(p, 1, n) - part(p, 0, n - 1)  # p[i + 1] - p[i], for i = 0 .. n - 2
    finite = np.isfinite(step)
    ok = finite[0] & finite[1] & finite[2]  # (H, W): all three coordinates
    # the lowest priority first, each later choice overwriting: backward (at i: the step
    # i - 1), forward (at i: the step i), central (both)
    np.copyto(part(d, 1, n), step, where=ok)
    np.copyto(part(d, 0, n - 1), step, where=ok)
    both = part(ok, 1, n - 1) & part(ok, 0, n - 2)
    central = 0.5 * (part(step, 1, n - 1) + part(step, 0, n - 2))
    np.copyto(part(d, 1, n - 1), central, where=both)
    return d


def grid_normals(x: ArrayLike, y: ArrayLike, z: ArrayLike) -> np.ndarray:
    """Unit normals of an organised point grid (a structured-light cloud: one point per pixel).

    The normal of pixel (r, c) is the cross product of the surface's derivatives along the rows
    and along the columns, ``dP/dr x dP/dc``, each a central difference of the neighbouring
    points (one-sided at an edge of the valid area). With rows going down the image and
    columns to the right this points toward the camera: +z for ``measure``'s height points
    (height up toward the camera), -Z for a stereo cloud in the camera frame (Z away from it).

    Parameters
    ----------
    x, y, z : array_like, shape (H, W)
        The points' coordinates on the camera's pixel grid; NaN where invalid.

    Returns
    -------
    ndarray of float64, shape (H, W, 3)
        Unit normals; NaN where the point is invalid or has no valid neighbour along a row or
        a column.

    Examples
    --------
    >>> rows, cols = np.mgrid[0:3, 0:4].astype(float)
    >>> n = grid_normals(cols, -rows, 0.5 * cols)  # a plane z = x / 2, y up the image
    >>> np.round(n[1, 1] * np.sqrt(1.25), 6).tolist()
    [-0.5, 0.0, 1.0]
    """
    # the coordinates as planes (3, H, W): every step below works on contiguous (H, W) maps,
    # the same arithmetic as on (H, W, 3) points (np.cross's products and differences, the
    # norm's squares summed x, y, z in order) in about half the time at 2.8 Mpx
    p = np.stack([np.asarray(a, dtype=np.float64) for a in (x, y, z)])
    if p.ndim != 3:
        raise ValueError(
            f"normals need an organised (H, W) grid of points, got shape {(*p.shape[1:], 3)}"
        )
    a, b = _grid_derivative(p, 0), _grid_derivative(p, 1)
    n = np.empty((*p.shape[1:], 3))
    n[..., 0] = a[1] * b[2] - a[2] * b[1]
    n[..., 1] = a[2] * b[0] - a[0] * b[2]
    n[..., 2] = a[0] * b[1] - a[1] * b[0]
    with np.errstate(invalid="ignore", divide="ignore"):
        n /= np.sqrt(n[..., 0] * n[..., 0] + n[..., 1] * n[..., 1] + n[..., 2] * n[..., 2])[
            ..., None
        ]
    finite = np.isfinite(p)
    n[~(finite[0] & finite[1] & finite[2])] = np.nan
    return n


def intensity_colour(mean_intensity: ArrayLike, bit_depth: int) -> np.ndarray:
    """8-bit gray of a mean-intensity map, as a point's RGB: ``rint(255 I / (2^B - 1))``.

    Parameters
    ----------
    mean_intensity : array_like
        The mean intensity ``I'`` in DN (thesis Eq. 3.5), e.g. of the finest set.
    bit_depth : int
        The camera's bit depth B (full scale ``2^B - 1``).

    Returns
    -------
    ndarray of uint8
        Same shape; 0 where not finite.

    Examples
    --------
    >>> intensity_colour([0.0, 2047.5, 4095.0, np.nan], 12).tolist()
    [0, 128, 255, 0]
    """
    from hdrfringe.core._validation import full_scale

    i = np.asarray(mean_intensity, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        g = np.clip(np.rint(i * (255.0 / full_scale(bit_depth))), 0, 255)
    return np.where(np.isfinite(g), g, 0).astype(np.uint8)


def write_ply(
    path: str | Path,
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    *,
    intensity: ArrayLike | None = None,
    colour: ArrayLike | None = None,
    normals: bool = False,
) -> int:
    """Write the finite points as a binary little-endian PLY (vertex x, y, z [, intensity]
    [, red, green, blue] [, nx, ny, nz]).

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
    colour : array_like, optional
        The points' colour, uint8: gray (same size as ``x``; e.g. :func:`intensity_colour`)
        or RGB (a last axis of 3), stored as ``red``, ``green``, ``blue`` (uchar) as point
        cloud viewers (MeshLab, CloudCompare, Open3D, trimesh) read them.
    normals : bool
        Also store unit normals ``nx, ny, nz`` (float32) from the organised grid
        (:func:`grid_normals`; ``x``, ``y``, ``z`` must be (H, W) maps); 0, 0, 0 for a point
        without one (no valid neighbour along a row or a column).

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
    >>> write_ply(path, [[0.0, 1.0]], [[0.0, 0.0]], [[5.0, 6.0]], colour=[[0, 255]], normals=True)
    2
    >>> v = PlyData.read(str(path))["vertex"]
    >>> v["red"].tolist(), v["nz"].tolist()
    ([0, 255], [0.0, 0.0])
    """
    from plyfile import PlyData, PlyElement

    vert = _vertices(x, y, z, intensity, colour, normals)
    PlyData([PlyElement.describe(vert, "vertex")], byte_order="<").write(str(path))
    return int(vert.size)


def _vertices(
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    intensity: ArrayLike | None,
    colour: ArrayLike | None,
    normals: bool,
) -> np.ndarray:
    """The PLY vertex records of the finite points, in row-major order (:func:`write_ply`)."""
    xa, ya, za = (np.asarray(a, dtype=np.float64).ravel() for a in (x, y, z))
    ok = np.isfinite(xa) & np.isfinite(ya) & np.isfinite(za)
    fields = [("x", "<f4"), ("y", "<f4"), ("z", "<f4")]
    if intensity is not None:
        fields.append(("intensity", "<f4"))
    rgb = None
    if colour is not None:
        c = np.asarray(colour, dtype=np.uint8)
        if c.size == 3 * xa.size:  # RGB
            rgb = c.reshape(-1, 3)
        elif c.size == xa.size:  # gray
            rgb = np.repeat(c.reshape(-1, 1), 3, axis=1)
        else:
            raise ValueError(f"colour has {c.size} values for {xa.size} points (gray or RGB)")
        fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")]
    normal = None
    if normals:
        normal = grid_normals(x, y, z).reshape(-1, 3)
        normal = np.where(np.isfinite(normal), normal, 0.0)
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    vert = np.empty(int(ok.sum()), dtype=fields)
    vert["x"], vert["y"], vert["z"] = xa[ok], ya[ok], za[ok]
    if intensity is not None:
        vert["intensity"] = np.asarray(intensity, dtype=np.float64).ravel()[ok]
    if rgb is not None:
        vert["red"], vert["green"], vert["blue"] = rgb[ok].T
    if normal is not None:
        vert["nx"], vert["ny"], vert["nz"] = normal[ok].T
    return vert


#: The mesh formats :func:`write_mesh` writes, by file suffix.
MESH_FORMATS = ("ply", "stl")


def write_mesh(
    path: str | Path,
    x: ArrayLike,
    y: ArrayLike,
    z: ArrayLike,
    faces: ArrayLike,
    *,
    colour: ArrayLike | None = None,
    normals: bool = False,
) -> tuple[int, int]:
    """Write a triangle mesh of an organised cloud as PLY (binary, plyfile) or STL (binary,
    trimesh), by the file's suffix.

    The vertices are the finite points in row-major order, as :func:`write_ply` writes them
    (a mesh PLY's vertex element is ``points.ply``'s, colours and normals included); ``faces``
    index them (:func:`hdrfringe.core.cloud.grid_mesh`). STL holds the triangles only: no
    colours, no shared vertices; its unit is the points' (mm).

    Parameters
    ----------
    path : str or Path
        ``.ply`` or ``.stl`` file to write.
    x, y, z : array_like, shape (H, W)
        The points on the pixel grid; NaN where invalid.
    faces : array_like of int, shape (M, 3)
        Vertex indices of the triangles.
    colour : array_like, optional
        As :func:`write_ply` (PLY only).
    normals : bool
        As :func:`write_ply` (PLY only).

    Returns
    -------
    (int, int)
        Vertices and triangles written.

    Raises
    ------
    ValueError
        Another suffix, or a face indexing no vertex.

    Examples
    --------
    >>> import tempfile
    >>> import trimesh
    >>> from hdrfringe.core.cloud import grid_mesh
    >>> x, y = np.meshgrid([0.0, 1.0, 2.0], [0.0, -1.0])
    >>> z = np.zeros((2, 3))
    >>> path = Path(tempfile.mkdtemp()) / "mesh.stl"
    >>> write_mesh(path, x, y, z, grid_mesh(x, y, z))
    (6, 4)
    >>> len(trimesh.load(path).faces)
    4
    """
    from plyfile import PlyData, PlyElement

    kind = Path(path).suffix.lower().lstrip(".")
    if kind not in MESH_FORMATS:
        raise ValueError(f"{path}: a mesh is written as {' or '.join(MESH_FORMATS)}")
    vert = _vertices(x, y, z, None, colour if kind == "ply" else None, normals and kind == "ply")
    tri = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if tri.size and (tri.min() < 0 or tri.max() >= vert.size):
        raise ValueError(f"{path}: faces index vertices outside 0..{vert.size - 1}")
    if kind == "stl":
        import trimesh

        xyz = np.stack([vert["x"], vert["y"], vert["z"]], axis=-1)
        trimesh.Trimesh(xyz, tri, process=False).export(str(path), file_type="stl")
        return int(vert.size), int(tri.shape[0])
    face = np.empty(tri.shape[0], dtype=[("vertex_indices", "i4", (3,))])
    face["vertex_indices"] = tri
    elements = [PlyElement.describe(vert, "vertex"), PlyElement.describe(face, "face")]
    PlyData(elements, byte_order="<").write(str(path))
    return int(vert.size), int(tri.shape[0])


#: The map of the points ``measure --remove-outliers`` left out of ``points.ply`` and the mesh
#: (uint8, 1 = left out).
OUTLIERS_MAP = "outliers.tiff"


def read_result_points(folder: str | Path) -> tuple[np.ndarray, str]:
    """The organised point cloud of a ``measure`` result folder, as it was written.

    A stereo result's ``xyz.tiff`` (camera frame, mm); a phase-to-height result's
    ``points.ply`` put back on the pixel grid: its vertices are the pixels valid in
    ``height.tiff`` in row-major order (:func:`write_ply`). Points ``outliers.tiff`` marks (a
    ``measure --remove-outliers`` run) are invalid, as they are in ``points.ply``.

    Parameters
    ----------
    folder : str or Path
        The result folder (``hdrfringe measure -o``).

    Returns
    -------
    xyz : ndarray of float64, shape (H, W, 3)
        The points, mm (x and y in pixels for a calibration without camera geometry); NaN
        where invalid.
    kind : str
        ``stereo`` (camera frame: the camera at the origin, z away from it) or ``height``
        (z the height over the reference plane, toward the camera).

    Raises
    ------
    InputError
        No such folder, or none of the files above.
    CaptureFormatError
        A file that cannot be read, or ``points.ply`` and ``height.tiff`` that disagree.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.io.results import write_map_tiff
    >>> folder = Path(tempfile.mkdtemp())
    >>> h = np.array([[1.0, np.nan], [2.0, 3.0]])
    >>> write_map_tiff(folder / "height.tiff", h)
    >>> _ = write_ply(folder / "points.ply", [[0, 1], [0, 1.0]], [[0, 0], [-1, -1.0]], h)
    >>> xyz, kind = read_result_points(folder)
    >>> kind, xyz[..., 2].tolist()
    ('height', [[1.0, nan], [2.0, 3.0]])
    """
    from hdrfringe.errors import CaptureFormatError, InputError
    from hdrfringe.io.results import read_map_tiff

    root = Path(folder)
    if not root.is_dir():
        raise InputError(f"{root}: no such result folder; give a folder `hdrfringe measure` wrote")
    xyz_path, height_path, ply_path = root / "xyz.tiff", root / "height.tiff", root / "points.ply"
    if xyz_path.is_file():
        xyz = np.asarray(read_map_tiff(xyz_path), dtype=np.float64)
        if xyz.ndim != 3 or xyz.shape[-1] != 3:
            raise CaptureFormatError(
                f"{xyz_path}: shape {xyz.shape}, not (H, W, 3); regenerate it with measure"
            )
        valid, kind = np.isfinite(xyz).all(axis=-1), "stereo"
    elif height_path.is_file() and ply_path.is_file():
        height = read_map_tiff(height_path)
        if height.ndim != 2:
            raise CaptureFormatError(f"{height_path}: shape {height.shape}, not (H, W)")
        valid, kind = np.isfinite(height), "height"
    else:
        raise InputError(
            f"{root}: no xyz.tiff, nor height.tiff with points.ply: not the result of "
            "`hdrfringe measure` with a calibration (-c CAL)"
        )
    outliers = root / OUTLIERS_MAP
    if outliers.is_file():
        removed = read_map_tiff(outliers)
        if removed.shape != valid.shape:
            raise CaptureFormatError(
                f"{outliers}: shape {removed.shape}, the result's maps {valid.shape}"
            )
        valid &= removed == 0
    if kind == "stereo":
        xyz[~valid] = np.nan
        return xyz, kind
    from plyfile import PlyData

    try:
        v = PlyData.read(str(ply_path))["vertex"]
        pts = np.stack([np.asarray(v[c], dtype=np.float64) for c in "xyz"], axis=-1)
    except Exception as exc:  # any reader failure: truncated or not a PLY
        raise CaptureFormatError(
            f"{ply_path}: cannot read the point cloud ({type(exc).__name__}: {exc}); "
            "measure again"
        ) from None
    if pts.shape[0] != int(valid.sum()):
        raise CaptureFormatError(
            f"{ply_path}: {pts.shape[0]} points for {int(valid.sum())} valid pixels of "
            f"{height_path.name}: the folder changed after measure wrote it; measure again"
        )
    xyz = np.full((*valid.shape, 3), np.nan)
    xyz[valid] = pts
    return xyz, kind
