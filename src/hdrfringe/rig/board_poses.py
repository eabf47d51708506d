"""A calibration board at several poses on the virtual rig: captures and truth for
projector-camera (stereo) calibration (issue 12, docs/stereo_calibration.md).

The thesis rig (1.9 m standoff, a 320 mm field) is a narrow view in which focal length and
distance are hard to tell apart from a board; stereo calibration is posed well by a closer,
wider rig, :data:`CALIBRATION_GEOMETRY`: the camera 600 mm above the reference plane with a
400 mm wide field (a 640 x 480 camera: focal length 960 px), the projector at 20 degrees (an
800 x 600 projector: focal length 1021 px, a 218 mm baseline). Every pose is captured with
:func:`board_program`: one white frame (for the board detector) and vertical and horizontal
fringe sets whose coarsest pitch spans the projector with one period, so both projector
coordinates decode to absolute values by temporal unwrapping alone.

Examples
--------
>>> boards = default_board_poses(3)
>>> [(b.tilt_x_deg, b.tilt_y_deg) for b in boards]
[(0.0, 0.0), (35.0, 0.0), (0.0, -35.0)]
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from typing import Any

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.frames import Frame
from hdrfringe.core.programs import fringe_program
from hdrfringe.errors import InputError
from hdrfringe.rig.scenes import CalibrationBoard, Scene, board
from hdrfringe.rig.simulated import CameraModel, ProjectorModel, RigGeometry, SimulatedRig

__all__ = [
    "BOARD_PITCHES_PX",
    "CALIBRATION_GEOMETRY",
    "MAX_BOARD_POSES",
    "board_program",
    "calibration_rig",
    "capture_board_poses",
    "default_board_poses",
]

#: The virtual rig used for stereo calibration: close and wide enough for a well-posed
#: calibration from board poses (see the module docstring).
CALIBRATION_GEOMETRY = RigGeometry(
    standoff_mm=600.0, angle_deg=20.0, camera_field_mm=400.0, projector_field_mm=500.0
)
#: Fringe pitches of :func:`board_program` (projector px): the coarsest spans an 800 x 600
#: projector with one period (absolute phase without a centerline), the ratios stay below 13.
BOARD_PITCHES_PX: tuple[float, ...] = (1024.0, 96.0, 16.0)
#: Tilts (about X, about Y) of the poses of :func:`default_board_poses` at 35 degrees.
_TILTS = (
    (0.0, 0.0),
    (35.0, 0.0),
    (0.0, -35.0),
    (-22.0, 22.0),
    (-35.0, 0.0),
    (0.0, 35.0),
    (22.0, 22.0),
    (-22.0, -22.0),
    (22.0, -22.0),
    (12.0, -30.0),
)
#: At most this many poses are generated or simulated in one call.
MAX_BOARD_POSES = 100


def board_program(
    projector: ProjectorInfo,
    *,
    steps: int = 4,
    pitches: Sequence[float] = BOARD_PITCHES_PX,
    imin: float = 20.0,
    migl: float | None = None,
) -> list[Frame]:
    """The frames of one board pose: both fringe orientations, then one white frame.

    Parameters
    ----------
    projector : ProjectorInfo
        The projector; its full scale is the white level and the default MIGL.
    steps : int
        Phase shifts per set.
    pitches : sequence of float
        Fringe pitches, coarsest first; the coarsest must span the projector's width (and so
        its height) for an absolute phase without a centerline.
    imin : float
        Minimum input gray level of the fringes.
    migl : float, optional
        Maximum input gray level (default: the projector's full scale).

    Returns
    -------
    list of Frame
        ``2 * len(pitches) * steps + 1`` frames.

    Raises
    ------
    InputError
        The coarsest pitch is narrower than the projector, or a bad fringe parameter.

    Examples
    --------
    >>> frames = board_program(ProjectorInfo(width=800, height=600))
    >>> len(frames), frames[-1].kind, frames[-1].level
    (25, 'uniform', 255.0)
    """
    full = float(2**projector.bit_depth - 1)
    if max(pitches) < max(projector.width, projector.height):
        raise InputError(
            f"board pitches {list(pitches)}: the coarsest must span the projector "
            f"({projector.width} x {projector.height} px) with one period; add a pitch >= "
            f"{max(projector.width, projector.height)}"
        )
    return fringe_program(
        "sinusoidal",
        steps,
        sorted(pitches, reverse=True),
        ("vertical", "horizontal"),
        imin,
        (full if migl is None else migl,),
        projector=projector,
        centerline=False,
        grays=(full,),
    )


def default_board_poses(
    count: int = 10,
    *,
    pattern: str = "checkerboard",
    cols: int = 9,
    rows: int = 6,
    spacing_mm: float = 25.0,
    geometry: RigGeometry = CALIBRATION_GEOMETRY,
    camera_width: int = 640,
    max_tilt_deg: float = 35.0,
) -> list[CalibrationBoard]:
    """A spread of board poses for a calibration: tilted both ways about both axes.

    Pose ``k`` tilts the board by up to ``max_tilt_deg`` about X and Y (the first pose faces
    the camera), spins it by a few degrees, shifts it around the field and between -60 and
    +60 mm in height: the variety of orientations and depths a calibration needs (Zhang 2000).
    The board is antialiased over about one camera pixel (``footprint_mm``).

    Parameters
    ----------
    count : int
        Number of poses, 1..:data:`MAX_BOARD_POSES`.
    pattern : {"checkerboard", "circles"}
        Board pattern.
    cols, rows : int
        OpenCV pattern size (inner corners or dots).
    spacing_mm : float
        Square side or dot spacing.
    geometry : RigGeometry
        The rig (sets the antialiasing footprint: one camera pixel on the reference plane).
    camera_width : int
        Camera width in pixels (for the footprint).
    max_tilt_deg : float
        Largest tilt about either axis.

    Returns
    -------
    list of CalibrationBoard

    Examples
    --------
    >>> poses = default_board_poses(4)
    >>> [(round(p.tilt_x_deg), round(p.tilt_y_deg)) for p in poses]
    [(0, 0), (35, 0), (0, -35), (-22, 22)]
    """
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_BOARD_POSES:
        raise InputError(f"board poses: give 1..{MAX_BOARD_POSES}, got {count!r}")
    footprint = geometry.camera_field_mm / camera_width
    scale = max_tilt_deg / 35.0
    out = []
    for k in range(count):
        tx, ty = _TILTS[k % len(_TILTS)]
        turn = math.radians(20.0 * (k // len(_TILTS)))  # later rounds: directions turned
        tx, ty = (
            scale * (tx * math.cos(turn) - ty * math.sin(turn)),
            scale * (tx * math.sin(turn) + ty * math.cos(turn)),
        )
        x = 30.0 * math.sin(1.7 * k)
        y = 25.0 * math.cos(2.3 * k)
        z = 60.0 * math.sin(0.9 * k + 0.3)
        spin = 6.0 * math.sin(1.3 * k)
        out.append(
            board(
                pattern,
                cols,
                rows,
                spacing_mm,
                (x, y, z),
                round(tx, 6),
                round(ty, 6),
                round(spin, 6),
                footprint_mm=footprint,
            )
        )
    return out


def calibration_rig(
    scene: Scene,
    *,
    noise: float = 1.0,
    shot_noise: bool = False,
    seed: int = 0,
    camera_size: tuple[int, int] = (640, 480),
    projector_size: tuple[int, int] = (800, 600),
    geometry: RigGeometry = CALIBRATION_GEOMETRY,
) -> SimulatedRig:
    """The virtual stereo-calibration rig looking at a board.

    The default camera and projector models (8 bits, camera blur 0.5 px, projector defocus
    0.6 px) at the given sizes, with read noise ``noise`` gray levels and the aperture set so
    that the board's white (or a white plate) at the reference-plane centre reads 50 % of
    full scale (no clipping over the poses of :func:`default_board_poses`).

    Parameters
    ----------
    scene : Scene
        The board at one pose (any scene: a plate to test a calibration on).
    noise : float
        Camera read noise sigma in 8-bit gray levels.
    shot_noise : bool
        Add photon shot noise (default off: the noise is exactly ``noise`` DN).
    seed : int
        Noise seed.
    camera_size, projector_size : tuple of int
        ``(width, height)`` in pixels.
    geometry : RigGeometry
        The rig's geometry.

    Returns
    -------
    SimulatedRig

    Examples
    --------
    >>> rig = calibration_rig(default_board_poses(1)[0])
    >>> rig.image_shape, rig.projector.width, round(rig.stereo_calibration().baseline_mm, 1)
    ((480, 640), 800, 218.4)
    """
    cam = CameraModel(width=camera_size[0], height=camera_size[1], read_noise_dn8=noise)
    if not shot_noise:
        cam = dataclasses.replace(cam, full_well_e=None)
    white = getattr(scene, "white_reflectivity", 1.0)
    cam = dataclasses.replace(cam, white_level=0.5 / white)
    proj = ProjectorModel(width=projector_size[0], height=projector_size[1])
    return SimulatedRig(scene, camera=cam, projector_model=proj, geometry=geometry, seed=seed)


def capture_board_poses(
    boards: Sequence[CalibrationBoard],
    *,
    steps: int = 4,
    pitches: Sequence[float] = BOARD_PITCHES_PX,
    progress: Callable[[], object] | None = None,
    **rig_options: Any,
) -> list[Captures]:
    """Capture :func:`board_program` at every board pose on :func:`calibration_rig`.

    Parameters
    ----------
    boards : sequence of CalibrationBoard
        The poses (e.g. :func:`default_board_poses`).
    steps : int
        Phase shifts per set.
    pitches : sequence of float
        Fringe pitches (coarsest spans the projector).
    progress : callable, optional
        Called once per pose.
    **rig_options
        Keyword arguments of :func:`calibration_rig` (noise, seed, sizes, geometry).

    Returns
    -------
    list of Captures
        One per pose, each carrying the board scene in its ``scene`` entry.

    Examples
    --------
    >>> caps = capture_board_poses(default_board_poses(1), camera_size=(64, 48), steps=3)
    >>> len(caps), caps[0].images.shape
    (1, (19, 48, 64))
    """
    if not 1 <= len(boards) <= MAX_BOARD_POSES:
        raise InputError(f"board poses: give 1..{MAX_BOARD_POSES}, got {len(boards)}")
    out = []
    for b in boards:
        # the scene is part of each frame's noise key: the poses get independent noise
        rig = calibration_rig(b, **rig_options)
        out.append(rig.capture_folder(board_program(rig.projector, steps=steps, pitches=pitches)))
        if progress is not None:
            progress()
    return out
