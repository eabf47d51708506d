"""The fused block decode (hdrfringe.core._blockdecode) against a plain numpy loop written here.

The reference is the straightforward float64 loop (``S += I_k sin(delta_k)``, ``C += I_k
cos(delta_k)``, ``np.mod(atan2(-S, C), 2*pi)``, ``(2/N) sqrt(S^2 + C^2)``, sum / N) and the
validity rule of :func:`hdrfringe.core.phase.decode_set` spelled out; the kernel does the same
arithmetic in the same order, so every map must be bit-identical, whatever the block size
(edges: blocks that do not divide the image, 1-row and 1-pixel images), the thread count,
the input dtype (uint8, uint16, float with NaN) and the mask.
"""

from __future__ import annotations

import threading
import tracemalloc

import numpy as np
import pytest

from hdrfringe.core import _blockdecode
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set, sinusoidal_phase

TWO_PI = 2.0 * np.pi


def reference(imgs: np.ndarray, full: int, thr: float, reject: bool, mask) -> dict:
    """decode_set's maps computed the plain way, full-size arrays, no blocks."""
    n = imgs.shape[0]
    s = np.zeros(imgs.shape[1:])
    c = np.zeros(imgs.shape[1:])
    total = np.zeros(imgs.shape[1:])
    sat = np.zeros(imgs.shape[1:], dtype=np.uint8)
    for k in range(n):
        f = imgs[k].astype(np.float64)
        s += f * np.sin(TWO_PI * k / n)
        c += f * np.cos(TWO_PI * k / n)
        total += f
        sat += (imgs[k] >= full).astype(np.uint8)
    phase = np.mod(np.arctan2(-s, c), TWO_PI)
    phase[phase >= TWO_PI] = 0.0
    modulation = (2.0 / n) * np.sqrt(s * s + c * c)
    mean = total / n
    with np.errstate(invalid="ignore", divide="ignore"):
        psi = np.where(mean > 0, modulation / mean, np.nan)
    valid = np.isfinite(phase) & (modulation >= thr)
    if reject:
        valid &= sat == 0
    if mask is not None:
        valid &= mask
    maps = {"phase": phase, "modulation": modulation, "mean": mean, "psi": psi}
    out = {k: np.where(valid, v, np.nan) for k, v in maps.items()}
    out["raw_phase"], out["raw_modulation"], out["raw_mean"] = phase, modulation, mean
    out.update(sat=sat, valid=valid)
    return out


