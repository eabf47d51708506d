"""Spatial unwrapping without the full sort and, where loops close, without scikit-image
(issue 16): the same fringe orders as before, values exactly ``wrapped + 2 pi K``.

``unwrap_spatial`` anchored each region by a median taken from one ``lexsort`` of every valid
pixel, and always called scikit-image with a masked array; it now takes the medians by partial
sorts, skips the masks and gathers on a map without invalid pixels, and integrates the wrapped
differences itself where every loop of valid pixels closes. The reference here is the
implementation of before, kept verbatim (``_reference_unwrap_spatial``): the new code must
give the same NaN pattern and the same integer fringe order at every pixel, on maps with and
without invalid pixels, masks, specks removed by ``min_component_size``, references and
reference values; its values are ``wrapped + 2 pi K`` computed in one step, so they can differ
from the reference's ``(wrapped + 2 pi k) + 2 pi s`` in the last bit (checked: at most 4 ulp).
"""

from __future__ import annotations

import ctypes
import warnings

import numpy as np
import pytest
from scipy import ndimage
from skimage.restoration import unwrap_phase

from hdrfringe.core.unwrap import (
    _FOUR_CONNECTED,
    _SKIMAGE_SEED,
    TWO_PI,
    _component_medians,
    unwrap_spatial,
)


def reseed_c_rand(seed: int = 0) -> None:
    """Reseed the C library's ``rand()``: scikit-image's 2-D unwrapper draws the reliabilities
    of border pixels from it, not from its ``rng`` argument, so its result (one 2 pi constant
    per region, which moves the last bit of ``unwrap_spatial``'s values) depends on the calls
    made before in the process. Two runs compared bit for bit start from the same state."""
    ctypes.CDLL(None).srand(seed)


