"""Regions of interest on the camera's pixel grid: a rectangle, a polygon, the largest region.

``hdrfringe fit`` (:mod:`hdrfringe.tasks.fit`) selects the points of a fit with one of these
masks. Coordinates are camera pixels: ``x`` the column, ``y`` the row, (0, 0) the centre of
the top-left pixel.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.errors import InputError

__all__ = ["largest_region", "polygon_mask", "rectangle_mask"]

Mask = NDArray[np.bool_]


def _shape(shape: tuple[int, ...]) -> tuple[int, int]:
    if len(shape) != 2 or min(shape) < 1:
        raise InputError(f"a region of interest needs an (H, W) image shape, got {shape}")
    return int(shape[0]), int(shape[1])


def rectangle_mask(shape: tuple[int, ...], x0: int, y0: int, x1: int, y1: int) -> Mask:
    """The pixels ``x0 <= x < x1``, ``y0 <= y < y1`` (numpy's ``[y0:y1, x0:x1]``).

    Parameters
    ----------
    shape : (int, int)
        The image's (H, W).
    x0, y0, x1, y1 : int
        Corners in camera pixels; ``0 <= x0 < x1 <= W``, ``0 <= y0 < y1 <= H``.

    Returns
    -------
    ndarray of bool, shape (H, W)

    Raises
    ------
    InputError
        Corners that are not integers, not ordered, or outside the image.

    Examples
    --------
    >>> rectangle_mask((3, 4), 1, 0, 3, 2).astype(int).tolist()
    [[0, 1, 1, 0], [0, 1, 1, 0], [0, 0, 0, 0]]
    """
    h, w = _shape(shape)
    corners = (x0, y0, x1, y1)
    if any(isinstance(v, bool) or int(v) != v for v in corners):
        raise InputError(f"ROI rectangle {corners}: give integer pixel corners x0,y0,x1,y1")
    if not (0 <= x0 < x1 <= w and 0 <= y0 < y1 <= h):
        raise InputError(
            f"ROI rectangle x0,y0,x1,y1 = {x0},{y0},{x1},{y1} is not inside the {w}x{h} image "
            f"or is empty; give 0 <= x0 < x1 <= {w} and 0 <= y0 < y1 <= {h}"
        )
    mask = np.zeros((h, w), dtype=bool)
    mask[int(y0) : int(y1), int(x0) : int(x1)] = True
    return mask


def polygon_mask(shape: tuple[int, ...], vertices_xy: ArrayLike) -> Mask:
    """The pixels inside a polygon (:func:`skimage.draw.polygon2mask`).

    Parameters
    ----------
    shape : (int, int)
        The image's (H, W).
    vertices_xy : array_like, shape (N, 2)
        The polygon's vertices ``(x, y)`` in camera pixels, N >= 3, each inside the image
        (``0 <= x <= W - 1``, ``0 <= y <= H - 1``).

    Returns
    -------
    ndarray of bool, shape (H, W)

    Raises
    ------
    InputError
        Fewer than 3 vertices, non-finite ones, or one outside the image.

    Examples
    --------
    >>> polygon_mask((4, 5), [(0, 0), (4, 0), (0, 3)]).astype(int).tolist()
    [[1, 1, 1, 1, 1], [1, 1, 1, 0, 0], [1, 1, 0, 0, 0], [1, 0, 0, 0, 0]]
    """
    from skimage.draw import polygon2mask

    h, w = _shape(shape)
    v = np.asarray(vertices_xy, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3 or not np.isfinite(v).all():
        raise InputError(
            f"ROI polygon of shape {v.shape}: give at least 3 finite vertices (x, y)"
        )
    out = (v[:, 0] < 0) | (v[:, 0] > w - 1) | (v[:, 1] < 0) | (v[:, 1] > h - 1)
    if out.any():
        x, y = v[np.flatnonzero(out)[0]]
        raise InputError(
            f"ROI polygon vertex ({x:g}, {y:g}) is outside the {w}x{h} image; give vertices "
            f"with 0 <= x <= {w - 1} and 0 <= y <= {h - 1}"
        )
    return np.asarray(polygon2mask((h, w), v[:, ::-1]), dtype=bool)


def largest_region(valid: ArrayLike) -> Mask:
    """The largest 4-connected region of valid pixels (:func:`skimage.measure.label`).

    Parameters
    ----------
    valid : array_like of bool, shape (H, W)
        The pixels with a point.

    Returns
    -------
    ndarray of bool, shape (H, W)
        The region (the first in label order of equally large ones); all False when no pixel
        is valid.

    Examples
    --------
    >>> valid = np.array([[1, 1, 0, 1], [1, 0, 0, 1], [0, 0, 0, 1]], dtype=bool)
    >>> largest_region(valid).astype(int).tolist()
    [[1, 1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 0]]
    """
    from skimage.measure import label

    ok = np.asarray(valid, dtype=bool)
    _shape(ok.shape)
    labels = label(ok, connectivity=1)
    if labels.max() == 0:
        return np.zeros(ok.shape, dtype=bool)
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    return np.asarray(labels == int(np.argmax(sizes)))

