"""Error budget of the Ch. 4 reproduction: the numbers research/docs/reproduction.md explains with.

Not a timing benchmark: a study that computes, on the reproduction's own code paths,

1. the linear calibration model's residual (Eq. 2.15) on the virtual rig's geometry, noise
   free (:func:`hdrfringe_thesis.model_residual.model_residual`): RMS over the calibration
   depths 2..50 mm, mean over the Ch. 6 depths 10..28 mm, per depth; and the rational model's;
2. the split of the RMSE at pitch 6, sinusoidal 3-step, 0 lx, MIGL 255 (Table 4.3's first
   cell) into bias and std over pixels, beside the model residual and the thesis's 0.27 mm;
3. Table 4.1's trade-off under strong added light against the noise: the Eq. 4.1 simulation
   at 900 lx with Gaussian noise sigma 1, 4 and 8 gray levels (the thesis: 190), and where
   saturation starts on the rig's response at 500..900 lx (the highest MIGL at which no
   measurement pixel saturates at any depth).

Run::

    .venv/bin/python research/studies/error_budget.py            # thesis grid, 648 x 494, 25 depths
    .venv/bin/python research/studies/error_budget.py --quick    # the quick reproduction's setup
    .venv/bin/python research/studies/error_budget.py --json out.json

The full run takes a few minutes on two idle cores (the 900 lx study is 31 MIGLs x 25 depths x
8 simulated captures); ``--depth-step 2`` halves it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import numpy as np

from hdrfringe_thesis.ch4 import (
    QUICK_DEPTHS_MM,
    QUICK_MIGLS,
    QUICK_SETUP,
    THESIS_DEPTHS_MM,
    THESIS_MIGLS,
    Ch4Setup,
    ch4_block,
    ch4_modified_block,
)
from hdrfringe_thesis.model_residual import model_residual

THESIS_RMSE_0LX_255 = 0.27  # Table 4.3, sinusoidal 3-step, pitch 6
THESIS_TRADEOFF_900LX = 190.0  # Table 4.1
CH6_DEPTHS_MM = tuple(float(d) for d in range(10, 29, 2))
LUXES = (500.0, 600.0, 700.0, 800.0, 900.0)
SIGMAS = (1.0, 4.0, 8.0)


def _tradeoff(curve: np.ndarray, migls: np.ndarray) -> float:
    best = np.nanmin(curve)
    return float(migls[curve == best].max())


def study(quick: bool, depth_step: int) -> dict[str, Any]:
    setup = QUICK_SETUP if quick else Ch4Setup()
    depths = (QUICK_DEPTHS_MM if quick else THESIS_DEPTHS_MM)[::depth_step]
    migls = np.array(QUICK_MIGLS if quick else THESIS_MIGLS)
    out: dict[str, Any] = {"setup": setup.to_dict(), "depths_mm": list(depths)}

    t0 = time.perf_counter()
    lin = model_residual(setup, THESIS_DEPTHS_MM, (*THESIS_DEPTHS_MM,))
    rat = model_residual(setup, THESIS_DEPTHS_MM, model="rational")
    out["model_residual"] = {
        "linear_rms_2_50_mm": lin.rms_total_mm,
        "linear_mean_2_50_mm": lin.mean_mm,
        "linear_mean_10_28_mm": lin.over(CH6_DEPTHS_MM).mean_mm,
        "linear_rms_10_28_mm": lin.over(CH6_DEPTHS_MM).rms_total_mm,
        "linear_bias_per_depth_mm": dict(
            zip([f"{d:g}" for d in lin.depths_mm], lin.bias_mm.round(4).tolist(), strict=True)
        ),
        "rational_rms_2_50_mm": rat.rms_total_mm,
        "seconds": time.perf_counter() - t0,
    }

    t0 = time.perf_counter()
    cell = ch4_block("sinusoidal-3", 6, (0.0,), (255.0,), depths, setup)
    res = model_residual(setup, depths)
    rmse, bias, std = (float(cell[k][0, 0].mean()) for k in ("rmse_mm", "mean_error_mm", "std_mm"))
    out["split_0lx_255"] = {
        "rmse_mm": rmse,
        "bias_mm": bias,
        "std_mm": std,
        "model_rms_mm": res.rms_total_mm,
        "model_mean_mm": res.mean_mm,
        "bias_minus_model_per_depth_max_mm": float(
            np.abs(cell["mean_error_mm"][0, 0] - res.bias_mm).max()
        ),
        "thesis_rmse_mm": THESIS_RMSE_0LX_255,
        "ours_over_thesis_rmse": rmse / THESIS_RMSE_0LX_255,
        "std_over_thesis_rmse": std / THESIS_RMSE_0LX_255,
        "seconds": time.perf_counter() - t0,
    }

    t0 = time.perf_counter()
    sim = ch4_modified_block(
        "sinusoidal-3",
        6,
        LUXES,
        SIGMAS,
        tuple(migls.tolist()),
        depths,
        setup,
        noise_lux=900.0,
        calibration_depths_mm=depths,
    )
    light = sim["rmse_light_mm"].mean(axis=2)  # (lux, MIGL)
    noise = sim["rmse_noise_mm"].mean(axis=2)  # (sigma, MIGL)
    sat = sim["saturated_fraction_light"].max(axis=2)  # (lux, MIGL)
    onset = {}
    for i, lux in enumerate(LUXES):
        clear = migls[sat[i] == 0]
        onset[f"{lux:g}"] = float(clear.max()) if clear.size else None
    out["strong_light"] = {
        "tradeoff_migl_by_lux": {
            f"{lux:g}": _tradeoff(light[i], migls) for i, lux in enumerate(LUXES)
        },
        "saturation_onset_migl_by_lux": onset,
        "tradeoff_migl_900lx_by_sigma": {
            f"{s:g}": _tradeoff(noise[i], migls) for i, s in enumerate(SIGMAS)
        },
        "thesis_tradeoff_900lx": THESIS_TRADEOFF_900LX,
        "seconds": time.perf_counter() - t0,
    }
    return out


def markdown(r: dict[str, Any]) -> str:
    m, s, st = r["model_residual"], r["split_0lx_255"], r["strong_light"]
    lines = [
        f"setup {r['setup']['width']} x {r['setup']['height']}, "
        f"{len(r['depths_mm'])} depths {r['depths_mm'][0]:g}..{r['depths_mm'][-1]:g} mm",
        "",
        "1. Model residual, linear (Eq. 2.15), calibration 2..50 mm, noise-free: "
        f"RMS {m['linear_rms_2_50_mm']:.4f} mm (mean {m['linear_mean_2_50_mm']:+.4f}); "
        f"over 10..28 mm mean {m['linear_mean_10_28_mm']:+.4f}, RMS {m['linear_rms_10_28_mm']:.4f}"
        f"; rational {m['rational_rms_2_50_mm']:.2g} mm",
        "   per depth: "
        + ", ".join(f"{d} {b:+.3f}" for d, b in m["linear_bias_per_depth_mm"].items()),
        "",
        f"2. Pitch 6, sinusoidal 3-step, 0 lx, MIGL 255: RMSE {s['rmse_mm']:.4f} mm = bias "
        f"{s['bias_mm']:+.4f} (+) std {s['std_mm']:.4f}; model residual at these depths RMS "
        f"{s['model_rms_mm']:.4f}, mean {s['model_mean_mm']:+.4f} (per-depth bias - model: "
        f"at most {s['bias_minus_model_per_depth_max_mm']:.4f} mm); thesis RMSE "
        f"{s['thesis_rmse_mm']:g}: ours/thesis {s['ours_over_thesis_rmse']:.2f}, std/thesis "
        f"{s['std_over_thesis_rmse']:.2f}",
        "",
        "3. Eq. 4.1 added light, sinusoidal 3-step, pitch 6:",
        "   trade-off MIGL by lux: "
        + ", ".join(f"{k} lx {v:g}" for k, v in st["tradeoff_migl_by_lux"].items()),
        "   saturation starts above MIGL: "
        + ", ".join(f"{k} lx {v}" for k, v in st["saturation_onset_migl_by_lux"].items()),
        "   900 lx + noise sigma: trade-off "
        + ", ".join(f"sigma {k}: {v:g}" for k, v in st["tradeoff_migl_900lx_by_sigma"].items())
        + f" (thesis, sigma of its rig: {st['thesis_tradeoff_900lx']:g})",
        "",
        "seconds: "
        + ", ".join(f"{k} {r[k]['seconds']:.0f}" for k in ("model_residual", "split_0lx_255"))
        + f", strong_light {st['seconds']:.0f}",
    ]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the quick reproduction's setup")
    ap.add_argument("--depth-step", type=int, default=1, help="use every n-th depth")
    ap.add_argument("--json", help="write the numbers to this JSON file")
    args = ap.parse_args(argv)
    r = study(args.quick, args.depth_step)
    print(markdown(r))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(r, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
