"""Thesis Ch. 4-5 on the virtual rig: the uniform trade-off under 600 lx, and LPA beside it.

Methods are compared by the error's standard deviation: with the linear model every set
carries the same per-depth bias (-0.14, -0.16 and +0.08 mm at 10, 26 and 42 mm), which makes
most of the RMSE (issue 15). The checks are those of ``research/tests/reproduce_checks.py``;
:func:`test_the_std_checks_reject_what_the_rmse_checks_accepted` runs them on broken
variants built from the same captures.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from tests.test_pipeline import thesis_calibration

import reproduce_checks as checks
from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import CenterlineFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.pipeline import measure, tradeoff_search
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import Lighting, SimulatedRig
from hdrfringe.strategies.lpa import lpa
from hdrfringe.strategies.uniform import uniform

SPEC = FringeSpec("sinusoidal", 3, 6.0)  # thesis Table 4.3 / 5.1 conditions
LINE = [CenterlineFrame(512, "vertical", 255)]
DEPTHS = (10.0, 26.0, 42.0)
SWEEP_MIGLS = range(255, 104, -10)


@pytest.fixture(scope="module")
def calibration(tmp_path_factory: pytest.TempPathFactory):
    # the thesis's linear model, calibrated at 0 lx and MIGL 255 (Sec. 4.1): the noisy series
    # of seed 11 (SPEC), calibrated once for this and tests/test_pipeline.py
    return thesis_calibration(tmp_path_factory, SPEC.pattern, SPEC.steps)


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


@pytest.fixture(scope="module")
def plate(calibration) -> dict[str, Any]:
    """The white plate at each of DEPTHS: the 0 lx set at MIGL 255, the 600 lx trade-off sweep
    (MIGL 255..105, step 10), LPA S=5 and the automatic uniform rule under 600 lx; the error
    RMSE and std (mm) of each, averaged over the depths."""
    dark, sweeps, lpa5, auto = [], [], [], []
    for i, d in enumerate(DEPTHS):
        rig = SimulatedRig(white_plate(d), seed=20 + i)
        dark.append(tradeoff_search(rig, SPEC, calibration, [255], extra_frames=LINE))
        lit = SimulatedRig(white_plate(d), lighting=Lighting(ambient_lux=600), seed=30 + i)
        sweeps.append(tradeoff_search(lit, SPEC, calibration, SWEEP_MIGLS, extra_frames=LINE))
        lpa5.append(_measure_strategy(lambda r: lpa(r, SPEC, step=5), d, 40 + i, calibration))
        auto.append(
            _measure_strategy(lambda r: uniform(r, SPEC, tolerance=0.0), d, 40 + i, calibration)
        )

    def over_depth(key: str) -> dict[float, float]:  # per MIGL of the sweep
        return {float(m): float(np.mean([s[key][float(m)] for s in sweeps])) for m in SWEEP_MIGLS}

    (ml, sl), (ma, sa) = np.mean(lpa5, axis=0), np.mean(auto, axis=0)
    return {
        "best": [s["best_migl"] for s in sweeps],
        "dark_rmse": float(np.mean([s["rmse_mm"][255.0] for s in dark])),
        "dark_std": float(np.mean([s["std_mm"][255.0] for s in dark])),
        "rmse": over_depth("rmse_mm"),
        "std": over_depth("std_mm"),
        "tradeoff_rmse": float(np.mean([s["rmse_mm"][s["best_migl"]] for s in sweeps])),
        "tradeoff_std": float(np.mean([s["std_mm"][s["best_migl"]] for s in sweeps])),
        "lpa": (float(ml), float(sl)),
        "auto": (float(ma), float(sa)),
    }


def test_white_plate_600_lux_tradeoff_and_lpa(plate) -> None:
    """Tables 4.3 and 5.1 on the white plate (sinusoidal 3-step, pitch 6, linear model), in
    error std, mean over the depths. Measured: 0 lx MIGL 255 0.0464 mm; 600 lx MIGL 255
    0.1425 mm; trade-off (MIGL 225, 215, 215) 0.0580 mm (2.46 x below 255, 1.25 x the 0 lx
    std: 600 lx adds photon noise); LPA S=5 0.0562 mm, 3.4 % below the best single set of the
    sweep (MIGL 215, 0.0582 mm); the automatic uniform rule (MIGL 198, 192, 189) 0.0627 mm,
    1.08 x the trade-off, 10 % above LPA.

    The RMSEs (0.134, 0.193, 0.139, 0.138, 0.141 mm) are mostly the linear model's bias, the
    same for every set, and the former RMSE checks accepted broken variants that these reject
    (test_the_std_checks_reject_what_the_rmse_checks_accepted): a trade-off search returning
    any MIGL from 245 down to 115, a single set at any MIGL from 235 to 135 in LPA's place,
    an automatic rule landing anywhere from 235 to 145."""
    lit_std, dark_std, st = plate["std"], plate["dark_std"], plate["tradeoff_std"]
    (ml, sl), (ma, sa) = plate["lpa"], plate["auto"]
    print(
        f"\nwhite plate, sinusoidal 3-step pitch 6, linear model, mean over {DEPTHS} mm, RMSE "
        f"(std): 0 lx MIGL 255 {plate['dark_rmse']:.3f} ({dark_std:.4f}) mm; 600 lx MIGL 255 "
        f"{plate['rmse'][255.0]:.3f} ({lit_std[255.0]:.4f}) mm; 600 lx trade-off (MIGL "
        f"{plate['best']}) {plate['tradeoff_rmse']:.3f} ({st:.4f}) mm; 600 lx LPA S=5 "
        f"{ml:.3f} ({sl:.4f}) mm; automatic uniform {ma:.3f} ({sa:.4f}) mm"
    )
    best = plate["best"]
    assert 105 < min(best) and max(best) < 255  # an interior trade-off point
    # lowering the MIGL helps under 600 lx and recovers nearly the dark-room std (Table 4.3)
    assert not checks.check_saturation_costs_more_than_the_tradeoff(
        lit_std[255.0], st, dark_std, 1.5, 1.35
    )
    # LPA S=5 beats every single set of the sweep, the trade-off's included (Table 5.1) ...
    sets = {f"MIGL {m:g}": s for m, s in lit_std.items()}
    assert not checks.check_lpa_beats_every_uniform_set(sl, sets, 0.01)
    # ... and the set the automatic rule picks by at least 5 %
    assert sl < 0.95 * sa
    # the no-ground-truth rule lands near the trade-off (Sec. 4.2)
    assert not checks.check_rule_finds_the_tradeoff(sa, st, 0.10)


def test_the_std_checks_reject_what_the_rmse_checks_accepted(plate) -> None:
    """Broken variants from the same sweep, each a single set of it at MIGL m: (1) a trade-off
    search that returns m, (2) m in LPA's place, (3) an automatic rule that lands on m. The
    former RMSE checks (trade-off < MIGL 255 and within 25 % of the 0 lx RMSE; LPA within
    15 % of the trade-off; the rule within 10 %) accepted (1) at 245..115, (2) at 235..135 and
    (3) at 235..145; the std checks reject (1) and (3) at 255..235 and 185..105 (all but
    225..195, whose std is within 8 % of the trade-off's) and (2) everywhere."""
    rmse, std, dark_std = plate["rmse"], plate["std"], plate["dark_std"]
    mt, st, ml = plate["tradeoff_rmse"], plate["tradeoff_std"], plate["lpa"][0]
    sets = {f"MIGL {m:g}": s for m, s in std.items()}
    wrong = [m for m in std if m >= 235.0 or m <= 185.0]
    for m in std:
        assert checks.check_lpa_beats_every_uniform_set(std[m], sets, 0.01), m
    for m in wrong:
        assert checks.check_saturation_costs_more_than_the_tradeoff(
            std[255.0], std[m], dark_std, 1.5, 1.35
        ), m
        assert checks.check_rule_finds_the_tradeoff(std[m], st, 0.10), m
    m0 = plate["dark_rmse"]
    former = {  # the MIGLs each former RMSE check accepted in place of the method
        "tradeoff": [m for m in rmse if rmse[m] < rmse[255.0] and rmse[m] == approx(m0, 0.25)],
        "lpa": [m for m in rmse if rmse[m] == approx(mt, 0.15)],
        "rule": [m for m in rmse if rmse[m] == approx(mt, 0.10)],
    }
    for key, accepted in former.items():  # wrong MIGLs, rejected above, that each accepted
        assert {235.0, 185.0, 175.0, 165.0, 155.0} <= set(accepted), (key, accepted)
    assert ml == approx(mt, 0.15)  # the real LPA passed too: the check could not tell them apart


def approx(expected: float, rel: float) -> Any:
    return pytest.approx(expected, rel=rel)
