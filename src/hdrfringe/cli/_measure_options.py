"""Options of ``measure`` and ``train-correction``, and the inputs they build for the library.

The option types are declared here so the command modules stay a short list of parameters;
:func:`strategy_params` turns measure's strategy options into the strategy's ``Params``
(the live rig's fringe sets: :class:`hdrfringe.tasks.capture.LiveFringes`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from hdrfringe.cli._options import LIVE_PANEL, given_options
from hdrfringe.cli._strategy_options import (
    article,
    cli_options,
    params_from_options,
    strategy_file_readers,
    strategy_help,
    strategy_option_type,
)
from hdrfringe.errors import InputError

__all__ = [
    "CalibrationOpt",
    "ForceOpt",
    "MarginOpt",
    "MeasureFolderArg",
    "MeasurePitchOpt",
    "MeasureRigOpt",
    "MeshOpt",
    "MethodOpt",
    "NoiseSigmaOpt",
    "OrderOpt",
    "OutputOpt",
    "RemoveOutliersOpt",
    "StrategyOpt",
    "TrainAmbientOpt",
    "TrainFolderArg",
    "TrainForceOpt",
    "TrainOutputOpt",
    "TrainPitchOpt",
    "TrainStepsOpt",
    "TruthOpt",
    "UncertaintyOpt",
    "given_strategy_options",
    "strategy_params",
]

# --- measure --------------------------------------------------------------------------------
MeasureFolderArg = Annotated[
    Path | None,
    typer.Argument(help="Capture folder of the part (or a MIGL sweep with --strategy)."),
]
OutputOpt = Annotated[Path | None, typer.Option("-o", "--output", help="Output folder (required).")]
CalibrationOpt = Annotated[
    Path | None, typer.Option("--calibration", "-c", help="Calibration file from calibrate.")
]
StrategyOpt = Annotated[str | None, typer.Option("--strategy", help=strategy_help())]
#: ``--method``, the old spelling of ``--strategy`` (issue 29): hidden, deprecated.
MethodOpt = Annotated[
    str | None, typer.Option("--method", hidden=True, help="Deprecated: use --strategy.")
]
MeasureRigOpt = Annotated[
    str | None,
    typer.Option(
        help="Live source instead of FOLDER: 'sim', the virtual rig (scene options), or "
        "'hardware', a projector and camera (--rig-config and/or --projector, --camera; "
        "docs/hardware.md): the strategy runs live, OUT also holds the capture folder."
    ),
]
MeasurePitchOpt = Annotated[
    str,
    typer.Option(
        help="Pitch(es) in projector px, comma-separated; the strategy runs per pitch and "
        "the coarse pitches unwrap the finest temporally (the demo's 1024,64,8).",
        rich_help_panel=LIVE_PANEL,
    ),
]
ForceOpt = Annotated[bool, typer.Option(help="Replace an existing output folder.")]
UncertaintyOpt = Annotated[
    bool,
    typer.Option(
        help="Write the predicted per-pixel phase_std.tiff (rad) and, with a calibration, "
        "height_std.tiff (mm); metrics.json's uncertainty block says which noise was used "
        "(docs/uncertainty.md)."
    ),
]
NoiseSigmaOpt = Annotated[
    float | None,
    typer.Option(
        help="Camera noise std in DN for the predicted std (one value for every intensity); "
        "default: the manifest's camera.read_noise_dn, else estimated from the sets with 4 or "
        "more shifts."
    ),
]
MeshOpt = Annotated[
    str,
    typer.Option(
        help="Also write the point cloud's surface mesh, mesh.ply (coloured, with normals) or "
        "mesh.stl: two triangles per 2x2 block of valid pixels, none across a depth step "
        "(docs/measurement.md, \"Point cloud and mesh\"); none: the cloud only."
    ),
]
RemoveOutliersOpt = Annotated[
    bool,
    typer.Option(
        "--remove-outliers/--keep-outliers",
        help="Leave statistical outliers (mean distance to the 20 nearest points above the "
        "mean by 2 std) out of points.ply and the mesh; outliers.tiff maps them. The maps "
        "keep every point.",
    ),
]

# --- train-correction -----------------------------------------------------------------------
TrainFolderArg = Annotated[
    Path | None,
    typer.Argument(help="A step-1 MIGL sweep folder (simulate --migl-sweep 255:60:1)."),
]
TrainOutputOpt = Annotated[
    Path | None, typer.Option("-o", "--output", help="Correction polynomial file (.json).")
]
TrainAmbientOpt = Annotated[
    float,
    typer.Option(
        help="Added ambient light in lux (saturates the white plate).", rich_help_panel=LIVE_PANEL
    ),
]
TrainStepsOpt = Annotated[
    int, typer.Option(help="Number of phase shifts N (>= 4).", rich_help_panel=LIVE_PANEL)
]
TrainPitchOpt = Annotated[
    float | None,
    typer.Option(
        help="Pitch in projector px (live default 20, the thesis's; a folder: pick "
        "one of its pitches)."
    ),
]
OrderOpt = Annotated[int, typer.Option(help="Polynomial degree (thesis: low order).")]
TruthOpt = Annotated[
    str,
    typer.Option(help="Training truth: scaled (the pixel's own response) or thesis (Eq. 6.3)."),
]
MarginOpt = Annotated[
    int, typer.Option(help="Gray levels below N(x, y) of each pixel's reference set.")
]
TrainForceOpt = Annotated[bool, typer.Option(help="Replace an existing file.")]


def given_strategy_options(ctx: typer.Context, options: dict[str, Any]) -> dict[str, Any]:
    """The strategy options given on the command line (not left at their default), by option
    name (``"--step"``), as :func:`hdrfringe.cli._strategy_options.params_from_options` takes
    them.

    Parameters
    ----------
    ctx : typer.Context
        The command's context.
    options : dict
        The command's strategy options by Python name (``**strategy_options``).

    Returns
    -------
    dict
    """
    return {
        o.option: options[o.dest]
        for o in cli_options()
        if o.dest in options and given_options(ctx, (o.dest,))
    }


def strategy_params(
    ctx: typer.Context,
    strategy: str | None,
    options: dict[str, Any],
    recorded: dict[str, Any] | None = None,
) -> tuple[Any, dict[str, str]]:
    """The strategy's ``Params`` from the strategy options given, and the files they named.

    A strategy option given on the command line for a strategy that does not take it (e.g.
    ``--tolerance`` with ``--strategy lpa``, or without ``--strategy``) is refused, before its
    value is read or checked: silently ignoring it would run something other than what was
    asked for.

    Parameters
    ----------
    ctx : typer.Context
        The command's context (which options were given, not left at their default).
    strategy : str or None
        The strategy; None: no strategy (its exclusive options are refused).
    options : dict
        The command's strategy options by Python name (``**strategy_options``).
    recorded : dict, optional
        Options by option name recorded with the captures (``capture_log.json``'s
        ``strategy_options``): used where the command line gives none (a file option's path
        as a Path).

    Returns
    -------
    params : Params or None
        :func:`hdrfringe.cli._strategy_options.params_from_options`.

    Raises
    ------
    InputError
        A strategy option of another strategy, or a bad value.
    sources : dict
        Field name -> the file given for it (e.g. ``{"correction": "corr.json"}``).
    """
    readers = strategy_file_readers()
    given = given_strategy_options(ctx, options)  # this command's (built at import)
    for o in cli_options():  # refused before any value is read or checked
        if o.option in given and strategy not in o.fields:
            titles = o.titles()  # the wording of the library's refusal of exclusive options
            raise InputError(
                f"{o.option} is {article(titles[0])} {' or '.join(titles)} option; use it with "
                f"--strategy {' or '.join(o.fields)} or leave it out (got "
                f"{'no --strategy' if strategy is None else strategy})"
            )
    if recorded:
        files = {o.option for o in cli_options() if strategy_option_type(o)[1]}
        logged = {k: Path(v) if k in files and v is not None else v for k, v in recorded.items()}
        given = {**logged, **given}
    params = params_from_options(
        strategy, given, readers={t: read for t, (read, _) in readers.items()}
    )
    sources = {
        o.fields[strategy]: str(given[o.option])
        for o in cli_options()
        if strategy in o.fields and isinstance(given.get(o.option), Path)
    }
    return params, sources

