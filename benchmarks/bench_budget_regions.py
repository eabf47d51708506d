"""Benchmark: where a row's phase error comes from, by distance to a reflectivity edge.

Run ``.venv/bin/python benchmarks/bench_budget_regions.py --scene checkerboard --strategies
multiexposure,adaptive-epipolar,adaptive-12`` (the rig's 648 x 494 camera; rows of
:data:`hdrfringe.tasks.compare.METHODS`, each on a fresh rig of the scene with ``--seed``).
Per row it prints the std in order (mrad) of the finest set's phase error, the median
modulation of the finest set and the median level each pixel was projected at
(``index_map``: the MIGL, or for multi-exposure the exposure in ms), on the dark and the
bright side (reflectivity below / above half its maximum) in bands of camera pixels from
the nearest pixel of the other side (issue 26: the budget row's excess std on the
checkerboard is the dark side's first 4 pixels, starved by the map's erosion). ``--set
blur_px=0`` passes a parameter to every row; ``--ablate NAME=VALUE`` sets a constant of
:mod:`hdrfringe.strategies.adaptive` for the run (e.g. ``BUDGET_SMOOTH_MIN_PIXELS=1000000000``:
the map-bias blur fitted against the mapping's phase even where the budget dimmed it). With
``--near-probe`` the bands are instead the distance to the pixels that clipped in the
probe (the first set at the full MIGL: the specular part's highlight). Each row also prints
its fitted map-bias blur.
"""

from __future__ import annotations

import argparse
import ast
import sys

import numpy as np
from scipy import ndimage

import hdrfringe.strategies.adaptive as adaptive_module
from hdrfringe.core._validation import saturation_count
from hdrfringe.core.phase import decode_set
from hdrfringe.pipeline import measure
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.tasks.compare import METHODS, SCENES, compare_specs

#: Bands of distance (camera pixels) to the other side: (lower, upper].
BANDS = ((0, 1), (1, 2), (2, 3), (3, 4), (4, 6), (6, 8), (8, 1_000_000))


def main(argv: list[str] | None = None) -> int:
    """Run the rows and print their error by distance band.

    Parameters
    ----------
    argv : list of str, optional
        Command-line arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit code.
    """
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="checkerboard", choices=sorted(SCENES))
    ap.add_argument("--strategies", default="multiexposure,adaptive-epipolar,adaptive-12")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a strategy parameter for every row (a Python literal), e.g. blur_px=0; repeatable",
    )
    ap.add_argument(
        "--ablate",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a constant of hdrfringe.strategies.adaptive for the run; repeatable",
    )
    ap.add_argument(
        "--near-probe",
        action="store_true",
        help="bands by distance to the pixels that clipped in the first (probe) set",
    )
    args = ap.parse_args(argv)
    extra = {k: ast.literal_eval(v) for k, v in (item.split("=", 1) for item in args.set)}
    for item in args.ablate:
        name, sep, value = item.partition("=")
        if not sep or not hasattr(adaptive_module, name):
            ap.error(f"--ablate {item!r}: give NAME=VALUE, NAME a constant of "
                     "hdrfringe.strategies.adaptive")  # fmt: skip
        try:
            number = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            ap.error(f"--ablate {item!r}: the value must be a number, e.g. 1000000000")
        setattr(adaptive_module, name, type(getattr(adaptive_module, name))(number))
    specs = compare_specs(8.0)
    methods = {m.name: m for m in METHODS}
    for name in args.strategies.split(","):
        m = methods[name]
        rig = virtual_rig(seed=args.seed, **SCENES[args.scene])
        truth = rig.truth()
        bright = truth.reflectivity > 0.5 * np.nanmax(truth.reflectivity)
        dist = {
            "dark": (~bright, ndimage.distance_transform_edt(~bright)),
            "bright": (bright, ndimage.distance_transform_edt(bright)),
        }
        res = measure(
            rig, strategy=m.strategy, params=dict(m.params) | extra, specs=m.family(specs)
        )
        if args.near_probe:
            first = res.strategy_results[0]
            probe = saturation_count(first.images, rig.camera_bit_depth) > 0
            # the clipped pixels themselves in the first band
            near = np.where(probe, 0.5, ndimage.distance_transform_edt(~probe))
            dist = {"probe": (np.ones(probe.shape, bool), near)}
        fam = res.decoded.primary
        assert fam is not None and fam.absolute_phase is not None
        err = fam.absolute_phase - 2 * np.pi * truth.u / specs[-1].pitch_px
        ok = truth.valid & np.isfinite(err) & (np.abs(err) <= np.pi)
        last = res.strategy_results[-1]
        mod = decode_set(last.images, last.spec, rig.camera_bit_depth).modulation
        images = sum(r.images_captured for r in res.strategy_results)
        blur = last.details.get("blur_sigma_px")
        print(
            f"{m.label} {extra or ''}{' ' + ' '.join(args.ablate) if args.ablate else ''}: "
            f"{images} images, coverage {100 * np.mean(np.isfinite(err[truth.valid])):.2f} %, "
            f"{int((truth.valid & (np.abs(err) > np.pi)).sum())} wrong orders, "
            f"std in order {1e3 * err[ok].std():.2f} mrad, blur "
            f"{'-' if blur is None else f'{blur:.2f}'} px"
        )
        for side, (where, d) in dist.items():
            for lo, hi in BANDS:
                sel = ok & where & (d > lo) & (d <= hi)
                if not sel.any():
                    continue
                print(
                    f"  {side:6s} ({lo}, {hi if hi < 1_000_000 else 'inf'}] px: "
                    f"{100 * sel.sum() / ok.sum():5.1f} % of pixels, "
                    f"std {1e3 * err[sel].std():6.1f} mrad, modulation {np.median(mod[sel]):5.1f}, "
                    f"level {np.nanmedian(last.index_map[sel]):6.1f}"
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
