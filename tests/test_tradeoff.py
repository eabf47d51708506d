"""Thesis Ch. 4-5 on the virtual rig: the uniform trade-off under 600 lx, and LPA beside it."""

from __future__ import annotations

import numpy as np
import pytest

from hdrfringe.captures import Captures
from hdrfringe.frames import CenterlineFrame
from hdrfringe.patterns import FringeSpec
from hdrfringe.pipeline import calibrate, measure, tradeoff_search
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import Lighting, SimulatedRig
from hdrfringe.strategies.lpa import lpa
from hdrfringe.strategies.uniform import uniform
from tests.test_pipeline import series

SPEC = FringeSpec("sinusoidal", 3, 6.0)  # thesis Table 4.3 / 5.1 conditions
LINE = [CenterlineFrame(512, "vertical", 255)]
DEPTHS = (10.0, 26.0, 42.0)


@pytest.fixture(scope="module")
def calibration():
    # the thesis's linear model, calibrated at 0 lx and MIGL 255 (Sec. 4.1)
    return calibrate(series(SPEC, noise=True, seed=11), model="linear")


def _measure_strategy(strategy, depth: float, seed: int, calibration) -> tuple[float, float]:
    rig = SimulatedRig(white_plate(depth), lighting=Lighting(ambient_lux=600), seed=seed)
    res = strategy(rig)
    imgs = np.concatenate([res.images, rig.capture(LINE)])
    folder = Captures(
        [*SPEC.frames(), *LINE],
        imgs,
        8,
        projector=rig.projector,
        scene=rig.scene.to_manifest(),
        maps={"truth_height_mm": rig.truth().height_mm},
    )
    metrics = measure(folder, calibration, reject_saturated=False).metrics
    return metrics.rmse_mm, metrics.std_mm


def test_white_plate_600_lux_tradeoff_and_lpa(calibration) -> None:
    no_amb, at_255, at_tradeoff, lpa5, auto, best = [], [], [], [], [], []
    for i, d in enumerate(DEPTHS):
        dark = SimulatedRig(white_plate(d), seed=20 + i)
        no_amb.append(
            tradeoff_search(dark, SPEC, calibration, [255], extra_frames=LINE)["rmse_mm"][255.0]
        )
        lit = SimulatedRig(white_plate(d), lighting=Lighting(ambient_lux=600), seed=30 + i)
        sweep = tradeoff_search(lit, SPEC, calibration, range(255, 104, -10), extra_frames=LINE)
        at_255.append(sweep["rmse_mm"][255.0])
        best.append(sweep["best_migl"])
        at_tradeoff.append(sweep["rmse_mm"][sweep["best_migl"]])
        lpa5.append(_measure_strategy(lambda r: lpa(r, SPEC, step=5), d, 40 + i, calibration))
        auto.append(
            _measure_strategy(lambda r: uniform(r, SPEC, tolerance=0.0), d, 40 + i, calibration)
        )
    m0, m255, mt = (float(np.mean(v)) for v in (no_amb, at_255, at_tradeoff))
    (ml, sl), (ma, sa) = np.mean(lpa5, axis=0), np.mean(auto, axis=0)
    print(
        f"\nwhite plate, sinusoidal 3-step pitch 6, linear model, mean over {DEPTHS} mm: "
        f"0 lx MIGL 255 {m0:.3f} mm; 600 lx MIGL 255 {m255:.3f} mm; 600 lx trade-off "
        f"(MIGL {best}) {mt:.3f} mm; 600 lx LPA S=5 {ml:.3f} mm (std {sl:.4f}); automatic "
        f"uniform {ma:.3f} mm (std {sa:.4f})"
    )
    assert mt < m255  # lowering the MIGL helps under 600 lx (Table 4.3)
    assert mt == pytest.approx(m0, rel=0.25)  # and recovers nearly the dark-room accuracy
    assert 105 < min(best) and max(best) < 255  # an interior trade-off point
    assert ml == pytest.approx(mt, rel=0.15)  # LPA S = 5 matches the trade-off (Table 5.1)
    # ... and, in error std (the RMSE is mostly the linear model's bias, the same for every
    # method), beats the single set the automatic rule picks by at least 5 % (measured 0.0562
    # against 0.0627 mm, 10 %). A single set in LPA's place (ratio 1) fails; the RMSE check
    # above passes one (Table 5.1's in test_reproduce_broken).
    assert sl < 0.95 * sa
    assert ma == pytest.approx(mt, rel=0.10)  # the no-ground-truth rule lands there too
