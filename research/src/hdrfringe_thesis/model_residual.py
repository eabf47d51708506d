"""The calibration model's own residual on the virtual rig's geometry, computed, not assumed.

The linear phase-to-height model of thesis Eq. 2.11 / 2.15 (``h = K dphi``) is exact only for
a telecentric rig; on a pinhole camera and projector the phase difference grows slightly
faster than linearly with height (docs/calibration.md derives the exact, rational relation).
A linear ``K`` fitted over the calibration depths therefore mis-states every depth by a fixed
amount that no amount of averaging removes: the **model residual**. It is a property of the
geometry and of the calibration depths alone, not of noise or saturation.

:func:`model_residual` computes it the way the reproduction's calibration is made, without
noise: the noise-free absolute phase of every camera pixel at the reference plane and at each
plate depth comes from the rig's geometry (the projector column each pixel sees,
:meth:`~hdrfringe.rig.simulated.SimulatedRig.truth`, the same expected phase the sweeps take
their fringe orders from); :func:`hdrfringe.core.calibration.calibrate` fits the same model with the
same 21 px median and mean filter; the model's height at each measured depth, minus the depth,
over the measurement pixels (10 px border excluded), is the model residual per depth: its mean
(``bias_mm``) is what every method of a reproduction shares as bias, its RMS over pixels
(``rms_mm``) what it adds to their RMSE.

On the thesis's geometry (1.9 m standoff, 15 degrees, calibration 2..50 mm by 2) the linear
model's residual is 0.146 mm RMS over the 25 calibration depths and -0.166 mm on average over
the Ch. 6 depths 10..28 mm: the per-depth bias of the reproduction's Ch. 4 and Ch. 6 sweeps to
three decimals (``research/tests/test_model_residual.py``). The rational model is exact for this
geometry: its residual is what the 21 px filter leaves, 1e-5 mm on the reproduction's camera
(about 1e-3 mm on a 64 x 48 camera over the same field).

For a real calibration there is no geometry to trace: its model residual is the fit residual at
the calibration depths, which every :class:`~hdrfringe.core.calibration.Calibration` carries
(``residual_rms_mm``; ``hdrfringe calibrate`` prints it and ``measure`` writes it to
``metrics.json`` as ``calibration_residual_mm``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.calibration import MODELS, calibrate
from hdrfringe.errors import InputError
from hdrfringe_thesis.ch4 import TWO_PI, Ch4Setup

__all__ = ["ModelResidual", "model_residual"]


@dataclass(frozen=True)
class ModelResidual:
    """Per-depth residual of a calibration model fitted to noise-free phases.

    Parameters
    ----------
    model : str
        The calibration model (``"linear"``: Eq. 2.15).
    calibration_depths_mm : ndarray, shape (J,)
        Plate depths of the calibration.
    depths_mm : ndarray, shape (D,)
        Depths at which the residual is evaluated.
    bias_mm : ndarray, shape (D,)
        Mean over the measurement pixels of model height minus depth, per depth.
    rms_mm : ndarray, shape (D,)
        RMS over the measurement pixels of the same, per depth.

    References
    ----------
    Thesis Eq. 2.11, 2.15 (the linear model), Sec. 4.1 (filter, border, RMSE).

    Examples
    --------
    >>> r = ModelResidual("linear", np.array([2.0, 4.0]), np.array([2.0, 4.0]),
    ...                   np.array([-0.1, 0.1]), np.array([0.1, 0.2]))
    >>> round(r.mean_mm, 3), round(r.rms_total_mm, 4), r.over([4.0]).bias_mm.tolist()
    (0.0, 0.1581, [0.1])
    """

    model: str
    calibration_depths_mm: NDArray[np.float64]
    depths_mm: NDArray[np.float64]
    bias_mm: NDArray[np.float64]
    rms_mm: NDArray[np.float64]

    @property
    def mean_mm(self) -> float:
        """Mean of the per-depth bias: the bias a table averaged over these depths shows."""
        return float(np.mean(self.bias_mm))

    @property
    def rms_total_mm(self) -> float:
        """RMS over every depth and measurement pixel: what the model alone adds to an RMSE."""
        return float(np.sqrt(np.mean(self.rms_mm**2)))

    def over(self, depths_mm: Sequence[float]) -> ModelResidual:
        """The residual at some of the depths only.

        Parameters
        ----------
        depths_mm : sequence of float
            Depths, each one of :attr:`depths_mm`.

        Returns
        -------
        ModelResidual
            The same calibration, evaluated at ``depths_mm``.

        Raises
        ------
        InputError
            A depth that was not evaluated.
        """
        have = {float(d): i for i, d in enumerate(self.depths_mm)}
        missing = [float(d) for d in depths_mm if float(d) not in have]
        if missing:
            raise InputError(
                f"model residual not evaluated at {missing} mm; pass them as depths_mm to "
                "model_residual"
            )
        idx = [have[float(d)] for d in depths_mm]
        return ModelResidual(
            self.model,
            self.calibration_depths_mm,
            self.depths_mm[idx],
            self.bias_mm[idx],
            self.rms_mm[idx],
        )

    def to_dict(self) -> dict[str, object]:
        """JSON values: model, depths, per-depth bias and RMS, their mean and total RMS.

        Returns
        -------
        dict
            ``model``, ``calibration_depths_mm``, ``depths_mm``, ``bias_mm``, ``rms_mm``,
            ``mean_mm`` and ``rms_total_mm``.
        """
        return {
            "model": self.model,
            "calibration_depths_mm": self.calibration_depths_mm.tolist(),
            "depths_mm": self.depths_mm.tolist(),
            "bias_mm": self.bias_mm.tolist(),
            "rms_mm": self.rms_mm.tolist(),
            "mean_mm": self.mean_mm,
            "rms_total_mm": self.rms_total_mm,
        }


def model_residual(
    setup: Ch4Setup,
    calibration_depths_mm: Sequence[float],
    depths_mm: Sequence[float] | None = None,
    *,
    model: str = "linear",
    pitch: float = 6.0,
) -> ModelResidual:
    """The model residual of a noise-free calibration on the virtual rig's geometry.

    Parameters
    ----------
    setup : Ch4Setup
        Camera, field of view, filter window and border of the reproduction.
    calibration_depths_mm : sequence of float
        Plate depths of the calibration (the reference plane at 0 is added).
    depths_mm : sequence of float, optional
        Depths where the residual is evaluated (default the calibration depths).
    model : {"linear", "rational", "poly2", "poly3"}
        The calibration model.
    pitch : float
        Fringe pitch of the phase in projector pixels; the heights of every model do not
        depend on it (the phase scales with 1/pitch and the fitted coefficients follow).

    Returns
    -------
    ModelResidual
        Per depth, the mean and RMS over the measurement pixels of model height minus depth.

    Raises
    ------
    InputError
        An unknown model, or depths the calibration refuses (fewer than two, zero, repeated).

    References
    ----------
    Thesis Eq. 2.10, 2.11, 2.15 (the linear model), Sec. 4.1 (calibration procedure).

    Examples
    --------
    A small camera over the thesis's field (the residual is a property of the geometry):

    >>> setup = Ch4Setup(width=64, height=48)
    >>> r = model_residual(setup, [6.0, 18.0, 30.0, 42.0], [18.0, 42.0])
    >>> r.bias_mm.round(2).tolist()
    [-0.16, 0.14]
    >>> round(model_residual(setup, [6.0, 18.0, 30.0, 42.0], model="rational").rms_total_mm, 3)
    0.001
    """
    if model not in MODELS:
        raise InputError(f"unknown calibration model {model!r}; use one of {', '.join(MODELS)}")
    cal_depths = tuple(float(d) for d in calibration_depths_mm)
    depths = cal_depths if depths_mm is None else tuple(float(d) for d in depths_mm)
    bias, rms = _residual(
        json.dumps(setup.to_dict(), sort_keys=True), cal_depths, depths, model, float(pitch)
    )
    return ModelResidual(model, np.array(cal_depths), np.array(depths), bias, rms)


@lru_cache(maxsize=64)
def _plate_phase(setup_json: str, depth_mm: float, pitch: float) -> NDArray[np.float64]:
    """Noise-free absolute phase of the white plate at ``depth_mm`` (cached: reports ask for
    the same depths several times)."""
    setup = Ch4Setup(**json.loads(setup_json))
    return TWO_PI * setup.rig(depth_mm).truth().u / pitch


@lru_cache(maxsize=32)
def _residual(
    setup_json: str,
    cal_depths: tuple[float, ...],
    depths: tuple[float, ...],
    model: str,
    pitch: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    setup = Ch4Setup(**json.loads(setup_json))
    cal = calibrate(
        _plate_phase(setup_json, 0.0, pitch),
        np.stack([_plate_phase(setup_json, d, pitch) for d in cal_depths]),
        np.asarray(cal_depths),
        model=model,
        compare=[model],
        window_px=setup.window_px,
        border_px=setup.border_px,
    )
    mask = cal.measurement_mask()
    bias, rms = np.empty(len(depths)), np.empty(len(depths))
    for i, d in enumerate(depths):
        err = cal.height(_plate_phase(setup_json, d, pitch))[mask] - d
        bias[i], rms[i] = float(np.mean(err)), float(np.sqrt(np.mean(err * err)))
    bias.setflags(write=False)
    rms.setflags(write=False)
    return bias, rms
