"""``hdrfringe phase``: every fringe set of a capture folder to phase and quality maps.

The work is :func:`hdrfringe.tasks.phase.phase`; this module declares the options (and the
saturation options ``measure`` shares) and prints the summary.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import app, console, handle_errors
from hdrfringe.errors import InputError

__all__ = [
    "KeepSaturatedOpt",
    "MinShiftsOpt",
    "ReportOpt",
    "SaturatedOpt",
    "check_saturation_options",
    "decoder_min_shifts",
    "phase",
]

# --- the saturation options phase and measure share, and their one validation ----------------

ReportOpt = Annotated[
    bool,
    typer.Option(
        "--report/--no-report",
        help="Write report.html (settings, metrics, maps and an interactive 3D view that opens "
        "offline from the file) and report.md (docs/report.md); --no-report: skip both.",
    ),
]
KeepSaturatedOpt = Annotated[
    bool, typer.Option(help="Keep the (biased) phase of pixels with saturated shifts.")
]
SaturatedOpt = Annotated[
    str,
    typer.Option(
        help="flag: a pixel with a saturated shift is flagged (invalid unless "
        "--keep-saturated); exclude: its saturated shifts are left out and the phase is "
        "fitted from the others (at least --min-shifts; an inverted set in the folder "
        "joins its set), and shifts_used maps are written.",
    ),
]
MinShiftsOpt = Annotated[
    int, typer.Option(help="With --saturated exclude: least unsaturated shifts per pixel.")
]


def check_saturation_options(keep_saturated: bool, saturated: str, min_shifts: int) -> None:
    """Refuse an unknown ``--saturated`` mode or options that contradict each other.

    Parameters
    ----------
    keep_saturated : bool
        ``--keep-saturated``.
    saturated : str
        ``--saturated``: one of :data:`hdrfringe.core._validation.SATURATED_MODES`.
    min_shifts : int
        ``--min-shifts`` (3 unless given).

    Raises
    ------
    InputError
        One line: what is wrong and which option to drop or change.

    Examples
    --------
    >>> check_saturation_options(False, "exclude", 4)
    >>> check_saturation_options(False, "clip", 3)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --saturated 'clip' is unknown; give one of flag, exclude
    """
    from hdrfringe.core._validation import SATURATED_MODES

    if saturated not in SATURATED_MODES:
        raise InputError(
            f"--saturated {saturated!r} is unknown; give one of {', '.join(SATURATED_MODES)}"
        )
    if saturated == "exclude" and keep_saturated:
        raise InputError(
            "--keep-saturated keeps the biased phase of saturated pixels, --saturated exclude "
            "leaves their saturated shifts out; give one of them"
        )
    if saturated == "flag" and min_shifts != 3:
        raise InputError("--min-shifts applies to --saturated exclude; add it or drop --min-shifts")


def decoder_min_shifts(
    strategy: str | None, saturated: str, keep_saturated: bool, strategy_options: dict[str, Any]
) -> int:
    """``measure``'s ``--min-shifts``, checked as ``phase`` checks it.

    ``measure`` has ``--min-shifts`` from the tolerant strategy's options; with ``--strategy
    tolerant`` it stays the strategy's (which decodes with it), otherwise it is the decoder's
    (``--saturated exclude``) and is taken out of ``strategy_options``.

    Parameters
    ----------
    strategy : str or None
        ``--strategy``.
    saturated : str
        ``--saturated``.
    keep_saturated : bool
        ``--keep-saturated``.
    strategy_options : dict
        The command's strategy options by Python name (``min_shifts`` among them).

    Returns
    -------
    int
        The least unsaturated shifts per pixel.

    Examples
    --------
    >>> options = {"min_shifts": 4, "step": None}
    >>> decoder_min_shifts(None, "exclude", False, options), options
    (4, {'step': None})
    """
    if strategy == "tolerant":
        check_saturation_options(keep_saturated, saturated, 3)
        return int(strategy_options.get("min_shifts", 3))
    min_shifts = int(strategy_options.pop("min_shifts", 3))
    check_saturation_options(keep_saturated, saturated, min_shifts)
    return min_shifts


@app.command()
@handle_errors
def phase(
    folder: Annotated[Path, typer.Argument(help="Capture folder (manifest.json + images).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="Output folder for the maps.")],
    min_modulation: Annotated[
        float | None, typer.Option(help="Minimum intensity modulation I' in DN for a valid pixel.")
    ] = None,
    keep_saturated: KeepSaturatedOpt = False,
    saturated: SaturatedOpt = "flag",
    min_shifts: MinShiftsOpt = 3,
    force: Annotated[bool, typer.Option(help="Replace an existing output folder.")] = False,
    previews: Annotated[
        bool,
        typer.Option(
            "--previews/--no-previews",
            help="Write a PNG preview beside every map; --no-previews: the TIFF maps and the "
            "summary only (faster).",
        ),
    ] = True,
    uncertainty: Annotated[
        bool,
        typer.Option(
            help="Write the predicted per-pixel phase_std.tiff (rad) of every set; "
            "phase_summary.json's uncertainty block says which noise was used "
            "(docs/uncertainty.md).",
        ),
    ] = True,
    noise_sigma: Annotated[
        float | None,
        typer.Option(
            help="Camera noise std in DN for the predicted std (one value for every "
            "intensity); default: the manifest's camera.read_noise_dn, else estimated from the "
            "sets with 4 or more shifts.",
        ),
    ] = None,
    map_dtype: Annotated[
        str | None,
        typer.Option(
            help="float32 (default with --saturated flag): the maps computed in float64 per "
            "block of pixels and stored in float32, as they are written, half the memory of "
            "float64; float64: stored in float64, the unwrapped and absolute phase computed "
            "from the unrounded wrapped phase (docs/phase.md).",
            show_default=False,
        ),
    ] = None,
    harmonics: Annotated[
        str,
        typer.Option(
            help="Fringe-harmonic (projector nonlinearity) compensation: off (default); auto: "
            "estimate each sinusoidal set's harmonic phase error from its own wrapped phase "
            "and remove it where it is significant; a number K (1..8): remove K orders "
            "whatever their size (docs/harmonics.md).",
        ),
    ] = "off",
    per_set_maps: Annotated[
        bool,
        typer.Option(
            help="With several sets, also write every set's maps (wrapped_phase__<set "
            "label>.tiff, ...); default: the final maps only, those of the finest set and the "
            "unwrapped and absolute phase (docs/phase.md).",
        ),
    ] = False,
    make_report: ReportOpt = True,
) -> None:
    """Decode a capture folder: wrapped, unwrapped and absolute phase with quality maps."""
    from hdrfringe.cli._harmonics import check_harmonics
    from hdrfringe.tasks.phase import PhaseOptions
    from hdrfringe.tasks.phase import phase as task

    check_saturation_options(keep_saturated, saturated, min_shifts)
    if noise_sigma is not None and not (math.isfinite(noise_sigma) and noise_sigma >= 0):
        raise InputError(f"--noise-sigma must be a finite number of DN >= 0, got {noise_sigma:g}")
    if map_dtype is not None and map_dtype not in ("float64", "float32"):
        raise InputError(f"--map-dtype {map_dtype!r} is unknown; give float64 or float32")
    if map_dtype == "float32" and saturated != "flag":
        raise InputError("--map-dtype float32 applies to --saturated flag; drop one of them")
    if map_dtype is None:
        map_dtype = "float32" if saturated == "flag" else "float64"
    if noise_sigma is not None and not uncertainty:
        raise InputError("--noise-sigma is for the predicted std; drop --no-uncertainty")
    check_harmonics(harmonics, "--saturated exclude" if saturated == "exclude" else None)
    options = PhaseOptions(
        min_modulation, keep_saturated, saturated, min_shifts, previews, uncertainty,
        noise_sigma, map_dtype, harmonics, per_set_maps, make_report,
    )  # fmt: skip
    report = task(folder, output, options, force=force)
    _print_summary(report.summary, report.n_pixels, uncertainty)
    console.print(f"wrote {len(report.summary['files'])} files to {report.output}")
    if options.report:
        console.print(f"report: {report.output / 'report.html'} (opens in a browser)")


def _print_summary(summary: dict[str, Any], n_pixels: int, uncertainty: bool) -> None:
    """The lines ``phase`` prints: each set's valid and saturated pixels, how each family
    was unwrapped, the harmonics, the predicted std and the notes."""
    from hdrfringe.cli._harmonics import print_harmonics
    from hdrfringe.core._validation import describe_saturated

    for s in summary["sets"]:
        n_saturated = round(s["saturated_fraction"] * n_pixels)  # the fraction is count / n
        console.print(
            f"set {s['label']}: valid {100 * s['valid_fraction']:.1f} %, "
            f"saturated {describe_saturated(n_saturated, n_pixels)}"
        )
    print_harmonics(summary.get("harmonics"))
    for fam in [*summary["families"], *summary.get("gamma_families", [])]:
        extra = f", absolute by {fam['absolute_method']}" if "absolute_method" in fam else ""
        which = fam["orientation"]
        if "gamma_precompensation" in fam:  # a gamma capture's other exponent
            which += f" ({', '.join(fam['sets'])})"
        console.print(f"{which}: unwrapped by {fam['unwrapping']}{extra}")
    if uncertainty:
        from hdrfringe.core.uncertainty import describe_uncertainty

        console.print(describe_uncertainty(summary.get("uncertainty", {})))
    for note in summary["notes"]:
        console.print(f"note: {note}")
