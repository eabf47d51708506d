"""``unwrap_spatial``'s ways to the fringe orders (issue 16): integration where every loop of
valid pixels closes, elsewhere the native unwrapper (tests/test_native_unwrap.py) or, when it
is not built, scikit-image; and what that makes deterministic. The scikit-image side here runs
with the native kernels off.

The integration (``hdrfringe.core.unwrap._path_orders``) must give, on every map where it answers,
the orders scikit-image's path gives (the reference: the same function with the integration
switched off), bit for bit once both go through the same anchoring; it must refuse (None) every
map where a loop does not close: a residue, or a hole whose boundary turns by 2 pi. Its
results do not depend on the C library's ``rand()`` state, which scikit-image's border
reliabilities draw from.
"""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.core import unwrap as unwrap_module
from hdrfringe.core.unwrap import TWO_PI, unwrap_spatial
from tests.test_unwrap_identity import reseed_c_rand


def _ramp(shape: tuple[int, int], seed: int, noise: float = 0.05) -> np.ndarray:
    """Unwrapped truth: a tilted plane plus a bump (steps well below pi), a little noise."""
    rng = np.random.default_rng(seed)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    bump = 9.0 * np.exp(-((rows - shape[0] / 2) ** 2 + (cols - shape[1] / 3) ** 2) / 300.0)
    return 0.55 * cols + 0.2 * rows + bump + rng.normal(0, noise, shape) - 20.0


