"""Fused, row-block decoding of sinusoidal N-step sets on a small thread pool (issue 16).

The kernel behind :func:`hdrfringe.core.phase.sinusoidal_phase` (float64) and
:func:`hdrfringe.core.phase.decode_set` (sinusoidal sets with the contract's shifts). The image
stack is cut into blocks of consecutive pixels (whole rows, or parts of rows for very wide
images); for each block, one pass over the N shifts accumulates ``S``, ``C``, the sum and the
saturation count in cache-sized float64 work arrays, and the phase, modulation, mean, data
modulation and validity are written straight into the output maps. Nothing of full image size
is allocated besides the returned maps, so the peak memory is the outputs plus a few blocks
(benchmarks/bench_memory.py), where the plain expression first copies the whole stack to
float64 (8x the input for uint8). (The callers pass ``stack.reshape(N, -1)``: a view for the
usual C-ordered stacks, a copy in the input's dtype for strided or transposed ones.)

The arithmetic is the plain one, in the same order as a straightforward numpy loop: ``S = 0 +
I_0 sin(delta_0) + I_1 sin(delta_1) + ...`` (multiply, then add, in float64), ``C`` likewise,
``phase = atan2(-S, C)`` wrapped to [0, 2*pi) (zero is +0.0), ``I' = (2/N) sqrt(S^2 + C^2)``,
``I'' = (sum_k I_k) / N``. It is therefore bit-identical to that loop (the reference of
benchmarks/bench_phase.py), not to a BLAS product, whose fused multiply-adds round
differently in the last bit.

Maps stored in float32 (``dtype=np.float32``, ``decode_set(..., dtype=...)``) are computed the
same way in float64 per block and rounded into the maps at the end of each block: the float64
maps' ``astype(np.float32)``, bit for bit, at half the output memory.

Blocks are handed out one at a time to at most :func:`decode_threads` threads (numpy releases
the GIL inside its ufunc loops, so two threads keep two cores busy without BLAS); the pool is
created per call and joined before returning, so no thread outlives a call. Images of fewer
than two blocks are decoded in the calling thread.

Native kernel: when the C library ``hdrfringe/core/_native/decode.c`` is built
(:func:`hdrfringe.core._native.load`) and the stack is uint8, uint16, float32 or float64 with
contiguous pixels, a block is decoded by two C calls around one ``np.arctan2``:
``hf_decode_sums`` (one pass per pixel over the N shifts: ``-S``, ``C``, I', I'' and the
saturation count) and, after numpy's SIMD ``atan2`` on the block, ``hf_decode_finish`` (the
wrap to [0, 2*pi), validity, NaN filling, psi, the stores, float32 rounding). The C code does
the same operations in the same order as the numpy kernel below (no fused multiply-add: the
build uses ``-ffp-contract=off``), so the maps are bit-identical whichever path runs
(tests/test_native_decode.py). ctypes releases the GIL during each call, so the thread pool
uses both cores. Without the library, with ``HDRFRINGE_NATIVE=0``, or for other dtypes and
layouts, the numpy kernel runs.
"""

from __future__ import annotations

import ctypes
import itertools
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core import _native

__all__ = [
    "BLOCK_PIXELS",
    "DecodeMaps",
    "decode_sinusoidal_blocks",
    "decode_threads",
    "pixel_blocks",
]

#: Pixels per block. 32768 float64 values are 256 KiB: a block's work arrays and its slices of
#: the stack and maps stay in a core's L2/L3 cache, and the per-call overhead of the ~60 numpy
#: calls per block is paid ten times for a 648x494 image (``bench_phase.py --blocks``:
#: 16384-65536 are within noise of each other, 4096 and smaller are slower).
BLOCK_PIXELS = 32768

#: Upper bound on the worker threads of one decode (override: ``HDRFRINGE_DECODE_THREADS``).
MAX_THREADS = 8

TWO_PI = 2.0 * np.pi

F64 = NDArray[np.float64]