def stack(rng: np.random.Generator, n: int, shape: tuple[int, int], dtype) -> np.ndarray:
    """Fringes with clipped, dark and flat pixels; float stacks get NaN and negative values."""
    h, w = shape
    x = np.arange(w, dtype=np.float64)[None, :] + 0.3 * np.arange(h)[:, None]
    gain = rng.uniform(0.0, 1.6, (h, w))
    imgs = np.stack(
        [120 + 110 * gain * np.cos(TWO_PI * x / 7.3 + TWO_PI * k / n) for k in range(n)]
    )
    imgs += rng.normal(0.0, 2.0, imgs.shape)
    full = 255
    if np.dtype(dtype).kind in "ui":
        scale = 1 if dtype == np.uint8 else 16
        full = 255 * scale if dtype == np.uint8 else 4095
        imgs = np.clip(np.rint(imgs * scale), 0, full).astype(dtype)
        imgs[:, :, : max(1, w // 9)] = imgs[:1, :, : max(1, w // 9)]  # flat pixels (I' = 0)
    else:
        imgs = imgs.astype(dtype)
        imgs[rng.random(imgs.shape) < 0.02] = np.nan
        imgs[:, rng.random((h, w)) < 0.05] -= 300.0  # negative mean: psi NaN
        imgs = np.minimum(imgs, full)
    return imgs


def assert_same(got: np.ndarray, want: np.ndarray, what: str) -> None:
    assert got.shape == want.shape, what
    assert got.dtype == want.dtype, what
    assert np.array_equal(got, want, equal_nan=True), what
    if got.dtype.kind == "f":  # also the sign of zero (phase 0 is +0.0)
        assert np.array_equal(np.signbit(got), np.signbit(want)), what


CASES = [
    (3, (1, 1), np.uint8),
    (3, (1, 157), np.uint8),
    (4, (37, 29), np.uint8),
    (5, (23, 41), np.uint16),
    (7, (19, 13), np.float32),
    (8, (31, 17), np.uint8),
    (12, (11, 53), np.float64),
    (16, (9, 35), np.uint16),
]


@pytest.mark.parametrize(("n", "shape", "dtype"), CASES)
@pytest.mark.parametrize("block", [7, 64, 100, 4096])
def test_decode_set_blocks_equal_the_plain_loop(n, shape, dtype, block, monkeypatch) -> None:
    """Every map, bit for bit, for blocks that split rows, end mid-row, or hold the image."""
    monkeypatch.setattr(_blockdecode, "BLOCK_PIXELS", block)
    rng = np.random.default_rng(n * 1000 + shape[1])
    imgs = stack(rng, n, shape, dtype)
    bits = 12 if dtype == np.uint16 else 8
    full = (1 << bits) - 1
    mask = rng.random(shape) < 0.8
    spec = FringeSpec("sinusoidal", n, 7.3)
    for thr, reject, m in ((None, True, None), (5.0, False, mask)):
        res = decode_set(imgs, spec, bits, mask=m, min_modulation=thr, reject_saturated=reject)
        ref = reference(imgs, full, 2.0 * full / 255 if thr is None else thr, reject, m)
        assert_same(res.wrapped_phase, ref["phase"], "phase")
        assert_same(res.modulation, ref["modulation"], "modulation")
        assert_same(res.mean_intensity, ref["mean"], "mean")
        assert_same(res.data_modulation, ref["psi"], "data modulation")
        assert_same(res.saturation_count, ref["sat"], "saturation count")
        assert_same(res.valid, ref["valid"], "valid")
    if n >= 3:
        phase, modulation, mean = sinusoidal_phase(imgs)
        assert_same(phase, ref["raw_phase"], "sinusoidal_phase")
        assert_same(modulation, ref["raw_modulation"], "sinusoidal_phase modulation")
        assert_same(mean, ref["raw_mean"], "sinusoidal_phase mean")
        assert_same(sinusoidal_phase(imgs, quality=False)[0], ref["raw_phase"], "phase alone")


def test_the_test_rejects_a_kernel_that_skips_the_last_block(monkeypatch) -> None:
    """A kernel that forgets the tail block (the classic blocking bug) is caught."""
    imgs = stack(np.random.default_rng(0), 4, (7, 9), np.uint8)
    good = _blockdecode.pixel_blocks
    monkeypatch.setattr(_blockdecode, "pixel_blocks", lambda p, b: good(p, 16)[:-1])
    res = decode_set(imgs, FringeSpec("sinusoidal", 4, 7.3), 8, min_modulation=0.0)
    ref = reference(imgs, 255, 0.0, True, None)
    assert not np.array_equal(res.saturation_count, ref["sat"]) or not np.array_equal(
        res.modulation, ref["modulation"], equal_nan=True
    )


def test_thread_count_does_not_change_any_bit_and_no_thread_is_left(monkeypatch) -> None:
    rng = np.random.default_rng(7)
    imgs = stack(rng, 6, (40, 50), np.uint8)
    flat = imgs.reshape(6, -1)
    before = set(threading.enumerate())
    results = {}
    for threads in ("1", "2", "3"):
        monkeypatch.setenv("HDRFRINGE_DECODE_THREADS", threads)
        assert _blockdecode.decode_threads(100) == int(threads)
        results[threads] = _blockdecode.decode_sinusoidal_blocks(flat, full=255, block=37)
        assert set(threading.enumerate()) == before  # the pool is joined before returning
    for threads in ("2", "3"):
        for name in ("phase", "modulation", "mean", "data_modulation", "saturation_count"):
            a, b = getattr(results["1"], name), getattr(results[threads], name)
            assert np.array_equal(a, b, equal_nan=True), (threads, name)
    assert not any(t.name.startswith("hdrfringe-decode") for t in threading.enumerate())


def test_an_error_in_a_worker_thread_is_raised_and_stops_the_pool(monkeypatch) -> None:
    monkeypatch.setenv("HDRFRINGE_DECODE_THREADS", "2")
    done: list[int] = []

    def worker(p0: int, p1: int, work) -> None:
        if p0 == 30:
            raise ValueError("block 3 failed")
        done.append(p0)

    before = set(threading.enumerate())
    with pytest.raises(ValueError, match="block 3 failed"):
        _blockdecode._run_blocks(_blockdecode.pixel_blocks(10_000, 10), worker, 10)
    assert len(done) < 999  # the other thread stopped instead of finishing every block
    assert set(threading.enumerate()) == before


def test_peak_memory_is_the_outputs_plus_a_few_blocks() -> None:
    """tracemalloc sees numpy's buffers: the decode allocates its maps and cache-sized work
    arrays, never a float64 copy of the stack (the old path: 8x this uint8 input)."""
    rng = np.random.default_rng(3)
    imgs = rng.integers(0, 255, (8, 400, 500), dtype=np.uint8)  # 1.6 MB
    spec = FringeSpec("sinusoidal", 8, 9.0)
    px = 400 * 500
    block = _blockdecode.BLOCK_PIXELS
    threads = _blockdecode.decode_threads(len(_blockdecode.pixel_blocks(px, block)))
    work = threads * (4 * 8 + 1) * block + 256 * 1024  # work arrays per thread, slack
    for call, outputs in (
        (lambda: sinusoidal_phase(imgs, quality=False), 8 * px),
        (lambda: decode_set(imgs, spec, 8), (4 * 8 + 2) * px),
    ):
        call()  # warm-up (lazy imports)
        tracemalloc.start()
        try:
            result = call()
            _, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        del result
        assert peak <= outputs + work, (peak, outputs, imgs.nbytes)


def test_zero_phase_is_positive_zero_and_pi_is_pi(monkeypatch) -> None:
    """S exactly 0: atan2(-0.0, C > 0) is -0.0 and must wrap to +0.0 (np.mod's result);
    atan2(-0.0, C < 0) is -pi and must wrap to +pi; black pixels (S = C = 0) to +0.0."""
    monkeypatch.setattr(_blockdecode, "BLOCK_PIXELS", 2)
    # per pixel the 4 shifts: S = I_1 - I_3 + I_2 * sin(pi) = 0 exactly when I_1 = I_3, I_2 = 0
    pixels = [(10, 5, 0, 5), (0, 7, 0, 7), (9, 9, 9, 9), (0, 0, 0, 0), (200, 100, 0, 100)]
    imgs = np.array(pixels, dtype=np.uint8).T[:, None, :]
    phase, _, _ = sinusoidal_phase(imgs)
    ref = reference(imgs, 255, 0.0, False, None)["raw_phase"]
    assert_same(phase, ref, "phase at S = 0")
    # (9, 9, 9, 9) is not S = 0: 9 * sin(pi) = 1.1e-15 survives the rounding of 9 + ...
    assert phase[0, [0, 1, 3, 4]].tolist() == [0.0, np.pi, 0.0, 0.0]
    assert not np.signbit(phase).any()


@pytest.mark.parametrize(
    "view",
    [
        lambda a: a[:, ::2, ::3],  # strided rows and columns (reshape copies)
        lambda a: np.asfortranarray(a),
        lambda a: a.transpose(0, 2, 1),  # images transposed in memory
        lambda a: a[::-1],  # shifts reversed: a negative stride on axis 0
    ],
)
def test_non_contiguous_stacks_decode_like_contiguous_ones(view, monkeypatch) -> None:
    monkeypatch.setattr(_blockdecode, "BLOCK_PIXELS", 50)
    imgs = view(stack(np.random.default_rng(11), 5, (24, 30), np.uint16))
    res = decode_set(imgs, FringeSpec("sinusoidal", 5, 7.3), 12)
    ref = reference(np.ascontiguousarray(imgs), 4095, 2.0 * 4095 / 255, True, None)
    for got, name in ((res.wrapped_phase, "phase"), (res.data_modulation, "psi")):
        assert_same(got, ref[name], name)
    assert_same(res.valid, ref["valid"], "valid")


# --- float32 maps (decode_set(dtype=np.float32), issue 16: peak memory) ---------------------

F32_FIELDS = ("wrapped_phase", "modulation", "mean_intensity", "data_modulation")


@pytest.mark.parametrize(("n", "shape", "dtype"), CASES[2:6])
@pytest.mark.parametrize("block", [64, 4096])
def test_float32_maps_are_the_float64_maps_rounded(n, shape, dtype, block, monkeypatch) -> None:
    """float32 maps = the float64 maps' astype(float32), bit for bit (so the TIFFs, which store
    astype(float32), are identical); validity and saturation count identical; the phase within
    half a float32 ulp of the plain float64 loop written here (2.4e-7 rad, inside 1e-6)."""
    monkeypatch.setattr(_blockdecode, "BLOCK_PIXELS", block)
    rng = np.random.default_rng(n * 77 + shape[0])
    imgs = stack(rng, n, shape, dtype)
    bits = 12 if dtype == np.uint16 else 8
    full = (1 << bits) - 1
    spec = FringeSpec("sinusoidal", n, 7.3)
    mask = rng.random(shape) < 0.8
    for kw in ({}, {"mask": mask, "min_modulation": 5.0, "reject_saturated": False}):
        r64 = decode_set(imgs, spec, bits, **kw)
        r32 = decode_set(imgs, spec, bits, dtype=np.float32, **kw)
        for name in F32_FIELDS:
            assert_same(getattr(r32, name), getattr(r64, name).astype(np.float32), name)
        assert_same(r32.valid, r64.valid, "valid")
        assert_same(r32.saturation_count, r64.saturation_count, "saturation count")
        thr = kw.get("min_modulation", 2.0 * full / 255)
        ref = reference(imgs, full, thr, kw.get("reject_saturated", True), kw.get("mask"))
        ok = ref["valid"]
        err = np.abs(r32.wrapped_phase[ok].astype(np.float64) - ref["phase"][ok])
        assert err.size == 0 or err.max() <= 2.0**-22 + 1e-15  # half ulp in [4, 8): 2.38e-7


def test_float32_for_the_general_path_and_bad_dtypes() -> None:
    """Least-squares and triangular sets (no block kernel) give the rounded float64 maps too;
    a dtype other than float32/float64 is an InputError."""
    from hdrfringe.core.patterns import fringe_gray
    from hdrfringe.errors import InputError

    x = np.arange(40.0)[None, :] + np.arange(6.0)[:, None]
    for spec in (
        FringeSpec("sinusoidal", 4, 9.0, shifts_deg=(0.0, 80.0, 185.0, 270.0)),
        FringeSpec("triangular", 3, 9.0),
    ):
        imgs = np.stack([np.rint(fringe_gray(x, spec, k)) for k in range(spec.steps)])
        imgs = (imgs * 0.8 + 20).astype(np.uint8)
        r64 = decode_set(imgs, spec, 8)
        r32 = decode_set(imgs, spec, 8, dtype=np.float32)
        for name in F32_FIELDS:
            assert_same(getattr(r32, name), getattr(r64, name).astype(np.float32), name)
        assert_same(r32.valid, r64.valid, "valid")
    with pytest.raises(InputError, match="float32 or float64"):
        decode_set(imgs, spec, 8, dtype=np.float16)


def test_float32_maps_halve_the_outputs_and_nothing_else_grows() -> None:
    """tracemalloc peak of an 8-step uint8 decode with float32 maps: 4 x 4 + 2 bytes per pixel
    of outputs (2.25x the stack) plus the work and staging blocks, not the float64 maps."""
    rng = np.random.default_rng(5)
    imgs = rng.integers(0, 255, (8, 800, 1000), dtype=np.uint8)  # 6.4 MB: outputs >> work
    spec = FringeSpec("sinusoidal", 8, 9.0)
    px = 800 * 1000
    block = _blockdecode.BLOCK_PIXELS
    threads = _blockdecode.decode_threads(len(_blockdecode.pixel_blocks(px, block)))
    work = threads * (8 * 8 + 1) * block + 256 * 1024  # work + staging arrays, slack
    decode_set(imgs, spec, 8, dtype=np.float32)
    tracemalloc.start()
    try:
        result = decode_set(imgs, spec, 8, dtype=np.float32)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert result.wrapped_phase.dtype == np.float32
    assert peak <= (4 * 4 + 2) * px + work, (peak, imgs.nbytes)
    assert peak < (4 * 8 + 2) * px  # below the float64 maps alone


def test_phase_command_map_dtype_float32_writes_the_same_tiffs(capture_folder, tmp_path) -> None:
    """``hdrfringe phase --map-dtype float32`` against the default on the conftest folder
    (4-step, centerline): the per-set TIFFs (stored as float32 either way) are identical byte
    for byte in their values; the unwrapped and absolute phases, computed from the rounded
    wrapped phase, are within 1e-6 rad with the same NaN pattern; a bad value is refused."""
    import tifffile

    from tests.conftest import run_cli_in_process

    outs = {}
    for dt in ("float64", "float32"):
        out = tmp_path / dt
        res = run_cli_in_process(
            "phase", str(capture_folder), "-o", str(out), "--no-previews", "--map-dtype", dt
        )
        assert res.returncode == 0, res.stderr
        outs[dt] = {p.relative_to(out): tifffile.imread(p) for p in sorted(out.rglob("*.tif*"))}
    assert outs["float64"].keys() == outs["float32"].keys() and outs["float64"]
    differ = []
    for name, a in outs["float64"].items():
        b = outs["float32"][name]
        assert a.dtype == b.dtype and np.array_equal(np.isnan(a), np.isnan(b)), name
        if not np.array_equal(a, b, equal_nan=True):
            differ.append(str(name))
            assert np.nanmax(np.abs(a.astype(np.float64) - b)) <= 1e-6, name
    assert all("unwrapped" in n or "absolute" in n or "std" in n for n in differ), differ
    bad = run_cli_in_process("phase", str(capture_folder), "-o", str(tmp_path / "x"),
                             "--map-dtype", "float16")  # fmt: skip
    assert bad.returncode == 2 and "--map-dtype" in bad.stderr


def test_decode_captures_map_dtype() -> None:
    """decode_captures(map_dtype="float32"): float32 set maps equal to the float64 ones
    rounded, the unwrapped phase float64 within 2.4e-7 rad; bad values refused."""
    from hdrfringe.core.captures import Captures, ProjectorInfo
    from hdrfringe.core.decode import decode_captures
    from hdrfringe.core.patterns import fringe_gray
    from hdrfringe.errors import InputError

    spec = FringeSpec("sinusoidal", 4, 1024.0)
    x = np.tile(np.arange(40.0) * 7.3, (6, 1))
    images = np.stack([np.rint(fringe_gray(x, spec, k)) for k in range(4)]).astype(np.uint8)
    caps = Captures(spec.frames(), images, 8, projector=ProjectorInfo())
    d64 = decode_captures(caps)
    d32 = decode_captures(caps, map_dtype="float32")
    (label,) = d64.set_results
    a, b = d64.set_results[label], d32.set_results[label]
    for name in F32_FIELDS:
        assert_same(getattr(b, name), getattr(a, name).astype(np.float32), name)
    u64, u32 = d64.primary.unwrapped_phase, d32.primary.unwrapped_phase
    assert u32.dtype == np.float64 and np.array_equal(np.isnan(u64), np.isnan(u32))
    assert np.nanmax(np.abs(u64 - u32)) <= 2.4e-7
    with pytest.raises(InputError, match="float64 or float32"):
        decode_captures(caps, map_dtype="float16")
    with pytest.raises(InputError, match="saturated='flag'"):
        decode_captures(caps, map_dtype="float32", saturated="exclude")