def _u_shape(shape: tuple[int, int]) -> np.ndarray:
    """A region whose two arms start apart at the top and join at the bottom (the integration
    grows them as two trees of row runs and must join them)."""
    valid = np.ones(shape, bool)
    valid[: shape[0] * 2 // 3, shape[1] // 3 : shape[1] * 2 // 3] = False
    return valid


def _maps() -> dict[str, tuple[np.ndarray, np.ndarray | None]]:
    """Residue-free wrapped maps (and masks): every loop of valid pixels closes."""
    shape = (40, 64)
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    holes = np.zeros(shape, bool)
    for r, c, rad in ((10, 12, 5), (28, 45, 7)):
        holes |= (rows - r) ** 2 + (cols - c) ** 2 < rad**2
    specks = np.random.default_rng(3).random(shape) < 0.04
    islands = np.ones(shape, bool)
    islands[:, 30:33] = False
    out: dict[str, tuple[np.ndarray, np.ndarray | None]] = {}
    out["NaN-free"] = (np.mod(_ramp(shape, 1), TWO_PI), None)
    nan = np.mod(_ramp(shape, 2), TWO_PI)
    nan[holes | specks] = np.nan
    out["holes and specks (NaN)"] = (nan, None)
    out["two islands (mask)"] = (np.mod(_ramp(shape, 3), TWO_PI), islands)
    out["U shape"] = (np.mod(_ramp(shape, 4), TWO_PI), _u_shape(shape))
    out["one row"] = (np.mod(_ramp((1, 50), 5), TWO_PI), None)
    out["one column"] = (np.mod(_ramp((30, 1), 6), TWO_PI), None)
    # Wrapped differences of exactly pi: a tie that both paths must break alike (no jump).
    tie = np.tile(np.array([0.0, np.pi] * 8), (6, 1))
    out["ties at pi"] = (tie, None)
    return out


def _skimage_path(monkeypatch: pytest.MonkeyPatch, *args, **kw) -> np.ndarray:
    with monkeypatch.context() as m:
        m.setattr(unwrap_module, "_path_orders", lambda centred, valid: None)
        m.setenv("HDRFRINGE_NATIVE", "0")  # scikit-image, not the native unwrapper
        reseed_c_rand()
        return unwrap_spatial(*args, **kw)


@pytest.mark.parametrize("name", list(_maps()))
def test_integration_gives_scikit_images_orders(name: str, monkeypatch) -> None:
    wrapped, mask = _maps()[name]
    taken: list[bool] = []
    real = unwrap_module._path_orders

    def spy(centred, valid):
        result = real(centred, valid)
        taken.append(result is not None)
        return result

    monkeypatch.setattr(unwrap_module, "_path_orders", spy)
    got = unwrap_spatial(wrapped, mask)
    assert taken == [True], name  # the integration answered
    ref = _skimage_path(monkeypatch, wrapped, mask)
    assert np.array_equal(got.view(np.int64), ref.view(np.int64)), name  # every bit, NaN too
    ok = np.isfinite(got)
    turns = (got[ok] - wrapped[ok]) / TWO_PI
    assert np.array_equal(turns, np.rint(turns))  # exactly wrapped + 2 pi K


def test_integration_with_a_reference_and_small_regions(monkeypatch) -> None:
    wrapped, mask = _maps()["holes and specks (NaN)"]
    kw = {"reference": (20, 20), "reference_value": 40.0, "min_component_size": 3}
    got = unwrap_spatial(wrapped, mask, **kw)
    ref = _skimage_path(monkeypatch, wrapped, mask, **kw)
    assert np.array_equal(got.view(np.int64), ref.view(np.int64))
    assert abs(got[20, 20] - 40.0) <= np.pi


def _vortex(shape: tuple[int, int], centre: tuple[float, float]) -> np.ndarray:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    return np.mod(np.arctan2(rows - centre[0], cols - centre[1]) + 0.3 * cols, TWO_PI)


def test_loops_that_do_not_close_are_refused() -> None:
    """A residue (phase vortex), and a masked hole around one (every 2x2 loop of valid pixels
    closes, the loop round the hole does not): the integration answers None."""
    v = _vortex((30, 40), (14.5, 19.5))
    centred = np.mod(v, TWO_PI) - np.pi
    assert unwrap_module._path_orders(centred, None) is None
    valid = np.ones(v.shape, bool)
    valid[12:17, 17:22] = False
    assert unwrap_module._path_orders(centred, valid) is None
    # the same hole in a map without the vortex: answered
    plain = np.mod(_ramp((30, 40), 8), TWO_PI) - np.pi
    assert unwrap_module._path_orders(plain, valid) is not None
    # the U's arms are two trees of row runs, joined below the notch; a vortex in a loop
    # where they join gives two offsets for one pair of trees: refused
    u = _u_shape((30, 40))  # notch rows 0..19, columns 13..25
    joined = np.mod(_vortex((30, 40), (19.5, 30.5)), TWO_PI) - np.pi
    assert unwrap_module._path_orders(joined, u) is None
    # a vortex inside the notch is not enclosed by valid pixels: every loop closes, answered
    open_notch = np.mod(_vortex((30, 40), (8.5, 19.5)), TWO_PI) - np.pi
    assert unwrap_module._path_orders(open_notch, u) is not None


@pytest.mark.parametrize("name", ["NaN-free", "holes and specks (NaN)", "U shape"])
def test_results_do_not_depend_on_c_rand(name: str) -> None:
    """Two calls with different rand() states give the same bytes (the integration draws
    nothing; the anchoring counts each region's orders from its first pixel)."""
    wrapped, mask = _maps()[name]
    outs = []
    for seed in (0, 1, 987654):
        reseed_c_rand(seed)
        outs.append(unwrap_spatial(wrapped, mask))
    for o in outs[1:]:
        assert np.array_equal(o.view(np.int64), outs[0].view(np.int64))


def test_with_residues_a_region_constant_of_scikit_image_changes_no_bit(monkeypatch) -> None:
    """On a map with residues scikit-image decides when the native unwrapper is off (the
    fallback). Its border reliabilities come from rand(), which moves the 2 pi constant it
    leaves on a region (and, where paths disagree, some orders: benchmarks/README.md). A
    different constant must not change a bit: scikit-image's result shifted by 2 pi * 7 gives
    the same bytes."""
    import skimage.restoration

    monkeypatch.setenv("HDRFRINGE_NATIVE", "0")  # the fallback
    wrapped = np.mod(_ramp((24, 32), 9, noise=0.9), TWO_PI)
    assert unwrap_module._path_orders(wrapped - np.pi, None) is None  # residues: skimage
    reseed_c_rand()
    plain = unwrap_spatial(wrapped)
    real = skimage.restoration.unwrap_phase
    monkeypatch.setattr(
        skimage.restoration, "unwrap_phase", lambda *a, **k: real(*a, **k) + 7 * TWO_PI
    )
    reseed_c_rand()
    shifted = unwrap_spatial(wrapped)
    assert np.array_equal(plain.view(np.int64), shifted.view(np.int64))
