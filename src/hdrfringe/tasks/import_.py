"""``hdrfringe import``: camera images + a description of what was projected -> capture folder."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

__all__ = ["ImportReport", "import_folder", "next_step"]


@dataclass(frozen=True)
class ImportReport:
    """What ``import`` wrote.

    Parameters
    ----------
    output : Path
        The capture folder.
    report : ImportReport
        The importer's report (manifest, images copied and converted, files not used).
    hint : str or None
        The command that makes sense next (:func:`next_step`).

    Examples
    --------
    >>> ImportReport(Path("caps"), None, "hdrfringe phase caps -o OUT").hint
    'hdrfringe phase caps -o OUT'
    """

    output: Path
    report: Any
    hint: str | None


def import_folder(
    images: Path,
    description: Path,
    output: Path,
    *,
    bit_depth: int | None = None,
    crop_offset: tuple[int, int] | None = None,
    force: bool = False,
) -> ImportReport:
    """Import camera images as a capture folder (:func:`hdrfringe.io.importer.import_captures`).

    The output is checked (not an input, new or empty, or ``force``) before anything is read.

    Parameters
    ----------
    images : Path
        Folder of camera images (searched recursively).
    description : Path
        TOML import description, or a pattern folder's ``manifest.json``.
    output : Path
        The capture folder to write.
    bit_depth : int, optional
        Camera bit depth, for a pattern manifest only.
    crop_offset : tuple of int, optional
        ``(x0, y0)``: the images are crops of the camera frame starting there.
    force : bool
        Replace an existing output folder.

    Returns
    -------
    ImportReport

    Examples
    --------
    >>> import_folder(Path("images"), Path("images/description.toml"), Path("images"))
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: ...
    """
    from hdrfringe.io.importer import import_captures
    from hdrfringe.io.results import check_output_against_inputs, check_output_dir

    check_output_against_inputs(output, [images, description])
    check_output_dir(output, force)
    report = import_captures(
        images, description, output, bit_depth=bit_depth, crop_offset=crop_offset, force=force
    )
    return ImportReport(output, report, next_step(output))


def next_step(folder: Path) -> str | None:
    """The command that makes sense next on a capture folder, as ``import`` suggests it.

    ``hdrfringe gamma FOLDER -o OUT`` for fringe sets pre-distorted with several exponents
    that the gamma fit can use (e.g. the kamino410 gamma sheet; ``phase`` decodes them too),
    else ``hdrfringe phase FOLDER -o OUT`` when its fringe sets decode as families (no two sets
    of one family at one pitch), else ``hdrfringe gamma FOLDER -o OUT`` when the folder is a
    gamma capture of uniform grays (or fittable sets), else None (nothing to suggest).

    Parameters
    ----------
    folder : Path
        A capture folder.

    Returns
    -------
    str or None

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate
    >>> tmp = Path(tempfile.mkdtemp())
    >>> _ = simulate(tmp / "caps", "white_plate", rig_options={"resolution": (64, 48)})
    >>> next_step(tmp / "caps") == f"hdrfringe phase {tmp / 'caps'} -o OUT"
    True
    """
    from hdrfringe.core.decode import group_families
    from hdrfringe.core.gamma import select_gamma_sets, uniform_gray_means
    from hdrfringe.io.captures import read_capture_folder

    caps = read_capture_folder(folder)
    gamma0 = caps.projector.gamma_precompensation if caps.projector else 1.0
    exponents = [s.gamma_precompensation or gamma0 for s in caps.sets]
    chosen = select_gamma_sets([(s.spec, g) for s, g in zip(caps.sets, exponents, strict=True)])
    if len(set(exponents)) > 1 and chosen.fittable:  # phase decodes it too, gamma is its use
        return f"hdrfringe gamma {folder} -o OUT"
    families = group_families(caps.sets)
    if caps.sets and all(len({s.spec.pitch_px for s in f}) == len(f) for f in families):
        return f"hdrfringe phase {folder} -o OUT"
    if chosen.fittable or uniform_gray_means(caps) is not None:
        return f"hdrfringe gamma {folder} -o OUT"
    return None
