"""Phase unwrapping and absolute phase: spatial, temporal, centerline (thesis Sec. 2.4-2.5).

Every function here works on wrapped phase maps in the capture-folder contract's convention:
``phi = 2*pi*x/p (mod 2*pi)`` in ``[0, 2*pi)``, with ``x`` the projector coordinate seen by the
pixel, ``p`` the pitch in projector pixels, and NaN for invalid pixels. The unwrapped phases these
functions return always differ from the wrapped input by an exact integer multiple of ``2*pi``
at every valid pixel, and are NaN at every invalid one.

- :func:`unwrap_spatial` removes the ``2*pi`` jumps by following neighbouring pixels (thesis
  Sec. 2.4, Fig. 2.4). Its result is relative: each connected valid region is known only up to
  its own constant ``2*pi*k``.
- :func:`unwrap_temporal` (and :func:`unwrap_temporal_levels`) unwraps each pixel on its own from
  several fringe sets of decreasing pitch; when the coarsest set spans the field with one period
  the result is absolute.
- :func:`detect_centerline`, :func:`centerline_phase` (Eq. 2.12) and :func:`absolute_phase`
  (Eq. 2.13) fix the ``2*pi*k`` of a spatially unwrapped map with a projected centerline;
  :func:`absolute_phase_from_centerline` chains them.

See docs/unwrapping.md for the rules in full.
"""

from __future__ import annotations

import ctypes
import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core import _native
from hdrfringe.errors import InputError

__all__ = [
    "PhaseRegions",
    "TemporalUnwrapResult",
    "absolute_phase",
    "absolute_phase_from_centerline",
    "centerline_phase",
    "detect_centerline",
    "phase_regions",
    "unwrap_spatial",
    "unwrap_temporal",
    "unwrap_temporal_levels",
]

TWO_PI = 2.0 * np.pi

Orientation = Literal["vertical", "horizontal"]
AbsoluteMethod = Literal["round", "subtract"]
CenterlineMethod = Literal["gaussian", "halfmax"]

# 4-connectivity: the spatial unwrapper only ever compares horizontal and vertical neighbours,
# so two pixels that touch only at a corner are not connected.
_FOUR_CONNECTED = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], bool)  # 4-connectivity

# phase_regions: most one-pixel growth steps that give the pixels outside every region core
# (cuts, thin strips) a region; beyond it they count as separate specks.
_REGION_GROW_STEPS = 16

# scikit-image's unwrapper seeds a random generator; a fixed seed makes the result reproducible.
_SKIMAGE_SEED = 0


# --------------------------------------------------------------------------------------------
# Validation helpers
# --------------------------------------------------------------------------------------------


def _as_image(a: ArrayLike, name: str) -> NDArray[np.float64]:
    arr = np.asarray(a)
    if arr.ndim != 2:
        raise InputError(f"{name} must be a 2-D image, got an array of shape {arr.shape}")
    if arr.size == 0:
        raise InputError(f"{name} is empty (shape {arr.shape}); pass an image with pixels")
    if not (
        np.issubdtype(arr.dtype, np.floating)
        or np.issubdtype(arr.dtype, np.integer)
        or arr.dtype == np.bool_
    ):
        raise InputError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    return arr.astype(np.float64, copy=True)


def _valid_mask(shape: tuple[int, ...], mask: ArrayLike | None, name: str = "mask") -> NDArray:
    if mask is None:
        return np.ones(shape, dtype=bool)
    m = np.asarray(mask)
    if m.dtype != np.bool_:
        raise InputError(
            f"{name} must be a boolean array (True = valid), got dtype {m.dtype}; "
            f"pass {name}.astype(bool)"
        )
    if m.shape != shape:
        raise InputError(f"{name} has shape {m.shape} but the image has shape {shape}")
    return m


def _check_orientation(orientation: str) -> None:
    if orientation not in ("vertical", "horizontal"):
        raise InputError(f"unknown orientation {orientation!r}; use 'vertical' or 'horizontal'")