def decode_threads(n_blocks: int) -> int:
    """Worker threads for a decode of ``n_blocks`` blocks.

    The CPUs this process may run on (``os.sched_getaffinity`` where available), capped by
    :data:`MAX_THREADS` and by the number of blocks; ``HDRFRINGE_DECODE_THREADS`` (a positive
    integer) overrides the CPU count, e.g. 1 inside a process pool that already uses every
    core.

    Parameters
    ----------
    n_blocks : int
        Number of blocks to decode.

    Returns
    -------
    int
        At least 1.

    Examples
    --------
    >>> decode_threads(1)
    1
    """
    env = os.environ.get("HDRFRINGE_DECODE_THREADS", "").strip()
    if env.isdigit() and int(env) > 0:
        cpus = int(env)
    elif hasattr(os, "sched_getaffinity"):
        cpus = len(os.sched_getaffinity(0))
    else:  # pragma: no cover - platforms without affinity (macOS, Windows)
        cpus = os.cpu_count() or 1
    return max(1, min(cpus, MAX_THREADS, n_blocks))


def pixel_blocks(n_pixels: int, block: int) -> list[tuple[int, int]]:
    """Consecutive ``[start, stop)`` pixel ranges of at most ``block`` pixels covering all.

    Parameters
    ----------
    n_pixels : int
        Pixels to cover (``H * W``).
    block : int
        Largest block.

    Returns
    -------
    list of (int, int)

    Examples
    --------
    >>> pixel_blocks(10, 4)
    [(0, 4), (4, 8), (8, 10)]
    >>> pixel_blocks(0, 4)
    []
    """
    block = max(1, int(block))
    return [(p, min(p + block, n_pixels)) for p in range(0, n_pixels, block)]


class DecodeMaps:
    """The maps a block decode writes, as flat float / uint8 / bool arrays of P pixels.

    Parameters
    ----------
    n_pixels : int
        Pixels per map.
    quality : bool
        Allocate the modulation and mean maps.
    validity : bool
        Allocate the data modulation, saturation count and validity maps (``decode_set``).
    dtype : {float64, float32}
        Storage of the float maps (phase, modulation, mean, data modulation). The decode
        computes in float64 either way; float32 maps hold those values rounded to nearest.

    Examples
    --------
    >>> maps = DecodeMaps(6, quality=True, validity=False)
    >>> maps.phase.shape, maps.modulation.dtype, maps.valid is None
    ((6,), dtype('float64'), True)
    >>> DecodeMaps(6, quality=False, validity=False, dtype=np.float32).phase.dtype
    dtype('float32')
    """

    def __init__(
        self, n_pixels: int, *, quality: bool, validity: bool, dtype: type = np.float64
    ) -> None:
        quality = quality or validity
        self.dtype: np.dtype[Any] = np.dtype(dtype)
        dt = self.dtype
        self.phase: NDArray = np.empty(n_pixels, dt)
        self.modulation: NDArray | None = np.empty(n_pixels, dt) if quality else None
        self.mean: NDArray | None = np.empty(n_pixels, dt) if quality else None
        self.data_modulation: NDArray | None = np.empty(n_pixels, dt) if validity else None
        self.saturation_count: NDArray[np.uint8] | None = (
            np.empty(n_pixels, dtype=np.uint8) if validity else None
        )
        self.valid: NDArray[np.bool_] | None = np.empty(n_pixels, dtype=bool) if validity else None


class _Work:
    """One thread's cache-sized work arrays (with ``staging``: float64 copies of the float maps'
    blocks, for maps stored in float32)."""

    def __init__(self, size: int, staging: bool = False) -> None:
        self.s = np.empty(size)
        self.c = np.empty(size)
        self.f = np.empty(size)
        self.tmp = np.empty(size)
        self.flag = np.empty(size, dtype=bool)
        self.staged: tuple[F64, F64, F64, F64] | None = None
        if staging:
            self.staged = (np.empty(size), np.empty(size), np.empty(size), np.empty(size))


