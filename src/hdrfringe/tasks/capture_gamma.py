"""``hdrfringe capture-gamma``: the gamma-estimation program projected live, a capture folder out.

The program is the one ``hdrfringe gamma FOLDER`` fits (:func:`hdrfringe.core.gamma.gamma_report`):
uniform grays (the same builder as ``simulate --gray``,
:func:`hdrfringe.core.programs.fringe_program`) and one wide sinusoidal set shown at each of
several pre-distortion exponents (kamino410's design, docs/gamma.md "From fringes").
docs/hardware.md ("capture-gamma") describes it.

The rig comes from ``--rig-config`` and the hardware options as for ``capture``
(:func:`hdrfringe.tasks.capture.hardware_rig`), with one exception: the grays are always sent
with the command's own ``--gamma`` (default 1, the projector's raw response), never with the
configuration's gamma, so that the capture is taken with a known pre-compensation whatever
the file says; the configuration's gamma is recorded and judged against the fit.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hdrfringe.errors import HdrFringeError, InputError, StoppedError
from hdrfringe.tasks.capture import hardware_rig, live_record, stop_reason, write_capture_output

__all__ = [
    "WRONG_PRECOMPENSATION_PERCENT",
    "CaptureGammaReport",
    "capture_gamma",
    "precompensation_verdict",
    "spread_order",
]

#: The pre-compensation in use is reported as wrong when it leaves a residual nonlinearity this
#: many percent of the captured range above what the fitted gamma leaves (about a 3 % error
#: in gamma; camera noise moves the fit's own figure by far less).
WRONG_PRECOMPENSATION_PERCENT = 1.0


def precompensation_verdict(
    fit: Any, gamma_hat: float, source: str | None = None
) -> tuple[bool, str]:
    """Whether a pre-compensation exponent suits the projector a gamma fit describes.

    The residual nonlinearity (max deviation from a straight line, % of the captured range,
    :func:`hdrfringe.core.gamma.predicted_nonlinearity`) that pre-compensating with ``gamma_hat``
    leaves is compared with what the fitted gamma leaves; more than
    :data:`WRONG_PRECOMPENSATION_PERCENT` above it is wrong.

    Parameters
    ----------
    fit : GammaFit
        A uniform-gray or fringe-shape fit of the projector.
    gamma_hat : float
        The pre-compensation exponent judged.
    source : str, optional
        The rig configuration file it comes from (its ``gamma``); None: the ``--gamma`` in use.

    Returns
    -------
    wrong : bool
    line : str
        One line saying so, with the exponent to use when it is wrong.

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.16-2.17; docs/gamma.md ("Residual nonlinearity").

    Examples
    --------
    >>> import numpy as np
    >>> from hdrfringe.core.gamma import fit_gamma_uniform
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> precompensation_verdict(fit, 2.2)[0], precompensation_verdict(fit, 1.8)[0]
    (False, True)
    >>> precompensation_verdict(fit, 1.8, source="rig.toml")[1].split("; ")[-1]
    'set gamma = 2.200 in rig.toml'
    """
    from hdrfringe.core.gamma import predicted_nonlinearity

    best, _ = predicted_nonlinearity(fit, fit.gamma)
    used, _ = predicted_nonlinearity(fit, gamma_hat)
    if source is None:
        what = f"the pre-compensation in use (--gamma {gamma_hat:g})"
        fix = f"pre-compensate with --gamma {fit.gamma:.3f}"
    else:
        what = f"the rig configuration's gamma {gamma_hat:g} ({source})"
        fix = f"set gamma = {fit.gamma:.3f} in {source}"
    if used > best + WRONG_PRECOMPENSATION_PERCENT:
        return True, (
            f"warning: {what} is wrong for this projector: it leaves {used:.2f} % "
            f"nonlinearity, the fitted gamma {fit.gamma:.3f} leaves {best:.2f} %; {fix}"
        )
    return False, (
        f"{what} suits this projector: it leaves {used:.2f} % nonlinearity (the fitted gamma "
        f"{fit.gamma:.3f}: {best:.2f} %)"
    )


def spread_order(levels: list[float]) -> list[float]:
    """The gray levels in an order in which each differs widely from the two before it.

    Software synchronisation accepts an image only when it differs from the images of the
    last two different frames by clearly more than noise (docs/hardware.md
    "Synchronisation"). Neighbouring dark grays give nearly the same image (the projector's
    gamma crushes them: 0 and 15 differ by a fraction of a gray level at gamma 2.8), so they
    are never shown one after the other: the sorted levels are dealt into three runs (dark,
    middle, bright) and taken one from each in turn.

    Parameters
    ----------
    levels : list of float
        Gray levels, any order.

    Returns
    -------
    list of float
        The same levels, reordered.

    Examples
    --------
    >>> spread_order([0.0, 15.0, 30.0, 45.0, 60.0, 75.0])
    [0.0, 30.0, 60.0, 15.0, 45.0, 75.0]
    """
    ordered = sorted(levels)
    k = math.ceil(len(ordered) / 3)
    return [ordered[i] for i in sorted(range(len(ordered)), key=lambda i: (i % k, i // k))]


def _gamma_rig(
    rig_config: Path | None, given: Collection[str], gamma: float, **options: Any
) -> Any:
    """The (not yet open) hardware rig and its resolved configuration: the one place this
    task builds it (:func:`~hdrfringe.tasks.capture.hardware_rig`, from ``--rig-config`` and
    the hardware ``options``). The rig pre-compensates with ``gamma`` (the command's
    ``--gamma``), not with the configuration's gamma, which stays in the configuration (it is
    recorded and judged)."""
    rig, config = hardware_rig(rig_config, given, **options)
    rig.gamma_hat = gamma
    return rig, config


@dataclass(frozen=True)
class CaptureGammaReport:
    """What ``capture-gamma`` wrote and what the fits say.

    Parameters
    ----------
    output : Path
        The capture folder.
    images : int
        Images written.
    lines : list of str
        The fits' lines (:func:`hdrfringe.core.gamma.gamma_report`) and the verdicts on the
        pre-compensation in use and on the rig configuration's gamma.
    warning : str or None
        Why the folder gives no fit (then ``lines`` is empty).

    Examples
    --------
    >>> CaptureGammaReport(Path("gamma"), 22, ["uniform grays: gamma = 2.81"]).warning is None
    True
    """

    output: Path
    images: int
    lines: list[str] = field(default_factory=list)
    warning: str | None = None


def _run_program(
    recorder: Any,
    rig: Any,
    uniform: list[Any],
    fringe_set: list[Any],
    exponents: Sequence[float],
    gamma: float,
) -> tuple[str | None, int]:
    """Project and grab the gamma program: the uniform grays, then the fringe set once per
    exponent. Stopped after the first group by Ctrl-C, SIGTERM or SIGHUP, it keeps what is
    complete and returns why it stopped and the exit code (:func:`stop_reason`); before it, the
    interrupt propagates. Returns ``(None, 0)`` when the whole program ran."""
    from hdrfringe.io.results import signals_as_interrupt

    try:
        with signals_as_interrupt():  # SIGTERM, SIGHUP: kept as for Ctrl-C (issue 31)
            if uniform:
                recorder.capture(uniform)
            for exponent in exponents:
                rig.gamma_hat = exponent
                recorder.capture(fringe_set)
    except KeyboardInterrupt as stop:
        if not recorder.calls:
            raise
        return stop_reason(stop)
    finally:
        rig.gamma_hat = gamma
    return None, 0


def capture_gamma(
    output: Path,
    rig_config: Path | None,
    hardware: Mapping[str, Any],
    *,
    given: Collection[str] = (),
    levels: Sequence[float] = (),
    gray_text: str = "",
    gamma: float = 1.0,
    exponents: Sequence[float] = (),
    exponents_text: str = "",
    fringe_pitch: float = 128.0,
    steps: int = 4,
    force: bool = False,
    say: Callable[[str], Any] | None = None,
) -> CaptureGammaReport:
    """Project the gamma-estimation program live, write its capture folder, fit it.

    Uniform grays ``levels`` (sent with ``gamma``) and one wide sinusoidal set sent at each of
    ``exponents``; then :func:`hdrfringe.core.gamma.gamma_report` on what was written. The output
    is checked before the rig opens. Ctrl-C keeps the complete groups and raises
    :class:`~hdrfringe.errors.HdrFringeError` (before the first group: nothing written, the
    ``KeyboardInterrupt`` propagates).

    Parameters
    ----------
    output : Path
        The capture folder to write.
    rig_config : Path or None
        The rig configuration file (its gamma is judged, never sent).
    hardware : mapping
        Hardware options by Python name (:data:`~hdrfringe.tasks.capture.RIG_OPTION_KEYS`;
        no ``gamma``).
    given : collection of str
        The hardware options given explicitly.
    levels : sequence of float
        Gray levels (none: no grays).
    gray_text, exponents_text : str
        How the user gave the levels and exponents (for messages).
    gamma : float
        The pre-compensation the grays are sent with.
    exponents : sequence of float
        Pre-distortion exponents of the fringe set (none: no fringes).
    fringe_pitch : float
        Pitch of the fringe set, projector px.
    steps : int
        Phase shifts of the fringe set.
    force : bool
        Replace an existing output folder.
    say : callable, optional
        Called with the line saying what is projected once the rig is open.

    Returns
    -------
    CaptureGammaReport

    Examples
    --------
    >>> capture_gamma(Path("gamma"), None, {}, levels=[0.0, 255.0], gray_text="0,255")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --gray 0,255: 2 distinct levels; the fit needs at least ...
    """
    from hdrfringe.core.captures import ProjectorInfo
    from hdrfringe.core.gamma import (
        MIN_FRINGE_PITCH_PX,
        MIN_UNIFORM_LEVELS,
        gamma_report,
        select_gamma_sets,
    )
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.core.programs import fringe_program
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
    )

    levels, exponents = list(levels), list(exponents)
    grays, fringes = bool(levels), bool(exponents)
    if grays and len(set(levels)) < MIN_UNIFORM_LEVELS:
        raise InputError(
            f"--gray {gray_text}: {len(set(levels))} distinct levels; the fit needs at least "
            f"{MIN_UNIFORM_LEVELS} (e.g. 0:255:15)"
        )
    if any(e <= 0 for e in exponents) or not (math.isfinite(gamma) and gamma > 0):
        raise InputError("--gamma and --fringe-gamma exponents must be positive numbers")
    if fringes:
        if fringe_pitch < MIN_FRINGE_PITCH_PX:
            raise InputError(
                f"--fringe-pitch {fringe_pitch:g}: narrower than {MIN_FRINGE_PITCH_PX:g} px, "
                "which `hdrfringe gamma` leaves out (projector pixels and blur reshape narrow "
                f"fringes); give >= {MIN_FRINGE_PITCH_PX:g}"
            )
        design = FringeSpec("sinusoidal", steps, fringe_pitch, imin=0.0, migl=255.0)
        if not select_gamma_sets([(design, e) for e in dict.fromkeys(exponents)]).fittable:
            raise InputError(
                f"--fringe-gamma {exponents_text} with --steps {steps}: a shape fit needs two "
                "different exponents or >= 4 steps"
            )
    rig, config = _gamma_rig(rig_config, given, gamma, **hardware)
    check_output_against_inputs(output, [rig_config, config.gamma_file])
    checked = check_output_dir(output, force)
    recorder = Recorder(rig)
    with rig:
        width, height = rig.projector.width, rig.projector.height
        full = float(2**rig.projector.bit_depth - 1)
        frames = fringe_program(
            "sinusoidal", steps, [fringe_pitch], ("vertical",) if fringes else (), 0.0, [full],
            projector=ProjectorInfo(width, height, rig.projector.bit_depth, gamma),
            centerline=False, grays=spread_order(levels),
        )  # fmt: skip
        uniform = [f for f in frames if f.kind == "uniform"]
        fringe_set = [f for f in frames if f.kind != "uniform"]
        name = f" ({config.name})" if config.name else ""
        if say is not None:
            say(
                f"gamma program live{name}: projector {config.projector.spec} ({width}x{height}), "
                f"camera {config.camera.spec}; "
                f"{len(uniform)} grays at --gamma {gamma:g}, {len(exponents)} fringe sets "
                f"(pre-distorted with {', '.join(f'{e:g}' for e in exponents) or 'none'})"
            )
        stopped, code = _run_program(recorder, rig, uniform, fringe_set, exponents, gamma)
    program = {
        "program": "gamma",
        "gray_levels": levels,
        "gray_gamma_precompensation": gamma,
        "fringe_gamma_precompensation": exponents,
    }
    caps, state, log = live_record(
        recorder, rig, config, None, output.name, stopped, entries=program
    )
    with staged_output_dir(checked, force=force) as tmp:
        write_capture_output(tmp, caps, state, log)
    if stopped is not None:
        raise StoppedError(
            f"capture-gamma {stopped} after {len(recorder.calls)} complete groups; {output} "
            'holds those only (manifest "capture": {"complete": false}); capture again for the '
            "whole program",
            code,
        )
    try:
        report = gamma_report(caps, source=str(output))
    except HdrFringeError as err:  # the folder is written; say why it does not fit
        return CaptureGammaReport(output, len(caps.frames), warning=" ".join(str(err).split()))
    lines = list(report.lines)
    fit = report.uniform_fit or report.fringe_fit
    if fit is not None:
        lines.append(precompensation_verdict(fit, gamma)[1])
        if config.gamma is not None and config.gamma != gamma:  # the file's, not sent
            source = config.source or "the rig configuration"
            lines.append(precompensation_verdict(fit, config.gamma, source)[1])
    return CaptureGammaReport(output, len(caps.frames), lines)