def _lexsort_medians(labels: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """The region medians as computed before: one sort by (label, value)."""
    order = np.lexsort((values, labels))
    sorted_vals = values[order]
    counts = np.bincount(labels, minlength=n + 1)[1:]
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    return 0.5 * (sorted_vals[starts + (counts - 1) // 2] + sorted_vals[starts + counts // 2])


def _reference_unwrap_spatial(
    wrapped: np.ndarray,
    mask: np.ndarray | None = None,
    reference: tuple[int, int] | None = None,
    reference_value: float | None = None,
    min_component_size: int = 1,
) -> np.ndarray:
    """The body of ``unwrap_spatial`` before issue 16 (valid input only: no checks)."""
    phase = np.array(wrapped, dtype=np.float64)
    valid = (np.ones(phase.shape, bool) if mask is None else mask) & np.isfinite(phase)
    target = reference_value
    ref = reference
    out = np.full(phase.shape, np.nan)
    if not valid.any():
        return out
    labels, n = ndimage.label(valid, structure=_FOUR_CONNECTED)
    if min_component_size > 1:
        sizes = np.bincount(labels.ravel(), minlength=n + 1)
        small = sizes < min_component_size
        small[0] = False
        if small[1:].any():
            valid &= ~small[labels]
            if not valid.any():
                return out
            labels, n = ndimage.label(valid, structure=_FOUR_CONNECTED)
    phase[~valid] = 0.0
    centred = np.where(valid, np.mod(phase, TWO_PI) - np.pi, 0.0)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Image has a length 1 dimension")
        raw = unwrap_phase(np.ma.array(centred, mask=~valid), rng=_SKIMAGE_SEED)
    raw = np.ma.getdata(raw)
    w = phase[valid]
    order = np.rint((raw[valid] + np.pi - w) / TWO_PI)
    lab = labels[valid]
    unwrapped = w + TWO_PI * order
    median_target = target if ref is None else None
    lo = 0.0 if median_target is None else median_target - np.pi
    shift = -np.floor((_lexsort_medians(lab, unwrapped, n) - lo) / TWO_PI)
    out[valid] = unwrapped
    if ref is not None:
        lo = 0.0 if target is None else target - np.pi
        shift[labels[ref] - 1] = -np.floor((out[ref] - lo) / TWO_PI)
    out[valid] += TWO_PI * shift[lab - 1]
    return out


def _surface(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]].astype(float)
    tilt = rng.uniform(0.2, 1.2) * cols + rng.uniform(-0.3, 0.3) * rows
    bump = rng.uniform(5, 30) * np.exp(-((rows - shape[0] / 2) ** 2 + (cols - 40) ** 2) / 400)
    return tilt + bump + rng.normal(0, rng.choice([0.02, 0.6]), shape) + rng.uniform(-50, 50)


CASES = range(24)


@pytest.mark.parametrize("case", CASES)
def test_unwrap_spatial_is_the_implementation_of_before_bit_for_bit(
    case: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The scikit-image fallback (native kernels off): the orders of before on every map.
    With the native unwrapper, maps with residues get its orders instead
    (tests/test_native_unwrap.py; residue-free maps are unaffected by the switch)."""
    monkeypatch.setenv("HDRFRINGE_NATIVE", "0")
    rng = np.random.default_rng(1000 + case)
    shape = (int(rng.integers(1, 60)), int(rng.integers(1, 90))) if case % 6 == 5 else (48, 80)
    wrapped = np.mod(_surface(rng, shape), TWO_PI)
    kind = case % 4
    mask = None
    if kind >= 1:  # NaN / inf specks, a cut making islands, or a boolean mask
        bad = rng.random(shape) < rng.choice([0.02, 0.3, 0.55])
        wrapped[bad] = rng.choice([np.nan, np.inf, -np.inf])
    if kind == 2:
        wrapped[:, shape[1] // 2] = np.nan
    if kind == 3:
        mask = rng.random(shape) > 0.1
    kw: dict = {}
    if case % 3 == 1:
        kw["min_component_size"] = int(rng.integers(2, 40))
    if case % 5 == 2:
        kw["reference_value"] = float(rng.uniform(-100, 100))
    reseed_c_rand()
    ref = _reference_unwrap_spatial(wrapped, mask, **kw)
    if case % 7 == 3 and np.isfinite(ref).any():
        r, c = np.argwhere(np.isfinite(ref))[int(rng.integers(0, np.isfinite(ref).sum()))]
        kw["reference"] = (int(r), int(c))
        reseed_c_rand()
        ref = _reference_unwrap_spatial(wrapped, mask, **kw)
    reseed_c_rand()
    got = unwrap_spatial(wrapped, mask, **kw)
    assert_same_orders(got, ref, wrapped)


def assert_same_orders(got: np.ndarray, ref: np.ndarray, wrapped: np.ndarray) -> None:
    """Same NaN pattern, same integer order K at every valid pixel, ``got`` exactly
    ``wrapped + 2 pi K`` (every bit) and within 4 ulp of ``ref``."""
    assert np.array_equal(np.isnan(got), np.isnan(ref))
    ok = np.isfinite(ref)
    k_got = np.rint((got[ok] - wrapped[ok]) / TWO_PI)
    k_ref = np.rint((ref[ok] - wrapped[ok]) / TWO_PI)
    assert np.array_equal(k_got, k_ref)
    assert np.array_equal(got[ok].view(np.int64), (wrapped[ok] + TWO_PI * k_got).view(np.int64))
    assert np.all(np.abs(got[ok] - ref[ok]) <= 4 * np.spacing(np.abs(ref[ok])))


def test_a_map_without_invalid_pixels_takes_the_unmasked_path_identically(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The all-valid shortcut against the masked path on the same values: a map that differs
    only by one invalid corner pixel unwraps the rest to the same orders (scikit-image
    fallback)."""
    monkeypatch.setenv("HDRFRINGE_NATIVE", "0")
    rng = np.random.default_rng(7)
    wrapped = np.mod(_surface(rng, (64, 96)), TWO_PI)
    reseed_c_rand()
    full = unwrap_spatial(wrapped)
    reseed_c_rand()
    assert_same_orders(full, _reference_unwrap_spatial(wrapped), wrapped)
    assert np.isfinite(full).all()


@pytest.mark.parametrize("spread", ["one", "few", "many", "mixed"])
def test_region_medians_match_a_full_sort(spread: str) -> None:
    """The partial-sort medians are the sorted ones, ties included, for one region, a few
    large ones, many specks and a mix (both the partition and the small-region paths)."""
    rng = np.random.default_rng({"one": 1, "few": 2, "many": 3, "mixed": 4}[spread])
    p_valid = {"one": 1.0, "few": 0.75, "many": 0.45, "mixed": 0.55}[spread]
    valid = rng.random((90, 120)) < p_valid
    if spread == "few":
        valid[:, ::30] = False
    labels, n = ndimage.label(valid, structure=_FOUR_CONNECTED)
    lab = labels[valid]
    for _ in range(3):
        values = rng.normal(0, 20, lab.size)
        values[::3] = np.round(values[::3])  # ties
        assert np.array_equal(_component_medians(lab, values, n), _lexsort_medians(lab, values, n))
    sizes = np.bincount(lab)[1:]
    if spread == "mixed":
        assert (sizes > 64).any() and (sizes <= 64).any()  # both paths taken


def _random_masks() -> list[np.ndarray]:
    rng = np.random.default_rng(11)
    masks = [rng.random(shape) < p for shape, p in (((48, 80), 0.5), ((60, 70), 0.62),
             ((1, 40), 0.6), ((35, 1), 0.7), ((7, 9), 0.3), ((1, 1), 1.0))]  # fmt: skip
    big = rng.random((700, 900)) < 0.58  # large and near percolation: many regions, threads
    big[:, 300] = False
    masks += [big, np.ones((40, 50), bool), np.zeros((40, 50), bool)]
    snake = np.zeros((30, 30), bool)  # a region whose first pixel comes after another's
    snake[20, :] = snake[:, 25] = snake[5, 10:26] = True
    snake[0:4, 0:4] = True
    return [*masks, snake]


@pytest.mark.parametrize("index", range(10))
def test_labels_are_scipys(index: int) -> None:
    from hdrfringe.core.unwrap import _label4

    mask = _random_masks()[index]
    labels, n = _label4(mask)
    ref, n_ref = ndimage.label(mask, structure=_FOUR_CONNECTED)
    assert n == n_ref and labels.dtype == np.int32
    assert np.array_equal(labels, ref)


@pytest.mark.parametrize("index", range(10))
def test_the_opening_and_the_growing_step_are_scipys(index: int) -> None:
    """phase_regions' 5x5 opening (outside the image counts as cut) and its 4-neighbour
    growing step by OpenCV against scipy.ndimage, on the same masks and labels."""
    import cv2

    mask = _random_masks()[index]
    opened = cv2.morphologyEx(
        mask.astype(np.uint8), cv2.MORPH_OPEN, np.ones((5, 5), np.uint8),
        borderType=cv2.BORDER_CONSTANT, borderValue=0,
    ).astype(bool)  # fmt: skip
    assert np.array_equal(opened, ndimage.binary_opening(mask, structure=np.ones((5, 5), bool)))
    labels, _ = ndimage.label(mask, structure=_FOUR_CONNECTED)
    labels[labels > 0] += 70000  # beyond uint16
    grown = cv2.dilate(labels.astype(np.float64), _FOUR_CONNECTED.astype(np.uint8))
    assert np.array_equal(grown, ndimage.grey_dilation(labels, footprint=_FOUR_CONNECTED))


def test_labels_out_of_raster_order_are_renumbered(monkeypatch: pytest.MonkeyPatch) -> None:
    """OpenCV does not promise the numbering: labels given in another order are renumbered by
    their first pixel (a permuted labelling, as another OpenCV build might return)."""
    import cv2

    from hdrfringe.core.unwrap import _label4

    mask = _random_masks()[0]
    ref, n = ndimage.label(mask, structure=_FOUR_CONNECTED)
    perm = np.concatenate(([0], np.random.default_rng(3).permutation(n) + 1)).astype(np.int32)
    monkeypatch.setattr(cv2, "connectedComponents", lambda *a, **k: (n + 1, perm[ref]))
    labels, m = _label4(mask)
    assert m == n and np.array_equal(labels, ref)