def _finite_scalar(value: float, name: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(v):
        raise InputError(f"{name} must be finite, got {v}")
    return v


# --------------------------------------------------------------------------------------------
# Spatial unwrapping
# --------------------------------------------------------------------------------------------


#: Regions larger than this get their median by a partial sort (``np.partition``) of their own
#: values; the smaller ones (specks) share one sort.
_PARTITION_ABOVE = 64


def _sorted_medians(labels: NDArray, values: NDArray, counts: NDArray) -> NDArray[np.float64]:
    """Median per label of the labels with ``counts > 0``, in label order: one sort."""
    sorted_vals = values[np.lexsort((values, labels))]
    present = counts[counts > 0]
    starts = np.concatenate(([0], np.cumsum(present)[:-1]))
    return 0.5 * (sorted_vals[starts + (present - 1) // 2] + sorted_vals[starts + present // 2])


def _partition_median(values: NDArray) -> float:
    """The median of ``values`` (the mean of the two middle order statistics) without sorting."""
    lo, hi = (values.size - 1) // 2, values.size // 2
    part = np.partition(values, (lo, hi) if hi != lo else lo)
    return 0.5 * (part[lo] + part[hi])


def _component_medians(labels: NDArray | None, values: NDArray, n: int) -> NDArray[np.float64]:
    """Median of ``values`` per label 1..n (every label present; ``labels`` may be None if n = 1).

    The mean of the two middle order statistics, as a sort by (label, value) gives them, but
    without sorting every pixel: each large region's order statistics come from a partial sort
    of its values (O(size)); only the pixels of small regions are sorted. Identical values.
    """
    if n == 1:
        return np.array([_partition_median(values)])
    assert labels is not None
    counts = np.bincount(labels, minlength=n + 1)[1:]
    out = np.empty(n)
    big = np.flatnonzero(counts > _PARTITION_ABOVE)
    if big.size == 0:
        return _sorted_medians(labels, values, counts)
    is_big = np.zeros(n + 1, dtype=bool)
    is_big[big + 1] = True
    in_big = is_big[labels]
    small = counts.copy()
    small[big] = 0
    if big.size < n:
        rest = ~in_big
        out[small > 0] = _sorted_medians(labels[rest], values[rest], small)
    big_vals = values[in_big]
    if big.size > 1:  # group the large regions' values by label (a stable integer sort)
        big_vals = big_vals[np.argsort(labels[in_big], kind="stable")]
    ends = np.cumsum(counts[big])
    for i, start, end in zip(big, ends - counts[big], ends, strict=True):
        out[i] = _partition_median(big_vals[start:end])
    return out


def _label4(mask: NDArray[np.bool_]) -> tuple[NDArray[np.int32], int]:
    """The 4-connected components of ``mask``, numbered 1..n in the raster order of their first
    pixel (0 elsewhere): what ``scipy.ndimage.label`` gives, by OpenCV (a core dependency, far
    cheaper to import than scipy.ndimage; tests/test_unwrap_identity.py compares the two)."""
    import cv2

    count, found = cv2.connectedComponents(
        np.ascontiguousarray(mask, dtype=np.uint8), connectivity=4, ltype=cv2.CV_32S
    )
    labels: NDArray[np.int32] = np.asarray(found, dtype=np.int32)
    n = int(count) - 1
    flat = labels.ravel()
    if n > 1 and (np.diff(np.maximum.accumulate(flat)) > 1).any():  # not in raster order
        _, first = np.unique(flat, return_index=True)
        remap = np.zeros(n + 1, np.int32)
        remap[np.argsort(first[1:], kind="stable") + 1] = np.arange(1, n + 1, dtype=np.int32)
        labels = remap[labels]
    return labels, n


def _orders_to_window(anchor: NDArray | float, target: float | None) -> NDArray:
    """Integer shifts ``k`` putting ``anchor + 2*pi*k`` into the window of ``target``.

    The window is ``[0, 2*pi)`` when ``target`` is None, else ``[target - pi, target + pi)``.
    """
    lo = 0.0 if target is None else target - np.pi
    return -np.floor((np.asarray(anchor) - lo) / TWO_PI)


def unwrap_spatial(
    wrapped: ArrayLike,
    mask: ArrayLike | None = None,
    *,
    reference: tuple[int, int] | None = None,
    reference_value: float | None = None,
    min_component_size: int = 1,
) -> NDArray[np.float64]:
    """Spatially unwrap a wrapped phase map, one connected valid region at a time (Sec. 2.4).

    The wrapped phase (Eq. 2.4, or any phase decoded to the contract's ``[0, 2*pi)`` convention)
    is made continuous by adding to every valid pixel the integer multiple of ``2*pi`` that keeps
    the difference between 4-connected valid neighbours below ``pi``, following the most reliable
    pixels first (the sorting-by-reliability path-following algorithm of Herraez et al.; only
    maps whose loops do not close need it, see Notes). The map is exact wherever the true phase
    changes by less than ``pi`` between neighbours.

    Parameters
    ----------
    wrapped : array_like, shape (H, W)
        Wrapped phase in radians, nominally in ``[0, 2*pi)``; any real values are accepted and
        treated modulo ``2*pi``. NaN and +-inf mark invalid pixels.
    mask : array_like of bool, shape (H, W), optional
        True where the pixel is valid. Pixels that are False, or not finite in ``wrapped``, are
        invalid: they never guide the unwrapping and are NaN in the output.
    reference : (row, col), optional
        A valid pixel whose region is anchored by that pixel instead of by its median: its
        unwrapped value is put in ``[0, 2*pi)``, or nearest to ``reference_value`` if given.
    reference_value : float, optional
        Target value (radians) for the anchor. With ``reference``: the unwrapped phase at the
        reference pixel is the value congruent to the wrapped one that lies in
        ``[reference_value - pi, reference_value + pi)``. Without ``reference``: every region's
        median is put in that window instead of in ``[0, 2*pi)``. (With ``reference``, the
        other regions keep the default rule: median in ``[0, 2*pi)``.)
    min_component_size : int
        Connected valid regions with fewer pixels are set to NaN (their offset is meaningless
        and isolated pixels are usually noise). Default 1: keep every region.

    Returns
    -------
    ndarray of float64, shape (H, W)
        Unwrapped phase; ``result - wrapped`` is an exact multiple of ``2*pi`` at valid pixels,
        NaN elsewhere.

    Raises
    ------
    InputError
        If ``wrapped`` is not a non-empty 2-D real array, ``mask`` is not a boolean array of the
        same shape, ``reference`` is outside the image or on an invalid pixel,
        ``reference_value`` is not finite, or ``min_component_size < 1``.

    Notes
    -----
    *Connected regions.* Valid pixels are grouped into 4-connected regions (OpenCV's
    ``connectedComponents``, numbered as ``scipy.ndimage.label`` numbers them)
    and each region is unwrapped on its own. The ``2*pi*k`` offset between two regions that no
    path of valid pixels joins is not observable from the spatial data, so each region is
    anchored independently: by default the median of its unwrapped phase lies in ``[0, 2*pi)``
    (the first period). A temporal unwrap or a centerline is needed to relate them.

    *Degenerate input.* An image with no valid pixel (all NaN, or an all-False mask) gives an
    all-NaN result without error; a single valid pixel keeps its wrapped value.

    *NaN.* Invalid pixels are never read: they are replaced by 0 and masked (scikit-image's
    unwrapper, the fallback, does not return when its input contains NaN).

    *Loops that close.* Where the wrapped differences between valid neighbours sum to zero
    round every loop of valid pixels (no residue, no hole whose boundary turns by ``2*pi``),
    the orders are found by integrating those differences (row runs joined vertically, every
    edge checked): every path gives the same orders there.

    *Residues.* Elsewhere the path matters, and the reliability-guided unwrapper of Herraez et
    al. (2002) decides: every pixel's dispersion is the root sum of squares of its four
    wrapped second differences (on the border and beside invalid pixels, the available ones
    scaled to four terms; image-border pixels after every interior one), edges between valid
    neighbours are visited by increasing sum of their two pixels' dispersions (most reliable
    first, ties by position), and each edge
    between two groups joins them with the ``2*pi`` offset that keeps its step below ``pi``.
    It runs in C (``hdrfringe/core/_native/unwrap.c``); when that library is not built, or
    ``HDRFRINGE_NATIVE=0``, :func:`skimage.restoration.unwrap_phase` (the same algorithm)
    decides instead. The two give the same orders except where paths disagree, inside noisy
    patches (docs/unwrapping.md).

    *Determinism.* Values are exactly ``wrapped + 2*pi*K`` (integer ``K``, one rounding), and
    each region's orders are counted from its first pixel before anchoring, so no bit depends
    on anything but the input. Only the scikit-image fallback can depend on earlier calls in
    the process where paths disagree: its border reliabilities are drawn from the C library's
    ``rand()`` (docs/unwrapping.md).

    References
    ----------
    Thesis Sec. 2.4 and Fig. 2.4 (phase unwrapping in the measurement process); M. A. Herraez
    et al., "Fast two-dimensional phase-unwrapping algorithm based on sorting by reliability
    following a noncontinuous path", Appl. Opt. 41(35), 7437-7444 (2002).

    Examples
    --------
    >>> x = np.linspace(0.0, 40.0, 200)
    >>> truth = np.tile(x, (3, 1))
    >>> out = unwrap_spatial(np.mod(truth, 2 * np.pi))
    >>> bool(np.allclose(out - out[0, 0], truth - truth[0, 0]))
    True
    """
    phase = _as_image(wrapped, "wrapped phase")
    valid = _valid_mask(phase.shape, mask) & np.isfinite(phase)
    if int(min_component_size) != min_component_size or min_component_size < 1:
        raise InputError(f"min_component_size must be an integer >= 1, got {min_component_size}")
    target = None if reference_value is None else _finite_scalar(reference_value, "reference_value")
    ref: tuple[int, int] | None = None
    if reference is not None:
        try:
            r, c = (int(v) for v in reference)
        except (TypeError, ValueError):
            raise InputError(f"reference must be a (row, col) pair, got {reference!r}") from None
        if not (0 <= r < phase.shape[0] and 0 <= c < phase.shape[1]):
            raise InputError(
                f"reference pixel {(r, c)} is outside the image of shape {phase.shape}"
            )
        if not valid[r, c]:
            raise InputError(
                f"reference pixel {(r, c)} is invalid (NaN or masked); choose a valid pixel"
            )
        ref = (r, c)

    out = np.full(phase.shape, np.nan)
    if not valid.any():
        return out
    # A map without invalid pixels is one region: no labelling, no masked array, no gathers.
    all_valid = bool(valid.all())
    labels: NDArray | None = None
    n = 1
    if not all_valid:
        labels, n = _label4(valid)
    if min_component_size > 1:
        if labels is None:
            sizes = np.array([0, valid.size])
        else:
            sizes = np.bincount(labels.ravel(), minlength=n + 1)
        small = sizes < min_component_size
        small[0] = False
        if small[1:].any():
            valid &= ~small[labels] if labels is not None else False
            all_valid = False
            if ref is not None and not valid[ref]:
                raise InputError(
                    f"reference pixel {ref} lies in a region smaller than min_component_size="
                    f"{min_component_size}; choose another pixel or a smaller size"
                )
            if not valid.any():
                return out
            labels, n = _label4(valid)

    # Shift to [-pi, pi) (scikit-image's convention, the others' too); NaN/inf replaced and
    # masked (see Notes).
    if not all_valid:
        phase[~valid] = 0.0
    centred = np.mod(phase, TWO_PI)
    centred -= np.pi
    # Fringe orders by integrating the wrapped differences when every loop of valid pixels
    # closes (no residue): then every path-following unwrapper gives these orders up to one
    # constant per region. Otherwise the reliability-guided unwrapper decides (its path
    # matters there): in C when built, else scikit-image's.
    path = _path_orders(centred, None if all_valid else valid)
    if path is None:  # residues: the reliability-guided unwrapper in C, when it is built
        path = _native_orders(centred, None if all_valid else valid)
    if path is not None:
        raw = centred + TWO_PI * path
    else:
        # imported here: only maps with residues need it, without the native library
        from skimage.restoration import unwrap_phase

        with warnings.catch_warnings():
            # (1, W) and (H, 1) images work but warn about the length-1 dimension.
            warnings.filterwarnings("ignore", message="Image has a length 1 dimension")
            if all_valid:  # nothing masked: the same call as with an all-False mask
                raw = unwrap_phase(centred, rng=_SKIMAGE_SEED)
            else:
                centred[~valid] = 0.0
                masked = np.ma.array(centred, mask=~valid)
                raw = np.ma.getdata(unwrap_phase(masked, rng=_SKIMAGE_SEED))

    # Integer fringe order of every valid pixel relative to its wrapped value, in place in a
    # fresh array: `rint((raw + pi - w) / (2*pi))`.
    w = phase.ravel() if all_valid else phase[valid]
    orders = raw.ravel() if all_valid else raw[valid]
    orders += np.pi
    orders -= w
    orders /= TWO_PI
    np.rint(orders, out=orders)
    lab = None if labels is None else labels[valid]
    # Each region's orders counted from its first pixel (raster order): the unwrapper's own
    # constant per region (scikit-image's depends on C rand(), ours on the integration's
    # start or the union-find's roots) drops out, and so from here on the result depends on
    # the orders' differences only.
    if n == 1:
        orders -= orders[0]
    else:
        assert lab is not None
        firsts = np.flatnonzero(np.diff(np.maximum.accumulate(lab), prepend=0) > 0)
        orders -= orders[firsts][lab - 1]
    unwrapped = orders * TWO_PI
    unwrapped += w

    # Regions are anchored by their median; with a reference pixel, `target` is for that pixel.
    median_target = target if ref is None else None
    shift = _orders_to_window(_component_medians(lab, unwrapped, n), median_target)
    if ref is not None:
        i_ref = int(np.ravel_multi_index(ref, phase.shape))
        if not all_valid:  # its index among the valid pixels
            i_ref = int(np.count_nonzero(valid.ravel()[:i_ref]))
        shift[(1 if lab is None else lab[i_ref]) - 1] = _orders_to_window(unwrapped[i_ref], target)
    # Values exactly `w + 2*pi*K` with the integer order K, computed in one step: the same
    # orders give the same bits, whatever split of K the steps above went through.
    if n == 1:
        orders += shift[0]
    else:
        assert lab is not None
        orders += shift[lab - 1]
    orders *= TWO_PI
    orders += w
    if all_valid:
        return orders.reshape(phase.shape)
    out[valid] = orders
    return out


def _path_orders(
    centred: NDArray[np.float64], valid: NDArray[np.bool_] | None
) -> NDArray[np.float64] | None:
    """Fringe orders of a wrapped map by integrating its wrapped differences, or None.

    ``k[q] - k[p]`` for 4-neighbours ``p, q`` (``q`` right of or below ``p``) is +1 where
    ``c[p] - c[q] > pi``, -1 where it is ``< -pi``, else 0 (scikit-image's rule, ties at
    exactly pi included). Orders are integrated along each row run of valid pixels; every run
    takes its offset from the first run above it that it touches (a forest of runs, offsets
    accumulated by pointer jumping); trees that touch only below are joined by a small
    union-find. Every vertical edge is then checked: if any loop of valid pixels does not
    close (a residue, or a hole whose boundary turns by 2 pi), the orders depend on the path
    and None is returned. Otherwise the result is the only unwrapping up to one constant per
    4-connected region.

    Parameters
    ----------
    centred : ndarray of float64, shape (H, W)
        Wrapped phase in [-pi, pi) (any value at invalid pixels).
    valid : ndarray of bool, shape (H, W), or None
        Valid pixels (None: all).

    Returns
    -------
    ndarray of float64, shape (H, W), or None
        Integer orders (meaningless at invalid pixels), or None if the map has a loop that
        does not close.
    """
    h, w = centred.shape
    d = centred[:, :-1] - centred[:, 1:]
    jx = (d > np.pi).view(np.int8) - (d < -np.pi).view(np.int8)
    d = centred[:-1] - centred[1:]
    jy = (d > np.pi).view(np.int8) - (d < -np.pi).view(np.int8)
    del d
    k_row = np.zeros((h, w), np.int32)  # |orders| < 2^31: a map has fewer pixels than that
    if valid is None:
        np.cumsum(jx, axis=1, dtype=np.int32, out=k_row[:, 1:])
        col = np.zeros(h, np.int32)
        np.cumsum(jy[:, 0], dtype=np.int32, out=col[1:])
        k_row += col[:, None]
        if not np.array_equal(k_row[1:] - k_row[:-1], jy):
            return None
        return k_row.astype(np.float64)
    jx[~(valid[:, :-1] & valid[:, 1:])] = 0  # across gaps: the runs' offsets decide
    np.cumsum(jx, axis=1, dtype=np.int32, out=k_row[:, 1:])
    starts = valid.copy()
    starts[:, 1:] &= ~valid[:, :-1]
    run = np.cumsum(starts.ravel(), dtype=np.int64) - 1  # run of each valid pixel, raster order
    n_runs = int(run[-1]) + 1
    top = np.flatnonzero((valid[:-1] & valid[1:]).ravel())  # vertical edges (top pixel)
    bot = top + w
    kr = k_row.ravel()
    need = jy.ravel()[top].astype(np.int64) - (kr[bot] - kr[top])  # offset below - above
    ra, rb = run[top], run[bot]
    parent = np.arange(n_runs)
    off = np.zeros(n_runs, np.int64)
    if top.size:
        first = np.flatnonzero(np.diff(rb, prepend=-1))  # rb is sorted: each run's first edge
        parent[rb[first]] = ra[first]
        off[rb[first]] = need[first]
    while True:  # pointer jumping: offsets relative to each tree's root
        grand = parent[parent]
        if np.array_equal(grand, parent):
            break
        off += off[parent]
        parent = grand
    resid = need - (off[rb] - off[ra])
    ta, tb = parent[ra], parent[rb]
    same = ta == tb
    if resid[same].any():
        return None
    if not same.all():
        root_off = _join_trees(ta[~same], tb[~same], resid[~same])
        if root_off is None:
            return None
        extra = np.zeros(n_runs, np.int64)
        extra[list(root_off)] = list(root_off.values())
        off += extra[parent]
    orders = off[run].reshape(h, w).astype(np.float64)  # invalid pixels: any run, harmless
    orders += k_row
    return orders


def _native_library() -> ctypes.CDLL | None:
    """The compiled unwrapper (``_native/unwrap.c``) with its argument types, or None."""
    lib = _native.load("unwrap")
    if lib is not None and lib.hf_unwrap_orders.argtypes is None:
        ptr, i64 = ctypes.c_void_p, ctypes.c_int64
        lib.hf_unwrap_orders.argtypes = [ptr, ptr, i64, i64, ptr, i64, ptr]
        lib.hf_unwrap_orders.restype = ctypes.c_int
        lib.hf_unwrap_edge_keys.argtypes = [ptr, ptr, i64, i64, ptr]
        lib.hf_unwrap_edge_keys.restype = None
    return lib


def _native_orders(
    centred: NDArray[np.float64],
    valid: NDArray[np.bool_] | None,
    order: NDArray[np.int64] | None = None,
) -> NDArray[np.float64] | None:
    """Fringe orders by the reliability-guided unwrapper of Herraez et al. (2002) in C, or None
    when the library is not built (or ``HDRFRINGE_NATIVE=0``) or the map is too large for it.

    Parameters
    ----------
    centred : ndarray of float64, shape (H, W)
        Wrapped phase in [-pi, pi); never read at invalid pixels.
    valid : ndarray of bool, shape (H, W), or None
        Valid pixels (None: all).
    order : ndarray of int64, optional
        Edge ids (``2 i``: pixel ``i`` and its right neighbour, ``2 i + 1``: and the one below)
        in the order to visit them; default: by increasing key (the C library's stable radix
        sort, as ``np.argsort(_native_edge_keys(...), kind="stable")`` orders them).

    Returns
    -------
    ndarray of float64, shape (H, W), or None
        Integer orders, each group's counted from its root (0 at invalid pixels).
    """
    lib = _native_library()
    if lib is None:
        return None
    c = np.ascontiguousarray(centred, dtype=np.float64)
    v = None if valid is None else np.ascontiguousarray(valid, dtype=np.bool_)
    h, w = c.shape
    k = np.empty((h, w), np.int32)
    o = None if order is None else np.ascontiguousarray(order, dtype=np.int64)
    rc = lib.hf_unwrap_orders(
        c.ctypes.data, None if v is None else v.ctypes.data, h, w,
        None if o is None else o.ctypes.data, 0 if o is None else o.size, k.ctypes.data,
    )  # fmt: skip
    if rc == -2:  # 2 H W >= 2^31 edges: beyond the kernel's 32-bit ids
        return None
    if rc != 0:
        raise MemoryError(f"the native unwrapper could not allocate its work arrays ({h}x{w})")
    return k.astype(np.float64)


def _native_edge_keys(
    centred: NDArray[np.float64], valid: NDArray[np.bool_] | None
) -> NDArray[np.float64]:
    """The native unwrapper's edge keys (sum of the two pixels' dispersions; inf: no edge),
    indexed by edge id (see :func:`_native_orders`). Needs the library built."""
    lib = _native_library()
    assert lib is not None
    c = np.ascontiguousarray(centred, dtype=np.float64)
    v = None if valid is None else np.ascontiguousarray(valid, dtype=np.bool_)
    keys = np.empty(2 * c.size)
    lib.hf_unwrap_edge_keys(
        c.ctypes.data, None if v is None else v.ctypes.data, c.shape[0], c.shape[1],
        keys.ctypes.data,
    )  # fmt: skip
    return keys


def _join_trees(a: NDArray, b: NDArray, delta: NDArray) -> dict[int, int] | None:
    """Offsets ``z`` with ``z[b] - z[a] = delta`` for every pair (union-find), or None if
    two pairs disagree. Keys: the roots that need a non-zero offset."""
    pairs = np.unique(np.stack([a, b, delta], axis=1), axis=0)
    up: dict[int, tuple[int, int]] = {}  # node -> (parent, z[node] - z[parent])

    def find(x: int) -> tuple[int, int]:
        total = 0
        path = []
        while x in up:
            path.append(x)
            p, d = up[x]
            total += d
            x = p
        acc = total
        for node in path:  # path compression: straight to the root
            p, d = up[node]
            up[node] = (x, acc)
            acc -= d
        return x, total

    for x, y, dz in pairs.tolist():
        rx, zx = find(x)
        ry, zy = find(y)
        if rx == ry:
            if zy - zx != dz:
                return None
            continue
        up[ry] = (rx, zx + dz - zy)
    out = {}
    for node in list(up):
        _, z = find(node)
        if z:
            out[node] = z
    return out


# --------------------------------------------------------------------------------------------
# Regions (islands) of a spatially unwrapped map
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PhaseRegions:
    """Regions of a phase map whose fringe orders spatial unwrapping cannot relate.

    Parameters
    ----------
    labels : ndarray of int32, shape (H, W)
        0 at invalid pixels; 1, 2, ... the regions by decreasing size.
    sizes : tuple of int
        Pixel count of region 1, 2, ...
    significant : int
        Regions of at least ``min_pixels`` and ``min_fraction`` of the valid pixels (they are
        labels ``1..significant``); the rest are specks.

    Examples
    --------
    >>> r = phase_regions([np.zeros((2, 5))], np.array([[1, 1, 0, 1, 1]] * 2, bool), min_pixels=1)
    >>> r.labels.tolist(), r.sizes, r.islands
    ([[1, 1, 0, 2, 2], [1, 1, 0, 2, 2]], (4, 4), True)
    """

    labels: NDArray[np.int32]
    sizes: tuple[int, ...]
    significant: int

    @property
    def islands(self) -> bool:
        """Whether there are two or more significant regions (their relative order is unknown)."""
        return self.significant > 1


def phase_regions(
    wrapped_phases: Sequence[ArrayLike],
    valid: ArrayLike | None = None,
    *,
    threshold: float = 0.8,
    min_fraction: float = 0.005,
    min_pixels: int = 100,
) -> PhaseRegions:
    """Split the valid area into regions separated by invalid pixels or phase discontinuities.

    Spatial unwrapping relates the fringe orders of two pixels only through a path of valid
    pixels along which the phase is continuous. Two parts of the valid area joined by no such
    path (islands: a separate object, or one behind a depth step) keep unknown relative orders.
    A pixel is a discontinuity when, in any of the given wrapped maps (e.g. every pitch of a
    family), the wrapped second difference ``wrap(wrap(phi[i+b] - phi[i]) - wrap(phi[i] -
    phi[i-b]))`` along a row or column, for ``b = 1`` or ``2`` (the baseline 2 catches steps
    blurred over two pixels), exceeds ``threshold``: a smooth surface has second differences
    near zero whatever its slope and pitch. Regions are the 4-connected parts of the valid
    area without the discontinuities, opened by a 5 x 5 square (strips and corridors narrower
    than 5 px, such as the remnant between two cuts along one step, form no region of their
    own); every other valid pixel then joins the region that reaches it first through valid
    pixels, and valid parts that no region reaches (a speck inside an unlit area) get labels
    of their own, so every valid pixel has a label.

    A step whose height is a multiple of every pitch (to within about ``threshold / (2*pi)``
    of a period) leaves the wrapped phases continuous and cannot be seen: the report is a
    lower bound on the islands, never a proof that there are none.

    Parameters
    ----------
    wrapped_phases : sequence of array_like, each shape (H, W)
        Wrapped phases (NaN invalid).
    valid : array_like of bool, shape (H, W), optional
        The pixels to split (default: finite in every map).
    threshold : float
        Second difference (radians) that marks a discontinuity.
    min_fraction, min_pixels : float, int
        A region counts as significant with at least ``min_pixels`` pixels and
        ``min_fraction`` of the valid pixels.

    Returns
    -------
    PhaseRegions

    Raises
    ------
    InputError
        No maps, maps of different shapes, a bad threshold.

    References
    ----------
    Thesis Sec. 2.4 (spatial unwrapping); Herraez et al. (2002) Appl. Opt. 41, 7437 (second
    differences as the reliability of a pixel).

    Examples
    --------
    A ramp with a step of 2.5 periods in the middle: two regions.

    >>> x = np.tile(np.arange(40.0), (20, 1))
    >>> x[:, 20:] += 25.0
    >>> r = phase_regions([np.mod(2 * np.pi * x / 10, 2 * np.pi)])
    >>> r.significant, r.sizes
    (2, (400, 400))
    """
    maps = [_as_image(m, "wrapped phase") for m in wrapped_phases]
    if not maps:
        raise InputError("phase_regions needs at least one wrapped phase map")
    shape = maps[0].shape
    if any(m.shape != shape for m in maps):
        raise InputError("the wrapped phase maps must all have one shape")
    t = _finite_scalar(threshold, "threshold")
    if not 0 < t <= np.pi:
        raise InputError(f"threshold must be in (0, pi] radians, got {threshold}")
    ok = np.ones(shape, bool)
    for m in maps:
        ok &= np.isfinite(m)
    if valid is not None:
        ok &= _valid_mask(shape, valid, "valid")
    cut = np.zeros(shape, bool)
    for m in maps:
        for b in (1, 2):
            for axis in (0, 1):
                n = shape[axis]
                if n <= 2 * b:
                    continue
                a = np.moveaxis(m, axis, 0)
                fwd = _wrap_pi(a[2 * b :] - a[b:-b])
                bwd = _wrap_pi(a[b:-b] - a[: -2 * b])
                with np.errstate(invalid="ignore"):
                    jump = np.abs(_wrap_pi(fwd - bwd)) > t
                np.moveaxis(cut, axis, 0)[b : n - b] |= jump
    import cv2  # OpenCV's morphology: scipy.ndimage's import costs more than the work (issue 16)

    # regions are the 4-connected parts of the kept area opened by a 5x5 square: strips and
    # corridors under 5 px wide (the remnants between two cuts along one step, a chance
    # bridge across it) belong to no region of their own (outside the image counts as cut,
    # as for scipy.ndimage.binary_opening)
    keep = cv2.morphologyEx(
        (ok & ~cut).astype(np.uint8), cv2.MORPH_OPEN, np.ones((5, 5), np.uint8),
        borderType=cv2.BORDER_CONSTANT, borderValue=0,
    ).astype(bool)  # fmt: skip
    labels, n = _label4(keep)
    # the other valid pixels join the region that reaches them first through valid pixels
    # (a few pixels: the cuts and strips are thin); valid parts no region reaches are specks
    for _ in range(_REGION_GROW_STEPS):
        todo = ok & (labels == 0)
        if not todo.any():
            break
        # the largest label among the pixel and its 4 neighbours (float64: exact for int32)
        grown = cv2.dilate(labels.astype(np.float64), _FOUR_CONNECTED.astype(np.uint8))
        step = todo & (grown > 0)
        if not step.any():
            break
        labels[step] = grown[step]
    rest = ok & (labels == 0)
    if rest.any():
        extra, n_extra = _label4(rest)
        labels[rest] = extra[rest] + n
        n += n_extra
    if n == 0:
        return PhaseRegions(np.zeros(shape, np.int32), (), 0)
    sizes = np.bincount(labels.ravel(), minlength=n + 1)[1:]
    order = np.argsort(-sizes, kind="stable")
    order = order[sizes[order] > 0]
    remap = np.zeros(n + 1, np.int32)
    remap[order + 1] = np.arange(1, len(order) + 1, dtype=np.int32)
    ranked = tuple(int(v) for v in sizes[order])
    least = max(int(min_pixels), float(min_fraction) * int(ok.sum()))
    significant = sum(1 for v in ranked if v >= least)
    return PhaseRegions(remap[labels], ranked, significant)


def _wrap_pi(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Wrap to ``[-pi, pi]`` by rounding to the nearest turn (as harmonics.py does).

    Only the size of a wrapped difference is used (against a jump threshold), so which end a
    value of exactly +-pi lands on does not matter. ``np.mod`` gives the same values between
    the ends but is many times slower on maps holding NaN (the invalid pixels), and
    phase_regions wraps 24 differences per map.
    """
    return a - TWO_PI * np.rint(a / TWO_PI)


# --------------------------------------------------------------------------------------------
# Temporal (multi-frequency) unwrapping
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TemporalUnwrapResult:
    """All levels of a hierarchical temporal unwrap (see :func:`unwrap_temporal_levels`).

    Parameters
    ----------
    phase : ndarray
        Unwrapped phase of the finest pitch (the last level), radians.
    levels : tuple of ndarray
        Unwrapped phase of every level, coarsest first; ``levels[-1] is phase``.
    level_residuals : tuple of ndarray
        For each level k >= 1, the fringe-order consistency residual
        ``|Phi_{k-1} * p_{k-1}/p_k - Phi_k|`` in radians of level k, in ``[0, pi]``.
    residual : ndarray
        Per pixel, the largest of ``level_residuals`` (zeros for a single level). Near ``pi``
        the fringe order was a coin toss; near 0 it was unambiguous.

    Examples
    --------
    >>> x = np.array([3.0, 100.5, 900.25])
    >>> phis = [np.mod(2 * np.pi * x / p, 2 * np.pi) for p in (1024, 128, 16)]
    >>> res = unwrap_temporal_levels(phis, [1024, 128, 16])
    >>> len(res.levels), len(res.level_residuals), res.levels[-1] is res.phase
    (3, 2, True)
    >>> (res.phase * 16 / (2 * np.pi)).tolist(), float(res.residual.max()) < 1e-9
    ([3.0, 100.5, 900.25], True)
    """

    phase: NDArray[np.float64]
    levels: tuple[NDArray[np.float64], ...]
    level_residuals: tuple[NDArray[np.float64], ...]
    residual: NDArray[np.float64]


def unwrap_temporal_levels(
    wrapped_phases: Sequence[ArrayLike],
    pitches: Sequence[float],
    *,
    coarse_unwrapped: bool = False,
    max_residual: float | None = None,
) -> TemporalUnwrapResult:
    """Hierarchical multi-frequency temporal unwrapping, with every level and a quality map.

    Level 0 (the coarsest pitch ``p_0``) is taken as already continuous: either its wrapped phase
    spans the field within one period (``coarse_unwrapped=False``: ``Phi_0 = phi_0 mod 2*pi``),
    or the caller passes an unwrapped phase (``coarse_unwrapped=True``: ``Phi_0 = phi_0``). Each
    finer level k then takes the fringe order predicted by the level above::

        Phi_k = phi_k + 2*pi * round((Phi_{k-1} * p_{k-1}/p_k - phi_k) / (2*pi))

    since, in the contract's convention, ``Phi_k = 2*pi*x/p_k`` for the same projector coordinate
    ``x``. The pitch ratios need not be integers. Pixels are independent, so this is exact
    wherever the scaled coarse phase ``Phi_{k-1} * p_{k-1}/p_k`` is within ``pi`` of the truth,
    i.e. where the phase error of level k-1 is below ``pi * p_k/p_{k-1}``.

    Parameters
    ----------
    wrapped_phases : sequence of array_like
        Wrapped phase maps (radians, contract convention, NaN invalid), coarsest pitch first,
        all of the same shape (any number of dimensions).
    pitches : sequence of float
        Fringe pitch of each map in projector pixels, strictly decreasing, same length.
    coarse_unwrapped : bool
        True if ``wrapped_phases[0]`` is already unwrapped (used as is, not reduced mod 2*pi).
    max_residual : float, optional
        Reliability threshold in radians, in ``(0, pi]``. A pixel whose consistency residual
        (see :class:`TemporalUnwrapResult`) exceeds it at some level is NaN from that level on.

    Returns
    -------
    TemporalUnwrapResult

    Raises
    ------
    InputError
        No maps; lengths differ; shapes differ; a pitch not finite and positive; pitches not
        strictly decreasing; ``max_residual`` outside ``(0, pi]``.

    Notes
    -----
    NaN at a pixel in any level makes that pixel NaN in that level and every finer one. With
    ``coarse_unwrapped=False`` the coarsest pitch must exceed the projector extent seen by the
    camera with some margin: a pixel whose true ``x`` is near 0 or ``p_0`` can decode to the
    other end of ``[0, 2*pi)`` and be off by ``p_0/p_k`` fringes.

    Examples
    --------
    Three pitches; the middle pixel's finest phase is corrupted by 2 rad, which the consistency
    residual exposes and ``max_residual`` rejects:

    >>> x = np.array([3.0, 100.5, 900.25])
    >>> phis = [np.mod(2 * np.pi * x / p, 2 * np.pi) for p in (1024, 128, 16)]
    >>> phis[2][1] += 2.0
    >>> res = unwrap_temporal_levels(phis, [1024, 128, 16])
    >>> res.residual.round(3).tolist()
    [0.0, 2.0, 0.0]
    >>> out = unwrap_temporal_levels(phis, [1024, 128, 16], max_residual=1.0).phase
    >>> (out * 16 / (2 * np.pi)).round(3).tolist()
    [3.0, nan, 900.25]
    """
    n = len(wrapped_phases)
    if n == 0:
        raise InputError("unwrap_temporal needs at least one wrapped phase map")
    if len(pitches) != n:
        raise InputError(
            f"got {n} wrapped phase maps but {len(pitches)} pitches; pass one pitch per map"
        )
    p = [_finite_scalar(v, f"pitches[{i}]") for i, v in enumerate(pitches)]
    for i, v in enumerate(p):
        if v <= 0:
            raise InputError(f"pitches[{i}] = {v:g} is not positive; pitches are in projector px")
    for i in range(1, n):
        if not p[i] < p[i - 1]:
            raise InputError(
                f"pitches must be strictly decreasing (coarsest first), but pitches[{i - 1}] = "
                f"{p[i - 1]:g} and pitches[{i}] = {p[i]:g}; sort the maps by decreasing pitch"
            )
    maps = [np.asarray(m, dtype=np.float64) for m in wrapped_phases]
    for i, m in enumerate(maps[1:], start=1):
        if m.shape != maps[0].shape:
            raise InputError(
                f"wrapped phase map {i} has shape {m.shape} but map 0 has shape {maps[0].shape}; "
                "all maps must come from the same camera pixels"
            )
    thr = None
    if max_residual is not None:
        thr = _finite_scalar(max_residual, "max_residual")
        if not 0 < thr <= np.pi:
            raise InputError(f"max_residual must be in (0, pi] radians, got {thr:g}")

    with np.errstate(invalid="ignore"):
        current = maps[0].copy() if coarse_unwrapped else np.mod(maps[0], TWO_PI)
        current[~np.isfinite(current)] = np.nan
        levels = [current]
        residuals: list[NDArray[np.float64]] = []
        for k in range(1, n):
            phi = maps[k]
            predicted = current * (p[k - 1] / p[k])
            current = phi + TWO_PI * np.rint((predicted - phi) / TWO_PI)
            current[~np.isfinite(current)] = np.nan
            res = np.abs(predicted - current)
            if thr is not None:
                current[res > thr] = np.nan
            levels.append(current)
            residuals.append(res)
        if residuals:
            worst = np.max(np.stack(residuals), axis=0)
        else:
            worst = np.where(np.isnan(current), np.nan, 0.0)
    return TemporalUnwrapResult(current, tuple(levels), tuple(residuals), worst)


def unwrap_temporal(
    wrapped_phases: Sequence[ArrayLike],
    pitches: Sequence[float],
    *,
    coarse_unwrapped: bool = False,
    max_residual: float | None = None,
) -> NDArray[np.float64]:
    """Unwrapped phase of the finest pitch by hierarchical temporal unwrapping.

    Shorthand for ``unwrap_temporal_levels(...).phase``; see :func:`unwrap_temporal_levels` for
    the method (``Phi_k = phi_k + 2*pi*round((Phi_{k-1}*p_{k-1}/p_k - phi_k)/(2*pi))``), the
    parameters and the errors. When the coarsest map spans the field within one period, the
    result is the absolute phase ``2*pi*x/p`` of the contract, no centerline needed.

    Parameters
    ----------
    wrapped_phases : sequence of array_like
        Wrapped phase maps (radians, contract convention, NaN invalid), coarsest pitch first,
        all of the same shape.
    pitches : sequence of float
        Fringe pitch of each map in projector pixels, strictly decreasing, same length.
    coarse_unwrapped : bool
        True if ``wrapped_phases[0]`` is already unwrapped (used as is, not reduced mod 2*pi).
    max_residual : float, optional
        Reliability threshold in radians, in ``(0, pi]``: pixels whose fringe order is less
        certain are NaN.

    Returns
    -------
    ndarray of float64
        Unwrapped phase of the finest pitch (``pitches[-1]``), shape of the maps; NaN where
        any level is NaN or the residual exceeds ``max_residual``.

    Raises
    ------
    InputError
        As :func:`unwrap_temporal_levels`.

    Examples
    --------
    >>> x = np.array([3.0, 100.5, 900.25])
    >>> phis = [np.mod(2 * np.pi * x / p, 2 * np.pi) for p in (1024, 128, 16)]
    >>> bool(np.allclose(unwrap_temporal(phis, [1024, 128, 16]), 2 * np.pi * x / 16))
    True
    """
    if max_residual is not None or len(wrapped_phases) < 2:
        return unwrap_temporal_levels(
            wrapped_phases, pitches, coarse_unwrapped=coarse_unwrapped, max_residual=max_residual
        ).phase
    # Fast path: the same arithmetic in place, without keeping every level and residual map,
    # block by block of pixels (every operation is per pixel, so the blocks give the same bits
    # as whole maps): float32 maps are widened a block at a time, and nothing of image size is
    # allocated but the result. Validation is shared by calling the full version on a
    # one-pixel view of the inputs.
    maps = [np.asarray(m) for m in wrapped_phases]
    maps = [m if m.dtype in (np.float32, np.float64) else m.astype(np.float64) for m in maps]
    unwrap_temporal_levels(
        [m.reshape(-1)[:1] if m.size else m for m in maps],
        pitches,
        coarse_unwrapped=coarse_unwrapped,
    )
    for i, m in enumerate(maps[1:], start=1):
        if m.shape != maps[0].shape:
            raise InputError(
                f"wrapped phase map {i} has shape {m.shape} but map 0 has shape {maps[0].shape}; "
                "all maps must come from the same camera pixels"
            )
    p = [float(v) for v in pitches]
    out = np.empty(maps[0].shape, dtype=np.float64)
    flat_out = out.reshape(-1)
    flat = [m.reshape(-1) for m in maps]
    block = _TEMPORAL_BLOCK
    with np.errstate(invalid="ignore"):
        for i0 in range(0, flat_out.size, block):
            part = slice(i0, i0 + block)
            first = flat[0][part].astype(np.float64)
            current = flat_out[part]
            if coarse_unwrapped:
                current[...] = first
            else:
                np.mod(first, TWO_PI, out=current)
            order = np.empty_like(current)
            for k in range(1, len(maps)):
                phi = flat[k][part].astype(np.float64, copy=False)
                current *= p[k - 1] / p[k]  # predicted phase at pitch p_k
                np.subtract(current, phi, out=order)
                order /= TWO_PI
                np.rint(order, out=order)
                order *= TWO_PI
                np.add(phi, order, out=current)
            current[~np.isfinite(current)] = np.nan
    return out


#: Pixels per block of :func:`unwrap_temporal`'s fast path (256 KiB of float64: in cache).
_TEMPORAL_BLOCK = 32768


# --------------------------------------------------------------------------------------------
# Centerline and absolute phase (Eq. 2.12-2.13)
# --------------------------------------------------------------------------------------------


def _first_index(cond: NDArray, default: int) -> NDArray[np.intp]:
    """Per row, the first column where ``cond`` holds, else ``default``."""
    has = cond.any(axis=1)
    return np.where(has, np.argmax(cond, axis=1), default)


def _last_index(cond: NDArray, default: int) -> NDArray[np.intp]:
    """Per row, the last column where ``cond`` holds, else ``default``."""
    ncol = cond.shape[1]
    has = cond.any(axis=1)
    return np.where(has, ncol - 1 - np.argmax(cond[:, ::-1], axis=1), default)


def detect_centerline(
    image: ArrayLike,
    orientation: Orientation = "vertical",
    mask: ArrayLike | None = None,
    *,
    min_contrast: float = 0.0,
    min_snr: float = 6.0,
    method: CenterlineMethod = "gaussian",
) -> NDArray[np.float64]:
    """Sub-pixel position of a projected centerline in a camera image (Sec. 2.5).

    For a vertical line (a bright column, ``CenterlineFrame`` with orientation "vertical") each
    camera row is searched for the brightest pixel; for a horizontal line each column. Around
    that peak:

    1. the background is the row's median (robust to the line, to a dark background and to
       uniform ambient light) and the noise is ``1.4826 * MAD`` of the row;
    2. the row has no line (NaN) if the peak's contrast above the background is not positive, is
       below ``min_contrast``, or is below ``min_snr`` times the noise;
    3. ``method="gaussian"``: a Gaussian through the peak and its two neighbours (a parabola
       through the logarithms of the background-subtracted values; exact for a Gaussian line
       profile; a parabola through the raw values if a neighbour is not above the background);
       ``method="halfmax"``: the midpoint of the two places where the profile crosses half the
       contrast on either side of the peak (linear interpolation between the pixels around
       each crossing), suited to wide or flat-topped lines. A saturated plateau (two or more
       neighbouring pixels sharing the maximum value) always uses "halfmax".

    Parameters
    ----------
    image : array_like, shape (H, W)
        Camera image of the centerline frame (any real dtype; NaN = invalid).
    orientation : {"vertical", "horizontal"}
        Orientation of the projected line: "vertical" returns one column per row,
        "horizontal" one row per column.
    mask : array_like of bool, shape (H, W), optional
        True where the pixel may be used. Masked pixels are ignored.
    min_contrast : float
        Minimum peak height above the background, in image units.
    min_snr : float
        Minimum peak height above the background in units of the row's robust noise.
    method : {"gaussian", "halfmax"}
        Sub-pixel estimator, see above.

    Returns
    -------
    ndarray of float64
        Shape (H,) for a vertical line, (W,) for a horizontal one: the sub-pixel column (row)
        of the line centre, pixel centres at integers; NaN where no line was found, where the
        peak or its run touches the image edge or a masked pixel.

    Raises
    ------
    InputError
        Bad image, mask, orientation, method or thresholds.

    Notes
    -----
    The brightest feature of each row is taken to be the line, so a specular highlight brighter
    than the line in the same row is mistaken for it; masking such regions avoids that. The
    estimate is unbiased for a symmetric line profile on a locally constant background.

    References
    ----------
    Thesis Sec. 2.5: the centerline image whose middle pixels are the zero phase reference
    (the method of Zhang and Huang, thesis ref. [60]).

    Examples
    --------
    A Gaussian line at column 12.3 in row 0; row 1 has no line:

    >>> cols = np.arange(24.0)
    >>> img = np.tile(10 + 200 * np.exp(-0.5 * ((cols - 12.3) / 1.2) ** 2), (2, 1))
    >>> img[1] = 10
    >>> detect_centerline(img).round(3).tolist()
    [12.3, nan]
    >>> detect_centerline(img, method="halfmax").round(2).tolist()
    [12.29, nan]
    """
    _check_orientation(orientation)
    if method not in ("gaussian", "halfmax"):
        raise InputError(f"unknown centerline method {method!r}; use 'gaussian' or 'halfmax'")
    min_contrast = _finite_scalar(min_contrast, "min_contrast")
    min_snr = _finite_scalar(min_snr, "min_snr")
    if min_contrast < 0 or min_snr < 0:
        raise InputError(
            f"min_contrast and min_snr must be >= 0, got {min_contrast:g} and {min_snr:g}"
        )
    a = _as_image(image, "centerline image")
    valid = _valid_mask(a.shape, mask) & np.isfinite(a)
    if orientation == "horizontal":
        a, valid = a.T.copy(), valid.T.copy()
    nrow, ncol = a.shape
    rows = np.arange(nrow)
    cols = np.arange(ncol)[None, :]
    result = np.full(nrow, np.nan)
    a[~valid] = np.nan
    has_any = valid.any(axis=1)
    if ncol < 3 or not has_any.any():
        return result

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN rows: nanmedian warns
        background = np.nanmedian(a, axis=1)
        noise = 1.4826 * np.nanmedian(np.abs(a - background[:, None]), axis=1)
    peak_col = np.argmax(np.where(valid, a, -np.inf), axis=1)
    peak = a[rows, peak_col]
    contrast = peak - background
    with np.errstate(invalid="ignore"):
        found = has_any & (contrast > 0) & (contrast >= min_contrast)
        found &= contrast >= min_snr * noise
    found &= (peak_col > 0) & (peak_col < ncol - 1)

    # Plateau: the run of pixels equal to the maximum that starts at the (first) argmax.
    after = cols > peak_col[:, None]
    plateau_end = _first_index(after & ~(a == peak[:, None]), ncol)  # exclusive
    plateau = (plateau_end - peak_col) >= 2

    # Half-contrast crossings: the contiguous run of pixels at or above half the contrast around
    # the peak, and where the profile crosses that level on each flank (linear interpolation).
    rel = a - background[:, None]
    half = 0.5 * contrast
    with np.errstate(invalid="ignore"):
        below = ~(rel >= half[:, None])  # NaN counts as below: the run stops at invalid pixels
    run_start = _last_index(below & (cols < peak_col[:, None]), -1) + 1  # first in run
    run_end = _first_index(below & after, ncol)  # first after run
    run_ok = (run_start > 0) & (run_end < ncol)
    s_out = np.clip(run_start - 1, 0, ncol - 1)
    s_in = np.clip(run_start, 0, ncol - 1)
    e_in = np.clip(run_end - 1, 0, ncol - 1)
    e_out = np.clip(run_end, 0, ncol - 1)
    # The run must end at a flank, not at a masked pixel.
    run_ok &= valid[rows, s_out] & valid[rows, e_out]
    with np.errstate(invalid="ignore", divide="ignore"):
        left_x = s_out + (half - rel[rows, s_out]) / (rel[rows, s_in] - rel[rows, s_out])
        right_x = e_in + (rel[rows, e_in] - half) / (rel[rows, e_in] - rel[rows, e_out])
    halfmax = 0.5 * (left_x + right_x)
    run_ok &= np.isfinite(halfmax)

    if method == "halfmax":
        position = halfmax
        ok = found & run_ok
    else:
        left_col = np.clip(peak_col - 1, 0, ncol - 1)
        right_col = np.clip(peak_col + 1, 0, ncol - 1)
        left = a[rows, left_col]
        right = a[rows, right_col]
        lb, cb, rb = left - background, contrast, right - background
        with np.errstate(invalid="ignore", divide="ignore"):
            use_log = (lb > 0) & (rb > 0)
            ll = np.log(np.where(use_log, lb, 1.0))
            lc = np.log(np.where(cb > 0, cb, 1.0))
            lr = np.log(np.where(use_log, rb, 1.0))
            den_g = ll - 2.0 * lc + lr
            den_p = left - 2.0 * peak + right
            d_gauss = 0.5 * (ll - lr) / den_g
            d_parab = 0.5 * (left - right) / den_p
            offset = np.where(use_log, d_gauss, d_parab)
        fit_ok = np.isfinite(offset) & np.isfinite(left) & np.isfinite(right)
        position = np.where(plateau, halfmax, peak_col + np.clip(offset, -0.5, 0.5))
        ok = found & np.where(plateau, run_ok, fit_ok)

    result[ok] = position[ok]
    return result


def centerline_phase(
    unwrapped: ArrayLike,
    line_positions: ArrayLike,
    orientation: Orientation = "vertical",
    *,
    statistic: Literal["mean", "median"] = "mean",
) -> float:
    """Average unwrapped phase on the centerline, ``phi_c`` of Eq. 2.12.

    For a vertical line, row ``r`` contributes the unwrapped phase at ``(r, line_positions[r])``,
    linearly interpolated between the two columns around the sub-pixel position (for a
    horizontal line, column ``c`` contributes the phase at ``(line_positions[c], c)``). Rows with
    a NaN position, a position outside the image, or a NaN phase at either interpolation node
    are skipped; ``N_c`` is the number of rows that remain::

        phi_c = (1/N_c) * sum_n phi_n                         (Eq. 2.12)

    Parameters
    ----------
    unwrapped : array_like, shape (H, W)
        Unwrapped phase map (radians, NaN invalid).
    line_positions : array_like
        Output of :func:`detect_centerline`: shape (H,) for "vertical", (W,) for "horizontal".
    orientation : {"vertical", "horizontal"}
        Orientation of the line (as for :func:`detect_centerline`).
    statistic : {"mean", "median"}
        "mean" is Eq. 2.12; "median" resists a few wrong line pixels.

    Returns
    -------
    float
        ``phi_c`` in radians.

    Raises
    ------
    InputError
        Shape mismatch, bad orientation or statistic, or no line pixel with a valid phase.

    References
    ----------
    Thesis Sec. 2.5, Eq. 2.12.

    Examples
    --------
    A phase map of pitch 4 that grows by pi/2 per column; the line is found at columns 1 and 2.5
    of rows 0 and 1, and not in row 2:

    >>> phase = np.tile(np.arange(5.0) * np.pi / 2, (3, 1))
    >>> phi_c = centerline_phase(phase, [1.0, 2.5, np.nan])
    >>> round(phi_c / (np.pi / 2), 6)
    1.75
    """
    _check_orientation(orientation)
    if statistic not in ("mean", "median"):
        raise InputError(f"unknown statistic {statistic!r}; use 'mean' or 'median'")
    phase = _as_image(unwrapped, "unwrapped phase")
    if orientation == "horizontal":
        phase = phase.T
    pos = np.asarray(line_positions, dtype=np.float64)
    if pos.shape != (phase.shape[0],):
        axis = "rows" if orientation == "vertical" else "columns"
        raise InputError(
            f"line_positions has shape {pos.shape} but a {orientation} line needs one position "
            f"per image {axis}: shape ({phase.shape[0]},)"
        )
    ncol = phase.shape[1]
    inside = np.isfinite(pos) & (pos >= 0) & (pos <= ncol - 1)
    rows = np.flatnonzero(inside)
    p = pos[rows]
    c0 = np.floor(p).astype(np.intp)
    frac = p - c0
    c1 = np.minimum(c0 + 1, ncol - 1)
    v0 = phase[rows, c0]
    v1 = phase[rows, c1]
    # At an exact integer position only the node itself is used (its neighbour may be NaN).
    samples = np.where(frac > 0, (1.0 - frac) * v0 + frac * v1, v0)
    samples = samples[np.isfinite(samples)]
    if samples.size == 0:
        # Name the actual cause: a wholly invalid phase map is not the centerline's fault.
        if not np.isfinite(phase).any():
            raise InputError(
                "the unwrapped phase map has no valid pixel, so the centerline has no phase "
                "(N_c = 0); check the exposure, saturation and the modulation threshold "
                "(--min-modulation)"
            )
        if rows.size == 0:
            raise InputError(
                "the centerline was not detected in any image row or column (N_c = 0); check "
                "that the centerline frame shows the line and that it lies inside the image"
            )
        raise InputError(
            "no centerline pixel has a valid unwrapped phase (N_c = 0); check that the line was "
            "detected and that it crosses the valid part of the phase map"
        )
    return float(np.mean(samples) if statistic == "mean" else np.median(samples))


def absolute_phase(
    unwrapped: ArrayLike,
    phi_c: float,
    position: float,
    pitch: float,
    method: AbsoluteMethod = "round",
) -> NDArray[np.float64]:
    """Absolute phase ``2*pi*x/p`` from a relative unwrapped phase and its centerline phase.

    At the centerline the projector coordinate is ``x = position``, so the absolute phase there
    is ``2*pi*position/p``.

    - ``method="subtract"`` is Eq. 2.13, ``phi_a = phi - phi_c``, shifted by the constant
      ``2*pi*position/p`` so the result is in the contract's convention::

          phi_abs = phi - phi_c + 2*pi*position/p

      The whole map inherits the error of ``phi_c`` (line detection, interpolation, noise).
    - ``method="round"`` (default) adds only the multiple of ``2*pi`` nearest to the difference::

          phi_abs = phi + 2*pi * round((2*pi*position/p - phi_c) / (2*pi))

      Since a correctly unwrapped map differs from the absolute phase by an exact ``2*pi*k``,
      this keeps the phase's own sub-fringe accuracy and the line's error does not enter,
      provided ``phi_c`` is within ``pi`` (half a period, ``p/2`` projector pixels) of the true
      phase at the line.

    Parameters
    ----------
    unwrapped : array_like
        Spatially unwrapped phase (radians, NaN invalid), any shape.
    phi_c : float
        Centerline phase from :func:`centerline_phase` (Eq. 2.12).
    position : float
        Projector coordinate of the centerline (``CenterlineFrame.position``).
    pitch : float
        Fringe pitch of the phase map in projector pixels.
    method : {"round", "subtract"}
        "round": add the nearest multiple of 2*pi (default); "subtract": Eq. 2.13 as printed.

    Returns
    -------
    ndarray of float64
        Absolute phase; NaN where ``unwrapped`` is NaN.

    Raises
    ------
    InputError
        Non-finite ``phi_c`` or ``position``, non-positive pitch, unknown method.

    References
    ----------
    Thesis Sec. 2.5, Eq. 2.13.

    Examples
    --------
    >>> x = np.array([[100.0, 130.0, 170.0]])
    >>> relative = 2 * np.pi * x / 32 - 2 * np.pi * 7          # off by 7 fringes
    >>> out = absolute_phase(relative, phi_c=relative[0, 1] + 0.3, position=130.0, pitch=32)
    >>> bool(np.allclose(out, 2 * np.pi * x / 32))
    True
    """
    phi_c = _finite_scalar(phi_c, "phi_c")
    position = _finite_scalar(position, "position")
    pitch = _finite_scalar(pitch, "pitch")
    if pitch <= 0:
        raise InputError(f"pitch must be a positive number of projector pixels, got {pitch:g}")
    phase = np.asarray(unwrapped, dtype=np.float64)
    target = TWO_PI * position / pitch
    if method == "round":
        return phase + TWO_PI * np.rint((target - phi_c) / TWO_PI)
    if method == "subtract":
        return phase - phi_c + target
    raise InputError(f"unknown absolute-phase method {method!r}; use 'round' or 'subtract'")


def absolute_phase_from_centerline(
    unwrapped: ArrayLike,
    centerline_image: ArrayLike,
    position: float,
    pitch: float,
    orientation: Orientation = "vertical",
    *,
    mask: ArrayLike | None = None,
    min_contrast: float = 0.0,
    min_snr: float = 6.0,
    line_method: CenterlineMethod = "gaussian",
    statistic: Literal["mean", "median"] = "mean",
    method: AbsoluteMethod = "round",
) -> NDArray[np.float64]:
    """Absolute phase from an unwrapped phase map and a centerline capture (Eq. 2.12-2.13).

    Chains :func:`detect_centerline` (``orientation``, ``mask``, ``min_contrast``, ``min_snr``,
    ``line_method``), :func:`centerline_phase` (``statistic``) and :func:`absolute_phase`
    (``position``, ``pitch``, ``method``); see those for the details.

    Parameters
    ----------
    unwrapped : array_like, shape (H, W)
        Spatially unwrapped phase of the fringe set with pitch ``pitch`` (same orientation as
        the line).
    centerline_image : array_like, shape (H, W)
        Camera image of the centerline frame.
    position : float
        Projector coordinate of the line.
    pitch : float
        Fringe pitch in projector pixels.
    orientation : {"vertical", "horizontal"}
        Orientation of the fringes and the line.
    mask : array_like of bool, shape (H, W), optional
        Pixels the line detection may use (:func:`detect_centerline`).
    min_contrast : float
        Minimum line contrast (:func:`detect_centerline`).
    min_snr : float
        Minimum line signal-to-noise ratio (:func:`detect_centerline`).
    line_method : {"gaussian", "halfmax"}
        Sub-pixel line estimator (``method`` of :func:`detect_centerline`).
    statistic : {"mean", "median"}
        Average over the line (:func:`centerline_phase`).
    method : {"round", "subtract"}
        How the centerline phase is applied (:func:`absolute_phase`).

    Returns
    -------
    ndarray of float64, shape (H, W)
        Absolute phase ``2*pi*x/p`` (contract convention); NaN where ``unwrapped`` is NaN.

    Raises
    ------
    InputError
        As the chained functions; in particular when no line pixel with a valid phase is found.

    References
    ----------
    Thesis Sec. 2.5, Eq. 2.12 and 2.13.

    Examples
    --------
    A relative phase of pitch 32 that is 3 fringes off, and a line at projector column 102.3
    seen at camera column 12.3: the camera columns 0..3 see projector columns 90..93.

    >>> cols = np.arange(24.0)
    >>> line_img = np.tile(10 + 200 * np.exp(-0.5 * ((cols - 12.3) / 1.2) ** 2), (2, 1))
    >>> relative = np.tile(2 * np.pi * (cols + 90) / 32 - 3 * 2 * np.pi, (2, 1))
    >>> out = absolute_phase_from_centerline(relative, line_img, position=102.3, pitch=32)
    >>> (out[0, :4] * 32 / (2 * np.pi)).round(6).tolist()
    [90.0, 91.0, 92.0, 93.0]
    """
    u = np.asarray(unwrapped)
    c = np.asarray(centerline_image)
    if u.shape != c.shape:
        raise InputError(
            f"centerline image has shape {c.shape} but the unwrapped phase has shape {u.shape}"
        )
    line = detect_centerline(
        c, orientation, mask, min_contrast=min_contrast, min_snr=min_snr, method=line_method
    )
    phi_c = centerline_phase(u, line, orientation, statistic=statistic)
    return absolute_phase(u, phi_c, position, pitch, method=method)
