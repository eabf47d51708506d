"""Training data of DPA's error correction (thesis Sec. 6.1.2): live, or from a step-1 sweep.

The correction polynomial is trained on LPA with a step of one gray level
(:func:`hdrfringe.core.saturation.estimate.training_data_from_rig`). :func:`training_spec` is the
set the thesis trained on (with the changes a user asks for); :func:`training_data_from_folder`
replays a captured step-1 MIGL sweep instead of a live rig. :data:`THESIS_CORRECTION_RMSE` is
what the thesis reports for its correction.
"""

from __future__ import annotations

import math

from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import UniformFrame
from hdrfringe.core.patterns import FringeSpec, same_fringes
from hdrfringe.core.saturation.estimate import TrainingData, training_data_from_rig
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.rig.replay import ReplayRig

__all__ = [
    "THESIS_CORRECTION_RMSE",
    "THESIS_TRAINING_PITCH_PX",
    "training_data_from_folder",
    "training_spec",
]

#: Thesis Sec. 6.1.2: RMSE (gray levels) of the saturated-intensity estimate against Eq. 6.3's
#: truth before and after the error correction (Eq. 6.4).
THESIS_CORRECTION_RMSE: tuple[float, float] = (71.05, 2.99)

#: Thesis Sec. 6.1.2: the correction is trained on a 4-step set at a 20 px pitch.
THESIS_TRAINING_PITCH_PX = 20.0


def training_spec(
    *,
    steps: int = 4,
    pitch: float | None = None,
    imin: float = 40.0,
    migl: float = 255.0,
) -> FringeSpec:
    """The sinusoidal, vertical set a live training sweep runs LPA step 1 on.

    Parameters
    ----------
    steps : int
        Phase shifts N (at least 4: the estimate needs a shift beyond the three a sinusoid
        takes, Eq. 6.2).
    pitch : float, optional
        Pitch in projector pixels; None: the thesis's 20 px.
    imin, migl : float
        Minimum gray level and the sweep's top MIGL.

    Returns
    -------
    FringeSpec

    Raises
    ------
    InputError
        Fewer than 4 steps.

    References
    ----------
    Thesis Sec. 6.1.2 (training on a 4-step set, 20 px pitch) and Eq. 6.2.

    Examples
    --------
    >>> training_spec().label()
    's4_p20_v_i40_g255'
    """
    if steps < 4:
        raise InputError(
            f"the saturated-intensity estimate needs at least 4 steps (Eq. 6.2), got {steps}"
        )
    p = THESIS_TRAINING_PITCH_PX if pitch is None else pitch
    return FringeSpec("sinusoidal", steps, p, "vertical", imin, migl)


def training_data_from_folder(
    folder: Captures, pitch: float | None = None, *, margin: int = 10
) -> TrainingData:
    """The correction's training data (thesis Sec. 6.1.2) from a step-1 MIGL sweep.

    The captures must hold a sinusoidal set of at least 4 steps at every integer MIGL from its
    highest down to its lowest one (``hdrfringe simulate white_plate --migl-sweep 255:60:1
    --pitch 20 --ambient-lux 600``);
    :func:`~hdrfringe.core.saturation.estimate.training_data_from_rig`
    then replays LPA with a step of 1 on it. ``pitch`` picks the set when the sweep holds
    several pitches. Uniform frames at ``imin``, when present, give the offset ``A``.

    Parameters
    ----------
    folder : Captures
        The sweep (e.g. read with :func:`hdrfringe.io.captures.read_capture_folder`).
    pitch : float, optional
        The pitch to train on; required when the sweep holds several.
    margin : int
        Gray levels between a pixel's ``N(x, y)`` and its reference set.

    Returns
    -------
    TrainingData

    Raises
    ------
    CaptureFormatError
        No sinusoidal set of 4 or more steps, or a MIGL missing from the sweep.
    InputError
        Several pitches and none chosen, or a pitch the sweep does not hold.

    References
    ----------
    Thesis Sec. 6.1.2 (the training sweep) and Eq. 6.3-6.4.

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=40, height=30),
    ...                    lighting=Lighting(ambient_lux=600))
    >>> frames = [f for m in range(255, 199, -1) for f in training_spec(migl=m).frames()]
    >>> sweep = rig.capture_folder(frames)
    >>> data = training_data_from_folder(sweep)
    >>> data.spec.pitch_px, data.sets_captured > 1
    (20.0, True)
    """
    sets = [s for s in folder.sets if s.spec.pattern == "sinusoidal" and s.spec.steps >= 4]
    if not sets:
        raise CaptureFormatError(
            f"{folder.name}: no sinusoidal set of 4 or more steps; the correction is trained on "
            "sinusoidal sets (thesis: 4-step, 20 px pitch)"
        )
    pitches = sorted({s.spec.pitch_px for s in sets})
    if pitch is None:
        if len(pitches) > 1:
            raise InputError(
                f"{folder.name}: holds pitches {', '.join(f'{p:g}' for p in pitches)} px; choose "
                "one with --pitch (the thesis trains at 20 px)"
            )
        pitch = pitches[0]
    chosen = [s for s in sets if s.spec.pitch_px == pitch]
    if not chosen:
        raise InputError(
            f"{folder.name}: no sinusoidal set at pitch {pitch:g} px; it holds "
            + ", ".join(f"{p:g}" for p in pitches)
        )
    top_set = max(chosen, key=lambda s: s.spec.migl)
    spec = top_set.spec
    migls = {float(s.spec.migl) for s in chosen if same_fringes(s.spec, spec)}
    low = min(migls)
    missing = [m for m in range(round(low), round(spec.migl) + 1) if float(m) not in migls]
    if len(migls) < 2 or missing or spec.migl != round(spec.migl):
        what = (
            f"{len(missing)} integer MIGLs between {low:g} and {spec.migl:g} are missing"
            if missing
            else f"it holds MIGLs {', '.join(f'{m:g}' for m in sorted(migls, reverse=True)[:5])}"
        )
        raise CaptureFormatError(
            f"{folder.name}: training needs the set at every integer MIGL from the top down "
            f"(LPA with a step of 1), but {what}; capture e.g. hdrfringe simulate "
            "--migl-sweep 255:60:1"
        )
    n_offset = sum(1 for f in folder.frames if isinstance(f, UniformFrame) and f.level == spec.imin)
    return training_data_from_rig(
        ReplayRig(folder),
        spec,
        lowest_migl=max(low, math.floor(spec.imin) + 1),
        margin=margin,
        offset_captures=min(n_offset, 1),
    )
