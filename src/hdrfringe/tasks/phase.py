"""``hdrfringe phase``: every fringe set of a capture folder to phase and quality maps."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["PhaseOptions", "PhaseReport", "phase"]


@dataclass(frozen=True)
class PhaseOptions:
    """How ``phase`` decodes (:func:`hdrfringe.core.decode.decode_captures`) and what it writes.

    Parameters
    ----------
    min_modulation : float, optional
        Least intensity modulation I' in DN of a valid pixel.
    keep_saturated : bool
        Keep the (biased) phase of pixels with saturated shifts.
    saturated : str
        ``flag`` or ``exclude``.
    min_shifts : int
        With ``exclude``: least unsaturated shifts per pixel.
    previews : bool
        A PNG preview beside every map.
    uncertainty : bool
        Write the predicted per-pixel phase std.
    noise_sigma : float, optional
        Camera noise std in DN (else the manifest's, else estimated).
    map_dtype : str
        ``float64`` or ``float32``.
    harmonics : str
        ``off``, ``auto`` or a number of orders.

    Examples
    --------
    >>> PhaseOptions(saturated="exclude", min_shifts=4).min_shifts
    4
    """

    min_modulation: float | None = None
    keep_saturated: bool = False
    saturated: str = "flag"
    min_shifts: int = 3
    previews: bool = True
    uncertainty: bool = True
    noise_sigma: float | None = None
    map_dtype: str = "float64"
    harmonics: str = "off"


@dataclass(frozen=True)
class PhaseReport:
    """What ``phase`` wrote.

    Parameters
    ----------
    output : Path
        The result folder.
    summary : dict
        ``phase_summary.json`` (sets, families, uncertainty, notes, files).
    n_pixels : int
        Pixels per image.

    Examples
    --------
    >>> PhaseReport(Path("out"), {"files": []}, 3072).n_pixels
    3072
    """

    output: Path
    summary: dict[str, Any]
    n_pixels: int


def phase(folder: Path, output: Path, options: PhaseOptions, *, force: bool = False) -> PhaseReport:
    """Decode a capture folder: wrapped, unwrapped and absolute phase with quality maps.

    The output is checked (not the input, new or empty, or ``force``) before the folder is
    read, and written all or nothing.

    Parameters
    ----------
    folder : Path
        The capture folder.
    output : Path
        The result folder.
    options : PhaseOptions
        Decoding and what is written.
    force : bool
        Replace an existing output folder.

    Returns
    -------
    PhaseReport

    Raises
    ------
    CaptureFormatError
        A folder without fringe sets.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate
    >>> tmp = Path(tempfile.mkdtemp())
    >>> _ = simulate(tmp / "caps", "white_plate", rig_options={"resolution": (64, 48)},
    ...              pitches=[1024.0, 64.0, 8.0])
    >>> report = phase(tmp / "caps", tmp / "out", PhaseOptions(previews=False))
    >>> [s["label"] for s in report.summary["sets"]][:1]
    ['s4_p1024_v_i40_g255']
    >>> "unwrapped_phase.tiff" in report.summary["files"]
    True
    """
    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.io.captures import DECODE_BYTES_PER_PIXEL, read_capture_folder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        staged_output_dir,
    )

    check_output_against_inputs(output, [folder])
    output = check_output_dir(output, force)
    captures = read_capture_folder(folder, work_bytes_per_pixel=DECODE_BYTES_PER_PIXEL)
    if not captures.sets:
        raise CaptureFormatError(
            f"{folder}: no fringe frames in the manifest; add a complete phase-shifted set"
        )
    # imported once the inputs are known good: a refused folder or output does not pay for
    # the decoder's and unwrapper's imports (scipy.ndimage, scikit-image)
    from hdrfringe.core.decode import decode_captures
    from hdrfringe.io.phase_maps import write_phase_maps

    o = options
    if o.saturated == "flag":
        decoded = decode_captures(
            captures,
            min_modulation=o.min_modulation,
            reject_saturated=not o.keep_saturated,
            map_dtype=o.map_dtype,
            harmonics=o.harmonics,
        )
    else:
        decoded = decode_captures(
            captures, min_modulation=o.min_modulation, saturated="exclude", min_shifts=o.min_shifts
        )
    unc, unc_block = None, None
    if o.uncertainty:
        from hdrfringe.core.uncertainty import NoiseModel, NoiseUnknownError, predict_uncertainty

        noise = None
        if o.noise_sigma is not None:
            noise = NoiseModel(o.noise_sigma, source="given (--noise-sigma)")
        try:
            unc = predict_uncertainty(captures, decoded, noise=noise)
        except NoiseUnknownError as exc:  # none given and none to estimate (every set N = 3)
            unc_block = {"predicted": False, "reason": str(exc)}
    with staged_output_dir(output, force=force) as tmp:
        summary = write_phase_maps(
            tmp, decoded, str(folder), previews=o.previews, uncertainty=unc
        )
        if unc_block is not None:  # not predicted: the reason, where the block would be
            files = summary.pop("files")
            summary |= {"uncertainty": unc_block, "files": files}
            text = json.dumps(summary, indent=1) + "\n"
            (Path(tmp) / "phase_summary.json").write_text(text, encoding="utf-8")
    n_pixels = captures.image_shape[0] * captures.image_shape[1]
    return PhaseReport(output, summary, n_pixels)