def _decode_block(
    flat: NDArray,
    p0: int,
    p1: int,
    maps: DecodeMaps,
    work: _Work,
    sin_d: F64,
    cos_d: F64,
    full: float | None,
    min_modulation: float,
    reject_saturated: bool,
    mask: NDArray[np.bool_] | None,
) -> None:
    """Decode pixels ``[p0, p1)`` of ``flat`` (N, P) into ``maps`` (one fused pass).

    Only plain (unmasked) ufuncs and ``np.putmask``: a ufunc with ``where=`` costs several
    times the plain one (benchmarks/README.md, "Fused block decode").
    """
    m = p1 - p0
    n = flat.shape[0]
    s, c, f, tmp, flag = work.s[:m], work.c[:m], work.f[:m], work.tmp[:m], work.flag[:m]
    quality = maps.modulation is not None
    validity = maps.valid is not None
    # float64 destinations of this block: the maps themselves, or (float32 maps) the staging
    # arrays, rounded into the maps at the end: the same values as the float64 maps' astype.
    staged = work.staged is not None
    phase: F64
    modulation: F64 | None
    total: F64 | None
    psi: F64 | None
    if work.staged is not None:
        phase, modulation, total, psi = (a[:m] for a in work.staged)
        modulation = None if maps.modulation is None else modulation
        total = None if maps.mean is None else total
        psi = None if maps.data_modulation is None else psi
    else:
        phase = maps.phase[p0:p1]
        modulation = None if maps.modulation is None else maps.modulation[p0:p1]
        total = None if maps.mean is None else maps.mean[p0:p1]
        psi = None if maps.data_modulation is None else maps.data_modulation[p0:p1]
    s.fill(0.0)
    c.fill(0.0)
    sat = None
    limit = np.inf if full is None else full
    if quality:
        assert total is not None
        total.fill(0.0)
    if validity:
        assert maps.saturation_count is not None
        sat = maps.saturation_count[p0:p1]
        sat.fill(0)
    for k in range(n):
        img = flat[k, p0:p1]
        np.copyto(f, img)  # exact: every camera type fits a float64
        np.multiply(f, sin_d[k], out=tmp)
        s += tmp
        np.multiply(f, cos_d[k], out=tmp)
        c += tmp
        if total is not None:
            total += f
        if sat is not None:
            np.greater_equal(img, limit, out=flag)
            sat += flag
    if quality:
        assert modulation is not None and total is not None
        np.multiply(s, s, out=modulation)
        np.multiply(c, c, out=tmp)
        modulation += tmp
        np.sqrt(modulation, out=modulation)
        modulation *= 2.0 / n
        total /= n
    np.negative(s, out=s)
    np.arctan2(s, c, out=phase)
    # [0, 2*pi) like np.mod(phase, 2*pi), bit for bit: atan2 is in [-pi, pi], so adding 2*pi
    # where <= 0 is np.mod's result (adding +0.0 elsewhere changes nothing: no -0.0 is left
    # there), and a sum that rounds to 2*pi (from -0.0 or a tiny negative) becomes +0.0.
    np.less_equal(phase, 0.0, out=flag)
    np.multiply(flag, TWO_PI, out=tmp)
    phase += tmp
    np.greater_equal(phase, TWO_PI, out=flag)
    np.putmask(phase, flag, 0.0)
    if validity:
        assert modulation is not None and total is not None and psi is not None
        _validity(flat, p0, p1, maps, phase, modulation, total, psi, flag, min_modulation,
                  reject_saturated, mask)  # fmt: skip
    if staged:
        np.copyto(maps.phase[p0:p1], phase)  # float64 -> float32, rounded to nearest
        for dst, src in ((maps.modulation, modulation), (maps.mean, total),
                         (maps.data_modulation, psi)):  # fmt: skip
            if dst is not None:
                assert src is not None
                np.copyto(dst[p0:p1], src)


