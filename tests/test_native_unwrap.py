"""The reliability-guided unwrapper in C (``hdrfringe/core/_native/unwrap.c``, issue 16).

``unwrap_spatial`` calls it for the maps whose loops do not close (residues), where it called
scikit-image before; scikit-image remains the fallback when the library is not built or
``HDRFRINGE_NATIVE=0``. References the kernel did not produce: on residue-free maps the
integration path (``_path_orders``), whose orders every path-following unwrapper must give;
on noisy maps the known truth (the wrapped phase's unwrapped origin) and scikit-image's
``unwrap_phase``, the same algorithm (Herraez et al. 2002) with random border reliabilities.
Every test here turns the native library on, whatever the environment says.
"""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.core import _native
from hdrfringe.core import unwrap as unwrap_module
from hdrfringe.core.unwrap import TWO_PI, _label4, unwrap_spatial
from tests.test_unwrap_identity import reseed_c_rand
from tests.test_unwrap_paths import _maps, _ramp, _vortex


@pytest.fixture(autouse=True)
def _native_on(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("HDRFRINGE_NATIVE", "1")


def test_the_library_is_built() -> None:
    path = _native.library_path("unwrap")
    assert path.is_file(), f"{path} is missing: build the native kernels (make native)"
    assert _native.load("unwrap") is not None


def _noisy(seed: int, sigma: float, nan: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(truth, wrapped, low-modulation area) on 96x128: a tilted plane with a bump at pitch
    12 px, noise 0.05 rad, and ``sigma`` rad in round low-modulation patches covering a
    quarter of the field (residues there); with ``nan``, 5 % of the pixels NaN."""
    rng = np.random.default_rng(seed)
    h, w = 96, 128
    rows, cols = np.mgrid[0:h, 0:w].astype(float)
    bump = 12 * np.exp(-((rows - h / 2) ** 2 + (cols - 0.6 * w) ** 2) / (2 * (0.15 * w) ** 2))
    truth = TWO_PI * (3 + 0.9 * cols + 0.1 * rows + bump) / 12
    low = np.zeros((h, w), bool)
    while low.mean() < 0.25:
        r, c, rad = rng.uniform(0, h), rng.uniform(0, w), rng.uniform(0.06, 0.14) * w
        low |= (rows - r) ** 2 + (cols - c) ** 2 < rad**2
    wrapped = np.mod(truth + rng.normal(0, 1, (h, w)) * np.where(low, sigma, 0.05), TWO_PI)
    if nan:
        wrapped[rng.random((h, w)) < 0.05] = np.nan
    return truth, wrapped, low


NOISY = [(seed, sigma, seed % 2 == 1) for seed in range(8) for sigma in (0.9, 1.2)]


def _orders_per_region(result: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """For every valid pixel of ``result``: whether its fringe order relative to ``reference``
    differs from the most common one of its 4-connected region (the region's 2 pi constant is
    arbitrary)."""
    ok = np.isfinite(result)
    labels, _ = _label4(ok)
    lab = labels[ok]
    d = np.rint((result[ok] - reference[ok]) / TWO_PI).astype(np.int64)
    d -= d.min()
    counts = np.zeros((lab.max() + 1, d.max() + 1), np.int64)
    np.add.at(counts, (lab, d), 1)
    return d != counts.argmax(axis=1)[lab]


def _unwrap_by(how: str, wrapped: np.ndarray, monkeypatch: pytest.MonkeyPatch) -> np.ndarray:
    with monkeypatch.context() as m:
        if how == "skimage":
            m.setenv("HDRFRINGE_NATIVE", "0")
            reseed_c_rand()
        elif how == "increasing reliability":  # broken: least reliable edges first
            real = unwrap_module._native_orders

            def broken(centred, valid, order=None):
                keys = unwrap_module._native_edge_keys(centred, valid)
                keys[np.isinf(keys)] = -1.0
                return real(centred, valid, np.argsort(-keys, kind="stable"))

            m.setattr(unwrap_module, "_native_orders", broken)
        return unwrap_spatial(wrapped)


@pytest.fixture(scope="module")
def noisy_results() -> dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]]:
    """Per method, per noisy map: (wrong order vs truth, result, low-modulation area)."""
    out: dict[str, list] = {"native": [], "skimage": [], "increasing reliability": []}
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("HDRFRINGE_NATIVE", "1")
        for params in NOISY:
            truth, wrapped, low = _noisy(*params)
            for how in out:
                result = _unwrap_by(how, wrapped, mp)
                out[how].append((_orders_per_region(result, truth), result, low))
    return out


def test_noisy_maps_take_the_native_path(monkeypatch: pytest.MonkeyPatch) -> None:
    """The test maps have residues (the integration refuses) and the kernel answers."""
    taken: list[bool] = []
    real = unwrap_module._native_orders

    def spy(centred, valid, order=None):
        result = real(centred, valid, order)
        taken.append(result is not None)
        return result

    monkeypatch.setattr(unwrap_module, "_native_orders", spy)
    for params in NOISY[:4]:
        unwrap_spatial(_noisy(*params)[1])
    assert taken == [True] * 4


def test_wrong_orders_no_more_than_scikit_image(noisy_results) -> None:
    """Fraction of pixels whose fringe order is wrong against the truth (up to one constant
    per region), mean over 16 noisy maps: the kernel's within 0.005 of scikit-image's (the
    two differ by border reliabilities and tie-breaks; benchmarks/README.md has 100 larger
    maps), and the broken variant that joins the least reliable edges first is far worse."""
    mean = {k: float(np.mean([w.mean() for w, _, _ in v])) for k, v in noisy_results.items()}
    assert 0.005 < mean["native"] <= mean["skimage"] + 0.005, mean
    assert mean["increasing reliability"] > 10 * mean["native"], mean


def test_orders_agree_with_scikit_image_outside_the_noisy_patches(noisy_results) -> None:
    """Where the kernel and scikit-image disagree the orders depend on the path: inside or
    beside the low-modulation patches, where the residues are. On the clean three quarters of
    the field (2 px away from any patch) they agree on nearly every pixel."""
    import cv2

    clean_differ = clean = 0
    for (_, ours, low), (_, theirs, _) in zip(
        noisy_results["native"], noisy_results["skimage"], strict=True
    ):
        differ = np.zeros(ours.shape, bool)
        differ[np.isfinite(ours)] = _orders_per_region(ours, theirs)
        near = cv2.dilate(low.astype(np.uint8), np.ones((5, 5), np.uint8)).astype(bool)
        clean_differ += int((differ & ~near).sum())
        clean += int((np.isfinite(ours) & ~near).sum())
    assert clean_differ <= 0.001 * clean, (clean_differ, clean)


@pytest.mark.parametrize("name", list(_maps()))
def test_residue_free_maps_give_the_integrations_orders(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With the integration switched off the kernel decides: the same bytes (NaN included),
    on NaN-free maps, holes and specks, islands, a U, one row or column, ties at pi."""
    wrapped, mask = _maps()[name]
    expected = unwrap_spatial(wrapped, mask)
    monkeypatch.setattr(unwrap_module, "_path_orders", lambda centred, valid: None)
    got = unwrap_spatial(wrapped, mask)
    assert np.array_equal(got.view(np.int64), expected.view(np.int64)), name


def test_deterministic_whatever_the_c_rand_state() -> None:
    """No random numbers: the same bytes under three rand() states and on a second call."""
    wrapped = _noisy(3, 1.2, True)[1]
    outs = []
    for seed in (0, 1, 987654, 1):
        reseed_c_rand(seed)
        outs.append(unwrap_spatial(wrapped))
    for o in outs[1:]:
        assert np.array_equal(o.view(np.int64), outs[0].view(np.int64))


def test_nan_inf_and_masks() -> None:
    """NaN, +-inf and masked pixels are NaN in the output and decide nothing: any values
    under them give the same bytes; valid pixels are exactly ``wrapped + 2 pi K``."""
    rng = np.random.default_rng(5)
    wrapped = np.mod(_ramp((40, 56), 5, noise=0.9), TWO_PI)  # residues
    assert unwrap_module._path_orders(wrapped - np.pi, None) is None
    mask = rng.random(wrapped.shape) > 0.1
    bad = rng.random(wrapped.shape) < 0.1
    holes = wrapped.copy()
    holes[bad] = rng.choice([np.nan, np.inf, -np.inf], bad.sum())
    got = unwrap_spatial(holes, mask)
    invalid = bad | ~mask
    assert np.array_equal(np.isnan(got), invalid)
    k = (got[~invalid] - wrapped[~invalid]) / TWO_PI
    assert np.array_equal(k, np.rint(k))
    garbage = holes.copy()
    garbage[~mask] = rng.choice([np.nan, 1e300, -7.0], (~mask).sum())
    garbage[bad & mask] = np.nan
    assert np.array_equal(unwrap_spatial(garbage, mask).view(np.int64), got.view(np.int64))
    # a vortex (a residue the integration refuses): unwrapped, congruent
    v = _vortex((30, 40), (14.5, 19.5))
    out = unwrap_spatial(v)
    assert np.isfinite(out).all()
    k = (out - v) / TWO_PI
    assert np.array_equal(k, np.rint(k))


def test_the_kernel_refuses_maps_beyond_its_32_bit_edge_ids() -> None:
    """A map with 2 H W >= 2^31 edges is refused with -2 before any buffer is read (the
    caller then returns None and scikit-image decides); one edge fewer is not refused."""
    lib = unwrap_module._native_library()
    assert lib is not None
    k = np.zeros(1, np.int32)
    c = np.zeros(1)
    assert lib.hf_unwrap_orders(c.ctypes.data, None, 1 << 15, 1 << 15, None, 0, k.ctypes.data) == -2
    assert lib.hf_unwrap_orders(c.ctypes.data, None, 1, 1, None, 0, k.ctypes.data) == 0


def _reference_orders(centred: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Herraez et al. (2002) written plainly in numpy and Python, independently of the C
    kernel: dispersions from the four wrapped second differences (the available ones scaled to
    four terms beside invalid pixels, 100 with none; 100 added on the image border), edges by
    increasing D_p + D_q (stable), groups joined by relabelling the smaller one."""
    h, w = centred.shape
    c = np.pad(np.where(valid, centred, np.nan), 1, constant_values=np.nan)
    centre = c[1:-1, 1:-1]

    def wrap(d: np.ndarray) -> np.ndarray:
        return np.where(d > np.pi, d - TWO_PI, np.where(d < -np.pi, d + TWO_PI, d))

    total = np.zeros((h, w))
    count = np.zeros((h, w), int)
    for dr, dc in ((0, -1), (-1, 0), (-1, -1), (-1, 1)):
        a = c[1 + dr : 1 + dr + h, 1 + dc : 1 + dc + w]
        b = c[1 - dr : 1 - dr + h, 1 - dc : 1 - dc + w]
        s = wrap(a - centre) - wrap(centre - b)
        total += np.where(np.isnan(s), 0.0, s * s)
        count += ~np.isnan(s)
    with np.errstate(divide="ignore", invalid="ignore"):
        disp = np.where(count == 4, np.sqrt(total), np.sqrt(total * (4.0 / count)))
    disp[count == 0] = 100.0
    disp[[0, -1], :] += 100.0  # the image border after every interior pixel
    disp[1:-1, [0, -1]] += 100.0
    keys = np.full(2 * h * w, np.inf)
    d = disp.ravel()
    v = valid.ravel()
    for i in range(h * w):
        if v[i] and i % w + 1 < w and v[i + 1]:
            keys[2 * i] = d[i] + d[i + 1]
        if v[i] and i + w < h * w and v[i + w]:
            keys[2 * i + 1] = d[i] + d[i + w]
    group = np.arange(h * w)
    k = np.zeros(h * w, np.int64)
    flat = centred.ravel()
    for e in np.argsort(keys, kind="stable"):
        if not np.isfinite(keys[e]):
            break
        p = e // 2
        q = p + (w if e % 2 else 1)
        if group[p] == group[q]:
            continue
        diff = flat[p] - flat[q]
        want = k[p] + (1 if diff > np.pi else -1 if diff < -np.pi else 0)  # k[q] after joining
        gp, gq = group == group[p], group == group[q]
        if gq.sum() <= gp.sum():
            k[gq] += want - k[q]
            group[gq] = group[p]
        else:
            k[gp] -= want - k[q]
            group[gp] = group[q]
    return k.reshape(h, w)


@pytest.mark.parametrize("seed", range(4))
def test_orders_are_the_papers_algorithm_written_plainly(seed: int) -> None:
    """Per region, the kernel's orders equal the plain reference's up to one constant, on
    small noisy maps with residues, NaN and a masked border strip; and its radix sort visits the
    edges in the order of numpy's stable argsort of its keys."""
    rng = np.random.default_rng(seed)
    wrapped = np.mod(_ramp((20, 26), seed, noise=1.0), TWO_PI)
    valid = rng.random(wrapped.shape) > (0.15 if seed % 2 else 0.0)
    valid[:, -2:] &= seed < 2
    centred = np.where(valid, np.mod(wrapped, TWO_PI) - np.pi, 0.0)
    assert unwrap_module._path_orders(centred, valid) is None  # residues
    got = unwrap_module._native_orders(centred, valid)
    assert got is not None
    ref = _reference_orders(centred, valid)
    labels, n = _label4(valid)
    for r in range(1, n + 1):
        diff = got[labels == r] - ref[labels == r]
        assert np.all(diff == diff[0]), (seed, r)
    keys = unwrap_module._native_edge_keys(centred, valid)
    by_argsort = unwrap_module._native_orders(centred, valid, np.argsort(keys, kind="stable"))
    assert np.array_equal(by_argsort, got)
