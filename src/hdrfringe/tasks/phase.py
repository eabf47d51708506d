"""``hdrfringe phase``: every fringe set of a capture folder to phase and quality maps."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hdrfringe.core import strict_json

if TYPE_CHECKING:
    from hdrfringe.core.decode import FolderPhase
    from hdrfringe.core.uncertainty import Uncertainty
    from hdrfringe.io.report import CloudView

__all__ = ["PhaseOptions", "PhaseReport", "phase", "phase_cloud"]


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
        ``float32`` (default: the maps computed in float64 per block, stored in float32, as
        they are written) or ``float64``; with ``saturated="exclude"`` float64 always.
    harmonics : str
        ``off``, ``auto`` or a number of orders.
    per_set_maps : bool
        With several sets, also every set's maps (``__<set label>`` appended); default: the
        final maps only (:func:`hdrfringe.io.phase_maps.write_phase_maps`, ``per_set``).
    report : bool
        Write ``report.html`` and ``report.md`` (docs/report.md); False: ``--no-report``.

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
    map_dtype: str = "float32"
    harmonics: str = "off"
    per_set_maps: bool = False
    report: bool = True


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
    >>> "unwrapped_phase_vertical.tiff" in report.summary["files"], len(report.summary["files"])
    (True, 8)
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
            quality_maps="every" if o.per_set_maps else "final",
        )
    else:
        decoded = decode_captures(
            captures, min_modulation=o.min_modulation, saturated="exclude", min_shifts=o.min_shifts
        )
    unc, unc_block = None, None
    n_pixels = captures.image_shape[0] * captures.image_shape[1]
    if o.uncertainty:
        from hdrfringe.core.uncertainty import (
            NoiseModel,
            NoiseUnknownError,
            predict_uncertainty,
            resolve_noise,
        )

        noise = None
        if o.noise_sigma is not None:
            noise = NoiseModel(o.noise_sigma, source="given (--noise-sigma)")
        try:
            model = resolve_noise(captures, noise)
        except NoiseUnknownError as exc:  # none given and none to estimate (every set N = 3)
            unc_block = {"predicted": False, "reason": str(exc)}
        else:
            if o.saturated == "flag":  # the std needs the decoded maps, not the images
                captures = _without_images(captures)
            unc = predict_uncertainty(
                captures, decoded, noise=model, finest_only=not o.per_set_maps
            )
    del captures  # the image stack, released before the maps are written
    with staged_output_dir(output, force=force) as tmp:
        summary = write_phase_maps(
            tmp,
            decoded,
            str(folder),
            previews=o.previews,
            uncertainty=unc,
            per_set=o.per_set_maps,
        )
        if unc_block is not None:  # not predicted: the reason, where the block would be
            files = summary.pop("files")
            summary |= {"uncertainty": unc_block, "files": files}
            text = strict_json.dumps(summary) + "\n"
            (Path(tmp) / "phase_summary.json").write_text(text, encoding="utf-8")
        if o.report:  # last, in the same staged folder: it embeds the previews written
            from hdrfringe.io.report import ReportContent, write_report

            settings = {"input": str(folder), "output": str(output), **vars(o)}
            del settings["report"]
            content = ReportContent(
                f"hdrfringe phase: {folder}", settings, summary, summary["sets"],
                phase_cloud(decoded, unc),
            )  # fmt: skip
            write_report(tmp, content)
    return PhaseReport(output, summary, n_pixels)


def phase_cloud(decoded: FolderPhase, uncertainty: Uncertainty | None) -> CloudView | None:
    """The report's 3D view of a decoding without a calibration: the primary family's absolute
    phase (else its unwrapped phase) over the pixel grid, coloured by the phase, the data
    modulation and mean intensity of its finest set and the predicted phase std.

    Parameters
    ----------
    decoded : FolderPhase
        The decoded folder.
    uncertainty : Uncertainty or None
        The predicted std, if computed.

    Returns
    -------
    CloudView or None
        None without a fringe family.

    Examples
    --------
    >>> from hdrfringe.core.decode import FolderPhase
    >>> phase_cloud(FolderPhase({}, []), None) is None
    True
    """
    import numpy as np

    from hdrfringe.io.report import CloudView

    fam = decoded.primary
    if fam is None:
        return None
    phase = fam.unwrapped_phase if fam.absolute_phase is None else fam.absolute_phase
    which = "unwrapped" if fam.absolute_phase is None else "absolute"
    finest = decoded.set_results[fam.sets[-1].label]
    colours = {
        f"{which} phase (rad)": phase,
        "data modulation (DN)": finest.data_modulation,
        "mean intensity (DN)": finest.mean_intensity,
    }
    if uncertainty is not None and uncertainty.phase_std is not None:
        colours["predicted phase std (rad)"] = uncertainty.phase_std
    h, w = np.shape(phase)
    cols = np.broadcast_to(np.arange(w, dtype=np.float64), (h, w))  # views: no (H, W) copies
    rows = np.broadcast_to(-np.arange(h, dtype=np.float64)[:, None], (h, w))
    # the phase's ramp across the projector (least squares on about 20000 pixels), taken off
    # the view: what is left shows the surface's shape, as the height would
    step = max(1, int(np.sqrt(phase.size / 20_000)))
    sub = [a[::step, ::step].ravel() for a in (cols, rows, phase)]
    keep = np.isfinite(sub[2])
    plane = None
    if np.count_nonzero(keep) >= 3:
        design = np.column_stack([sub[0][keep], sub[1][keep], np.ones(np.count_nonzero(keep))])
        a, b, c = np.linalg.lstsq(design, sub[2][keep], rcond=None)[0]
        plane = (float(a), float(b), float(c))
    what = (
        f"the {fam.orientation} family's {which} phase over the pixel grid, less its best-fit "
        "plane (the fringes' ramp); no calibration: a phase, not a height"
    )
    title = f"{which} phase - plane (rad)" if plane is not None else f"{which} phase (rad)"
    return CloudView(cols, rows, phase, colours, ("column (px)", "-row (px)", title), False,
                     what, plane)  # fmt: skip


def _without_images(captures: Any) -> Any:
    """The captures' description (frames, sets, bit depth, camera) with their images replaced
    by a read-only view of one zero, so that the image stack (12 bytes per pixel for three
    4-step 8-bit sets) is freed once decoded:
    :func:`hdrfringe.core.uncertainty.predict_uncertainty` given a noise model reads the
    decoded maps only, except for a tolerant decode's images, which keep theirs
    (benchmarks/README.md, "Real camera sizes")."""
    import dataclasses

    import numpy as np

    zero = captures.images.dtype.type(0)
    return dataclasses.replace(captures, images=np.broadcast_to(zero, captures.images.shape))