def _validity(
    flat: NDArray,
    p0: int,
    p1: int,
    maps: DecodeMaps,
    phase: F64,
    modulation: F64,
    total: F64,
    psi: F64,
    flag: NDArray[np.bool_],
    min_modulation: float,
    reject_saturated: bool,
    mask: NDArray[np.bool_] | None,
) -> None:
    """Validity, NaN filling and data modulation of one block (float64 block arrays)."""
    assert maps.valid is not None and maps.saturation_count is not None
    sat = maps.saturation_count[p0:p1]
    valid = maps.valid[p0:p1]
    np.greater_equal(modulation, min_modulation, out=valid)
    if flat.dtype.kind == "f":  # integer images always give a finite phase
        np.isfinite(phase, out=flag)
        valid &= flag
    if reject_saturated:
        np.equal(sat, 0, out=flag)
        valid &= flag
    if mask is not None:
        valid &= mask[p0:p1]
    np.logical_not(valid, out=flag)
    for arr in (phase, modulation, total):
        np.putmask(arr, flag, np.nan)
    # psi = I'/I'' where I'' > 0, else NaN (np.nan, as the fill of data_modulation). Where
    # invalid, I'' is np.nan already and so is the quotient; I'' <= 0 is masked after.
    with np.errstate(divide="ignore", invalid="ignore"):
        np.divide(modulation, total, out=psi)
    np.less_equal(total, 0.0, out=flag)
    np.putmask(psi, flag, np.nan)


# --- native kernel (hdrfringe/core/_native/decode.c) ---------------------------------------------

#: Stack dtypes the C kernel reads (its ``dtype`` codes); others take the numpy path.
_NATIVE_DTYPES = {np.dtype(np.uint8): 0, np.dtype(np.uint16): 1, np.dtype(np.float32): 2,
                  np.dtype(np.float64): 3}  # fmt: skip


#: Instruction set of the C kernel's loops: -1 the best the CPU has (decode.c picks it per call),
#: else 0 baseline (SSE2 on x86-64), 1 AVX2, 2 AVX-512F, capped at what the CPU has. Every
#: variant gives the same bits (tests/test_native_decode.py runs each one).
_ISA = -1


class _Params(ctypes.Structure):
    """``hf_decode_params`` of decode.c (same fields, same order)."""

    _fields_ = [
        ("stack", ctypes.c_void_p),
        ("row_stride", ctypes.c_int64),
        ("sin_d", ctypes.c_void_p),
        ("cos_d", ctypes.c_void_p),
        ("full", ctypes.c_double),
        ("min_modulation", ctypes.c_double),
        ("mask", ctypes.c_void_p),
        ("phase", ctypes.c_void_p),
        ("modulation", ctypes.c_void_p),
        ("mean", ctypes.c_void_p),
        ("psi", ctypes.c_void_p),
        ("sat", ctypes.c_void_p),
        ("valid", ctypes.c_void_p),
        ("dtype", ctypes.c_int32),
        ("n", ctypes.c_int32),
        ("quality", ctypes.c_int32),
        ("validity", ctypes.c_int32),
        ("check_finite", ctypes.c_int32),
        ("reject_saturated", ctypes.c_int32),
        ("out_f32", ctypes.c_int32),
        ("isa", ctypes.c_int32),
    ]


@cache
def _kernel_functions(lib: ctypes.CDLL) -> tuple[Any, Any]:
    """``hf_decode_sums`` and ``hf_decode_finish`` of ``lib`` with their C signatures."""
    ptr, i64 = ctypes.c_void_p, ctypes.c_int64
    sums, finish = lib.hf_decode_sums, lib.hf_decode_finish
    sums.argtypes = [ctypes.POINTER(_Params), i64, i64, ptr, ptr, ptr, ptr]
    finish.argtypes = [ctypes.POINTER(_Params), i64, i64, ptr, ptr, ptr]
    sums.restype = finish.restype = ctypes.c_int
    return sums, finish


def _native_kernels(flat: NDArray) -> tuple[Any, Any] | None:
    """The C kernel's two functions when it is built, enabled and can read ``flat``, else None.

    Readable: a dtype of :data:`_NATIVE_DTYPES` in native byte order, aligned, pixels
    contiguous within each shift (any stride between shifts, negative included).
    """
    lib = _native.load("decode")
    code = _NATIVE_DTYPES.get(flat.dtype)
    if lib is None or code is None or not flat.dtype.isnative or not flat.flags.aligned:
        return None
    item = flat.dtype.itemsize
    if flat.shape[1] > 1 and flat.strides[1] != item:
        return None
    if flat.strides[0] % item:
        return None
    return _kernel_functions(lib)


