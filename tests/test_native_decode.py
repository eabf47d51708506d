"""The native decode kernel (hdrfringe/core/_native/decode.c) against the numpy block kernel.

Both paths of :func:`hdrfringe.core._blockdecode.decode_sinusoidal_blocks` must give the same maps
bit for bit (phase, I', I'', psi, saturation count, validity, the sign of zero and the NaN
pattern), for uint8/uint16/float32/float64 stacks, N = 3..9, saturated, dark, flat and NaN
pixels, blocks that end mid-row, float32 maps, masks, and for every instruction-set variant
of the kernel this CPU can run. The numpy path runs with ``HDRFRINGE_NATIVE=0``; the plain
loop of tests/test_phase_blocks.py checks the default (native) path independently. A kernel
that sums the shifts in reverse order (the same sums, rounded differently) must be caught.
"""

from __future__ import annotations

import ctypes
import os

import numpy as np
import pytest

from hdrfringe.core import _blockdecode, _native
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set

TWO_PI = 2.0 * np.pi
MAPS = ("phase", "modulation", "mean", "data_modulation", "saturation_count", "valid")


def library() -> ctypes.CDLL:
    lib = _native.load("decode")
    if lib is None:
        pytest.fail("the decode kernel is not built (make native) or HDRFRINGE_NATIVE=0 is set")
    return lib


def isa_levels() -> list[int]:
    """The kernel variants this CPU runs: 0 baseline, 1 AVX2, 2 AVX-512F (x86-64)."""
    return list(range(int(library().hf_decode_isa()) + 1))


