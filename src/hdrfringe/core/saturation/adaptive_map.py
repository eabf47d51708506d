"""Per-pixel adaptive projection: each pixel's response, its safe MIGL, the projector map.

Beyond the thesis (its Sec. 7.2 names it as future work; Li & Kofman 2014, Lin et al. 2016):
instead of sweeping one global MIGL down (LPA, DPA), measure how each camera pixel responds to
the projector, compute the highest MIGL that keeps all its shifts below clipping, carry that
level to the projector pixels the camera pixel sees, and project one set whose MIGL varies per
projector pixel (:class:`~hdrfringe.core.frames.PixelwiseFringeFrame`). The steps, each one function
(docs/adaptive.md):

1. :func:`response_from_fringes` / :func:`response_from_levels`: gain ``a`` and ambient ``c``
   of the linear response ``I = a * g + c`` (``g`` the linear projected gray, i.e. after gamma
   pre-compensation), from a low-MIGL fringe set or from uniform captures.
2. :func:`safe_migl`: the highest MIGL ``m`` with ``a * m + c <= (1 - margin) * (2^B - 1)``.
3. :func:`projector_coordinates`: camera -> projector coordinates from absolute phases.
4. :func:`scatter_min`: camera-side levels to projector pixels (the minimum over the camera
   pixels that land on one).
5. :func:`fill_holes`: projector pixels no camera pixel landed on take their nearest neighbour.
6. :func:`erode_map` and :func:`smooth_below`: robustness to projector blur, the camera pixel's
   footprint and mapping errors: a minimum filter over a disk, and a smoothing that never raises
   a value.
7. :func:`projector_migl_map`: steps 4-6 and the clip to ``[imin, 2^Bp - 1]``;
   :func:`sample_map` reads a projector map back at the camera pixels, and
   :func:`lowered_where_clipped` lowers the camera-side level where a capture still clipped.
8. :func:`boosted_map`: the safe map raised around dim pixels the erosion starved (a second
   set, merged per pixel where its modulation is larger).

Pure numpy/scipy: no rig, no files.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import full_scale, saturation_count
from hdrfringe.core.saturation.estimate import saturated_peak_lower_bound
from hdrfringe.core.stereo import StereoCalibration, triangulate
from hdrfringe.errors import InputError

__all__ = [
    "boosted_map",
    "epipolar_rows",
    "erode_map",
    "fill_holes",
    "fit_blur_sigma",
    "footprint_px",
    "lowered_floor",
    "lowered_where_clipped",
    "map_phase_bias",
    "median_smooth",
    "projector_coordinates",
    "projector_migl_map",
    "refined_migl",
    "response_from_fringes",
    "response_from_levels",
    "safe_migl",
    "sample_map",
    "scatter_min",
    "smooth_below",
]

F64 = NDArray[np.float64]
TWO_PI = 2.0 * np.pi


def _image(a: ArrayLike, name: str) -> F64:
    """A 2-D float64 copy of ``a``; InputError otherwise."""
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim != 2:
        raise InputError(f"{name} must be a 2-D image, got shape {arr.shape}")
    return arr


def _same_shape(name: str, a: NDArray, ref: NDArray) -> None:
    if a.shape != ref.shape:
        raise InputError(
            f"{name} has shape {a.shape}, expected {ref.shape}; give one value per camera pixel"
        )


def response_from_fringes(
    offset: ArrayLike, modulation: ArrayLike, migl: float, imin: float
) -> tuple[F64, F64]:
    """Gain and ambient of ``I = a * g + c`` from one fringe set at MIGL ``migl``.

    A set whose projected gray is ``g = imin + (migl - imin) (1 + cos) / 2`` has offset
    ``I' = c + a (migl + imin) / 2`` and modulation ``I'' = a (migl - imin) / 2`` (thesis
    Eq. 3.4-3.6 with the linear response); so ``a = 2 I'' / (migl - imin)`` and
    ``c = I' - a (migl + imin) / 2``. The modulation is taken at face value: use a set whose
    pitch is large against the projector and camera blur (a one-period set), where the blur
    does not attenuate it.

    Parameters
    ----------
    offset, modulation : array_like (H, W)
        ``I'`` and ``I''`` of the set in DN (:class:`~hdrfringe.core.phase.PhaseResult`'s
        ``mean_intensity`` and ``modulation``).
    migl, imin : float
        The set's MIGL and minimum gray, ``migl > imin``.

    Returns
    -------
    gain : ndarray (H, W)
        ``a`` in DN per gray level.
    ambient : ndarray (H, W)
        ``c`` in DN: what the pixel reads at projected gray 0 (ambient light, projector black).

    Raises
    ------
    InputError
        ``migl <= imin`` or maps of different shapes.

    References
    ----------
    Thesis Eq. 3.3 (the linear intensity model) and Eq. 3.4-3.6 (I', I'').

    Examples
    --------
    A pixel with ``a = 2`` and ``c = 10`` under a set from 40 to 60:

    >>> g, c = response_from_fringes([[10 + 2 * 50.0]], [[2 * 10.0]], 60.0, 40.0)
    >>> float(g[0, 0]), float(c[0, 0])
    (2.0, 10.0)
    """
    off, mod = _image(offset, "offset"), _image(modulation, "modulation")
    _same_shape("modulation", mod, off)
    if not float(migl) > float(imin):
        raise InputError(f"the response needs a set with migl > imin, got {migl:g} <= {imin:g}")
    gain = 2.0 * mod / (float(migl) - float(imin))
    return gain, off - gain * (float(migl) + float(imin)) / 2.0


def response_from_levels(images: ArrayLike, levels: ArrayLike) -> tuple[F64, F64]:
    """Gain and ambient of ``I = a * g + c`` by least squares over uniform captures.

    Parameters
    ----------
    images : array_like (K, H, W)
        Captures of the whole projector at the linear grays ``levels`` (K >= 2), unsaturated.
    levels : array_like (K,)
        The grays, at least two of them different.

    Returns
    -------
    gain, ambient : ndarray (H, W)
        The least-squares line per pixel.

    Raises
    ------
    InputError
        Fewer than two distinct levels, or a count that does not match the images.

    References
    ----------
    Thesis Eq. 3.3 (intensity linear in the projected light).

    Examples
    --------
    >>> imgs = np.array([[[10.0]], [[110.0]], [[210.0]]])
    >>> g, c = response_from_levels(imgs, [0, 50, 100])
    >>> float(g[0, 0]), float(c[0, 0])
    (2.0, 10.0)
    """
    stack = np.asarray(images, dtype=np.float64)
    lv = np.asarray(levels, dtype=np.float64).ravel()
    if stack.ndim != 3 or stack.shape[0] != lv.size:
        raise InputError(
            f"response_from_levels needs K images (K, H, W) for K levels, got images "
            f"{stack.shape} and {lv.size} levels"
        )
    if np.unique(lv).size < 2:
        raise InputError("response_from_levels needs at least two different gray levels")
    lc = lv - lv.mean()
    gain = np.tensordot(lc, stack, axes=1) / float(lc @ lc)
    return gain, stack.mean(axis=0) - gain * lv.mean()


def safe_migl(
    gain: ArrayLike,
    ambient: ArrayLike,
    bit_depth: int,
    *,
    margin: float,
    imin: float,
    projector_full: float,
) -> F64:
    """Per camera pixel, the highest MIGL whose brightest shift stays ``margin`` below clipping.

    ``m = ((1 - margin) (2^B - 1) - c) / a``, clipped to ``[imin, projector_full]``; pixels
    with ``a <= 0`` (no response: shadow, outside the projector) take ``projector_full``
    (nothing to protect), pixels with a non-finite gain or ambient are NaN (unknown).

    Parameters
    ----------
    gain, ambient : array_like (H, W)
        ``a`` and ``c`` (:func:`response_from_fringes`).
    bit_depth : int
        Camera bit depth B.
    margin : float
        Fraction of the camera's full scale kept free, in ``[0, 1)``: it absorbs the noise of
        the shifts and the error of the response estimate.
    imin : float
        The set's minimum gray (the lowest MIGL that can be asked).
    projector_full : float
        The projector's ``2^Bp - 1``.

    Returns
    -------
    ndarray (H, W) float64

    Raises
    ------
    InputError
        A margin outside ``[0, 1)``.

    References
    ----------
    Thesis Sec. 7.2 (future work: per-pixel adaptive projection); Eq. 3.3 (the linear model).

    Examples
    --------
    ``a = 2``, ``c = 10`` at 8 bits, 2 % margin: ``(0.98 * 255 - 10) / 2 = 119.95``:

    >>> safe_migl([[2.0, 0.5, 0.0]], [[10.0, 10.0, 5.0]], 8, margin=0.02, imin=40,
    ...           projector_full=255).round(2).tolist()
    [[119.95, 255.0, 255.0]]
    """
    a, c = _image(gain, "gain"), _image(ambient, "ambient")
    _same_shape("ambient", c, a)
    if not 0.0 <= float(margin) < 1.0:
        raise InputError(f"margin must be a fraction of full scale in [0, 1), got {margin!r}")
    top = (1.0 - float(margin)) * full_scale(bit_depth)
    with np.errstate(divide="ignore", invalid="ignore"):
        m = np.where(a > 0, (top - c) / a, float(projector_full))
    m = np.clip(m, float(imin), float(projector_full))
    m[~(np.isfinite(a) & np.isfinite(c))] = np.nan
    return m


def median_smooth(image: ArrayLike, size: int) -> F64:
    """NaN-aware median over a ``size`` x ``size`` window (NaN stays NaN).

    Denoises a low-MIGL phase map before it predicts the fringe order of a finer set: the
    median of a linear ramp over a symmetric window is its centre value, so smooth surfaces
    keep their phase, and a step (a depth edge) is kept rather than blurred. At the image
    border the map is continued by point reflection (``2 edge - mirror``), which continues a
    ramp; next to invalid (NaN) pixels inside the image the window is one-sided and follows
    the valid side.

    Parameters
    ----------
    image : array_like (H, W)
        The map; NaN where invalid.
    size : int
        Odd window size >= 1 (1: unchanged).

    Returns
    -------
    ndarray (H, W) float64

    Examples
    --------
    >>> ramp = np.arange(5.0)[None, :] * np.ones((3, 1))
    >>> noisy = ramp.copy(); noisy[1, 2] = 9.0
    >>> median_smooth(noisy, 3)[1].tolist()
    [0.0, 1.0, 2.0, 3.0, 4.0]
    """
    img = _image(image, "image")
    if isinstance(size, bool) or int(size) != size or size < 1 or size % 2 == 0:
        raise InputError(f"median window must be an odd whole number >= 1, got {size!r}")
    if size == 1:
        return img.copy()
    r = int(size) // 2
    # point reflection at the border (2 edge - mirror) continues a ramp: no one-sided bias
    padded = np.pad(img, r, mode="reflect", reflect_type="odd")
    windows = np.lib.stride_tricks.sliding_window_view(padded, (int(size), int(size)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows stay NaN
        out = np.nanmedian(windows.reshape(*img.shape, -1), axis=-1)
    out[~np.isfinite(img)] = np.nan
    return np.asarray(out, np.float64)


def lowered_floor(migl: ArrayLike, imin: float, span: float) -> F64:
    """Per projector pixel the fringe's floor when its MIGL falls below ``imin + span``.

    A fringe shows ``floor + (m - floor) (1 + P) / 2``. At or above the lowest usable MIGL
    ``imin + span`` the floor is the set's ``imin`` (thesis Eq. 3.8-3.9); below it the floor
    falls with the MIGL, ``m - span``, keeping the span of the lowest usable fringe, down to
    the projector's black (0), under which the fringe spans ``[0, m]``. A pixel too bright
    for the lowest usable MIGL then still carries a fringe: its brightest shift is ``m``, and
    the phase does not depend on the offset.

    Parameters
    ----------
    migl : array_like
        MIGL per projector pixel (the map), >= 0.
    imin : float
        The set's minimum gray.
    span : float
        The lowest usable fringe's span, ``lowest usable MIGL - imin`` (> 0).

    Returns
    -------
    ndarray of float64
        ``clip(m - span, 0, imin)``, the shape of ``migl``.

    References
    ----------
    Thesis Eq. 3.8-3.9 (the fringe's offset and amplitude from imin and the MIGL).

    Examples
    --------
    >>> lowered_floor([255.0, 60.0, 50.0, 12.0], imin=40.0, span=20.0).tolist()
    [40.0, 40.0, 30.0, 0.0]
    """
    m = np.asarray(migl, dtype=np.float64)
    if not float(span) > 0:
        raise InputError(f"the lowest usable fringe's span must be > 0 gray levels, got {span!r}")
    return np.clip(m - float(span), 0.0, float(imin))


def epipolar_rows(calibration: StereoCalibration, u: ArrayLike) -> F64:
    """Projector row of each camera pixel from its projector column and the calibration.

    The camera pixel's ray meets the projector's column surface of ``u`` in one 3-D point
    (:func:`hdrfringe.core.stereo.triangulate` with ``u_proj`` alone); its projection into the
    projector is ``(u, v)``. One phase direction plus the epipolar constraint thus gives both
    projector coordinates (Zhao et al. 2025), where the scene is a single surface along the ray.

    Parameters
    ----------
    calibration : StereoCalibration
        The projector-camera calibration; its camera size must be ``u``'s shape (width, height).
    u : array_like, shape (H, W)
        Projector column per camera pixel (NaN invalid), pixel centres at integers.

    Returns
    -------
    ndarray of float64, shape (H, W)
        The projector row (NaN where ``u`` is NaN or the ray does not meet the column in front
        of both lenses).

    Raises
    ------
    InputError
        When ``u`` is not an image of the calibration's camera size.

    References
    ----------
    Zhang & Huang 2006 (the projector as an inverse camera); docs/adaptive.md ("One direction
    + the epipolar constraint").

    Examples
    --------
    >>> from hdrfringe.rig.simulated import RigGeometry
    >>> calib = RigGeometry().stereo_calibration((8, 6), (1024, 768))
    >>> k = calib.camera.matrix  # the ray of camera pixel (column 3, row 2), 1850 mm deep
    >>> point = 1850.0 * np.array([(3 - k[0, 2]) / k[0, 0], (2 - k[1, 2]) / k[1, 1], 1.0])
    >>> pu, pv = calib.projector.project(point @ calib.rotation.T + calib.translation_mm)
    >>> u = np.full((6, 8), np.nan)
    >>> u[2, 3] = pu
    >>> v = epipolar_rows(calib, u)
    >>> int(np.isfinite(v).sum()), round(float(v[2, 3] - pv), 6)
    (1, 0.0)
    """
    uu = _image(u, "u")
    if not isinstance(calibration, StereoCalibration):
        raise InputError(
            "epipolar_rows: calibration must be a hdrfringe.core.stereo.StereoCalibration"
        )
    width, height = calibration.camera.size
    if uu.shape != (height, width):
        raise InputError(
            f"epipolar_rows: u has shape {uu.shape}, but the calibration's camera is "
            f"{width} x {height}; give the calibration of this camera"
        )
    rows, cols = np.mgrid[0:height, 0:width].astype(np.float64)
    ok = np.isfinite(uu)
    out = np.full(uu.shape, np.nan)
    if ok.any():
        xyz = triangulate(calibration, cols[ok], rows[ok], u_proj=uu[ok]).xyz
        _, v = calibration.projector.project(
            xyz @ calibration.rotation.T + calibration.translation_mm
        )
        out[ok] = v
    return out


def projector_coordinates(absolute_phase: ArrayLike, pitch_px: float) -> F64:
    """Projector coordinate (column for vertical fringes, row for horizontal) from the absolute
    phase of a set of pitch ``pitch_px``: ``x = Phi * p / (2 pi)`` (the contract's phase).

    Parameters
    ----------
    absolute_phase : array_like
        Absolute phase in radians (NaN invalid).
    pitch_px : float
        The set's pitch in projector pixels.

    Returns
    -------
    ndarray of float64

    References
    ----------
    Thesis Eq. 2.1 (phase = 2 pi x / p).

    Examples
    --------
    >>> projector_coordinates([[2 * np.pi * 2.5]], 8.0).tolist()
    [[20.0]]
    """
    if not float(pitch_px) > 0:
        raise InputError(f"pitch must be a positive number of projector pixels, got {pitch_px}")
    return np.asarray(absolute_phase, dtype=np.float64) * float(pitch_px) / TWO_PI


def _projector_index(
    u: F64, v: F64, shape: tuple[int, int]
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.bool_]]:
    """Nearest projector pixel (row, column) of each coordinate pair, and where it is inside."""
    ok = np.isfinite(u) & np.isfinite(v)
    col = np.rint(np.where(ok, u, -1.0)).astype(np.intp)
    row = np.rint(np.where(ok, v, -1.0)).astype(np.intp)
    ok &= (col >= 0) & (col < shape[1]) & (row >= 0) & (row < shape[0])
    return row, col, ok


def scatter_min(
    values: ArrayLike, u: ArrayLike, v: ArrayLike, projector_shape: tuple[int, int]
) -> F64:
    """Projector map of the smallest camera-side value landing on each projector pixel.

    Each camera pixel with a finite value and finite coordinates inside the projector lands on
    the nearest projector pixel ``(round(v), round(u))``; projector pixels no camera pixel lands
    on are NaN (holes, :func:`fill_holes`).

    Parameters
    ----------
    values : array_like (H, W)
        Camera-side values (e.g. :func:`safe_migl`).
    u, v : array_like (H, W)
        Projector column and row of each camera pixel (:func:`projector_coordinates`).
    projector_shape : (int, int)
        Projector (height, width).

    Returns
    -------
    ndarray (projector height, projector width) float64

    Examples
    --------
    Two camera pixels land on projector pixel (0, 1), one on (1, 2):

    >>> out = scatter_min([[200.0, 150.0, 90.0]], [[1.2, 0.8, 2.0]], [[0.1, 0.0, 1.0]], (2, 3))
    >>> out.tolist()
    [[nan, 150.0, nan], [nan, nan, 90.0]]
    """
    val = _image(values, "values")
    uu, vv = _image(u, "u"), _image(v, "v")
    _same_shape("u", uu, val)
    _same_shape("v", vv, val)
    h, w = (int(x) for x in projector_shape)
    row, col, ok = _projector_index(uu, vv, (h, w))
    ok &= np.isfinite(val)
    out = np.full(h * w, np.inf)
    np.minimum.at(out, row[ok] * w + col[ok], val[ok])
    out[np.isinf(out)] = np.nan
    return out.reshape(h, w)


def fill_holes(projector_map: ArrayLike) -> F64:
    """Give every NaN projector pixel the value of its nearest finite neighbour.

    Parameters
    ----------
    projector_map : array_like (h, w)
        A map with holes (NaN); at least one finite value.

    Returns
    -------
    ndarray (h, w) float64
        No NaN left.

    Raises
    ------
    InputError
        A map without any finite value (no camera pixel was mapped).

    Examples
    --------
    >>> fill_holes([[np.nan, 100.0, np.nan, np.nan, 60.0]]).tolist()
    [[100.0, 100.0, 100.0, 60.0, 60.0]]
    """
    m = _image(projector_map, "projector map")
    holes = ~np.isfinite(m)
    if holes.all():
        raise InputError(
            "no camera pixel was mapped to the projector; check the mapping sets (modulation, "
            "saturation) and the projector size"
        )
    if not holes.any():
        return m
    from scipy.ndimage import distance_transform_edt  # here: cold start of measure (issue 16)

    idx = distance_transform_edt(holes, return_distances=False, return_indices=True)
    return m[tuple(idx)]


def _disk(radius: float) -> NDArray[np.bool_]:
    r = int(np.floor(radius))
    y, x = np.mgrid[-r : r + 1, -r : r + 1]
    return np.asarray(x * x + y * y <= radius * radius + 1e-9)


def erode_map(projector_map: ArrayLike, radius: float) -> F64:
    """Minimum over a disk of ``radius`` projector pixels (grey erosion).

    A camera pixel receives light from every projector pixel within its footprint, the
    projector's blur and the mapping's error of where it looks; after the erosion every
    projector pixel within ``radius`` of a camera pixel's location is at most that camera
    pixel's safe level.

    Parameters
    ----------
    projector_map : array_like (h, w)
        Finite values.
    radius : float
        Disk radius in projector pixels, >= 0 (0: unchanged).

    Returns
    -------
    ndarray (h, w) float64

    Examples
    --------
    >>> erode_map([[200.0, 200.0, 90.0, 200.0, 200.0, 200.0]], 1).tolist()
    [[200.0, 90.0, 90.0, 90.0, 200.0, 200.0]]
    """
    m = _image(projector_map, "projector map")
    if not float(radius) >= 0:
        raise InputError(f"erosion radius must be >= 0 projector pixels, got {radius!r}")
    if radius < 1:
        return m.copy()
    from scipy.ndimage import grey_erosion

    return np.asarray(grey_erosion(m, footprint=_disk(float(radius)), mode="nearest"), np.float64)


def smooth_below(projector_map: ArrayLike, sigma: float) -> F64:
    """Gaussian smoothing that never raises a value: ``min(gaussian(map, sigma), map)``.

    Softens the steps of an eroded map (so a slight mapping error lands on an intermediate
    level rather than across a cliff) while every value stays at or below the input, which is
    at or below every camera pixel's safe level.

    Parameters
    ----------
    projector_map : array_like (h, w)
        Finite values.
    sigma : float
        Standard deviation in projector pixels, >= 0 (0: unchanged).

    Returns
    -------
    ndarray (h, w) float64

    Examples
    --------
    >>> out = smooth_below([[200.0, 200.0, 100.0, 200.0, 200.0]], 1.0)
    >>> bool(np.all(out <= [[200.0, 200.0, 100.0, 200.0, 200.0]])), float(out[0, 1]) < 200
    (True, True)
    """
    m = _image(projector_map, "projector map")
    if not float(sigma) >= 0:
        raise InputError(f"smoothing sigma must be >= 0 projector pixels, got {sigma!r}")
    if sigma == 0:
        return m.copy()
    from scipy.ndimage import gaussian_filter

    return np.minimum(np.asarray(gaussian_filter(m, float(sigma), mode="nearest")), m)


def footprint_px(u: ArrayLike, v: ArrayLike) -> float:
    """Projector pixels one camera pixel spans: the median step of ``u`` and ``v`` between
    neighbouring camera pixels (the larger of the two directions).

    Parameters
    ----------
    u, v : array_like (H, W)
        Projector column and row of each camera pixel (NaN invalid).

    Returns
    -------
    float
        0 when no two neighbouring pixels are mapped.

    Examples
    --------
    >>> yy, xx = np.mgrid[0:4, 0:5].astype(float)
    >>> footprint_px(3 * xx, 2.5 * yy)
    3.0
    """
    uu, vv = _image(u, "u"), _image(v, "v")
    _same_shape("v", vv, uu)

    def step(a: F64, axis: int) -> float:
        d = np.abs(np.diff(a, axis=axis))
        d = d[np.isfinite(d)]
        return float(np.median(d)) if d.size else 0.0

    along_x = float(np.hypot(step(uu, 1), step(vv, 1)))
    along_y = float(np.hypot(step(uu, 0), step(vv, 0)))
    return max(along_x, along_y)


def projector_migl_map(
    camera_migl: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    projector_shape: tuple[int, int],
    *,
    radius: float,
    sigma: float,
    imin: float,
    projector_full: float,
) -> F64:
    """The projector MIGL map: scatter (min), fill holes, erode, smooth below, clip.

    Parameters
    ----------
    camera_migl : array_like (H, W)
        Camera-side safe MIGL (:func:`safe_migl`); NaN: unknown (not used).
    u, v : array_like (H, W)
        Projector column and row of each camera pixel.
    projector_shape : (int, int)
        Projector (height, width).
    radius : float
        Erosion radius in projector pixels (:func:`erode_map`).
    sigma : float
        Smoothing in projector pixels (:func:`smooth_below`).
    imin : float
        Lowest value (the set's minimum gray).
    projector_full : float
        Highest value, ``2^Bp - 1``.

    Returns
    -------
    ndarray (projector height, projector width) float64
        In ``[imin, projector_full]``.

    References
    ----------
    Thesis Sec. 7.2 (future work); docs/adaptive.md.

    Examples
    --------
    >>> cam = np.array([[200.0, 120.0]])
    >>> out = projector_migl_map(cam, [[1.0, 4.0]], [[0.0, 0.0]], (1, 6), radius=1, sigma=0,
    ...                          imin=40, projector_full=255)
    >>> out.tolist()
    [[200.0, 200.0, 120.0, 120.0, 120.0, 120.0]]
    """
    m = scatter_min(camera_migl, u, v, projector_shape)
    seen = np.isfinite(m)
    m = fill_holes(m)
    if seen.any():  # erode and smooth only around what the camera sees (the rest is not lit
        # into any camera pixel): the bounding box plus the reach of both filters
        pad = int(np.ceil(float(radius) + 4.0 * float(sigma))) + 2
        rows, cols = np.flatnonzero(seen.any(axis=1)), np.flatnonzero(seen.any(axis=0))
        r0, r1 = max(rows[0] - pad, 0), min(rows[-1] + pad + 1, m.shape[0])
        c0, c1 = max(cols[0] - pad, 0), min(cols[-1] + pad + 1, m.shape[1])
        m[r0:r1, c0:c1] = smooth_below(erode_map(m[r0:r1, c0:c1], radius), sigma)
    return np.clip(m, float(imin), float(projector_full))


def boosted_map(
    projector_map: ArrayLike,
    camera_migl: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    *,
    radius: float,
    projector_full: float,
) -> F64:
    """A projector map raised around the given camera pixels to their own levels.

    The erosion of :func:`projector_migl_map` lowers a dim camera pixel next to a bright one
    to the bright one's level (their projector neighbourhoods overlap). This map is the
    complement: each projector pixel within ``radius`` of a camera pixel with a finite
    ``camera_migl`` takes the largest such level (a maximum scattered, then a grey dilation
    over a disk), never below ``projector_map``. Its bright neighbours may clip in it; a
    second set projected with it is merged per pixel where it is better (the strategy keeps
    the first set's images elsewhere).

    Parameters
    ----------
    projector_map : array_like (h, w)
        The safe map (the floor of the result).
    camera_migl : array_like (H, W)
        Levels of the camera pixels to raise (NaN: leave alone).
    u, v : array_like (H, W)
        Projector column and row of each camera pixel.
    radius : float
        Dilation radius in projector pixels (>= 0).
    projector_full : float
        Highest value.

    Returns
    -------
    ndarray (h, w) float64
        ``>= projector_map``, at most ``max(projector_map, projector_full)``.

    References
    ----------
    Thesis Sec. 7.2 (future work), Eq. 5.1 (the per-pixel merge of two sets); docs/adaptive.md.

    Examples
    --------
    A dim pixel at projector column 3 whose safe map there is 64 (eroded by a bright
    neighbour at column 1) asks for 255:

    >>> base = np.array([[64.0, 64.0, 64.0, 64.0, 64.0, 200.0]])
    >>> boosted_map(base, [[255.0]], [[3.0]], [[0.0]], radius=1, projector_full=255).tolist()
    [[64.0, 64.0, 255.0, 255.0, 255.0, 200.0]]
    """
    base = _image(projector_map, "projector map")
    if not float(radius) >= 0:
        raise InputError(f"dilation radius must be >= 0 projector pixels, got {radius!r}")
    high = -scatter_min(-_image(camera_migl, "camera_migl"), u, v, (base.shape[0], base.shape[1]))
    if not np.isfinite(high).any():
        return base.copy()
    high = np.where(np.isfinite(high), np.minimum(high, float(projector_full)), -np.inf)
    if radius >= 1:
        from scipy.ndimage import grey_dilation  # here: cold start of measure (issue 16)

        high = grey_dilation(high, footprint=_disk(float(radius)), mode="nearest")
    return np.maximum(base, high)


def sample_map(projector_map: ArrayLike, u: ArrayLike, v: ArrayLike) -> F64:
    """The projector map at each camera pixel's nearest projector pixel (NaN outside).

    Parameters
    ----------
    projector_map : array_like (h, w)
        A projector map.
    u, v : array_like (H, W)
        Projector column and row of each camera pixel.

    Returns
    -------
    ndarray (H, W) float64

    Examples
    --------
    >>> sample_map([[1.0, 2.0], [3.0, 4.0]], [[0.2, 1.4, 9.0]], [[0.9, 0.0, 0.0]]).tolist()
    [[3.0, 2.0, nan]]
    """
    pm = _image(projector_map, "projector map")
    uu, vv = _image(u, "u"), _image(v, "v")
    _same_shape("v", vv, uu)
    row, col, ok = _projector_index(uu, vv, (pm.shape[0], pm.shape[1]))
    out = np.full(uu.shape, np.nan)
    out[ok] = pm[row[ok], col[ok]]
    return out


def refined_migl(
    offset: ArrayLike,
    modulation: ArrayLike,
    received_migl: ArrayLike,
    ambient: ArrayLike,
    bit_depth: int,
    *,
    margin: float,
    imin: float,
    projector_full: float,
) -> F64:
    """Per camera pixel, the highest safe MIGL re-fitted from an unclipped set at its own pitch.

    A fine fringe loses modulation to the projector's and the camera's blur, so its brightest
    shift stays below ``a m + c``, which :func:`safe_migl` assumes. From a set captured at MIGL
    ``m`` per pixel (offset ``I'``, modulation ``I''``) the same set at ``m'`` has
    ``I'(m') = c + (I' - c) (m' + imin) / (m + imin)`` and ``I''(m') = I'' (m' - imin) /
    (m - imin)`` (both linear in the projected light); the level is the ``m'`` where
    ``I'(m') + I''(m') = (1 - margin) (2^B - 1)``, clipped to ``[imin, projector_full]``.

    Parameters
    ----------
    offset, modulation : array_like (H, W)
        ``I'`` and ``I''`` of the set in DN (pixels with a clipped shift: pass NaN).
    received_migl : array_like (H, W)
        The MIGL each pixel received, ``> imin``.
    ambient : array_like (H, W)
        ``c`` of the response.
    bit_depth : int
        Camera bit depth B.
    margin : float
        As in :func:`safe_migl`.
    imin : float
        The set's minimum gray.
    projector_full : float
        Highest MIGL.

    Returns
    -------
    ndarray (H, W) float64
        NaN where an input is not finite or ``received_migl <= imin``.

    References
    ----------
    Thesis Eq. 3.3-3.6 (the linear model, I' and I''); Sec. 7.2.

    Examples
    --------
    ``a = 1``, ``c = 10``, ``imin = 40`` and a blur that keeps 60 % of the modulation: at
    ``m = 140`` the set reads ``I' = 100``, ``I'' = 30``; at ``m'`` its peak is
    ``10 + (m' + 40) / 2 + 0.3 (m' - 40)``, which meets ``0.8 * 255 = 204`` at ``m' = 232.5``
    (:func:`safe_migl` would stop at ``(204 - 10) / 1 = 194``):

    >>> refined_migl([[100.0]], [[30.0]], [[140.0]], [[10.0]], 8, margin=0.2, imin=40.0,
    ...              projector_full=255).round(2).tolist()
    [[232.5]]
    """
    off, mod = _image(offset, "offset"), _image(modulation, "modulation")
    m = _image(received_migl, "received_migl")
    c = _image(ambient, "ambient")
    for name, arr in (("modulation", mod), ("received_migl", m), ("ambient", c)):
        _same_shape(name, arr, off)
    top = (1.0 - float(margin)) * full_scale(bit_depth)
    with np.errstate(divide="ignore", invalid="ignore"):
        alpha = (off - c) / (m + imin)
        beta = mod / (m - imin)
        out = (top - c - alpha * imin + beta * imin) / (alpha + beta)
    out[~(np.isfinite(out) & (m > imin) & (alpha + beta > 0))] = np.nan
    return np.where(np.isfinite(out), np.clip(out, float(imin), float(projector_full)), np.nan)


def lowered_where_clipped(
    camera_migl: ArrayLike,
    images: ArrayLike,
    projected_migl: ArrayLike,
    ambient: ArrayLike,
    bit_depth: int,
    *,
    margin: float,
    imin: float,
) -> tuple[F64, NDArray[np.bool_]]:
    """Camera-side levels lowered where a set projected at ``projected_migl`` still clipped.

    A clipped pixel's true peak is at least the bound of
    :func:`~hdrfringe.core.saturation.estimate.saturated_peak_lower_bound` (``P``), so its gain is
    at least ``(P - c) / m`` at the MIGL ``m`` it received; the new level is
    ``((1 - margin) (2^B - 1) - c) / a_lb``. Where every shift clipped (no bound) the level
    halves its distance to ``imin``. Unclipped pixels keep their level.

    Parameters
    ----------
    camera_migl : array_like (H, W)
        The levels the set was built from.
    images : array_like (N, H, W)
        The set captured.
    projected_migl : array_like (H, W)
        The MIGL each pixel received (:func:`sample_map` of the projector map).
    ambient : array_like (H, W)
        ``c`` of the response.
    bit_depth : int
        Camera bit depth B.
    margin : float
        As in :func:`safe_migl`.
    imin : float
        The set's minimum gray.

    Returns
    -------
    levels : ndarray (H, W)
        ``camera_migl`` with the clipped pixels lowered (never raised).
    clipped : ndarray (H, W) bool
        The pixels with a saturated shift.

    References
    ----------
    docs/dpa.md, "pending pixels" (the peak bound); thesis Sec. 7.2.

    Examples
    --------
    A 4-step pixel at MIGL 100 with three shifts clipped and 200 in the fourth: peak >= 310,
    so ``a >= (310 - 10) / 100 = 3`` and the new level is ``(255 - 10) / 3``:

    >>> imgs = np.array([[[255]], [[255]], [[255]], [[200]]], np.uint8)
    >>> lv, clip = lowered_where_clipped([[100.0]], imgs, [[100.0]], [[10.0]], 8,
    ...                                  margin=0.0, imin=40)
    >>> round(float(lv[0, 0]), 2), bool(clip[0, 0])
    (81.67, True)
    """
    cam = _image(camera_migl, "camera_migl")
    stack = np.asarray(images)
    clipped = saturation_count(stack, bit_depth) > 0
    proj = _image(projected_migl, "projected_migl")
    c = _image(ambient, "ambient")
    _same_shape("projected_migl", proj, cam)
    _same_shape("ambient", c, cam)
    top = (1.0 - float(margin)) * full_scale(bit_depth)
    peak = saturated_peak_lower_bound(stack, bit_depth)
    out = cam.copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        a_lb = (peak - c) / proj
        bounded = clipped & np.isfinite(a_lb) & (a_lb > 0)
        out[bounded] = (top - c[bounded]) / a_lb[bounded]
    rest = clipped & ~bounded
    base = np.where(np.isfinite(proj), np.minimum(proj, cam), cam)
    out[rest] = imin + (base[rest] - imin) / 2.0
    out = np.where(clipped, np.minimum(out, cam), cam)
    return np.maximum(out, float(imin)), clipped


def map_phase_bias(
    projector_map: ArrayLike,
    u: ArrayLike,
    v: ArrayLike,
    *,
    pitch_px: float,
    orientation: str,
    sigma_px: float,
    imin: float,
    floor_span: float | None = None,
) -> F64:
    """Phase bias a camera pixel sees from a MIGL map that varies under its blur.

    A camera pixel at projector coordinate ``x0`` (along the fringe axis) integrates the
    fringe over a blur ``k`` (projector defocus, camera footprint and blur; Gaussian of
    ``sigma_px`` projector pixels here); with the fringe amplitude ``w = m - imin`` varying
    under ``k`` its phase is shifted by ``arg sum_s k(s) w(x0 + s) exp(2 pi i s / p)``, zero
    for a map constant under the blur. Where the map steps down in front of a dark surface this
    reaches tenths of a radian at fine pitches; the reflectivity's own steps bias every method
    alike (thesis Sec. 3.3) and are not part of this.

    Parameters
    ----------
    projector_map : array_like (h, w)
        The MIGL map projected.
    u, v : array_like (H, W)
        Projector column and row of each camera pixel.
    pitch_px : float
        The set's pitch.
    orientation : {"vertical", "horizontal"}
        The fringe axis: along ``u`` (vertical fringes) or ``v``.
    sigma_px : float
        Blur standard deviation in projector pixels along that axis (>= 0).
    imin : float
        The set's minimum gray.
    floor_span : float, optional
        The map's floor falls below the lowest usable MIGL ``imin + floor_span``
        (:func:`lowered_floor`): the amplitude is ``m - lowered_floor(m)``. None: ``m - imin``.

    Returns
    -------
    ndarray (H, W) float64
        Radians, to subtract from the measured phase.

    References
    ----------
    Thesis Eq. 2.1 (the fringe) and Sec. 3.3 (the intensity model); docs/adaptive.md.

    Examples
    --------
    A map constant under the blur gives no bias; on a ramp the bias follows its log slope,
    about ``sigma^2 (2 pi / p) d ln w / dx``:

    >>> flat = np.full((3, 64), 200.0)
    >>> float(abs(map_phase_bias(flat, [[32.0]], [[1.0]], pitch_px=8.0, orientation="vertical",
    ...                          sigma_px=1.0, imin=40.0)).max()) < 1e-12
    True
    >>> ramp = np.tile(40.0 + np.exp(0.05 * np.arange(64.0)), (3, 1))
    >>> b = map_phase_bias(ramp, [[32.0]], [[1.0]], pitch_px=8.0, orientation="vertical",
    ...                    sigma_px=1.0, imin=40.0)
    >>> round(float(b[0, 0]), 4), round(0.05 * 2 * np.pi / 8, 4)
    (0.0393, 0.0393)
    """
    pm = _image(projector_map, "projector map")
    uu, vv = _image(u, "u"), _image(v, "v")
    _same_shape("v", vv, uu)
    if orientation not in ("vertical", "horizontal"):
        raise InputError(f"orientation must be vertical or horizontal, got {orientation!r}")
    if not float(pitch_px) > 0 or not float(sigma_px) >= 0:
        raise InputError(f"pitch must be > 0 and sigma >= 0, got {pitch_px!r}, {sigma_px!r}")
    if orientation == "horizontal":  # the same along rows: transpose the problem
        return map_phase_bias(
            pm.T,
            vv,
            uu,
            pitch_px=pitch_px,
            orientation="vertical",
            sigma_px=sigma_px,
            imin=imin,
            floor_span=floor_span,
        )
    out = np.full(uu.shape, np.nan)
    ok = np.isfinite(uu) & np.isfinite(vv)
    h, w = pm.shape
    ok &= (uu > -0.5) & (uu < w - 0.5) & (vv > -0.5) & (vv < h - 0.5)
    if sigma_px == 0 or not ok.any():
        out[ok] = 0.0
        return out
    # the blur as taps on the projector pixels around each camera pixel's x0 (its row nearest)
    x0, row = uu[ok], np.clip(np.rint(vv[ok]).astype(np.intp), 0, h - 1)
    reach = int(np.ceil(4.0 * float(sigma_px))) + 1
    cols = np.floor(x0)[:, None].astype(np.intp) + np.arange(-reach, reach + 1)[None, :]
    s = cols - x0[:, None]
    k = np.exp(-0.5 * (s / float(sigma_px)) ** 2)
    seen = pm[row[:, None], np.clip(cols, 0, w - 1)]
    floor = float(imin) if floor_span is None else lowered_floor(seen, imin, floor_span)
    amp = np.maximum(seen - floor, 0.0)
    z = np.sum(k * amp * np.exp(2j * np.pi * s / float(pitch_px)), axis=1)
    out[ok] = np.angle(z)
    return out


def fit_blur_sigma(
    residual: ArrayLike,
    bias_of: Callable[[float], F64],
    max_sigma_px: float,
) -> float:
    """The blur whose map bias best explains a phase residual (least squares, one scalar).

    ``residual`` is the measured phase minus a reference that does not carry the map's bias
    (the mapping sets' phase, projected at one MIGL); its noise averages out over the pixels,
    so one blur for the whole field is well determined from the pixels near map steps.

    Parameters
    ----------
    residual : array_like (H, W)
        Radians (NaN ignored), wrapped into ``(-pi, pi]`` before use.
    bias_of : callable
        ``sigma -> bias map`` (e.g. :func:`map_phase_bias` with the other arguments bound).
    max_sigma_px : float
        Upper end of the search, > 0.

    Returns
    -------
    float
        The blur in ``[0, max_sigma_px]``.

    Examples
    --------
    >>> x = np.linspace(-1, 1, 200)[None, :]
    >>> fit = fit_blur_sigma(0.3 * 1.5**2 * x, lambda s: 0.3 * s**2 * x, 4.0)
    >>> round(fit, 3)
    1.5
    """
    r = np.angle(np.exp(1j * np.asarray(residual, dtype=np.float64)))
    if not float(max_sigma_px) > 0:
        raise InputError(f"max_sigma_px must be > 0, got {max_sigma_px!r}")

    def cost(sigma: float) -> float:
        d = r - bias_of(float(sigma))
        d = d[np.isfinite(d)]
        return float(np.mean(d**2)) if d.size else 0.0

    from scipy.optimize import minimize_scalar

    out = minimize_scalar(
        cost, bounds=(0.0, float(max_sigma_px)), method="bounded", options={"xatol": 1e-3}
    )
    return float(out.x)