class _NativeWork:
    """One thread's scratch for the C kernel: ``C`` of a block, and (float32 maps) float64
    blocks of the phase, I' and I'' (the float64 maps' own slices are used otherwise)."""

    def __init__(self, size: int, staging: bool) -> None:
        self.c = np.empty(size)
        self.staged: tuple[F64, F64, F64] | None = None
        if staging:
            self.staged = (np.empty(size), np.empty(size), np.empty(size))


def _address(arr: NDArray | None) -> int | None:
    return None if arr is None else int(arr.ctypes.data)


def _decode_native(
    kernels: tuple[Any, Any],
    flat: NDArray,
    maps: DecodeMaps,
    blocks: list[tuple[int, int]],
    size: int,
    sin_d: F64,
    cos_d: F64,
    full: float | None,
    min_modulation: float,
    reject_saturated: bool,
    mask: NDArray[np.bool_] | None,
) -> None:
    """Decode every block of ``flat`` into ``maps`` with the C kernel (same maps, bit for bit,
    as :func:`_decode_block`)."""
    sums, finish = kernels
    n = flat.shape[0]
    quality = maps.modulation is not None
    validity = maps.valid is not None
    staging = maps.dtype != np.float64
    mask_c = None if mask is None or not validity else np.ascontiguousarray(mask, dtype=bool)
    params = _Params(
        stack=_address(flat),
        row_stride=flat.strides[0],
        sin_d=_address(sin_d),
        cos_d=_address(cos_d),
        full=np.inf if full is None else float(full),
        min_modulation=float(min_modulation),
        mask=_address(mask_c),
        phase=_address(maps.phase),
        modulation=_address(maps.modulation),
        mean=_address(maps.mean),
        psi=_address(maps.data_modulation),
        sat=_address(maps.saturation_count),
        valid=_address(maps.valid),
        dtype=_NATIVE_DTYPES[flat.dtype],
        n=n,
        quality=int(quality),
        validity=int(validity),
        check_finite=int(flat.dtype.kind == "f"),
        reject_saturated=int(reject_saturated),
        out_f32=int(staging),
        isa=_ISA,
    )
    ref = ctypes.byref(params)
    phase_map = maps.phase
    bases = (
        int(phase_map.ctypes.data),
        _address(maps.modulation) if quality else None,
        _address(maps.mean) if quality else None,
    )

    def worker(p0: int, p1: int, work: _NativeWork) -> None:
        m = p1 - p0
        c = work.c[:m]
        ph: int | None
        mb: int | None
        tb: int | None
        if work.staged is not None:
            phase = work.staged[0][:m]
            ph, mb, tb = (int(a.ctypes.data) for a in work.staged)
        else:
            phase = phase_map[p0:p1]
            ph, mb, tb = (None if b is None else b + 8 * p0 for b in bases)
        if sums(ref, p0, p1, ph, int(c.ctypes.data), mb, tb):
            raise RuntimeError(f"native decode: unsupported stack dtype {flat.dtype}")
        np.arctan2(phase, c, out=phase)  # numpy's SIMD atan2 on (-S, C), in place
        finish(ref, p0, p1, ph, mb, tb)

    # keep the buffers the C code reads alive for the duration of the pool
    _keep = (flat, sin_d, cos_d, mask_c)
    _run_blocks(blocks, worker, size, make_work=lambda: _NativeWork(size, staging))
    del _keep


def _run_blocks(
    blocks: list[tuple[int, int]],
    worker: Callable[[int, int, Any], None],
    size: int,
    staging: bool = False,
    make_work: Callable[[], Any] | None = None,
) -> None:
    """Run ``worker(p0, p1, work)`` on every block, on up to :func:`decode_threads` threads.

    ``work`` is one thread's work arrays: ``make_work()``, or ``_Work(size, staging)``.
    Blocks are taken one at a time from a shared counter (a busy core just takes fewer); the
    calling thread is one of the workers. An exception in any thread stops the others at
    their next block and is raised here.
    """
    if make_work is None:

        def make_work() -> _Work:
            return _Work(size, staging)

    threads = decode_threads(len(blocks))
    if threads == 1:
        work = make_work()
        for p0, p1 in blocks:
            worker(p0, p1, work)
        return
    counter = itertools.count()
    failed = threading.Event()

    def run() -> None:
        work = make_work()
        while not failed.is_set():
            i = next(counter)
            if i >= len(blocks):
                return
            try:
                worker(*blocks[i], work)
            except BaseException:
                failed.set()
                raise

    # The calling thread is one of the workers: one thread fewer to start per call.
    with ThreadPoolExecutor(threads - 1, thread_name_prefix="hdrfringe-decode") as pool:
        futures = [pool.submit(run) for _ in range(threads - 1)]
        run()  # an exception here stops the pool's threads at their next block
    for future in futures:
        future.result()


