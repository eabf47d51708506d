"""Saturation-tolerant phase on the real over-exposed checkerboard (docs/realdata.md).

thomriiii/dec2025_checkerboard_saturated_4step: a printed checkerboard on a flat board, 4-step
sine (phase offset -90 degrees), 1280 x 720 (read at every other row and column here), white
squares clipping in one (rarely two) of four shifts. The board is flat, so its unwrapped phase
is a smooth surface: a cubic in the pixel coordinates, fitted to the unclipped pixels, and the
residual of the clipped pixels beside theirs says what the decoder made of them.

Run: ``.venv/bin/pytest -m realdata tests/test_tolerant_realdata.py -s``.
"""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set
from hdrfringe.core.saturation.tolerant import decode_set_tolerant
from hdrfringe.core.unwrap import unwrap_spatial, unwrap_temporal
from hdrfringe.io.captures import load_image
from tests.conftest import realdata_path

pytestmark = pytest.mark.realdata

TWO_PI = 2 * np.pi
CHECKER = ("thomriiii", "dec2025_checkerboard_saturated_4step")
FREQS = (4, 8, 16, 32)
PREFIX = {"vertical": "scan", "horizontal": "scanh"}
WIDTH = 1024.0  # only the pitch ratios matter (tests/test_realdata.py)


def _spec(orientation: str, freq: int) -> FringeSpec:
    """Their ``sin(2 pi F x + 2 pi K / 4)``: the contract's cosine with a -90 degree offset."""
    return FringeSpec("sinusoidal", 4, WIDTH / freq, orientation, 0, 255, phase_offset_deg=-90)  # type: ignore[arg-type]


def _cubic_residual(phase: np.ndarray, fit_mask: np.ndarray) -> np.ndarray:
    """``phase`` minus a cubic surface in (x, y) fitted to it on ``fit_mask`` (every 5th pixel)."""
    h, w = phase.shape
    yy, xx = np.mgrid[0:h, 0:w]
    x, y = (xx - w / 2) / w, (yy - h / 2) / h
    terms = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y, x**3, x * x * y, x * y * y, y**3])
    a = terms.reshape(10, -1).T
    use = np.flatnonzero(fit_mask.ravel())[::5]
    coef, *_ = np.linalg.lstsq(a[use], phase.ravel()[use], rcond=None)
    return phase - (a @ coef).reshape(h, w)


@pytest.fixture(scope="module")
def board() -> dict[str, dict[str, object]]:
    """Per orientation: the F = 32 set decoded three ways, unwrapped with one set of orders."""
    root = realdata_path(*CHECKER) / "images"
    out = {}
    for o, prefix in PREFIX.items():
        imgs = {
            f: np.stack(
                [load_image(root / f"{prefix}_f{f:03d}_n{k:02d}.png", 8) for k in range(4)]
            )[:, ::2, ::2]  # every other row and column: the whole board, a quarter of the cost
            for f in FREQS
        }
        kept = {f: decode_set(imgs[f], _spec(o, f), 8, reject_saturated=False) for f in FREQS}
        # Fringe orders from every pixel as it is (tests/test_realdata.py: right on 100 %);
        # each decoder's F = 32 wrapped phase takes them.
        orders = unwrap_temporal(
            [unwrap_spatial(kept[4].wrapped_phase), *(kept[f].wrapped_phase for f in FREQS[1:])],
            [WIDTH / f for f in FREQS],
            coarse_unwrapped=True,
        )
        tol = decode_set_tolerant(imgs[32], _spec(o, 32), 8)
        flagged = decode_set(imgs[32], _spec(o, 32), 8)

        def unwrapped(w: np.ndarray, orders: np.ndarray = orders) -> np.ndarray:
            return w + TWO_PI * np.round((orders - w) / TWO_PI)

        count = kept[32].saturation_count
        fit = (count == 0) & kept[32].valid & np.isfinite(orders)
        out[o] = {
            "count": count,
            "flagged": flagged,
            "tolerant": tol,
            "res_kept": _cubic_residual(unwrapped(kept[32].wrapped_phase), fit),
            "res_tol": _cubic_residual(unwrapped(tol.wrapped_phase), fit),
        }
    return out


def _rms(v: np.ndarray) -> float:
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v**2)))


@pytest.mark.parametrize("orientation", ["vertical", "horizontal"])
def test_tolerant_phase_on_the_clipped_real_checkerboard(board: dict, orientation: str) -> None:
    """Every pixel with one clipped shift of four, invalid for Eq. 2.2, is decoded from its
    three others, and its plane-fit residual is the unclipped pixels' (within 10 %; measured
    vertical 0.083 vs 0.085 rad, horizontal 0.082 vs 0.082 rad). Pixels with two clipped
    shifts (two left) stay invalid."""
    b = board[orientation]
    count, tol, flagged = b["count"], b["tolerant"], b["flagged"]
    one, two, none = count == 1, count == 2, count == 0
    assert not flagged.valid[one].any()  # Eq. 2.2 flags them all
    assert tol.valid[one].mean() > 0.999 and not tol.valid[two].any()
    assert np.array_equal(tol.shifts_used[one], np.full(one.sum(), 3, np.uint8))
    unclipped = _rms(b["res_tol"][none & tol.valid])
    clipped = _rms(b["res_tol"][one & tol.valid])
    kept = _rms(b["res_kept"][one])
    print(
        f"[realdata] checkerboard {orientation} F=32: plane-fit residual rms, unclipped "
        f"{unclipped:.4f} rad ({none.sum()} px); one clipped, tolerant {clipped:.4f} rad "
        f"({one.sum()} px); the same with Eq. 2.2 on the clipped value {kept:.4f} rad; two "
        f"clipped: {two.sum()} px, invalid"
    )
    assert 0.05 < unclipped < 0.12, unclipped
    assert clipped < 1.10 * unclipped, (clipped, unclipped)
