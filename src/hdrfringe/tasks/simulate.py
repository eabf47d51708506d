"""Capture folders from the virtual rig: one folder, or a series of folders (one per depth).

:func:`write_simulation` captures a program on one or several virtual rigs
(:func:`hdrfringe.rig.acquire.simulated_captures`), optionally with Eq. 4.1 applied, and writes
capture folders that record the rig (manifest field ``simulator``), the modification
(``modification``) and the scene's true height map (``truth_height_mm.tiff``). A series (the
thesis's calibration positions) is a folder holding one capture folder per depth, named by
:func:`series_folder_name`; the whole output is staged and moved into place only when complete.

Examples
--------
>>> series_depths([2.0, 4.0]), series_folder_name("white_plate", 2.0)
([0.0, 2.0, 4.0], 'white_plate_002.00mm')
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core._validation import is_saturated
from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import Frame
from hdrfringe.core.limits import MAX_SERIES_FOLDERS, check_count
from hdrfringe.errors import InputError
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.io.results import staged_output_dir
from hdrfringe.rig.acquire import IntensityModification, simulated_captures
from hdrfringe.rig.simulated import SimulatedRig
from hdrfringe.tasks._progress import Progress, quiet

__all__ = [
    "SimulateReport",
    "SimulationWritten",
    "series_depths",
    "series_folder_name",
    "simulate",
    "simulate_to_folder",
    "write_simulation",
]


def series_depths(depths: Sequence[float], *, reference: bool = True) -> list[float]:
    """The depths of a calibration series: ``depths``, after the reference plane when asked.

    Parameters
    ----------
    depths : sequence of float
        Plate positions in mm (thesis Sec. 2.7: 2 to 50 mm in steps of 2).
    reference : bool
        Put the reference plane (depth 0) first, unless ``depths`` holds it already.

    Returns
    -------
    list of float

    Raises
    ------
    InputError
        More than :data:`~hdrfringe.core.limits.MAX_SERIES_FOLDERS` depths, or none.

    Examples
    --------
    >>> series_depths([0.0, 5.0]), series_depths([5.0], reference=False)
    ([0.0, 5.0], [5.0])
    """
    out = [float(d) for d in depths]
    if not out:
        raise InputError("a series needs at least one depth")
    if reference and 0.0 not in out:
        out = [0.0, *out]
    check_count(
        len(out), MAX_SERIES_FOLDERS, "capture folders in the series", fix="give fewer depths"
    )
    return out


def series_folder_name(scene: str, depth_mm: float) -> str:
    """The name of a series' capture folder at one depth: ``<scene>_<depth, 000.00>mm``.

    Parameters
    ----------
    scene : str
        Scene name.
    depth_mm : float
        Plate depth in mm.

    Returns
    -------
    str

    Examples
    --------
    >>> series_folder_name("checkerboard", 12.5)
    'checkerboard_012.50mm'
    """
    return f"{scene}_{depth_mm:06.2f}mm"


@dataclass(frozen=True)
class SimulationWritten:
    """What :func:`write_simulation` wrote.

    Parameters
    ----------
    path : Path
        The output folder.
    folders : tuple of Path
        The capture folders (``(path,)`` for a single folder).
    images_per_folder : int
        Frames captured into each folder.
    saturated_fractions : tuple of float
        Per folder, the fraction of pixels saturated in at least one image.

    References
    ----------
    Thesis Sec. 2.7 (calibration positions).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> depths = series_depths([2.0])
    >>> camera = CameraModel(width=32, height=24)
    >>> rigs = [SimulatedRig(white_plate(d), camera=camera) for d in depths]
    >>> done = write_simulation(
    ...     Path(tempfile.mkdtemp()) / "series",
    ...     rigs,
    ...     FringeSpec(steps=3).frames(),
    ...     folder_names=[series_folder_name("white_plate", d) for d in depths],
    ...     modification=IntensityModification(add_lux=600),
    ... )
    >>> [f.relative_to(done.path).as_posix() for f in done.folders], done.images_per_folder
    (['white_plate_000.00mm', 'white_plate_002.00mm'], 3)
    >>> [round(s, 3) for s in done.saturated_fractions], round(done.max_saturated_fraction, 3)
    ([0.954, 0.852], 0.954)
    """

    path: Path
    folders: tuple[Path, ...]
    images_per_folder: int
    saturated_fractions: tuple[float, ...]

    @property
    def max_saturated_fraction(self) -> float:
        """The largest of :attr:`saturated_fractions`."""
        return max(self.saturated_fractions)


def write_simulation(
    path: str | Path,
    rigs: Sequence[SimulatedRig],
    frames: Sequence[Frame],
    *,
    folder_names: Sequence[str] | None = None,
    modification: IntensityModification | None = None,
    force: bool = False,
    progress: Callable[[], Any] | None = None,
) -> SimulationWritten:
    """Capture ``frames`` on each rig and write capture folders (staged: all or nothing).

    Parameters
    ----------
    path : str or Path
        Output folder; refused if it exists and is not empty, unless ``force``.
    rigs : sequence of SimulatedRig
        One rig per capture folder (e.g. one per depth of a series).
    frames : sequence of Frame
        The program each rig captures.
    folder_names : sequence of str, optional
        One sub-folder name per rig (a series). None: exactly one rig, written at ``path``.
    modification : IntensityModification, optional
        Eq. 4.1 applied to every folder's captures and recorded in its manifest.
    force : bool
        Replace an existing non-empty output folder.
    progress : callable, optional
        Called once per captured frame.

    Returns
    -------
    SimulationWritten

    Raises
    ------
    InputError
        No rig, several rigs without folder names, or names that do not match the rigs.

    References
    ----------
    Thesis Sec. 2.7 (calibration positions), Eq. 4.1 (the modification).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.frames import UniformFrame
    >>> from hdrfringe.rig.factory import virtual_rig
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     done = write_simulation(Path(tmp) / "caps", [virtual_rig("white_plate")],
    ...                             [UniformFrame(128)])
    ...     names = sorted(p.name for p in done.path.iterdir())
    >>> names, done.images_per_folder, done.max_saturated_fraction
    (['gray_128.png', 'manifest.json', 'truth_height_mm.tiff'], 1, 0.0)
    """
    frames = list(frames)
    if not rigs:
        raise InputError("no rig to capture with; give at least one")
    if folder_names is None and len(rigs) != 1:
        raise InputError(f"{len(rigs)} rigs need one folder name each; give folder_names")
    if folder_names is not None and len(folder_names) != len(rigs):
        raise InputError(f"{len(folder_names)} folder names for {len(rigs)} rigs; give one each")
    out = Path(path)
    fractions: list[float] = []
    folders: list[Path] = []
    with staged_output_dir(path, force=force) as tmp:  # path may carry the start's check
        for i, rig in enumerate(rigs):
            captures = simulated_captures(rig, frames, modification=modification, progress=progress)
            extra: dict[str, Any] = {"simulator": rig.to_manifest()}
            if modification is not None and not modification.is_identity:
                extra["modification"] = modification.to_manifest(with_seed=False)
            name = None if folder_names is None else folder_names[i]
            write_capture_folder(
                tmp if name is None else tmp / name, captures, extra=extra, force=True
            )
            folders.append(out if name is None else out / name)
            sat = is_saturated(captures.images, captures.camera_bit_depth).any(axis=0)
            fractions.append(float(np.mean(sat)))
    return SimulationWritten(out, tuple(folders), len(frames), tuple(fractions))


def simulate_to_folder(
    path: str | Path,
    rig: SimulatedRig,
    frames: Sequence[Frame],
    *,
    names: Sequence[str] | None = None,
    force: bool = False,
    provenance: bool = True,
) -> NDArray[np.integer]:
    """Capture ``frames`` with a virtual rig and write them as a capture folder.

    The manifest's ``scene`` is the scene's :meth:`~hdrfringe.rig.scenes.Scene.to_manifest`
    (``depth_mm`` for flat plates); with ``provenance`` an optional top-level ``simulator``
    entry records every rig parameter (:meth:`SimulatedRig.to_manifest`).

    Parameters
    ----------
    path : str or Path
        Target folder (see :func:`write_capture_folder`).
    rig : SimulatedRig
        The virtual rig (:mod:`hdrfringe.rig.simulated`).
    frames : sequence of Frame
        What to project, in order.
    names : sequence of str, optional
        File stems (default from the frames).
    force : bool
        Replace an existing non-empty folder.
    provenance : bool
        Record the rig parameters in the manifest's ``simulator`` field.

    Returns
    -------
    ndarray
        The captured images.

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, SimulatedRig
    >>> rig = SimulatedRig(white_plate(12.0), camera=CameraModel(width=32, height=24))
    >>> out = Path(tempfile.mkdtemp()) / "caps"
    >>> simulate_to_folder(out, rig, FringeSpec(steps=3).frames()).shape
    (3, 24, 32)
    >>> from hdrfringe.io.captures import read_capture_folder
    >>> read_capture_folder(out).scene["depth_mm"]
    12.0
    """
    frames = list(frames)
    images = rig.capture(frames)
    captures = Captures(
        frames,
        images,
        rig.camera_bit_depth,
        projector=rig.projector,
        scene=rig.scene.to_manifest(),
    )
    write_capture_folder(
        path,
        captures,
        names=names,
        extra={"simulator": rig.to_manifest()} if provenance else None,
        force=force,
    )
    return images


@dataclass(frozen=True)
class SimulateReport:
    """What ``simulate`` wrote.

    Parameters
    ----------
    output : Path
        The capture folder, or the folder of a series.
    folders : int
        Capture folders written (1 without a series).
    images : int
        Images per folder.
    n_pixels : int
        Pixels per image.
    saturated : int
        Pixels saturated in at least one image (of the folder with the most).

    Examples
    --------
    >>> SimulateReport(Path("caps"), 1, 13, 3072, 0).images
    13
    """

    output: Path
    folders: int
    images: int
    n_pixels: int
    saturated: int


def simulate(
    output: Path,
    scene: str,
    *,
    depths: Sequence[float | None] = (None,),
    series: bool = False,
    rig_options: dict[str, Any] | None = None,
    seed: int = 0,
    add_lux: float = 0.0,
    add_dn: float = 0.0,
    add_noise: float = 0.0,
    pattern: str = "sinusoidal",
    steps: int = 4,
    pitches: Sequence[float] = (8.0,),
    orientations: Sequence[str] = ("vertical",),
    imin: float = 40.0,
    migls: Sequence[float] = (255.0,),
    centerline: bool = True,
    grays: Sequence[float] = (),
    ideal: bool = False,
    force: bool = False,
    progress: Progress = quiet,
) -> SimulateReport:
    """Capture fringe sets of a scene on the virtual rig and write a capture folder (or one
    per depth: a calibration series).

    The output is checked (new or empty, or ``force``) before any rig is built, and written
    all or nothing (:func:`write_simulation`).

    Parameters
    ----------
    output : Path
        The capture folder, or the series' folder.
    scene : str
        The scene (:func:`hdrfringe.rig.factory.virtual_rig`).
    depths : sequence of float or None
        One rig per depth (None: the scene's own).
    series : bool
        Name the folders by depth (:func:`series_folder_name`) inside ``output``.
    rig_options : dict, optional
        Keyword arguments of :func:`~hdrfringe.rig.factory.virtual_rig` (``ideal`` among them).
    seed : int
        Noise seed.
    add_lux, add_dn, add_noise : float
        Eq. 4.1 applied to the captures (:class:`~hdrfringe.rig.acquire.IntensityModification`
        with ``seed``).
    pattern, steps, pitches, orientations, imin, migls, centerline, grays
        The program (:func:`hdrfringe.core.programs.fringe_program`).
    ideal : bool
        An ideal rig: the program's levels at 8 bit.
    force : bool
        Replace an existing output folder.
    progress : callable
        The captures, one unit per frame and rig.

    Returns
    -------
    SimulateReport

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "caps"
    >>> report = simulate(out, "white_plate", rig_options={"resolution": (64, 48)},
    ...                   pitches=[1024.0, 64.0, 8.0])
    >>> report.folders, report.images, report.n_pixels
    (1, 13, 3072)
    """
    from hdrfringe.core.programs import fringe_program
    from hdrfringe.io.results import check_output_dir
    from hdrfringe.rig.factory import virtual_rig

    output = check_output_dir(output, force)
    rigs = [virtual_rig(scene, depth_mm=d, seed=seed, **(rig_options or {})) for d in depths]
    frames = fringe_program(
        pattern,
        steps,
        list(pitches),
        list(orientations),
        imin,
        list(migls),
        projector=rigs[0].projector,
        centerline=centerline,
        grays=grays,
        level_bits=8 if ideal else None,
    )
    modification = IntensityModification(add_lux, add_dn, add_noise, seed)
    names = [series_folder_name(scene, d or 0.0) for d in depths] if series else None
    with progress(f"simulating {scene}", len(frames) * len(rigs)) as advance:
        done = write_simulation(
            output, rigs, frames, folder_names=names, modification=modification, force=force,
            progress=advance,
        )  # fmt: skip
    n_pixels = rigs[0].image_shape[0] * rigs[0].image_shape[1]
    saturated = round(done.max_saturated_fraction * n_pixels)  # the fraction is count / n
    return SimulateReport(output, len(rigs), len(frames), n_pixels, saturated)
