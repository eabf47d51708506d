"""The loop camera: the X display a projector window shows, seen through the virtual rig.

``--camera loop:SCENE`` tries the hardware path (projector window, camera protocol,
synchronisation, live capture) without any hardware: :class:`LoopCamera` grabs the screen the
:class:`~hdrfringe.hardware.projector.ScreenProjector` draws on, takes that image as the 8-bit
levels the projector is sent (an :class:`~hdrfringe.core.frames.ImageFrame`), and renders it with a
:class:`~hdrfringe.rig.simulated.SimulatedRig` of the named scene: geometry (camera pixel ->
projector ``(u, v)``), projector gamma and defocus, reflectivity, ambient light, noise and
clipping (thesis Eq. 3.3), at the exposure, gain and pixel format set through the camera
protocol. A configurable latency makes the first ``k`` grabs after the screen changes return the
previous screen content (stale frames), as a real camera behind a projector does.

Specification (:func:`parse_loop_spec`)::

    loop:SCENE[?KEY=VALUE[&KEY=VALUE...]]

SCENE is a scene name of ``simulate`` (white_plate, black_plate, plate, checkerboard, mask,
glossy, specular_part, board). Keys, each at most once:

==============  ==========================================================================
``display``     X display to grab, e.g. ``:5`` (default: the ``DISPLAY`` variable)
``screen``      screen of that display, as ``--projector screen:N`` counts them (default 0)
``latency``     stale grabs after each change of the screen, integer >= 0 (default 0)
``noise``       read-noise sigma in 8-bit gray levels, >= 0 (default 1, as ``simulate``)
``shot``        photon shot noise, ``on`` or ``off`` (default on)
``ambient``     ambient light in lux, >= 0 (default 0)
``depth``       depth in mm (base height: mask, glossy, specular_part; default the scene's)
``aperture``    ``auto``, ``white`` or ``black`` (as ``simulate --aperture``)
``seed``        noise seed, integer >= 0 (default 0)
``size``        camera image ``WIDTHxHEIGHT`` (default the virtual rig's 648x494)
``projector``   the projector size ``WIDTHxHEIGHT`` the screen must have (default: any)
``pose``        scene ``board`` only: the board at pose K (0, 1, ...) of
                :func:`~hdrfringe.rig.board_poses.default_board_poses`, seen by the
                stereo-calibration rig (:func:`~hdrfringe.rig.board_poses.calibration_rig`,
                camera 640x480 unless ``size``); :meth:`LoopCamera.set_pose` moves it
==============  ==========================================================================

Example: ``loop:checkerboard?display=:5&latency=2&noise=1&seed=0``. docs/hardware.md ("Loop
camera") describes its use.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.frames import ImageFrame
from hdrfringe.core.limits import MAX_IMAGE_PIXELS, MAX_PROJECTOR_PIXELS
from hdrfringe.errors import InputError
from hdrfringe.hardware.camera import CameraBase, CameraError, _check_positive
from hdrfringe.rig.factory import APERTURES, virtual_rig
from hdrfringe.rig.scenes import SCENES
from hdrfringe.rig.simulated import SimulatedRig

__all__ = ["LOOP_FORMATS", "LoopCamera", "LoopSpec", "parse_loop_spec"]

#: Pixel formats the loop camera offers (its virtual sensor's bit depth follows the format).
LOOP_FORMATS: tuple[str, ...] = ("Mono8", "Mono12", "Mono16")

_FORMAT_BITS = {"Mono8": 8, "Mono12": 12, "Mono16": 16}
#: Screenshot attempts per grab, and the pause between them (a refused X connection).
_GRAB_ATTEMPTS, _GRAB_RETRY_S = 5, 0.05
_SYNTAX = "loop:SCENE[?key=value&...]"
_KEYS = (
    "display",
    "screen",
    "latency",
    "noise",
    "shot",
    "ambient",
    "depth",
    "aperture",
    "seed",
    "size",
    "projector",
    "pose",
)


@dataclass(frozen=True)
class LoopSpec:
    """The parsed options of a ``loop:`` camera specification (see the module docstring).

    Parameters
    ----------
    scene : str
        Scene name (a key of :data:`hdrfringe.rig.scenes.SCENES`).
    display : str or None
        X display to grab; None: the ``DISPLAY`` environment variable.
    screen : int
        Screen of the display (the order ``ScreenProjector`` uses).
    latency : int
        Stale grabs after each change of the screen content.
    noise : float
        Read-noise sigma in 8-bit gray levels.
    shot : bool
        Photon shot noise.
    ambient : float
        Ambient light in lux.
    depth : float or None
        Scene depth (mm); None: the scene's default.
    aperture : str
        ``auto``, ``white`` or ``black``.
    seed : int
        Noise seed.
    size : tuple of int or None
        Camera image (width, height); None: the virtual rig's default camera.
    projector : tuple of int or None
        Projector (width, height) the screen must have; None: whatever the screen has.
    pose : int or None
        Scene ``board`` only: the board at this pose of ``default_board_poses`` on the
        stereo-calibration rig; None: the scene of ``virtual_rig`` (thesis rig).

    Examples
    --------
    >>> LoopSpec("plate").latency, LoopSpec("plate").noise
    (0, 1.0)
    """

    scene: str
    display: str | None = None
    screen: int = 0
    latency: int = 0
    noise: float = 1.0
    shot: bool = True
    ambient: float = 0.0
    depth: float | None = None
    aperture: str = "auto"
    seed: int = 0
    size: tuple[int, int] | None = None
    projector: tuple[int, int] | None = None
    pose: int | None = None


def _bad(spec: str, key: str, value: str, want: str) -> InputError:
    return InputError(f"camera {spec!r}: {key}={value!r} is not valid; {key} must be {want}")


def _int(spec: str, key: str, value: str) -> int:
    if not value.isdigit():
        raise _bad(spec, key, value, "a whole number >= 0")
    return int(value)


def _float(spec: str, key: str, value: str) -> float:
    try:
        number = float(value)
    except ValueError:
        number = float("nan")
    if not (np.isfinite(number) and number >= 0):
        raise _bad(spec, key, value, "a number >= 0")
    return number


def _wxh(spec: str, key: str, value: str) -> tuple[int, int]:
    w, x, h = value.lower().partition("x")
    if not (x and w.isdigit() and h.isdigit() and int(w) > 0 and int(h) > 0):
        raise _bad(spec, key, value, "WIDTHxHEIGHT in pixels, e.g. 320x240")
    # checked before anything is allocated: size=100000x100000 asked for 9.3 GiB. A camera
    # image beyond MAX_IMAGE_PIXELS could not be read back from its capture folder either.
    limit = MAX_IMAGE_PIXELS if key == "size" else MAX_PROJECTOR_PIXELS
    if int(w) * int(h) > limit:
        raise _bad(spec, key, value, f"WIDTHxHEIGHT of at most {limit} pixels")
    return int(w), int(h)


def parse_loop_spec(spec: str) -> LoopSpec:
    """Parse ``loop:SCENE[?key=value&...]`` strictly.

    Parameters
    ----------
    spec : str
        The camera specification (keys in the module docstring).

    Returns
    -------
    LoopSpec

    Raises
    ------
    InputError
        One line naming the faulty part: no scene, an unknown scene or key, a key given twice,
        a part without ``=``, or a value of the wrong kind.

    Examples
    --------
    >>> parse_loop_spec("loop:checkerboard?display=:5&latency=2&noise=0").latency
    2
    >>> parse_loop_spec("loop:plate?size=64x48").size
    (64, 48)
    >>> parse_loop_spec("loop:plate?lag=2")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: camera 'loop:plate?lag=2': unknown option 'lag'; use ...
    """
    kind, _, rest = spec.partition(":")
    if kind != "loop":
        raise InputError(f"camera {spec!r}: not a loop camera; use {_SYNTAX}")
    scene, question, query = rest.partition("?")
    if not scene:
        raise InputError(
            f"camera {spec!r}: no scene given; use {_SYNTAX} with SCENE one of {', '.join(SCENES)}"
        )
    if scene not in SCENES:
        raise InputError(
            f"camera {spec!r}: unknown scene {scene!r}; use one of {', '.join(SCENES)}"
        )
    values: dict[str, str] = {}
    for part in query.split("&") if question else ():
        key, eq, value = part.partition("=")
        if not eq or not key or not value:
            raise InputError(
                f"camera {spec!r}: option {part!r} is not key=value; write e.g. latency=2 and "
                "join options with &"
            )
        if key not in _KEYS:
            raise InputError(f"camera {spec!r}: unknown option {key!r}; use {', '.join(_KEYS)}")
        if key in values:
            raise InputError(f"camera {spec!r}: option {key!r} is given twice; give it once")
        values[key] = value
    out: dict[str, Any] = {"scene": scene}
    for key, value in values.items():
        if key == "display":
            out[key] = value
        elif key in ("screen", "latency", "seed", "pose"):
            out[key] = _int(spec, key, value)
        elif key in ("noise", "ambient", "depth"):
            out[key] = _float(spec, key, value)
        elif key == "shot":
            if value not in ("on", "off"):
                raise _bad(spec, key, value, "on or off")
            out[key] = value == "on"
        elif key == "aperture":
            if value not in APERTURES:
                raise _bad(spec, key, value, " or ".join(APERTURES))
            out[key] = value
        else:  # size, projector
            out[key] = _wxh(spec, key, value)
    if "pose" in out:
        _check_pose(spec, scene, out["pose"])
        for key in ("depth", "aperture"):
            if key in out:
                raise InputError(
                    f"camera {spec!r}: {key}= does not apply with pose= (the board's pose and "
                    "the calibration rig set them); leave it out"
                )
    return LoopSpec(**out)


def _check_pose(spec: str, scene: str, pose: int) -> None:
    from hdrfringe.rig.board_poses import MAX_BOARD_POSES

    if scene != "board":
        raise InputError(
            f"camera {spec!r}: pose= is for the scene board only; use loop:board?pose=K"
        )
    if not 0 <= pose < MAX_BOARD_POSES:
        raise InputError(
            f"camera {spec!r}: pose={pose} is not valid; pose must be 0..{MAX_BOARD_POSES - 1}"
        )


def _screen_box(display: str, screen: int, spec: str) -> tuple[int, int, int, int]:
    """(x, y, width, height) of a screen of an X display, as pyglet (and so the projector
    window) lists them."""
    from hdrfringe.hardware.camera import import_optional

    pyglet = import_optional("pyglet", "the loop camera")
    pyglet.options["shadow_window"] = False
    import pyglet.display

    try:
        display_module: Any = pyglet.display
        screens = display_module.Display(name=display).get_screens()
    except Exception as err:
        if type(err).__name__ != "NoSuchDisplayException":
            raise
        raise InputError(
            f"camera {spec!r}: X display {display!r} not found; start its X server or set "
            "display= to one that runs"
        ) from err
    if screen >= len(screens):
        listed = ", ".join(f"{i}: {s.width}x{s.height}+{s.x}+{s.y}" for i, s in enumerate(screens))
        raise InputError(
            f"camera {spec!r}: screen {screen} does not exist on X display {display!r} (it has "
            f"{listed}); set screen= to one of those"
        )
    s = screens[screen]
    return int(s.x), int(s.y), int(s.width), int(s.height)


class LoopCamera(CameraBase):
    """A camera that sees the projector's X screen through the virtual rig (no hardware).

    Each :meth:`grab` takes a screenshot of the projector's screen (Pillow's ``ImageGrab``
    over XCB), uses it as the 8-bit levels sent to the projector (an
    :class:`~hdrfringe.core.frames.ImageFrame`; the pattern's gamma pre-compensation is already in
    them, so the rig adds none) and returns what the virtual rig's camera records of that
    projector image: :meth:`SimulatedRig.capture
    <hdrfringe.rig.simulated.SimulatedRig.capture>` at the exposure and gain set here, with the
    sensor bit depth of the pixel format (Mono8, Mono12, Mono16). Colour screenshots are turned
    to gray with Pillow's ``L`` conversion (ITU-R 601 luma; gray images pass unchanged).

    Latency: after the screen content changes, the first :attr:`latency` grabs still return the
    previous content (a fresh exposure of it, with its own noise); grab ``latency + 1`` returns
    the new one. A change during that wait restarts it. :meth:`set_latency` changes it at any
    time; the next grab follows the new value.

    Parameters
    ----------
    spec : str or LoopSpec
        ``loop:SCENE[?key=value&...]`` (keys in the module docstring) or its parsed form.

    Attributes
    ----------
    name : str
        The specification, for messages.
    options : LoopSpec
        The parsed options.

    References
    ----------
    Thesis Eq. 3.3 (the camera signal), Sec. 3.1 (clipping at ``2^B - 1``), Sec. 7.4 (bit depth).

    Examples
    --------
    >>> cam = LoopCamera("loop:checkerboard?latency=2&noise=0&shot=off")
    >>> cam.latency, cam.pixel_formats, cam.bit_depth
    (2, ('Mono8', 'Mono12', 'Mono16'), 8)
    >>> cam.set_latency(0)
    >>> cam.set_exposure(10.0)
    10.0
    """

    def __init__(self, spec: str | LoopSpec) -> None:
        self.options = spec if isinstance(spec, LoopSpec) else parse_loop_spec(spec)
        self.name = spec if isinstance(spec, str) else f"loop:{self.options.scene}"
        self._latency = self.options.latency
        self._format = "Mono8"
        self._settings = CameraSettings()
        self._box: tuple[int, int, int, int] | None = None
        self._display: str | None = None
        self._rigs: dict[int, SimulatedRig] = {}
        self._base: SimulatedRig | None = None
        self._pose = self.options.pose
        self._delivered: NDArray[np.uint8] | None = None
        self._pending: NDArray[np.uint8] | None = None
        self._pending_grabs = 0

    def __repr__(self) -> str:
        return f"LoopCamera({self.name!r})"

    # -- opening ---------------------------------------------------------------------------
    def open(self) -> None:
        """Find the screen to grab and check its size (nothing happens when already open).

        Raises
        ------
        InputError
            No display named, the display or screen does not exist, or the screen is not the
            ``projector=`` size.
        """
        if self._box is not None:
            return
        display = self.options.display or os.environ.get("DISPLAY")
        if not display:
            raise InputError(
                f"camera {self.name!r}: no X display to grab: DISPLAY is not set; add "
                "display=:N to the specification"
            )
        box = _screen_box(display, self.options.screen, self.name)
        want = self.options.projector
        if want is not None and want != box[2:]:
            raise InputError(
                f"camera {self.name!r}: screen {self.options.screen} of {display!r} is "
                f"{box[2]}x{box[3]}, not the projector={want[0]}x{want[1]} asked for; run the "
                "projector at that size or change projector="
            )
        self._display, self._box = display, box
        self._delivered = self._pending = None
        self._pending_grabs = 0

    def close(self) -> None:
        """Stop grabbing; closing twice is harmless."""
        self._box = None

    # -- what it expects and what it is ------------------------------------------------------
    @property
    def projector_size(self) -> tuple[int, int]:
        """The projector (width, height) it expects: the grabbed screen's size once open, else
        the ``projector=`` option.

        Returns
        -------
        tuple of int

        Raises
        ------
        CameraError
            Neither open nor given a ``projector=`` size.
        """
        if self._box is not None:
            return self._box[2], self._box[3]
        if self.options.projector is not None:
            return self.options.projector
        raise CameraError(
            f"camera {self.name}: the projector size is known once it is open (or give "
            "projector=WIDTHxHEIGHT)"
        )

    @property
    def latency(self) -> int:
        """Stale grabs after each change of the screen content."""
        return self._latency

    def set_latency(self, grabs: int) -> None:
        """Change the latency; the next grab follows it.

        Parameters
        ----------
        grabs : int
            Stale grabs after each change of the screen, >= 0.

        Raises
        ------
        InputError
            Not a whole number >= 0.
        """
        if isinstance(grabs, bool) or not isinstance(grabs, (int, np.integer)) or grabs < 0:
            raise InputError(
                f"camera {self.name}: latency must be a whole number of grabs >= 0, got {grabs!r}"
            )
        self._latency = int(grabs)

    @property
    def pose(self) -> int | None:
        """The board pose in view (``loop:board?pose=K``), None for the other scenes."""
        return self._pose

    def set_pose(self, pose: int) -> None:
        """Move the board to another pose of ``default_board_poses`` (as a user moves it
        between the poses of a stereo calibration); the next grab sees it there.

        Parameters
        ----------
        pose : int
            Pose index, 0 .. ``MAX_BOARD_POSES - 1``.

        Raises
        ------
        InputError
            The camera was not opened with ``pose=`` (scene ``board``), or a bad index.
        """
        if self._pose is None:
            raise InputError(
                f"camera {self.name}: set_pose needs a board camera; open loop:board?pose=0"
            )
        if isinstance(pose, bool) or not isinstance(pose, (int, np.integer)):
            raise InputError(f"camera {self.name}: pose must be a whole number, got {pose!r}")
        _check_pose(self.name, "board", int(pose))
        if int(pose) != self._pose:
            self._pose = int(pose)
            self._base = None
            self._rigs.clear()

    def _base_rig(self) -> SimulatedRig:
        """The scene's rig before the projector size and bit depth are set."""
        o = self.options
        if self._pose is None:
            return virtual_rig(
                o.scene,
                depth_mm=o.depth,
                ambient_lux=o.ambient,
                noise=o.noise,
                shot_noise=o.shot,
                aperture=o.aperture,
                gamma=1.0,
                seed=o.seed,
                resolution=o.size,
            )
        from hdrfringe.rig.board_poses import calibration_rig, default_board_poses
        from hdrfringe.rig.simulated import Lighting

        pose = default_board_poses(self._pose + 1)[self._pose]
        size = o.size or (640, 480)
        rig = calibration_rig(pose, noise=o.noise, shot_noise=o.shot, seed=o.seed, camera_size=size)
        return rig.replace(gamma_precompensation=1.0, lighting=Lighting(ambient_lux=o.ambient))

    @property
    def rig(self) -> SimulatedRig:
        """The virtual rig that renders the grabs, at the current pixel format's bit depth
        (projector of the screen's size, no gamma pre-compensation: the screen holds the levels
        already sent). Capturing the screen's content with it equals a noise-free grab.

        Returns
        -------
        SimulatedRig
        """
        bits = _FORMAT_BITS[self._format]
        if bits not in self._rigs:
            if self._base is None:
                self._base = self._base_rig()
            width, height = self.projector_size
            base = self._base
            self._rigs[bits] = base.replace(
                camera=dataclasses.replace(base.camera, bit_depth=bits),
                projector_model=dataclasses.replace(
                    base.projector_model, width=width, height=height
                ),
            )
        rig = self._rigs[bits]
        if rig.projector_model.width != self.projector_size[0] or (
            rig.projector_model.height != self.projector_size[1]
        ):
            self._rigs.clear()  # the screen changed size between two openings
            return self.rig
        return rig

    # -- settings ----------------------------------------------------------------------------
    def set_exposure(self, ms: float) -> float:
        """Set the exposure time; the signal scales with it as on the virtual rig.

        Parameters
        ----------
        ms : float
            Exposure time in milliseconds, > 0.

        Returns
        -------
        float
            The exposure time applied (exactly ``ms``).
        """
        _check_positive("exposure time", ms, self.name)
        self._settings = CameraSettings(exposure_ms=float(ms), gain_db=self._settings.gain_db)
        return float(ms)

    def set_gain(self, db: float) -> float:
        """Set the analogue gain; the signal and the noise scale as on the virtual rig.

        Parameters
        ----------
        db : float
            Gain in dB, finite.

        Returns
        -------
        float
            The gain applied (exactly ``db``).
        """
        if not np.isfinite(db):
            raise InputError(f"camera {self.name}: gain must be a finite number of dB, got {db}")
        self._settings = CameraSettings(exposure_ms=self._settings.exposure_ms, gain_db=float(db))
        return float(db)

    def _offered_formats(self) -> tuple[str, ...]:
        return LOOP_FORMATS

    def _current_format(self) -> str:
        return self._format

    def _apply_pixel_format(self, pixel_format: str) -> None:
        self._format = pixel_format

    # -- grabbing ----------------------------------------------------------------------------
    def _screenshot(self) -> NDArray[np.uint8]:
        from PIL import ImageGrab

        assert self._box is not None
        x, y, w, h = self._box
        # Each grab is a new X connection (Pillow's ImageGrab), and a busy Xvfb refuses some
        # connections opened in quick succession (measured: about 1 in 8 back to back on a
        # loaded machine, none 50 ms apart): a refused one is tried again a few times.
        for attempt in range(_GRAB_ATTEMPTS):
            try:
                shot = ImageGrab.grab(bbox=(x, y, x + w, y + h), xdisplay=self._display)
                break
            except OSError as err:
                if attempt + 1 < _GRAB_ATTEMPTS:
                    time.sleep(_GRAB_RETRY_S)
                    continue
                raise CameraError(
                    f"camera {self.name}: cannot grab X display {self._display!r} ({err}); is "
                    "its X server still running?"
                ) from err
        image = np.asarray(shot.convert("L"), dtype=np.uint8)
        if image.shape != (h, w):
            raise CameraError(
                f"camera {self.name}: the grab is {image.shape[1]}x{image.shape[0]}, not the "
                f"screen's {w}x{h}; the X screen changed size, reopen the camera"
            )
        return image

    def _seen(self, screen: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """The screen content the camera sees now, after the latency."""
        if self._delivered is None or np.array_equal(screen, self._delivered):
            self._delivered, self._pending, self._pending_grabs = screen, None, 0
            return screen
        if self._pending is None or not np.array_equal(screen, self._pending):
            self._pending, self._pending_grabs = screen, 0
        self._pending_grabs += 1
        if self._pending_grabs > self._latency:
            self._delivered, self._pending, self._pending_grabs = screen, None, 0
        return self._delivered

    def _grab(self, timeout_s: float) -> NDArray[np.generic]:
        if self._box is None:
            raise self._not_open()
        seen = self._seen(self._screenshot())
        frame = ImageFrame(seen.astype(np.float32), "screen")
        return self.rig.capture([frame], self._settings)[0]