def decode_sinusoidal_blocks(
    flat: NDArray,
    *,
    quality: bool = True,
    full: float | None = None,
    min_modulation: float = 0.0,
    reject_saturated: bool = True,
    mask: NDArray[np.bool_] | None = None,
    block: int | None = None,
    dtype: type = np.float64,
) -> DecodeMaps:
    """Eq. 2.2 and the quality maps of a checked (N, P) stack, block by block, in float64.

    Parameters
    ----------
    flat : ndarray, shape (N, P)
        Shift k at index k, ``delta_k = 2*pi*k/N``; any real dtype (uint8, uint16, float
        with NaN), any strides.
    quality : bool
        Also compute the modulation ``I' = (2/N) sqrt(S^2 + C^2)`` and mean ``I''``.
    full : float, optional
        Full scale ``2^B - 1``. When given, also the saturation count, data modulation
        ``psi = I'/I''`` (NaN where ``I'' <= 0``) and validity (finite phase, ``I' >=
        min_modulation``, no saturated shift if ``reject_saturated``, inside ``mask``), and
        every float map is NaN where invalid: :func:`hdrfringe.core.phase.decode_set`'s maps.
    min_modulation : float
        Validity threshold on I' (with ``full``).
    reject_saturated : bool
        A pixel with a saturated shift is invalid (with ``full``).
    mask : ndarray of bool, shape (P,), optional
        Pixels to decode (with ``full``).
    block : int, optional
        Pixels per block (default :data:`BLOCK_PIXELS`; tests use small blocks to exercise
        the edges).
    dtype : {float64, float32}
        Storage of the float maps. The computation is float64 either way (validity included);
        float32 maps are the float64 maps rounded to nearest, bit for bit
        (``maps64.phase.astype(np.float32)``), at half the memory.

    Returns
    -------
    DecodeMaps
        Flat maps of P pixels (``None`` for the ones not asked for).

    References
    ----------
    Thesis Eq. 2.2 (phase), Eq. 3.4-3.6 (quality maps), Sec. 5.1 (saturation).

    Examples
    --------
    >>> x = np.linspace(0, 20, 9)
    >>> imgs = np.stack([100 + 50*np.cos(2*np.pi*x/8 + 2*np.pi*k/4) for k in range(4)])
    >>> maps = decode_sinusoidal_blocks(imgs, block=4)
    >>> from hdrfringe.core.phase import angle_difference
    >>> err = np.abs(angle_difference(maps.phase, 2*np.pi*x/8)).max()
    >>> bool(err < 1e-9), round(float(maps.modulation[0]), 9)
    (True, 50.0)
    """
    n, n_pixels = flat.shape
    block = BLOCK_PIXELS if block is None else max(1, int(block))
    delta = TWO_PI * np.arange(n) / n
    sin_d, cos_d = np.sin(delta), np.cos(delta)
    validity = full is not None
    maps = DecodeMaps(n_pixels, quality=quality, validity=validity, dtype=dtype)
    staging = maps.dtype != np.float64
    blocks = pixel_blocks(n_pixels, block)
    size = min(block, max(n_pixels, 1))
    kernels = _native_kernels(flat)
    if kernels is not None:
        _decode_native(kernels, flat, maps, blocks, size, sin_d, cos_d, full, min_modulation,
                       reject_saturated, mask)  # fmt: skip
        return maps

    def worker(p0: int, p1: int, work: _Work) -> None:
        _decode_block(
            flat, p0, p1, maps, work, sin_d, cos_d, full, min_modulation, reject_saturated, mask
        )

    _run_blocks(blocks, worker, size, staging)
    return maps