def stack(rng: np.random.Generator, n: int, shape: tuple[int, int], dtype) -> np.ndarray:
    """Fringes with clipped (saturated), dark, flat (I' = 0) pixels; floats with NaN and
    negative means (psi NaN)."""
    h, w = shape
    x = np.arange(w, dtype=np.float64)[None, :] + 0.37 * np.arange(h)[:, None]
    gain = rng.uniform(0.0, 1.7, (h, w))
    imgs = np.stack(
        [110 + 120 * gain * np.cos(TWO_PI * x / 6.7 + TWO_PI * k / n) for k in range(n)]
    )
    imgs += rng.normal(0.0, 2.0, imgs.shape)
    imgs[:, : max(1, h // 5)] *= 0.02  # dark rows: I' below any threshold
    if np.dtype(dtype).kind == "u":
        scale = 1 if dtype == np.uint8 else 16
        imgs = np.clip(np.rint(imgs * scale), 0, 255 * scale).astype(dtype)
        imgs[:, :, : max(1, w // 8)] = imgs[:1, :, : max(1, w // 8)]  # flat pixels
        return imgs
    imgs = imgs.astype(dtype)
    imgs[rng.random(imgs.shape) < 0.02] = np.nan
    imgs[:, rng.random((h, w)) < 0.05] -= 300.0
    return np.minimum(imgs, 255.0).astype(dtype)


def full_of(dtype) -> float:
    return 4080.0 if dtype == np.uint16 else 255.0


def decode(flat: np.ndarray, monkeypatch, *, native: bool, isa: int = -1, **kw):
    with monkeypatch.context() as m:
        m.setenv("HDRFRINGE_NATIVE", "1" if native else "0")
        m.setattr(_blockdecode, "_ISA", isa)
        assert (_blockdecode._native_kernels(flat) is not None) == native
        return _blockdecode.decode_sinusoidal_blocks(flat, **kw)


def same(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    if a is None or b is None:
        return a is None and b is None
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind != "f":
        return bool(np.array_equal(a, b))
    return bool(np.array_equal(a, b, equal_nan=True)) and bool(
        np.array_equal(np.signbit(a), np.signbit(b))
    )


def assert_same_maps(got, want) -> None:
    for name in MAPS:
        assert same(getattr(got, name), getattr(want, name)), name


def test_the_decode_kernel_is_built_and_used() -> None:
    """The test environment (the Makefile's editable install) has the compiled kernel: a broken
    C build fails here instead of silently testing the numpy path twice."""
    path = _native.library_path("decode")
    assert path.is_file(), f"{path} missing: run `make native`"
    lib = ctypes.CDLL(str(path))
    assert int(lib.hf_decode_isa()) in (0, 1, 2)
    if os.environ.get("HDRFRINGE_NATIVE", "1") != "0":
        flat = np.zeros((4, 10), dtype=np.uint8)
        assert _blockdecode._native_kernels(flat) is not None


CASES = [
    (3, (5, 37), np.uint8),
    (4, (13, 29), np.uint8),
    (5, (7, 41), np.uint16),
    (6, (9, 23), np.float32),
    (7, (11, 19), np.uint8),
    (8, (6, 31), np.float64),
    (9, (8, 27), np.uint16),
]


@pytest.mark.parametrize(("n", "shape", "dtype"), CASES)
def test_native_maps_equal_the_numpy_kernel_bit_for_bit(n, shape, dtype, monkeypatch) -> None:
    """Every map of decode_set's kernel and of sinusoidal_phase's (quality on and off), with and
    without mask / threshold / saturation rejection, float64 and float32 maps, blocks of 53
    pixels on two threads (tails mid-row) and one block; every instruction-set variant."""
    monkeypatch.setenv("HDRFRINGE_DECODE_THREADS", "2")
    rng = np.random.default_rng(100 * n + shape[1])
    flat = stack(rng, n, shape, dtype).reshape(n, -1)
    mask = rng.random(flat.shape[1]) < 0.85
    full = full_of(dtype)
    options = [
        {"full": full, "min_modulation": 2.0},
        {"full": full, "min_modulation": 7.5, "reject_saturated": False, "mask": mask},
        {"full": full, "min_modulation": 0.0, "dtype": np.float32, "mask": mask},
        {"quality": True},
        {"quality": False},
    ]
    for kw in options:
        for block in (53, 4096):
            want = decode(flat, monkeypatch, native=False, block=block, **kw)
            for isa in isa_levels():
                got = decode(flat, monkeypatch, native=True, isa=isa, block=block, **kw)
                assert_same_maps(got, want)


def test_the_test_data_has_every_kind_of_pixel(monkeypatch) -> None:
    """The identity above covers what it claims: saturated, invalid (dark, masked, NaN) and
    valid pixels, psi NaN where I'' <= 0."""
    rng = np.random.default_rng(606)
    flat = stack(rng, 6, (9, 23), np.float32).reshape(6, -1)
    maps = decode(flat, monkeypatch, native=True, full=255.0, min_modulation=2.0)
    assert maps.saturation_count is not None and maps.valid is not None
    assert (maps.saturation_count > 0).any() and maps.valid.any() and (~maps.valid).any()
    assert maps.data_modulation is not None and np.isnan(maps.data_modulation).any()
    assert np.isnan(maps.phase).any() and np.isfinite(maps.phase).any()
    u8 = stack(rng, 4, (13, 29), np.uint8)
    assert (u8 == 255).any() and (u8 == 0).any()


def test_zero_and_pi_phases_keep_their_sign(monkeypatch) -> None:
    """S exactly 0: atan2(-0.0, C > 0) = -0.0 wraps to +0.0, atan2(-0.0, C < 0) to +pi, black
    pixels to +0.0, on both paths (the sign bit is compared)."""
    pixels = [(10, 5, 0, 5), (0, 7, 0, 7), (9, 9, 9, 9), (0, 0, 0, 0), (200, 100, 0, 100)]
    flat = np.array(pixels, dtype=np.uint8).T.copy()
    for kw in ({"quality": False}, {"full": 255.0}):
        want = decode(flat, monkeypatch, native=False, **kw)
        got = decode(flat, monkeypatch, native=True, **kw)
        assert_same_maps(got, want)
        assert not np.signbit(got.phase[[0, 1, 3, 4]]).any()
        assert got.phase[[0, 1, 3, 4]].tolist() == [0.0, np.pi, 0.0, 0.0]


@pytest.mark.parametrize(
    ("view", "native"),
    [
        (lambda a: a[::-1], True),  # shifts reversed in memory: a negative stride between rows
        (lambda a: a[:, :, 1:-1], True),  # rows with gaps: reshape copies (contiguous)
        (lambda a: a.transpose(0, 2, 1), True),  # likewise
        (lambda a: a.astype(a.dtype.newbyteorder(">")), False),  # big-endian: numpy path
        (lambda a: a.astype(np.int16), False),  # a dtype the kernel does not read
    ],
)
def test_layouts_and_dtypes(view, native, monkeypatch) -> None:
    """The kernel reads any stride between shifts; other dtypes and byte orders take the numpy
    path; the maps are the numpy kernel's either way."""
    base = stack(np.random.default_rng(8), 5, (12, 21), np.uint16)
    flat = view(base).reshape(5, -1)
    if view(base).strides[0] < 0:
        assert flat.strides[0] < 0 and np.shares_memory(flat, base)  # read in place
    want = decode(flat, monkeypatch, native=False, full=4080.0, block=40)
    if native:
        got = decode(flat, monkeypatch, native=True, full=4080.0, block=40)
    else:
        monkeypatch.setenv("HDRFRINGE_NATIVE", "1")
        assert _blockdecode._native_kernels(flat) is None
        got = _blockdecode.decode_sinusoidal_blocks(flat, full=4080.0, block=40)
    assert_same_maps(got, want)


def test_pixel_strided_flat_view_takes_the_numpy_path(monkeypatch) -> None:
    """A (N, P) view with a pixel stride (every other column of a wider stack) is not read by
    the kernel; the numpy kernel decodes it."""
    imgs = stack(np.random.default_rng(9), 4, (6, 40), np.uint8)
    flat = imgs.reshape(4, -1)[:, ::2]
    monkeypatch.setenv("HDRFRINGE_NATIVE", "1")
    assert _blockdecode._native_kernels(flat) is None
    assert _blockdecode._native_kernels(np.ascontiguousarray(flat)) is not None


def test_decode_set_native_and_numpy_agree_on_a_bench_sized_set(monkeypatch) -> None:
    """decode_set end to end (default blocks and threads), float64 and float32 maps."""
    rng = np.random.default_rng(4)
    imgs = stack(rng, 4, (120, 160), np.uint8)
    spec = FringeSpec("sinusoidal", 4, 6.7)
    for dtype in (np.float64, np.float32):
        results = {}
        for native in ("1", "0"):
            monkeypatch.setenv("HDRFRINGE_NATIVE", native)
            results[native] = decode_set(imgs, spec, 8, dtype=dtype)
        for name in ("wrapped_phase", "modulation", "mean_intensity", "data_modulation"):
            assert same(getattr(results["1"], name), getattr(results["0"], name)), name
        assert same(results["1"].valid, results["0"].valid)
        assert same(results["1"].saturation_count, results["0"].saturation_count)


def test_a_kernel_summing_the_shifts_in_reverse_order_is_caught(monkeypatch) -> None:
    """The same S and C summed from the last shift to the first (mathematically equal, rounded
    differently; what a reordered or vectorised-by-reduction kernel would do) changes some
    maps in the last bit: the bit-for-bit comparison rejects it."""
    rng = np.random.default_rng(12)
    flat = stack(rng, 7, (13, 29), np.uint8).reshape(7, -1)
    monkeypatch.setenv("HDRFRINGE_NATIVE", "1")
    good = _blockdecode._native_kernels(flat)
    assert good is not None
    sums, finish = good
    n = flat.shape[0]
    delta = TWO_PI * np.arange(n) / n
    sin_r, cos_r = np.sin(delta)[::-1].copy(), np.cos(delta)[::-1].copy()

    def reversed_sums(ref, *args):
        params = ref._obj
        saved = (params.stack, params.row_stride, params.sin_d, params.cos_d)
        params.stack = saved[0] + (n - 1) * saved[1]
        params.row_stride = -saved[1]
        params.sin_d, params.cos_d = sin_r.ctypes.data, cos_r.ctypes.data
        try:
            return sums(ref, *args)
        finally:
            params.stack, params.row_stride, params.sin_d, params.cos_d = saved

    want = decode(flat, monkeypatch, native=False, full=255.0)
    monkeypatch.setattr(_blockdecode, "_native_kernels", lambda f: (reversed_sums, finish))
    broken = _blockdecode.decode_sinusoidal_blocks(flat, full=255.0)
    assert same(broken.saturation_count, want.saturation_count)  # the counts do not round
    assert not all(same(getattr(broken, k), getattr(want, k)) for k in MAPS)
    fringe = want.modulation > 1.0  # flat pixels' phase is the rounding noise of S, C ~ 0
    d = np.abs(broken.phase - want.phase)[fringe]
    d = np.minimum(d, TWO_PI - d)  # 0 and 2*pi - tiny are the same angle
    assert 0.0 < np.max(d) < 1e-12  # the same sums: only the rounding differs
