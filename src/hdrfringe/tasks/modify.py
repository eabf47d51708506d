"""Eq. 4.1 on a capture folder: read it, add light and noise, write a new folder.

The new folder keeps everything the old one records: frames and their file names, projector,
camera, scene, maps (e.g. the true height), and any additional manifest fields; its manifest
adds a ``modification`` entry naming the source folder and the parameters.

Examples
--------
>>> import tempfile
>>> import numpy as np
>>> from hdrfringe.core.captures import Captures
>>> from hdrfringe.core.frames import UniformFrame
>>> from hdrfringe.io.captures import read_capture_folder, write_capture_folder
>>> from hdrfringe.rig.acquire import IntensityModification
>>> caps = Captures([UniformFrame(128)], np.array([[[100, 200]]], np.uint8), 8)
>>> with tempfile.TemporaryDirectory() as tmp:
...     src = write_capture_folder(Path(tmp) / "caps", caps)
...     done = modify_capture_folder(src, Path(tmp) / "mod", IntensityModification(add_lux=600))
...     images = read_capture_folder(done.path).images
>>> images.tolist(), done.saturated_fraction
([[[202, 255]]], 0.5)
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hdrfringe.core._validation import is_saturated
from hdrfringe.io.captures import read_capture_folder, read_manifest, write_capture_folder
from hdrfringe.io.results import check_output_dir
from hdrfringe.rig.acquire import IntensityModification

__all__ = ["ModifyReport", "modify", "modify_capture_folder"]

#: Top-level manifest fields the captures write themselves (the rest is carried over as is).
_CONTRACT_FIELDS = ("format", "version", "camera", "projector", "scene", "frames", "maps")


@dataclass(frozen=True)
class ModifyReport:
    """What :func:`modify_capture_folder` wrote.

    Parameters
    ----------
    path : Path
        The new capture folder.
    n_images : int
        Images written.
    saturated_fraction : float
        Fraction of pixels saturated in at least one modified image.
    saturated_pixels, n_pixels : int
        That count, and the pixels of an image (not compared: the fraction says it).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate_to_folder
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=32, height=24))
    >>> tmp = Path(tempfile.mkdtemp())
    >>> _ = simulate_to_folder(tmp / "caps", rig, FringeSpec(steps=3).frames())
    >>> done = modify_capture_folder(tmp / "caps", tmp / "mod", IntensityModification())
    >>> done == ModifyReport(tmp / "mod", 3, 0.0)  # nothing added: nothing saturates
    True
    """

    path: Path
    n_images: int
    saturated_fraction: float
    saturated_pixels: int = field(default=0, compare=False)
    n_pixels: int = field(default=0, compare=False)


def modify_capture_folder(
    folder: str | Path,
    output: str | Path,
    modification: IntensityModification,
    *,
    force: bool = False,
) -> ModifyReport:
    """Apply thesis Eq. 4.1 to every image of a capture folder and write the result.

    Parameters
    ----------
    folder : str or Path
        The capture folder to read (left unchanged).
    output : str or Path
        The new folder; refused (before anything is read) if it exists and is not empty,
        unless ``force``.
    modification : IntensityModification
        Added lux, DN and noise, with clipping at ``2^B - 1``.
    force : bool
        Replace an existing non-empty output folder.

    Returns
    -------
    ModifyReport

    Raises
    ------
    OutputExistsError
        ``output`` exists and is not empty, without ``force``.
    CaptureFormatError
        ``folder`` is not a valid capture folder.

    References
    ----------
    Thesis Eq. 4.1, Sec. 4.3.1.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate_to_folder
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=32, height=24))
    >>> tmp = Path(tempfile.mkdtemp())
    >>> int(simulate_to_folder(tmp / "caps", rig, FringeSpec(steps=3).frames()).max())
    186
    >>> done = modify_capture_folder(tmp / "caps", tmp / "mod", IntensityModification(add_lux=600))
    >>> done.n_images, round(done.saturated_fraction, 3)  # 186 + 0.17 * 600 clips at 255
    (3, 0.954)
    >>> read_manifest(done.path)["modification"]["add_lux"], read_manifest(tmp / "caps")["scene"]
    (600.0, {'name': 'white_plate', 'depth_mm': 0.0, 'reflectivity': 1.0})
    """
    output = check_output_dir(output, force)
    caps = read_capture_folder(folder)
    manifest = read_manifest(folder)  # the fields Captures does not keep: file names, extras
    images = modification.apply(caps.images, caps.camera_bit_depth)
    extra = {k: v for k, v in manifest.items() if k not in _CONTRACT_FIELDS}
    extra["modification"] = {"source": str(folder), **modification.to_manifest()}
    names = [Path(e["file"]).stem for e in manifest["frames"]]
    write_capture_folder(
        output, dataclasses.replace(caps, images=images), names=names, extra=extra, force=force
    )
    sat = is_saturated(images, caps.camera_bit_depth).any(axis=0)
    return ModifyReport(
        Path(output), len(names), float(np.mean(sat)), int(np.count_nonzero(sat)), int(sat.size)
    )


def modify(
    folder: str | Path,
    output: str | Path,
    *,
    add_lux: float = 0.0,
    add_dn: float = 0.0,
    noise: float = 0.0,
    seed: int = 0,
    force: bool = False,
) -> ModifyReport:
    """``hdrfringe modify``: add light and noise to a capture folder's images (thesis Eq. 4.1).

    The output is checked (not the input, new or empty, or ``force``) before the folder is
    read.

    Parameters
    ----------
    folder : str or Path
        The capture folder.
    output : str or Path
        The modified capture folder.
    add_lux, add_dn, noise, seed
        The modification (:class:`~hdrfringe.rig.acquire.IntensityModification`).
    force : bool
        Replace an existing output folder.

    Returns
    -------
    ModifyReport

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.tasks.simulate import simulate
    >>> tmp = Path(tempfile.mkdtemp())
    >>> _ = simulate(tmp / "caps", "white_plate", rig_options={"resolution": (32, 24)})
    >>> modify(tmp / "caps", tmp / "bright", add_dn=300.0).saturated_pixels
    768
    """
    from hdrfringe.io.results import check_output_against_inputs

    check_output_against_inputs(output, [folder])
    check_output_dir(output, force)
    modification = IntensityModification(add_lux, add_dn, noise, seed)
    return modify_capture_folder(folder, output, modification, force=force)
