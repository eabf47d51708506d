"""Why DPA loses to LPA on the thesis-matched preset's glint plate (Table 6.1, issue 15).

Not a speed benchmark: one cell of the ``ch6_plate`` experiment of ``hdrfringe reproduce
--quick --preset thesis`` (quick view, sinusoidal 4-step, 600 lx, the plate with the glint;
default pitch 14 px at 18 mm), measured step by step against the rig's noise-free signal:

* the saturated pixels of the first set (MIGL 255) on the glint and on the rest of the plate,
  by how many of the four shifts are saturated, and the MIGL at which each pixel's noise-free
  signal drops below full scale (``ideal``: its best MIGL);
* the Eq. 6.2 estimate of the one-saturated-shift pixels against the noise-free peak, raw and
  after each correction polynomial, and the unsaturation MIGL the CDF gives it against ``ideal``;
* the training: how much the Eq. 6.2 estimate tells about each truth on the 25-position
  training pixels (correlation; the truth's own spread against the corrected RMSE; the range of
  corrected values), and the scaled truth (what the reproduction trains on) against the
  noise-free peak at one training position;
* every method (LPA S = 15/20/30, DPA 10 %/20 % with the reproduction's correction, and with
  the correction trained on Eq. 6.3's truth as the thesis does): sets, the MIGLs and rules of
  the captures, the phase-height std over the glint and over the rest, and how many gray levels
  below its ``ideal`` MIGL each pixel was merged into the composite (``gap``).

On the checkerboard (Table 6.2): LPA's large-step penalty at the same pitch and depth, with the
white squares' ideal MIGLs, the gap per step, the std of the same runs on noise-free images and
the ratios averaged over 15 top MIGLs (:func:`board_study`); and DPA 10 % at 8 px with each
correction (:func:`board_dpa`).

``--grid`` runs the sets and stds of those methods over the quick grid's nine cells (pitches
8/14/20, depths 10/18/26 mm) of the glint plate and of the checkerboard (Tables 6.1 and 6.2).
docs/reproduction.md ("Thesis-matched preset") quotes the output.

Run: ``.venv/bin/python research/studies/study_dpa_glint.py [--pitch 14 --depth 18] [--grid]
[--json out.json]`` (about 2 minutes on one core at load 10, the 25-position training included;
``--grid`` about 3 minutes more).
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.calibration import measurement_mask
from hdrfringe.core.phase import saturation_count
from hdrfringe.core.saturation.estimate import (
    CorrectionPolynomial,
    peak_and_trough,
    true_peak_scaled,
    unsaturation_migl,
)
from hdrfringe.rig.scenes import white_plate
from hdrfringe.strategies.dpa import dpa
from hdrfringe.strategies.lpa import lpa
from hdrfringe_thesis.adaptive import (
    TRAINING_PITCH,
    Experiment,
    SweepRig,
    experiments,
    training_data,
    training_depths,
)
from hdrfringe_thesis.ch4 import (
    THESIS_DEPTHS_MM,
    Ch4Setup,
    PlateSweep,
    calibrate_pattern,
    orders_from_expected,
    pattern_spec,
    sweep_phase,
)

__all__ = [
    "PATTERN",
    "board_study",
    "cell_study",
    "corrections",
    "grid_study",
    "main",
    "training_truth",
]

PATTERN = "sinusoidal-4"
#: Full scale minus half a gray level: where the rounded reading of a signal saturates.
FULL = 254.5
#: (label, method, correction name) of the methods compared.
METHODS = (
    ("lpa-15", "lpa-15", ""),
    ("lpa-20", "lpa-20", ""),
    ("lpa-30", "lpa-30", ""),
    ("dpa-10", "dpa-10", "scaled"),
    ("dpa-20", "dpa-20", "scaled"),
    ("dpa-10 eq6.3", "dpa-10", "thesis"),
    ("dpa-20 eq6.3", "dpa-20", "thesis"),
)


def corrections(base: Ch4Setup) -> tuple[dict[str, CorrectionPolynomial], dict[str, Any]]:
    """The reproduction's correction (scaled truth) and the thesis's (Eq. 6.3 truth), and what
    the Eq. 6.2 estimate tells about each truth on the training pixels.

    Both from one 25-position training sweep (:func:`~hdrfringe_thesis.adaptive.training_data`);
    ``"scaled"`` is what :func:`~hdrfringe_thesis.adaptive.train_correction` returns for a
    preset.

    Returns
    -------
    (dict, dict)
        The polynomials by truth; per truth the training pixels' ``correlation`` of estimate and
        truth, the truth's ``truth_std_dn`` (the RMSE of predicting every pixel by the mean),
        ``rmse_before_dn`` / ``rmse_after_dn`` of the correction, its corrected value at the
        training domain's ends and highest inside it (``corrected_range_dn``).
    """
    data = training_data(base, training_depths(base))
    polys: dict[str, CorrectionPolynomial] = {}
    info: dict[str, Any] = {}
    for truth in ("scaled", "thesis"):
        poly = data.train(2, truth=truth)
        est, true = data.samples(truth=truth)
        grid = np.linspace(*poly.domain, 301)
        corrected = poly.apply(grid)
        polys[truth] = poly
        info[truth] = {
            "pixels": int(est.size),
            "correlation": float(np.corrcoef(est, true)[0, 1]),
            "truth_mean_dn": float(true.mean()),
            "truth_std_dn": float(true.std()),
            "rmse_before_dn": poly.rmse_before,
            "rmse_after_dn": poly.rmse_after,
            "domain_dn": [float(v) for v in poly.domain],
            "corrected_range_dn": [
                float(corrected[0]),
                float(corrected[-1]),
                float(corrected.max()),
            ],
        }
    return polys, info


def training_truth(base: Ch4Setup, depth_mm: float = 26.0) -> dict[str, float]:
    """The scaled training truth against the noise-free peak at one training position.

    Returns
    -------
    dict
        ``bias_dn`` and ``rmse_dn`` of ``I**`` (scaled) minus the noise-free highest shift at
        MIGL 255, over the pixels saturated there; ``pixels``.
    """
    data = training_data(base, (depth_mm,))
    spec = pattern_spec(PATTERN, TRAINING_PITCH, base.imin)
    truth = PlateSweep(depth_mm, base, spec).signal(255.0, 600.0).max(axis=0)
    migl = data.reference_migl.astype(np.float64)
    migl[data.reference_migl < 0] = np.nan
    scaled = true_peak_scaled(data.reference, migl, 8, 255.0, base.imin, offset=data.offset)
    use = (saturation_count(data.images_at_top, 8) > 0) & np.isfinite(scaled)
    err = scaled[use] - truth[use]
    return {
        "bias_dn": float(err.mean()),
        "rmse_dn": float(np.sqrt(np.mean(err**2))),
        "pixels": int(use.sum()),
    }


def _run(method: str, rig: SweepRig, corr: CorrectionPolynomial | None) -> Any:
    spec = rig.sweep.spec
    kind, _, value = method.partition("-")
    if kind == "lpa":
        return lpa(rig, spec, step=float(value))
    return dpa(rig, spec, threshold=float(value) / 100.0, correction=corr)


def _pct(x: NDArray, q: Sequence[float] = (5, 50, 95)) -> list[float]:
    return [float(v) for v in np.percentile(x, q)] if x.size else []


def _setup(exp: Experiment, base: Ch4Setup, pitch: int, depth: float) -> tuple[Any, ...]:
    setup = exp.setup(base)
    spec = pattern_spec(PATTERN, pitch, setup.imin)
    cal_setup = base if exp.white_level is not None else setup
    cal, _ = calibrate_pattern(
        PATTERN, pitch, cal_setup, THESIS_DEPTHS_MM, plate_reflectivity=exp.calibration_plate
    )
    mask = measurement_mask((setup.height, setup.width), setup.border_px)
    sweep = PlateSweep(depth, setup, spec, scene=exp.scene_at(depth))
    rig = SweepRig(sweep, setup, exp.lux, (exp.name, PATTERN, pitch, depth))
    return setup, spec, cal, mask, sweep, rig


class _NoiseFreeRig(SweepRig):
    """:class:`SweepRig` without sensor noise: the signal rounded and clipped."""

    def capture(self, frames: Sequence[Any], settings: Any = None) -> NDArray:
        migl = float(frames[0].spec.migl)
        if migl not in self._sets:
            signal = self.sweep.signal(migl, self.lux)
            self._sets[migl] = np.clip(np.rint(signal), 0, 255).astype(np.uint8)
        return self._sets[migl]


def _height_error(res: Any, sweep: PlateSweep, cal: Any) -> NDArray:
    phase = orders_from_expected(sweep_phase(res.images, sweep.spec), sweep.expected_phase)
    return np.asarray(cal.height(phase) - sweep.truth_height_mm)


def cell_study(
    base: Ch4Setup,
    corr: dict[str, CorrectionPolynomial],
    pitch: int = 14,
    depth_mm: float = 18.0,
) -> dict[str, Any]:
    """The diagnosis of one glint-plate cell (see the module docstring).

    Returns
    -------
    dict
        ``top_set``, ``estimate``, ``predicted_migl`` and ``methods`` (JSON-ready).
    """
    exp = experiments(quick=True, preset=base.preset)["ch6_plate"]
    setup, spec, cal, mask, sweep, rig = _setup(exp, base, pitch, depth_mm)
    lux = exp.lux
    s_top = sweep.signal(255.0, lux)
    plain = PlateSweep(depth_mm, setup, spec, scene=white_plate(depth_mm)).signal(255.0, lux)
    glint = mask & ((s_top.max(axis=0) - plain.max(axis=0)) > 1.0)
    rest = mask & ~glint
    ideal = np.full(glint.shape, np.nan)
    for m in range(255, int(setup.imin), -1):
        new = np.isnan(ideal) & (sweep.signal(float(m), lux).max(axis=0) < FULL)
        ideal[new] = m
    top = rig.capture(spec.frames())
    nsat = saturation_count(top, 8)
    out: dict[str, Any] = {"pitch_px": pitch, "depth_mm": depth_mm, "top_set": {}}
    for name, reg in (("rest", rest), ("glint", glint)):
        sat = reg & (nsat > 0)
        out["top_set"][name] = {
            "pixels": int(reg.sum()),
            "saturated": int(sat.sum()),
            "by_saturated_shifts": [int((reg & (nsat == k)).sum()) for k in range(1, 5)],
            "ideal_migl_p5_p50_p95": _pct(ideal[sat]),
            "ideal_migl_min": float(np.nanmin(ideal[sat])) if sat.any() else None,
        }
    peak, trough = peak_and_trough(top, 8, nsat > 0)
    one = mask & (nsat == 1)
    true_peak = s_top.max(axis=0)[one]
    est = {"raw": peak[one]} | {k: c.apply(peak[one]) for k, c in corr.items()}
    out["estimate"] = {
        k: {
            "bias_dn": float(np.mean(v - true_peak)),
            "rmse_dn": float(np.sqrt(np.mean((v - true_peak) ** 2))),
            "below_full_scale": float(np.mean(v < FULL)),
        }
        for k, v in est.items()
    }
    out["estimate"]["pixels"] = int(one.sum())
    out["estimate"]["true_peak_p5_p50_p95"] = _pct(true_peak)
    out["estimate"]["offset_trough_p5_p50_p95"] = _pct(trough[one])
    out["predicted_migl"] = {}
    for k, c in corr.items():
        m = np.floor(
            unsaturation_migl(est[k], 255, setup.imin, 8, model=c.truth, offset=trough[one])
        )
        m = np.minimum(m, 254.0)  # the CDF's ceiling: saturated at the capture
        d = m - ideal[one]
        out["predicted_migl"][k] = {
            "minus_ideal_mean": float(d.mean()),
            "minus_ideal_p5_p50_p95": _pct(d),
            "at_254": float(np.mean(m >= 254.0)),
        }
    out["methods"] = {}
    for label, method, cname in METHODS:
        res = _run(method, rig, corr.get(cname))
        err = _height_error(res, sweep, cal)
        gap = ideal - res.index_map
        sat_top = nsat > 0
        steps = []
        index = res.index_map
        for m_cap, n_new in zip(res.migls, res.newly_unsaturated, strict=True):
            at = index == m_cap
            steps.append([float(m_cap), int((at & rest).sum()), int((at & glint).sum()), n_new])
        out["methods"][label] = {
            "sets": res.sets_captured,
            "rules": res.details.get("rules"),
            "std_mm": {
                "all": float(err[mask].std()),
                "rest": float(err[rest].std()),
                "glint": float(err[glint].std()),
            },
            "gap_levels_mean": {
                "rest": float(np.nanmean(gap[rest & sat_top])),
                "glint": float(np.nanmean(gap[glint & sat_top])),
            },
            "gap_over_20_rest": float(np.nanmean(gap[rest & sat_top] > 20)),
            "steps_migl_rest_glint": steps,
        }
    return out


def board_study(
    base: Ch4Setup,
    pitch: int = 14,
    depth_mm: float = 18.0,
    steps: Sequence[int] = (15, 20, 30, 45),
    tops: Sequence[int] = tuple(range(255, 240, -1)),
) -> dict[str, Any]:
    """LPA's large-step penalty on the checkerboard (Table 6.2): where the white squares clear.

    LPA with step S merges each pixel at the first captured MIGL ``top - k S`` at or below its
    best. The study records the white (saturated at 255) squares' noise-free ``ideal`` MIGLs,
    and, for each S, the std and the mean ``gap`` (ideal minus merged MIGL) with the
    reproduction's top MIGL 255 and averaged over the top MIGLs ``tops`` (every alignment of the
    MIGL grid against the white squares' clearing MIGL).

    Returns
    -------
    dict
        ``white``: pixels and ideal-MIGL percentiles; ``lpa``: per S, per top: std (all, white,
        black) and the white squares' mean gap; ``noise_free``: per S at top 255, the std
        (all, white, black) of the same method on the noise-free images (rounded and clipped):
        the part of the std that does not depend on the noise; ``plate_noise_free_std_mm``: the
        std of the white plate at the same position, unsaturated (MIGL 150, 0 lx), noise-free,
        with the same calibration.
    """
    exp = experiments(quick=True, preset=base.preset)["checkerboard"]
    setup, spec, cal, mask, sweep, rig = _setup(exp, base, pitch, depth_mm)
    top = rig.capture(spec.frames())
    white = mask & (saturation_count(top, 8) > 0)
    black = mask & ~white
    ideal = np.full(white.shape, np.nan)
    for m in range(255, int(setup.imin), -1):
        new = np.isnan(ideal) & (sweep.signal(float(m), exp.lux).max(axis=0) < FULL)
        ideal[new] = m
    vals, counts = np.unique(ideal[white], return_counts=True)
    modes = sorted(zip(counts.tolist(), vals.tolist(), strict=True), reverse=True)[:4]
    out: dict[str, Any] = {
        "pitch_px": pitch,
        "depth_mm": depth_mm,
        "white": {
            "pixels": int(white.sum()),
            "of": int(mask.sum()),
            "ideal_migl_p5_p50_p95": _pct(ideal[white]),
            "ideal_migl_modes": [[float(v), int(c)] for c, v in modes],
        },
        "lpa": {},
    }
    for s in steps:
        rows = []
        for t in tops:
            res = lpa(rig, spec.with_migl(float(t)), step=float(s))
            err = _height_error(res, sweep, cal)
            gap = ideal - res.index_map
            rows.append(
                {
                    "top": t,
                    "sets": res.sets_captured,
                    "std_mm": [float(err[r].std()) for r in (mask, white, black)],
                    "gap_white": float(np.nanmean(gap[white])),
                }
            )
        out["lpa"][str(s)] = rows
    quiet = _NoiseFreeRig(sweep, setup, exp.lux, rig.key)
    out["noise_free"] = {}
    for s in steps:
        err = _height_error(lpa(quiet, spec, step=float(s)), sweep, cal)
        out["noise_free"][str(s)] = [float(err[r].std()) for r in (mask, white, black)]
    plate = PlateSweep(depth_mm, setup, spec, scene=white_plate(depth_mm))
    images = np.clip(np.rint(plate.signal(150.0, 0.0)), 0, 255).astype(np.uint8)
    phase = orders_from_expected(sweep_phase(images, spec), plate.expected_phase)
    err = np.asarray(cal.height(phase) - plate.truth_height_mm)
    out["plate_noise_free_std_mm"] = float(err[mask].std())
    return out


def board_dpa(
    base: Ch4Setup,
    corr: dict[str, CorrectionPolynomial],
    pitch: int = 8,
    depth_mm: float = 18.0,
) -> dict[str, Any]:
    """DPA 10 % on one checkerboard cell with each correction: where it places the estimable
    saturated pixels and where it captures.

    Returns
    -------
    dict
        ``by_saturated_shifts`` at 255, the raw Eq. 6.2 peak of the one-saturated-shift pixels
        (p5/50/95), and per correction the CDF MIGL of those pixels (p5/50/95, minimum), the
        MIGLs DPA captured, its rules and its std.
    """
    exp = experiments(quick=True, preset=base.preset)["checkerboard"]
    setup, spec, cal, mask, sweep, rig = _setup(exp, base, pitch, depth_mm)
    top = rig.capture(spec.frames())
    nsat = saturation_count(top, 8)
    peak, trough = peak_and_trough(top, 8, nsat > 0)
    one = nsat == 1
    out: dict[str, Any] = {
        "pitch_px": pitch,
        "depth_mm": depth_mm,
        "by_saturated_shifts": [int((nsat == k).sum()) for k in range(5)],
        "raw_peak_p5_p50_p95": _pct(peak[one]),
    }
    for k, c in corr.items():
        m = unsaturation_migl(
            c.apply(peak[one]), 255, setup.imin, 8, model=c.truth, offset=trough[one]
        )
        m = np.minimum(np.floor(m), 254.0)
        res = _run("dpa-10", rig, c)
        out[k] = {
            "cdf_migl_p5_p50_p95": _pct(m),
            "cdf_migl_min": float(m.min()),
            "migls": [float(v) for v in res.migls],
            "rules": res.details.get("rules"),
            "std_mm": float(_height_error(res, sweep, cal)[mask].std()),
        }
    return out


def grid_study(
    base: Ch4Setup, corr: dict[str, CorrectionPolynomial], stores: Sequence[str]
) -> dict[str, Any]:
    """Sets and std of every method of :data:`METHODS` over the quick grid's cells.

    Returns
    -------
    dict
        ``{store: {label: {"sets": [...], "std_mm": [...]}}}`` in cell order (pitch, depth).
    """
    exps = experiments(quick=True, preset=base.preset)
    out: dict[str, Any] = {}
    for store in stores:
        exp = exps[store]
        rows: dict[str, dict[str, list[float]]] = {
            label: {"sets": [], "std_mm": []} for label, _, _ in METHODS
        }
        for pitch in exp.pitches:
            for depth in exp.depths_mm:
                t0 = time.perf_counter()
                _, _, cal, mask, sweep, rig = _setup(exp, base, pitch, depth)
                for label, method, cname in METHODS:
                    res = _run(method, rig, corr.get(cname))
                    rows[label]["sets"].append(float(res.sets_captured))
                    rows[label]["std_mm"].append(float(_height_error(res, sweep, cal)[mask].std()))
                print(f"{store} pitch {pitch} depth {depth}: {time.perf_counter() - t0:.0f} s")
        out[store] = rows
    return out


def board_summary(board: dict[str, Any]) -> list[str]:
    """Plain-text lines of :func:`board_study`."""
    w = board["white"]
    lines = [
        f"checkerboard pitch {board['pitch_px']} px, depth {board['depth_mm']} mm: white "
        f"(saturated at 255) {w['pixels']} of {w['of']} pixels, ideal MIGL p5/50/95 "
        f"{w['ideal_migl_p5_p50_p95']}, most common [MIGL, pixels] {w['ideal_migl_modes']}"
    ]
    lines.append(
        f"  noise-free unsaturated white plate (MIGL 150, same calibration): std "
        f"{board['plate_noise_free_std_mm']:.3f} mm"
    )
    ref = board["lpa"].get("15")
    for s, rows in board["lpa"].items():
        at255 = rows[0]
        line = (
            f"  LPA S={s:>2s} top 255: sets {at255['sets']:3d} std all/white/black "
            f"{'/'.join(f'{v:.3f}' for v in at255['std_mm'])} mm, white gap "
            f"{at255['gap_white']:5.1f}"
        )
        if ref is not None:
            r0 = at255["std_mm"][0] / ref[0]["std_mm"][0]
            ratios = [r["std_mm"][0] / q["std_mm"][0] for r, q in zip(rows, ref, strict=True)]
            gaps = np.mean([r["gap_white"] for r in rows])
            line += (
                f"; std / S=15: {r0:.3f} at top 255, mean {np.mean(ratios):.3f} (range "
                f"{min(ratios):.3f}-{max(ratios):.3f}) over tops {rows[-1]['top']}.."
                f"{rows[0]['top']}, white gap mean {gaps:.1f}"
            )
        quiet = board["noise_free"][s]
        line += f"; noise-free std all/white/black {'/'.join(f'{v:.3f}' for v in quiet)}"
        lines.append(line)
    return lines


def summary(cell: dict[str, Any], grid: dict[str, Any] | None) -> str:
    """Plain-text summary of :func:`cell_study` and :func:`grid_study`."""
    lines = [f"cell: pitch {cell['pitch_px']} px, depth {cell['depth_mm']} mm"]
    for name, t in cell["top_set"].items():
        lines.append(
            f"  {name}: {t['saturated']} of {t['pixels']} pixels saturated at 255, by saturated "
            f"shifts 1/2/3/4: {t['by_saturated_shifts']}; ideal MIGL min {t['ideal_migl_min']}, "
            f"p5/50/95 {t['ideal_migl_p5_p50_p95']}"
        )
    e = cell["estimate"]
    lines.append(
        f"  Eq. 6.2 on {e['pixels']} one-saturated-shift pixels, true peak p5/50/95 "
        f"{[round(v, 1) for v in e['true_peak_p5_p50_p95']]} DN:"
    )
    for k in ("raw", "scaled", "thesis"):
        lines.append(
            f"    {k:7s} bias {e[k]['bias_dn']:+7.2f} DN, RMSE {e[k]['rmse_dn']:6.2f} DN, "
            f"below full scale {100 * e[k]['below_full_scale']:5.1f} %"
        )
    for k, p in cell["predicted_migl"].items():
        lines.append(
            f"    CDF MIGL ({k}) minus ideal: mean {p['minus_ideal_mean']:+.1f}, p5/50/95 "
            f"{p['minus_ideal_p5_p50_p95']}, placed at 254: {100 * p['at_254']:.1f} %"
        )
    for label, r in cell["methods"].items():
        s = r["std_mm"]
        g = r["gap_levels_mean"]
        migls = " ".join(f"{m:g}" for m, *_ in r["steps_migl_rest_glint"][:10])
        lines.append(
            f"  {label:13s} sets {r['sets']:3d}  std all/rest/glint {s['all']:.3f}/"
            f"{s['rest']:.3f}/{s['glint']:.3f} mm  gap rest/glint {g['rest']:5.1f}/"
            f"{g['glint']:5.1f} levels (rest > 20: {100 * r['gap_over_20_rest']:.0f} %)  "
            f"MIGLs {migls}{' ...' if r['sets'] > 10 else ''}"
        )
    if "training_truth" in cell:
        t = cell["training_truth"]
        lines.append(
            f"  training truth (scaled) minus noise-free peak, one position, {t['pixels']} px: "
            f"bias {t['bias_dn']:+.2f} DN, RMSE {t['rmse_dn']:.2f} DN"
        )
    for name, c in cell.get("corrections", {}).items():
        lo, hi = c["domain_dn"]
        lines.append(
            f"  correction {name} ({c['pixels']} training pixels): RMSE {c['rmse_before_dn']:.2f}"
            f" -> {c['rmse_after_dn']:.2f} DN; the truth's own std {c['truth_std_dn']:.2f} DN "
            f"(mean {c['truth_mean_dn']:.1f}); correlation of estimate and truth "
            f"{c['correlation']:+.3f}; corrected value at estimate {lo:.0f} / {hi:.0f} DN: "
            f"{c['corrected_range_dn'][0]:.1f} / {c['corrected_range_dn'][1]:.1f}, highest "
            f"{c['corrected_range_dn'][2]:.1f}"
        )
    if "board" in cell:
        lines += board_summary(cell["board"])
    if "board_dpa" in cell:
        b = cell["board_dpa"]
        lines.append(
            f"checkerboard pitch {b['pitch_px']} px, depth {b['depth_mm']} mm, DPA 10 %: "
            f"saturated shifts 0..4 at 255 {b['by_saturated_shifts']}, raw Eq. 6.2 peak of the "
            f"one-saturated pixels p5/50/95 {b['raw_peak_p5_p50_p95']} DN"
        )
        for k in ("scaled", "thesis"):
            r = b[k]
            lines.append(
                f"  correction {k}: CDF MIGL p5/50/95 {r['cdf_migl_p5_p50_p95']} min "
                f"{r['cdf_migl_min']:g}; captures {r['migls']} ({r['rules']}); std "
                f"{r['std_mm']:.3f} mm"
            )
    for store, rows in (grid or {}).items():
        lines.append(f"grid {store} (means over {len(next(iter(rows.values()))['sets'])} cells):")
        for label, r in rows.items():
            lines.append(
                f"  {label:13s} sets {np.mean(r['sets']):6.2f}  std {np.mean(r['std_mm']):.3f} mm"
                f"  per cell sets {' '.join(f'{v:g}' for v in r['sets'])}"
            )
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    """Command line: the cell diagnosis, optionally the grid, optionally JSON."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--pitch", type=int, default=14)
    parser.add_argument("--depth", type=float, default=18.0)
    parser.add_argument("--grid", action="store_true", help="also the quick grid's nine cells")
    parser.add_argument("--json", help="write the results to this file")
    parser.add_argument("--preset", default="thesis", help="the rig preset (e.g. thesis-gamma)")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    base = Ch4Setup.thesis_matched(quick=True, preset=args.preset)
    corr, info = corrections(base)
    cell = cell_study(base, corr, args.pitch, args.depth)
    cell["training_truth"] = training_truth(base)
    cell["corrections"] = info
    cell["board"] = board_study(base, args.pitch, args.depth)
    cell["board_dpa"] = board_dpa(base, corr)
    grid = grid_study(base, corr, ("ch6_plate", "checkerboard")) if args.grid else None
    print(summary(cell, grid))
    print(f"({time.perf_counter() - t0:.0f} s)")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"cell": cell, "grid": grid}, f, indent=1)


if __name__ == "__main__":
    main()
