"""``hdrfringe train-correction``: DPA's error-correction polynomial, trained and saved."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hdrfringe.errors import InputError
from hdrfringe.tasks._progress import Progress, quiet

__all__ = ["TrainReport", "train_correction"]


@dataclass(frozen=True)
class TrainReport:
    """What ``train-correction`` wrote.

    Parameters
    ----------
    output : Path
        The polynomial's file (JSON).
    polynomial : CorrectionPolynomial
        The trained polynomial (samples, RMSE before and after).
    label : str
        The training set's label.
    sets_captured : int
        Sets of the LPA step-1 sweep.

    Examples
    --------
    >>> TrainReport(Path("corr.json"), None, "s4 p20", 196).sets_captured
    196
    """

    output: Path
    polynomial: Any
    label: str
    sets_captured: int


def train_correction(
    output: Path,
    *,
    folder: Path | None = None,
    sim: Mapping[str, Any] | None = None,
    steps: int = 4,
    pitch: float | None = None,
    imin: float = 40.0,
    migl: float = 255.0,
    order: int = 2,
    truth: str = "scaled",
    margin: int = 10,
    force: bool = False,
    progress: Progress = quiet,
) -> TrainReport:
    """Train DPA's error-correction polynomial (thesis Sec. 6.1.2, Eq. 6.3-6.4) and save it.

    From a step-1 MIGL sweep ``folder``, or live on the virtual rig ``sim``. The options and
    the output are checked before the (slow) training captures; the file is written
    atomically.

    Parameters
    ----------
    output : Path
        The JSON file to write.
    folder : Path, optional
        A step-1 MIGL sweep capture folder.
    sim : mapping, optional
        The live virtual rig: keyword arguments of :func:`hdrfringe.rig.factory.virtual_rig`
        (``scene`` among them).
    steps, pitch, imin, migl
        The training set (:func:`hdrfringe.strategies.dpa_training.training_spec`; ``pitch``
        also picks a folder's set).
    order : int
        Polynomial degree.
    truth : str
        The truth model (:data:`hdrfringe.core.saturation.estimate.TRUTH_MODELS`).
    margin : int
        Margin of the training pixels.
    force : bool
        Replace an existing file.
    progress : callable
        The live sweep, as one stage.

    Returns
    -------
    TrainReport

    Examples
    --------
    >>> train_correction(Path("corr.json"), truth="exact-ish")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: unknown truth 'exact-ish'; use one of ...
    """
    from hdrfringe.core.saturation.estimate import (
        TRUTH_MODELS,
        check_correction_order,
        training_data_from_rig,
    )
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_file,
        staged_output_file,
    )
    from hdrfringe.strategies.dpa_training import training_data_from_folder, training_spec

    if truth not in TRUTH_MODELS:
        raise InputError(f"unknown truth {truth!r}; use one of {', '.join(TRUTH_MODELS)}")
    check_correction_order(order)  # before the (slow) training captures
    check_output_against_inputs(output, [folder])
    output = check_output_file(output, force)  # before the work; the write replaces only this
    if sim is not None:
        from hdrfringe.rig.factory import virtual_rig  # the simulator loads only when used

        live = virtual_rig(**sim)
        spec = training_spec(steps=steps, pitch=pitch, imin=imin, migl=migl)
        source = (
            f"live virtual rig: {live.scene.to_manifest()}, "
            f"{sim.get('ambient_lux', 0.0):g} lx, seed {sim.get('seed', 0)}"
        )
        with progress("LPA step-1 sweep on the virtual rig", None):
            data = training_data_from_rig(live, spec, margin=margin)
    else:
        from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL, read_capture_folder

        assert folder is not None
        source = str(folder)
        caps = read_capture_folder(folder, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL)
        data = training_data_from_folder(caps, pitch, margin=margin)
    poly = data.train(order, truth=truth, metadata={"source": source})  # type: ignore[arg-type]
    with staged_output_file(output, force=force) as tmp:  # atomic: complete or not at all
        poly.save(tmp, force=True)  # (the temporary file exists already)
    return TrainReport(output, poly, data.spec.label(), data.sets_captured)
