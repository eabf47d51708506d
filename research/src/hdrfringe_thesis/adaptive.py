"""The pixel-wise adaptive experiments of thesis Ch. 5 (LPA) and Ch. 6 (DPA) on the virtual rig.

Three experiments, each a resumable sweep (:mod:`hdrfringe_thesis.engine`) over pattern,
pitch and depth:

* ``ch5_plate`` (Sec. 5.2.1): the white plate under 600 lx of added light, the three Ch. 4
  patterns, pitches 4..20 px, 25 depths 2..50 mm; LPA with S = 5 and, on the same captures,
  every uniform MIGL from 255 down to 190 by 5 (the 255 MIGL and trade-off columns of Table 5.1
  and Fig. 5.5); per MIGL of the LPA index image, the fraction of pixels and their error (Fig.
  5.6). White-plate calibration of Ch. 4.
* ``checkerboard`` (Sec. 5.2.2 and 6.2): the checkerboard on its board, 0 lx, the aperture
  opened for the black squares, sinusoidal 4-step, pitches 5..20, 10 depths 10..28 mm; LPA with
  S = 1, 2, 3, 5, 10, 15, 20, 30, 45, DPA with thresholds 10 % and 20 %, and every uniform MIGL
  from 255 down to 60 (the trade-off search that gave the thesis 96). Calibrated on the black
  plate with the same aperture, as the thesis did.
* ``ch6_plate`` (Sec. 6.2): the white plate under 600 lx, sinusoidal 4-step, the checkerboard's
  pitches and depths; LPA with S = 1, 10, 15, 20, 30 and DPA 10 % and 20 %; white-plate
  calibration.

As in the thesis, every method of one pitch and depth is computed from **one** MIGL sweep:
the set at each MIGL is captured (rendered and given sensor noise) once, the first time a
method asks for it, and every strategy then reads the same images (:class:`SweepRig`). The
strategies are the product's own (:func:`hdrfringe.strategies.lpa.lpa`,
:func:`hdrfringe.strategies.dpa.dpa`); DPA uses the error-correction polynomial trained once
per reproduction as in Sec. 6.1.2 (:func:`train_correction`). Fringe orders come from the
known geometry, as in Ch. 4, so the errors are the phase errors the chapters study.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.calibration import Calibration, measurement_mask
from hdrfringe.core.captures import CameraSettings, ProjectorInfo
from hdrfringe.core.frames import Frame, FringeFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import saturation_count
from hdrfringe.core.saturation.estimate import CorrectionPolynomial, TrainingData
from hdrfringe.errors import InputError
from hdrfringe.rig.base import RigBase
from hdrfringe.rig.scenes import BLACK_PLATE_REFLECTIVITY, Scene, checkerboard, white_plate
from hdrfringe.rig.sensor import sensor_readout
from hdrfringe_thesis.ch4 import (
    SWEEP_DTYPE,
    THESIS_DEPTHS_MM,
    WHITE_PLATE,
    Ch4Setup,
    PlateSweep,
    calibrate_pattern,
    cell_rng,
    orders_from_expected,
    pattern_spec,
    sweep_phase,
)

if TYPE_CHECKING:
    from hdrfringe.core.saturation.dpa_rules import SaturationCDF
    from hdrfringe.strategies.base import StrategyResult
    from hdrfringe_thesis.engine import SweepGrid, Variable

__all__ = [
    "CDF_MIGLS",
    "CHECKERBOARD_DEPTHS_MM",
    "DPA_METHODS",
    "LPA_STEPS_CH5",
    "PLATE_LUX",
    "TRAINING_DEPTH_MM",
    "TRAINING_PITCH",
    "Experiment",
    "SweepRig",
    "adaptive_cell",
    "adaptive_grid",
    "adaptive_task",
    "experiments",
    "train_correction",
    "training_data",
    "training_depths",
]

#: Added light of the white-plate experiments (Sec. 5.2.1, 6.2).
PLATE_LUX = 600.0
#: The MIGL grid of the CDFs kept for Fig. 6.3 (every integer from the top to imin + 20).
CDF_MIGLS: tuple[float, ...] = tuple(float(m) for m in range(255, 59, -1))


@dataclass(frozen=True)
class Experiment:
    """One pixel-wise adaptive experiment: scene, lighting, calibration plate and methods.

    Parameters
    ----------
    name : str
        Store name (``<name>.zarr``).
    scene : {"white_plate", "checkerboard"}
        The scene measured.
    lux : float
        Added ambient light.
    black_aperture : bool
        Camera opened for the black plate (Sec. 5.2.2), which is also the calibration plate.
    patterns, pitches, depths_mm : tuple
        The swept grid.
    methods : tuple of str
        ``"lpa-S"`` (step S gray levels), ``"dpa-P"`` (threshold P %) or ``"dpab-P"`` (DPA
        with the pending-pixel bound).
    uniform_migls : tuple of float
        MIGLs measured as uniform sets on the same captures (trade-off search).
    level_method : str or None
        The method whose index image is broken down by MIGL (Fig. 5.6).
    level_migls : tuple of float
        The MIGLs of that breakdown.
    glint : tuple of (str, float)
        :class:`~hdrfringe_thesis.presets.GlintPlate` arguments for a white plate with a
        specular spot (a rig preset's Ch. 6 plate); empty: the matte plate.
    white_level : float or None
        The camera's aperture (``white_level``) for this experiment's measurements, when a rig
        preset sets one (the ``thesis`` preset's Ch. 6 plate); the calibration then keeps the
        base setup's aperture (phase does not depend on the aperture; opened, the calibration
        plate would saturate at MIGL 255). None: the base setup's (or the black-plate aperture).

    References
    ----------
    Thesis Sec. 5.2.1, 5.2.2 and 6.2 (the three experiments).

    Examples
    --------
    >>> board = experiments(quick=True)["checkerboard"]
    >>> board.scene, board.calibration_plate < 1.0, board.methods[:3]
    ('checkerboard', True, ('lpa-1', 'lpa-2', 'lpa-3'))
    """

    name: str
    scene: str
    lux: float
    black_aperture: bool
    patterns: tuple[str, ...]
    pitches: tuple[int, ...]
    depths_mm: tuple[float, ...]
    methods: tuple[str, ...]
    uniform_migls: tuple[float, ...]
    level_method: str | None = None
    level_migls: tuple[float, ...] = ()
    white_level: float | None = None
    glint: tuple[tuple[str, float], ...] = ()

    def setup(self, base: Ch4Setup) -> Ch4Setup:
        """``base`` with the experiment's aperture.

        Parameters
        ----------
        base : Ch4Setup
            The reproduction's setup.

        Returns
        -------
        Ch4Setup
            ``base`` itself, or with the camera opened for the black plate (Sec. 5.2.2), or
            to the experiment's own ``white_level``.
        """
        if self.white_level is not None:
            return Ch4Setup(
                **{**base.to_dict(), "camera": {**base.camera, "white_level": self.white_level}}
            )
        if not self.black_aperture:
            return base
        cam = base.camera_model().with_aperture_for(BLACK_PLATE_REFLECTIVITY)
        return Ch4Setup(
            **{**base.to_dict(), "camera": {**base.camera, "white_level": cam.white_level}}
        )

    @property
    def calibration_plate(self) -> float:
        """Reflectivity of the calibration plate: the black plate with the opened aperture."""
        return BLACK_PLATE_REFLECTIVITY if self.black_aperture else WHITE_PLATE

    def scene_at(self, depth_mm: float) -> Scene:
        """The experiment's scene at a position.

        Parameters
        ----------
        depth_mm : float
            Plate or board position.

        Returns
        -------
        Scene
            The white plate or the checkerboard there.
        """
        if self.scene == "checkerboard":
            return checkerboard(depth_mm)
        if self.glint:
            from hdrfringe_thesis.presets import glint_plate

            return glint_plate(float(depth_mm), **dict(self.glint))
        return white_plate(depth_mm)


def _migls(top: int, bottom: int, step: int) -> tuple[float, ...]:
    return tuple(float(m) for m in range(top, bottom - 1, -step))


CHECKERBOARD_DEPTHS_MM: tuple[float, ...] = tuple(float(d) for d in range(10, 29, 2))
LPA_STEPS_CH5: tuple[int, ...] = (1, 2, 3, 5, 10, 15, 20, 30, 45)
#: DPA as the thesis ran it (10 % and 20 %), and with the pending-pixel bound ("dpab", beyond
#: the thesis: :func:`hdrfringe.strategies.dpa.bounded_cdf`).
DPA_METHODS: tuple[str, ...] = ("dpa-10", "dpa-20", "dpab-10", "dpab-20")


def experiments(quick: bool = False, preset: str = "") -> dict[str, Experiment]:
    """The three experiments, on the thesis's grid or the reduced ``quick`` one.

    Parameters
    ----------
    quick : bool
        The reduced grid (fewer pitches, depths and uniform MIGLs).
    preset : str
        The rig preset (:data:`hdrfringe_thesis.presets.PRESETS`; ``""``: the default rig). The
        ``thesis`` preset measures the Ch. 6 plate with its own aperture and glint, when it
        sets them (:class:`~hdrfringe_thesis.presets.RigPreset`), and its uniform MIGLs down to
        60, where its last pixels clear.

    Returns
    -------
    dict of str to Experiment
        ``ch5_plate``, ``checkerboard`` and ``ch6_plate``.

    Examples
    --------
    >>> {name: len(e.pitches) * len(e.depths_mm) for name, e in experiments(quick=True).items()}
    {'ch5_plate': 12, 'checkerboard': 9, 'ch6_plate': 9}
    """
    from hdrfringe_thesis.presets import PRESETS

    if preset and preset not in PRESETS:
        raise InputError(f"unknown rig preset {preset!r}; use one of {', '.join(PRESETS)}")
    plate6_level = PRESETS[preset].ch6_plate_white_level if preset else None
    glint = PRESETS[preset].ch6_plate_glint if preset else None
    plate6_glint = tuple(sorted(glint.items())) if glint else ()
    board_pitches = (8, 14, 20) if quick else tuple(range(5, 21))
    board_depths = (10.0, 18.0, 26.0) if quick else CHECKERBOARD_DEPTHS_MM
    plate_levels = _migls(255, 60, 5)
    return {
        "ch5_plate": Experiment(
            "ch5_plate",
            "white_plate",
            PLATE_LUX,
            False,
            ("sinusoidal-3", "triangular-3", "triangular-2"),
            (6, 12, 20) if quick else tuple(range(4, 21)),
            (6.0, 18.0, 30.0, 42.0) if quick else THESIS_DEPTHS_MM,
            ("lpa-5",),
            _migls(255, 190, 5),
            "lpa-5",
            plate_levels,
        ),
        "checkerboard": Experiment(
            "checkerboard",
            "checkerboard",
            0.0,
            True,
            ("sinusoidal-4",),
            board_pitches,
            board_depths,
            (*(f"lpa-{s}" for s in LPA_STEPS_CH5), *DPA_METHODS),
            _migls(255, 60, 5 if quick else 1),
        ),
        "ch6_plate": Experiment(
            "ch6_plate",
            "white_plate",
            PLATE_LUX,
            False,
            ("sinusoidal-4",),
            board_pitches,
            board_depths,
            ("lpa-1", "lpa-10", "lpa-15", "lpa-20", "lpa-30", *DPA_METHODS),
            _migls(255, 190, 5) if not preset else _migls(255, 60, 5),
            white_level=plate6_level,
            glint=plate6_glint,
        ),
    }


# --------------------------------------------------------------------------------------------
# one MIGL sweep, captured lazily, shared by every method
# --------------------------------------------------------------------------------------------
class SweepRig(RigBase):
    """The rig protocol over one scene position: each MIGL's set is captured once.

    ``capture(frames)`` accepts the fringe frames of ``sweep.spec`` at any MIGL; the noisy
    images are drawn from a generator seeded by ``key`` and the MIGL, and kept, so every
    strategy that asks for a MIGL gets the same images (the thesis processed one captured sweep
    with every method). ``sets_rendered`` counts distinct sets.

    Parameters
    ----------
    sweep : PlateSweep
        The noise-free signals of the position.
    setup : Ch4Setup
        Camera settings and seed.
    lux : float
        Added ambient light.
    key : tuple
        The cell's coordinates, for its noise (:func:`~hdrfringe_thesis.ch4.cell_rng`).

    Examples
    --------
    >>> setup = Ch4Setup(width=32, height=24, camera_field_mm=16.0)
    >>> spec = pattern_spec("sinusoidal-4", 8)
    >>> rig = SweepRig(PlateSweep(18.0, setup, spec), setup, 600.0, ("doc", 8, 18.0))
    >>> a = rig.capture(spec.with_migl(205.0).frames())
    >>> b = rig.capture(spec.with_migl(205.0).frames())
    >>> a.shape, a.dtype, a is b, rig.sets_rendered
    ((4, 24, 32), dtype('uint8'), True, 1)
    """

    def __init__(self, sweep: PlateSweep, setup: Ch4Setup, lux: float, key: tuple[Any, ...]):
        self.sweep = sweep
        self.setup = setup
        self.lux = float(lux)
        self.key = key
        self.camera = setup.camera_model()
        self.camera_bit_depth = self.camera.bit_depth
        self.image_shape = sweep.rig.image_shape
        self.projector: ProjectorInfo = sweep.rig.projector
        self._sets: dict[float, NDArray] = {}

    @property
    def sets_rendered(self) -> int:
        """Number of distinct sets captured so far."""
        return len(self._sets)

    def capture(self, frames: Sequence[Frame], settings: CameraSettings | None = None) -> NDArray:
        """The set's images at the frames' MIGL (camera settings: the reference only).

        Parameters
        ----------
        frames : sequence of Frame
            The fringe frames of ``sweep.spec`` at one MIGL, in shift order.
        settings : CameraSettings, optional
            Only the reference settings (or None) are accepted.

        Returns
        -------
        ndarray, shape (N, H, W)
            The set's images in the camera's dtype, the same array each time that MIGL is
            asked for.

        Raises
        ------
        InputError
            Other camera settings, frames that are not this set's, or no frames.
        """
        if settings is not None and settings != CameraSettings():
            raise InputError("the sweep rig captures at the reference camera settings only")
        frames = list(frames)
        fringes = [f for f in frames if isinstance(f, FringeFrame)]
        if not fringes or len(fringes) != len(frames):
            raise InputError("the sweep rig captures fringe sets only")
        migl = float(fringes[0].spec.migl)
        if fringes != self.sweep.spec.with_migl(migl).frames():
            raise InputError(
                f"the sweep rig holds {self.sweep.spec.label()} only; asked for "
                f"{fringes[0].spec.label()}"
            )
        if migl not in self._sets:
            signal = self.sweep.signal(migl, self.lux)
            rng = cell_rng(self.setup, *self.key, migl)
            self._sets[migl] = sensor_readout(signal, self.camera, rng, dtype=SWEEP_DTYPE)
        return self._sets[migl]


def _run_method(
    method: str, rig: SweepRig, spec: FringeSpec, correction: CorrectionPolynomial
) -> StrategyResult:
    from hdrfringe.strategies.dpa import dpa
    from hdrfringe.strategies.lpa import lpa

    kind, _, value = method.partition("-")
    if kind == "lpa":
        return lpa(rig, spec, step=float(value))
    if kind in ("dpa", "dpab"):
        return dpa(
            rig,
            spec,
            threshold=float(value) / 100.0,
            correction=correction,
            bound_pending=kind == "dpab",
        )
    raise InputError(f"unknown adaptive method {method!r}; use lpa-S, dpa-P or dpab-P")


def _errors(
    images: NDArray, spec: FringeSpec, sweep: PlateSweep, cal: Calibration, mask: NDArray[np.bool_]
) -> NDArray[np.float64]:
    phase = orders_from_expected(sweep_phase(images, spec), sweep.expected_phase)
    return (cal.height(phase) - sweep.truth_height_mm)[mask]


def _stats(err: NDArray[np.float64]) -> tuple[float, float, float]:
    """(RMSE, mean error, standard deviation) of an error sample; NaN when empty."""
    if err.size == 0:
        return np.nan, np.nan, np.nan
    return float(np.sqrt(np.mean(err * err))), float(np.mean(err)), float(np.std(err))


def _cdf_values(cdf: SaturationCDF) -> NDArray[np.float64]:
    values = cdf.values
    return np.array([values[int(m)] if int(m) < values.size else 1.0 for m in CDF_MIGLS])


def adaptive_cell(
    exp: Experiment,
    pattern: str,
    pitch: int,
    depth_mm: float,
    base: Ch4Setup,
    correction: CorrectionPolynomial,
) -> dict[str, NDArray[np.float64]]:
    """Every method of ``exp`` on one MIGL sweep of one pattern, pitch and depth.

    Parameters
    ----------
    exp : Experiment
        The experiment.
    pattern : str
        Pattern name (:data:`~hdrfringe_thesis.ch4.ALL_PATTERNS`).
    pitch : int
        Fringe pitch in projector pixels.
    depth_mm : float
        Scene position.
    base : Ch4Setup
        The reproduction's setup (the experiment may open the aperture).
    correction : CorrectionPolynomial
        DPA's error correction (:func:`train_correction`).

    Returns
    -------
    dict
        Per method (in ``exp.methods`` order): ``rmse_mm``, ``mean_error_mm``, ``std_mm``,
        ``sets`` (sets captured), ``never_unsaturated`` (fraction of measured pixels);
        per uniform MIGL: ``uniform_rmse_mm``, ``uniform_mean_error_mm``, ``uniform_std_mm``,
        ``saturated_fraction``; per level MIGL of ``exp.level_method``'s index image:
        ``level_fraction``, ``level_rmse_mm``, ``level_mean_error_mm``; per method and CDF MIGL
        (DPA only, NaN otherwise): ``cdf_initial`` and ``cdf_final``; per CDF MIGL, the actual
        CDF from LPA's step-1 index (``cdf_actual``, NaN without an ``lpa-1`` method).

    References
    ----------
    Thesis Sec. 5.2 (LPA, Eq. 5.1), Sec. 6.2-6.3 (DPA), Sec. 6.1.3 (the CDFs).
    """
    setup = exp.setup(base)
    spec = pattern_spec(pattern, pitch, setup.imin)
    cal_setup = base if exp.white_level is not None else setup
    cal, _ = calibrate_pattern(
        pattern, pitch, cal_setup, THESIS_DEPTHS_MM, plate_reflectivity=exp.calibration_plate
    )
    mask = measurement_mask((setup.height, setup.width), setup.border_px)
    sweep = PlateSweep(depth_mm, setup, spec, scene=exp.scene_at(depth_mm))
    rig = SweepRig(sweep, setup, exp.lux, (exp.name, pattern, pitch, depth_mm))
    nm, nu, nl, nc = len(exp.methods), len(exp.uniform_migls), len(exp.level_migls), len(CDF_MIGLS)
    out = {
        k: np.full(nm, np.nan)
        for k in ("rmse_mm", "mean_error_mm", "std_mm", "sets", "never_unsaturated")
    }
    out |= {
        k: np.full(nu, np.nan)
        for k in (
            "uniform_rmse_mm",
            "uniform_mean_error_mm",
            "uniform_std_mm",
            "saturated_fraction",
        )
    }
    out |= {
        k: np.full(max(nl, 1), np.nan)
        for k in ("level_fraction", "level_rmse_mm", "level_mean_error_mm")
    }
    out |= {"cdf_initial": np.full((nm, nc), np.nan), "cdf_final": np.full((nm, nc), np.nan)}
    out["cdf_actual"] = np.full(nc, np.nan)
    top = rig.capture(spec.frames())
    saturated_at_top = saturation_count(top, setup.camera_model().bit_depth) > 0
    for i, method in enumerate(exp.methods):
        res = _run_method(method, rig, spec, correction)
        err = _errors(res.images, spec, sweep, cal, mask)
        out["rmse_mm"][i], out["mean_error_mm"][i], out["std_mm"][i] = _stats(err)
        out["sets"][i] = res.sets_captured
        out["never_unsaturated"][i] = float(res.never_unsaturated[mask].mean())
        if "initial_cdf" in res.details:
            out["cdf_initial"][i] = _cdf_values(res.details["initial_cdf"])
            out["cdf_final"][i] = _cdf_values(res.details["final_cdf"])
        if method == "lpa-1" and saturated_at_top.any():  # Fig. 6.3's actual CDF
            from hdrfringe.core.saturation.dpa_rules import index_image_cdf
            from hdrfringe.strategies.dpa_analysis import index_without_never

            idx = index_without_never(res)
            actual = index_image_cdf(idx, saturated_at_top, spec.migl, CDF_MIGLS[-1])
            out["cdf_actual"] = _cdf_values(actual)
        if method == exp.level_method:
            index = res.migl_index[mask]
            for j, m in enumerate(exp.level_migls):
                at = index == m
                out["level_fraction"][j] = float(at.mean())
                rmse, bias, _ = _stats(err[at])
                out["level_rmse_mm"][j], out["level_mean_error_mm"][j] = rmse, bias
    for j, m in enumerate(exp.uniform_migls):
        imgs = rig.capture(spec.with_migl(m).frames())
        err = _errors(imgs, spec, sweep, cal, mask)
        stats = _stats(err)
        out["uniform_rmse_mm"][j], out["uniform_mean_error_mm"][j], out["uniform_std_mm"][j] = stats
        out["saturated_fraction"][j] = float(
            (saturation_count(imgs, rig.camera_bit_depth) > 0)[mask].mean()
        )
    return out


# --------------------------------------------------------------------------------------------
# the DPA correction polynomial of a reproduction (Sec. 6.1.2)
# --------------------------------------------------------------------------------------------
#: Sec. 6.1.2 training: white plate, 600 lx, sinusoidal 4-step, pitch 20 (one position, at the
#: middle of the calibration depths).
TRAINING_PITCH = 20
TRAINING_DEPTH_MM = 26.0


class _TrainingRig(RigBase):
    """The rig protocol over one plate position, any fringe or uniform frames of its set.

    Each call gets fresh noise from a generator keyed by the position, the frames and how many
    times those frames were captured before (as :class:`SimulatedRig` does), on the sweep's
    exact linear decomposition (:class:`PlateSweep`): the 25-position training of Sec. 6.1.2
    in seconds instead of minutes.
    """

    def __init__(self, sweep: PlateSweep, setup: Ch4Setup, lux: float) -> None:
        self.sweep, self.setup, self.lux = sweep, setup, float(lux)
        self.camera = setup.camera_model()
        self.camera_bit_depth = self.camera.bit_depth
        self._counts: dict[str, int] = {}

    def capture(self, frames: Sequence[Frame], settings: CameraSettings | None = None) -> NDArray:
        if settings is not None and settings != CameraSettings():
            raise InputError("the training rig captures at the reference camera settings only")
        frames = list(frames)
        label = json.dumps([f.manifest_entry("") for f in frames], sort_keys=True)
        n = self._counts.get(label, 0)
        self._counts[label] = n + 1
        rng = cell_rng(self.setup, "train", self.sweep.depth_mm, label, n)
        signal = self.sweep.frames_signal(frames, self.lux)
        return sensor_readout(signal, self.camera, rng, dtype=SWEEP_DTYPE)


def training_depths(base: Ch4Setup) -> tuple[float, ...]:
    """The plate positions of DPA's correction training for a setup.

    Parameters
    ----------
    base : Ch4Setup
        The reproduction's setup.

    Returns
    -------
    tuple of float
        The default rig: one position (:data:`TRAINING_DEPTH_MM`); a rig preset: the 25
        calibration positions, as the thesis's "25 sets" (Sec. 6.1.2).

    Examples
    --------
    >>> training_depths(Ch4Setup()), len(training_depths(Ch4Setup.thesis_matched()))
    ((26.0,), 25)
    """
    return THESIS_DEPTHS_MM if base.preset else (TRAINING_DEPTH_MM,)


def training_data(base: Ch4Setup, depths_mm: Sequence[float]) -> TrainingData:
    """The Sec. 6.1.2 training sweeps (LPA step 1, white plate, 600 lx, pitch 20) at several
    plate positions, joined into one :class:`~hdrfringe.core.saturation.estimate.TrainingData`.

    Each position is swept on its own
    (:func:`~hdrfringe.core.saturation.estimate.training_data_from_rig`
    on the sweep's decomposition of the rig); the per-pixel arrays are stacked along the image
    rows, so the training sees every position's pixels as one taller image.

    Parameters
    ----------
    base : Ch4Setup
        The rig (camera, projector, gamma pre-compensation, seed).
    depths_mm : sequence of float
        Plate positions.

    Returns
    -------
    TrainingData
        ``sets_captured`` is the total over the positions; ``expected_at_top`` is None.

    References
    ----------
    Thesis Sec. 6.1.2 ("25 sets of phase-shifted images ... pitch of 20 pixels on a flat white
    plate").

    Examples
    --------
    >>> setup = Ch4Setup(width=32, height=24, camera_field_mm=16.0)
    >>> data = training_data(setup, (10.0, 30.0))
    >>> data.index_image.shape, data.images_at_top.shape[0]
    ((48, 32), 4)
    """
    from hdrfringe.core.saturation.estimate import training_data_from_rig

    spec = pattern_spec("sinusoidal-4", TRAINING_PITCH, base.imin)
    parts = [
        training_data_from_rig(_TrainingRig(PlateSweep(d, base, spec), base, PLATE_LUX), spec)
        for d in depths_mm
    ]

    def join(name: str, axis: int) -> Any:
        values = [getattr(p, name) for p in parts]
        return None if values[0] is None else np.concatenate(values, axis=axis)

    return TrainingData(
        index_image=join("index_image", 0),
        images_at_top=join("images_at_top", 1),
        composite=join("composite", 1),
        reference=join("reference", 1),
        reference_migl=join("reference_migl", 0),
        offset=join("offset", 0),
        expected_at_top=None,
        spec=spec,
        bit_depth=parts[0].bit_depth,
        sets_captured=sum(p.sets_captured for p in parts),
    )


def train_correction(base: Ch4Setup, order: int = 2) -> CorrectionPolynomial:
    """The DPA error-correction polynomial of thesis Sec. 6.1.2 for this rig.

    LPA with a step of 1 on the white plate under 600 lx at a pitch of 20 px: every saturated
    pixel's true peak against its Eq. 6.2 estimate
    (:meth:`~hdrfringe.core.saturation.estimate.TrainingData.train`). The default rig trains at one
    position on the live virtual rig (the same camera as the sweeps); a rig preset at the 25
    positions of the thesis (:func:`training_depths`, :func:`training_data`). Deterministic.

    Parameters
    ----------
    base : Ch4Setup
        The reproduction's setup (its camera and seed).
    order : int
        Polynomial order.

    Returns
    -------
    CorrectionPolynomial
        With the RMSE of the estimate before and after correction.

    References
    ----------
    Thesis Sec. 6.1.2, Eq. 6.2-6.4.
    """
    from hdrfringe.core.saturation.estimate import training_data_from_rig
    from hdrfringe.rig.simulated import Lighting

    spec = pattern_spec("sinusoidal-4", TRAINING_PITCH, base.imin)
    depths = training_depths(base)
    if not base.preset:
        rig = base.rig(TRAINING_DEPTH_MM).replace(lighting=Lighting(ambient_lux=PLATE_LUX))
        data = training_data_from_rig(rig, spec)
        source = "hdrfringe reproduce: white plate, 600 lx, pitch 20"
    else:
        data = training_data(base, depths)
        source = (
            f"hdrfringe reproduce --preset {base.preset}: white plate at {len(depths)} "
            "positions, 600 lx, pitch 20"
        )
    return data.train(order, metadata={"source": source})


# --------------------------------------------------------------------------------------------
# sweep grids and tasks
# --------------------------------------------------------------------------------------------
def adaptive_grid(exp: Experiment, quick: bool = False) -> SweepGrid:
    """The sweep of ``exp``: one task per pattern, pitch and depth; methods, uniform MIGLs,
    level MIGLs and CDF MIGLs are trailing dims of the variables.

    Parameters
    ----------
    exp : Experiment
        The experiment.
    quick : bool
        Recorded in the grid's attributes (the grid itself comes from ``exp``).

    Returns
    -------
    SweepGrid
        Computed by :func:`adaptive_task`; the variables are the keys of
        :func:`adaptive_cell`'s result.

    Examples
    --------
    >>> grid = adaptive_grid(experiments(quick=True)["ch5_plate"], quick=True)
    >>> grid.n_blocks, grid.block_shape(grid.variables[0])
    (36, (1,))
    """
    from hdrfringe_thesis.engine import SweepGrid, Variable

    methods = {"strategy": list(exp.methods)}
    uniform = {"uniform_migl": list(exp.uniform_migls)}
    levels = {"index_migl": list(exp.level_migls or (0.0,))}
    cdf = {"cdf_migl": list(CDF_MIGLS)}

    def var(name: str, dims: dict[str, list[Any]], units: str, long_name: str) -> Variable:
        attrs = {"long_name": long_name} | ({"units": units} if units else {})
        return Variable(name, extra_dims=dims, attrs=attrs)

    return SweepGrid(
        dims={
            "pattern": list(exp.patterns),
            "pitch": list(exp.pitches),
            "depth_mm": list(exp.depths_mm),
        },
        variables=[
            var("rmse_mm", methods, "mm", "height RMSE"),
            var("mean_error_mm", methods, "mm", "mean height error (bias)"),
            var("std_mm", methods, "mm", "standard deviation of the height error"),
            var("sets", methods, "", "fringe sets captured"),
            var("never_unsaturated", methods, "", "fraction of pixels saturated in every set"),
            var("uniform_rmse_mm", uniform, "mm", "height RMSE of the uniform set"),
            var("uniform_mean_error_mm", uniform, "mm", "mean error of the uniform set"),
            var("uniform_std_mm", uniform, "mm", "error standard deviation, uniform set"),
            var("saturated_fraction", uniform, "", "fraction of pixels saturated (any shift)"),
            var("level_fraction", levels, "", "fraction of pixels with this index MIGL"),
            var("level_rmse_mm", levels, "mm", "RMSE of the pixels with this index MIGL"),
            var("level_mean_error_mm", levels, "mm", "mean error of those pixels"),
            var("cdf_initial", methods | cdf, "", "DPA CDF estimated from the first set"),
            var("cdf_final", methods | cdf, "", "DPA CDF after the last update"),
            var("cdf_actual", cdf, "", "actual CDF (LPA step-1 index image)"),
        ],
        attrs={
            "experiment": exp.name,
            "scene": exp.scene,
            "lux": exp.lux,
            "black_aperture": int(exp.black_aperture),
            "level_method": exp.level_method or "",
            "quick": int(quick),
        },
    )


def adaptive_task(coords: dict[str, Any], params: dict[str, Any]) -> dict[str, NDArray]:
    """Engine task: one pattern, pitch and depth of an experiment (:func:`adaptive_cell`).

    Parameters
    ----------
    coords : dict
        The block's ``pattern``, ``pitch`` and ``depth_mm`` (of :func:`adaptive_grid`).
    params : dict
        ``setup`` (:meth:`Ch4Setup.to_dict`), ``experiment`` (its name), ``quick`` and
        ``correction`` (:meth:`CorrectionPolynomial.to_dict`).

    Returns
    -------
    dict
        As :func:`adaptive_cell`.
    """
    preset = str(params["setup"].get("preset", ""))
    exp = experiments(bool(params["quick"]), preset)[params["experiment"]]
    return adaptive_cell(
        exp,
        coords["pattern"],
        int(coords["pitch"]),
        float(coords["depth_mm"]),
        Ch4Setup(**params["setup"]),
        CorrectionPolynomial.from_dict(params["correction"]),
    )
