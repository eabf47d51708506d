"""A rig configuration: projector, camera, synchronisation and gamma, described once.

:class:`RigConfig` is the plain data a lab's rig configuration file holds (docs/hardware.md,
"Rig configuration"; the TOML reader is :func:`hdrfringe.io.rig_config.load_rig_config`):
the projector (its specification and the size it must have), the camera (specification,
exposure, gain, pixel format, trigger line), the synchronisation (:class:`SyncSettings`), the
gamma pre-compensation and a free-text name. :meth:`RigConfig.from_dict` checks a parsed table
(unknown keys refused with their key path, types and ranges checked, each in one line that says
what, where and how to fix); :meth:`RigConfig.rig` builds the (not yet open)
:class:`~hdrfringe.hardware.rig.HardwareRig` it describes. A field left None is "not set": the
command's option default, or the device's own setting, applies.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, Self

from numpy.typing import ArrayLike

from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.limits import MAX_PROJECTOR_PIXELS
from hdrfringe.errors import InputError
from hdrfringe.hardware.backends import open_camera
from hdrfringe.hardware.camera import Camera, CameraBase
from hdrfringe.hardware.projector import Projector
from hdrfringe.hardware.rig import HardwareRig, SyncSettings, open_projector

__all__ = [
    "CameraConfig",
    "CheckedSizeProjector",
    "ProjectorConfig",
    "RigConfig",
]

#: Where the configuration is documented (named in every message).
DOC = "docs/hardware.md"
#: The pixel formats a camera may be set to (docs/hardware.md, "Pixel formats").
PIXEL_FORMATS = ("Mono8", "Mono10", "Mono12", "Mono16")
#: Longest text field (a specification, a name).
MAX_TEXT = 4096

_SYNC_KINDS: dict[str, str] = {
    "mode": "text",
    "settle_s": "seconds",
    "discard": "count",
    "max_grabs": "count",
    "grab_timeout_s": "seconds",
    "threshold": "number",
    "history": "count",
    "verify": "bool",
    "view_check": "bool",
}
_KEYS: dict[str, tuple[str, ...]] = {
    "": ("name", "gamma", "projector", "camera", "sync"),
    "projector": ("spec", "width", "height"),
    "camera": ("spec", "exposure_ms", "gain_db", "pixel_format", "trigger_line", "read_noise_dn"),
    "sync": tuple(_SYNC_KINDS),
}


def _label(key: str, labels: Mapping[str, str] | None) -> str:
    return (labels or {}).get(key, f"'{key}'")


_FIX_FILE = f"fix it in the rig configuration ({DOC})"
_FIX_OPTION = f"fix the option, or the rig configuration it overrides ({DOC})"


def _bad(where: str, what: str, fix: str = _FIX_FILE) -> str:
    return f"{where + ': ' if where else ''}{what}; {fix}"


def _check_value(
    key: str,
    value: Any,
    kind: str,
    where: str,
    labels: Mapping[str, str] | None,
    fix: str = _FIX_FILE,
) -> None:
    """Refuse a value of the wrong type or range for ``kind``, naming ``key``."""
    name = _label(key, labels)
    number = not isinstance(value, bool) and isinstance(value, int | float)
    if kind == "text":
        if not isinstance(value, str) or not value.strip() or len(value) > MAX_TEXT:
            raise InputError(
                _bad(
                    where,
                    f"{name} must be non-empty text (at most {MAX_TEXT} characters), "
                    f"got {_short(value)}",
                    fix,
                )
            )
    elif kind == "bool":
        if not isinstance(value, bool):
            raise InputError(_bad(where, f"{name} must be true or false, got {_short(value)}", fix))
    elif kind in ("count", "size"):
        lo, hi = (1, MAX_PROJECTOR_PIXELS) if kind == "size" else (0, 10**6)
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise InputError(
                _bad(where, f"{name} must be an integer in {lo}..{hi}, got {_short(value)}", fix)
            )
    else:  # seconds, ms, db, gamma, number: finite numbers
        positive = kind in ("ms", "gamma")
        ok = number and math.isfinite(value)
        ok = ok and (
            value > 0 if positive else (value >= 0 if kind in ("seconds", "noise") else True)
        )
        if kind == "seconds" and ok and value > 3600:
            ok = False
        if not ok:
            must = {
                "ms": "a positive number of milliseconds",
                "gamma": "a positive number (the pre-compensation exponent, e.g. 2.2)",
                "seconds": "a number of seconds in 0..3600",
                "db": "a finite number of dB",
                "noise": "a finite number of DN >= 0 (the noise std rig check measured)",
            }.get(kind, "a finite number")
            raise InputError(_bad(where, f"{name} must be {must}, got {_short(value)}", fix))


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else f"{text[:40]}...{text[-12:]}"


@dataclass(frozen=True)
class ProjectorConfig:
    """The projector of a rig configuration.

    Parameters
    ----------
    spec : str, optional
        ``screen:N[@DISPLAY]`` or ``folder:PATH[@WIDTHxHEIGHT]``
        (:func:`~hdrfringe.hardware.rig.open_projector`).
    width, height : int, optional
        The size the projector must have: an opened screen of another size is refused in one
        line; a ``folder:PATH`` without ``@WxH`` takes this size.

    Raises
    ------
    InputError
        A value of the wrong type or range, or only one of width and height.

    Examples
    --------
    >>> ProjectorConfig("screen:1", 1920, 1080).size
    (1920, 1080)
    """

    spec: str | None = None
    width: int | None = None
    height: int | None = None

    def __post_init__(self) -> None:
        _validate(self, "projector", "rig configuration", None)
        if (self.width is None) != (self.height is None):
            raise InputError(
                _bad("rig configuration", "projector width and height go together", "give both")
            )

    @property
    def size(self) -> tuple[int, int] | None:
        """``(width, height)`` when given, else None."""
        if self.width is None or self.height is None:
            return None
        return (self.width, self.height)


@dataclass(frozen=True)
class CameraConfig:
    """The camera of a rig configuration.

    Parameters
    ----------
    spec : str, optional
        ``pylon:SERIAL|emu``, ``opencv:N``, ``genicam:CTI[:SERIAL]`` or ``loop:SCENE[?...]``
        (:func:`~hdrfringe.hardware.backends.open_camera`).
    exposure_ms : float, optional
        Exposure time in ms; None: the camera's.
    gain_db : float, optional
        Gain in dB; None: the camera's.
    pixel_format : str, optional
        ``Mono8``, ``Mono10``, ``Mono12`` or ``Mono16``; None: the camera's.
    trigger_line : str, optional
        The camera input the projector's sync output is wired to (``--sync hardware``), for
        cameras with a hardware trigger (Basler, GenICam); None: the back end's ``Line1``.
    read_noise_dn : float, optional
        The camera's noise standard deviation in DN at these settings, as ``hdrfringe rig
        check`` measured it (``--write-config``); ``capture`` records it in the capture
        manifest (``camera.read_noise_dn``), from which ``phase`` and ``measure`` predict
        their std (docs/uncertainty.md). None: not known.

    Raises
    ------
    InputError
        A value of the wrong type or range.

    Examples
    --------
    >>> CameraConfig("pylon:emu", exposure_ms=20.0, pixel_format="Mono12").settings()
    CameraSettings(exposure_ms=20.0, gain_db=None)
    """

    spec: str | None = None
    exposure_ms: float | None = None
    gain_db: float | None = None
    pixel_format: str | None = None
    trigger_line: str | None = None
    read_noise_dn: float | None = None

    def __post_init__(self) -> None:
        _validate(self, "camera", "rig configuration", None)

    def settings(self) -> CameraSettings:
        """Exposure and gain as the rig's :class:`~hdrfringe.core.captures.CameraSettings`.

        Returns
        -------
        CameraSettings
        """
        return CameraSettings(exposure_ms=self.exposure_ms, gain_db=self.gain_db)


_KINDS: dict[str, str] = {
    "name": "text",
    "gamma": "gamma",
    "projector.spec": "text",
    "projector.width": "size",
    "projector.height": "size",
    "camera.spec": "text",
    "camera.exposure_ms": "ms",
    "camera.gain_db": "db",
    "camera.pixel_format": "format",
    "camera.trigger_line": "text",
    "camera.read_noise_dn": "noise",
    **{f"sync.{k}": v for k, v in _SYNC_KINDS.items()},
}


def _check_key(
    key: str,
    value: Any,
    where: str,
    labels: Mapping[str, str] | None,
    fix: str = _FIX_FILE,
) -> None:
    kind = _KINDS[key]
    if kind == "format":
        if value not in PIXEL_FORMATS:
            raise InputError(
                _bad(
                    where,
                    f"{_label(key, labels)} must be one of {', '.join(PIXEL_FORMATS)}, "
                    f"got {_short(value)}",
                    fix,
                )
            )
        return
    _check_value(key, value, kind, where, labels, fix)


def _normal(key: str, value: Any) -> Any:
    """Numbers of the real-valued fields as float (a file may write ``20`` for ``20.0``)."""
    if _KINDS[key] in ("ms", "db", "seconds", "gamma", "number", "noise"):
        return float(value)
    return value


def _validate(obj: Any, table: str, where: str, labels: Mapping[str, str] | None) -> None:
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if value is not None:
            _check_key(f"{table}.{f.name}", value, where, labels)


class CheckedSizeProjector:
    """A projector whose size is checked against the expected one when it opens.

    Wraps any :class:`~hdrfringe.hardware.projector.Projector`; after the wrapped one opens,
    a size other than ``(width, height)`` closes it again and raises one line, before
    anything is shown.

    Parameters
    ----------
    projector : Projector
        Not yet open.
    size : tuple of int
        The expected ``(width, height)``.
    spec : str
        How the projector was named (for the message).
    where : str
        Where the expected size came from (for the message).

    Raises
    ------
    InputError
        From :meth:`open`: the opened projector is not of the expected size.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import numpy as np
    >>> from hdrfringe.hardware.projector import FolderProjector
    >>> root = Path(tempfile.mkdtemp())
    >>> play = FolderProjector(root / "play", 64, 48)
    >>> with CheckedSizeProjector(play, (64, 48), "folder:play@64x48", "rig.toml") as p:
    ...     p.show(np.zeros((48, 64), np.uint8))
    1
    >>> other = FolderProjector(root / "other", 64, 48)
    >>> CheckedSizeProjector(other, (640, 480), "folder:other@64x48", "rig.toml").open()
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: projector folder:other@64x48 is 64x48 but rig.toml expects ...
    """

    def __init__(self, projector: Projector, size: tuple[int, int], spec: str, where: str) -> None:
        self.projector = projector
        self.expected = (int(size[0]), int(size[1]))
        self.spec = spec
        self.where = where

    def __repr__(self) -> str:
        return f"CheckedSizeProjector({self.projector!r}, {self.expected})"

    @property
    def size(self) -> tuple[int, int]:
        """The wrapped projector's (width, height)."""
        return self.projector.size

    @property
    def frame_counter(self) -> int:
        """The wrapped projector's frame counter."""
        return self.projector.frame_counter

    def open(self) -> None:
        """Open the wrapped projector and check its size.

        Raises
        ------
        InputError
            The size differs from the expected one (the projector is closed again).
        """
        self.projector.open()
        width, height = self.projector.size
        if (width, height) != self.expected:
            self.projector.close()
            w, h = self.expected
            raise InputError(
                f"projector {self.spec} is {width}x{height} but {self.where} expects {w}x{h} "
                "(projector.width, projector.height); choose the projector's screen, set its "
                "native mode, or fix the sizes"
            )

    def close(self) -> None:
        """Close the wrapped projector."""
        self.projector.close()

    def show(self, image: ArrayLike) -> int:
        """Show an image on the wrapped projector.

        Parameters
        ----------
        image : array_like of uint8

        Returns
        -------
        int
            Its frame number.
        """
        return self.projector.show(image)

    def __enter__(self) -> Self:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


@dataclass(frozen=True)
class RigConfig:
    """A rig described once: projector, camera, synchronisation, gamma and a name.

    Parameters
    ----------
    name : str, optional
        Free text (the lab's name for the rig).
    projector : ProjectorConfig
        Projector specification and expected size.
    camera : CameraConfig
        Camera specification and settings.
    sync : SyncSettings
        Synchronisation (:class:`~hdrfringe.hardware.rig.SyncSettings`).
    gamma : float, optional
        Gamma pre-compensation of the patterns (thesis Eq. 2.17); None: not set.
    gamma_file : str, optional
        The ``gamma.json`` (``hdrfringe gamma -o``) that ``gamma`` was read from.
    source : str, optional
        The configuration file read (None: built in Python or from options).
    sha256 : str, optional
        SHA-256 of that file's bytes.

    Raises
    ------
    InputError
        A value of the wrong type or range.

    References
    ----------
    Thesis Sec. 3.4.3 (the measurement system); Eq. 2.17 (gamma pre-compensation).

    Examples
    --------
    >>> cfg = RigConfig.from_dict({"name": "bench", "gamma": 2.2,
    ...     "projector": {"spec": "screen:1", "width": 1920, "height": 1080},
    ...     "camera": {"spec": "pylon:emu", "exposure_ms": 20.0},
    ...     "sync": {"settle_s": 0.05, "discard": 2}})
    >>> cfg.sync.discard, cfg.camera.exposure_ms, cfg.to_dict()["projector"]["width"]
    (2, 20.0, 1920)
    >>> RigConfig.from_dict({"camera": {"exposure": 20}}, where="rig.toml")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: rig.toml: unknown key 'camera.exposure'; did you mean ...
    """

    name: str | None = None
    projector: ProjectorConfig = field(default_factory=ProjectorConfig)
    camera: CameraConfig = field(default_factory=CameraConfig)
    sync: SyncSettings = field(default_factory=SyncSettings)
    gamma: float | None = None
    gamma_file: str | None = None
    source: str | None = None
    sha256: str | None = None

    def __post_init__(self) -> None:
        if self.name is not None:
            _check_key("name", self.name, "rig configuration", None)
        if self.gamma is not None:
            _check_key("gamma", self.gamma, "rig configuration", None)

    # -- from and to plain tables -----------------------------------------------------------
    @classmethod
    def from_dict(
        cls,
        data: Mapping[str, Any],
        *,
        where: str = "rig configuration",
        labels: Mapping[str, str] | None = None,
        **extra: Any,
    ) -> RigConfig:
        """Check a table (a parsed configuration file) and build the configuration.

        Parameters
        ----------
        data : mapping
            Keys ``name``, ``gamma`` (a number), and tables ``projector``, ``camera``,
            ``sync`` with the fields of :class:`ProjectorConfig`, :class:`CameraConfig` and
            :class:`~hdrfringe.hardware.rig.SyncSettings`; every key optional.
        where : str
            Where the table came from (the file), the start of every message.
        labels : mapping, optional
            Key path -> how to name it in messages (``{"camera.spec": "--camera"}``).
        **extra
            More fields of the result (``gamma_file``, ``source``, ``sha256``).

        Returns
        -------
        RigConfig

        Raises
        ------
        InputError
            An unknown key (named by its key path, with a did-you-mean), a table that is not
            a table, or a value of the wrong type or range.
        """
        _check_table(data, "", where)
        tables: dict[str, dict[str, Any]] = {}
        for table in ("projector", "camera", "sync"):
            value = data.get(table, {})
            if not isinstance(value, Mapping):
                raise InputError(
                    _bad(where, f"'{table}' must be a table ([{table}]), got {_short(value)}")
                )
            _check_table(value, table, where)
            tables[table] = {}
            for key, item in value.items():
                _check_key(f"{table}.{key}", item, where, labels)
                tables[table][key] = _normal(f"{table}.{key}", item)
        for key in ("name", "gamma"):
            if key in data:
                _check_key(key, data[key], where, labels)
        projector, camera = tables["projector"], tables["camera"]
        if ("width" in projector) != ("height" in projector):
            raise InputError(
                _bad(where, "projector width and height go together", "give both or neither")
            )
        try:
            sync = SyncSettings(**tables["sync"])
        except InputError as exc:
            raise InputError(_bad(where, str(exc).rstrip("."), f"fix it ({DOC})")) from None
        return cls(
            name=data.get("name"),
            projector=ProjectorConfig(**projector),
            camera=CameraConfig(**camera),
            sync=sync,
            gamma=None if data.get("gamma") is None else float(data["gamma"]),
            **extra,
        )

    def to_dict(self) -> dict[str, Any]:
        """The configuration as a table (TOML- and JSON-friendly; fields not set left out).

        Returns
        -------
        dict
            ``name``, ``gamma``, ``gamma_file`` and the tables ``projector``, ``camera`` and
            ``sync`` (every field of :class:`~hdrfringe.hardware.rig.SyncSettings`).
        """
        out: dict[str, Any] = {}
        if self.name is not None:
            out["name"] = self.name
        if self.gamma is not None:
            out["gamma"] = self.gamma
        if self.gamma_file is not None:
            out["gamma_file"] = self.gamma_file
        for table in ("projector", "camera"):
            values = dataclasses.asdict(getattr(self, table))
            out[table] = {k: v for k, v in values.items() if v is not None}
        out["sync"] = dataclasses.asdict(self.sync)
        return out

    def to_record(self) -> dict[str, Any]:
        """What a capture manifest records: :meth:`to_dict` plus the file read, if any.

        Returns
        -------
        dict
            :meth:`to_dict` and ``config_file``: ``{"path", "sha256"}`` (when read from one).
        """
        out = self.to_dict()
        if self.source is not None:
            out["config_file"] = {"path": self.source, "sha256": self.sha256}
        return out

    def replace(self, values: Mapping[str, Any], labels: Mapping[str, str] | None = None) -> Self:
        """A copy with the values of some key paths replaced, checked as in :meth:`from_dict`.

        Parameters
        ----------
        values : mapping
            Key path (``"camera.exposure_ms"``, ``"sync.settle_s"``, ``"gamma"``) -> value.
        labels : mapping, optional
            Key path -> how to name it in messages (the option it came from).

        Returns
        -------
        RigConfig

        Raises
        ------
        InputError
            An unknown key path or a bad value.
        """
        tables: dict[str, dict[str, Any]] = {
            "projector": dataclasses.asdict(self.projector),
            "camera": dataclasses.asdict(self.camera),
            "sync": dataclasses.asdict(self.sync),
        }
        top: dict[str, Any] = {"name": self.name, "gamma": self.gamma}
        for key, value in values.items():
            if key not in _KINDS:
                raise InputError(
                    f"unknown rig configuration key '{key}'; use one of {', '.join(_KINDS)}"
                )
            table, _, name = key.rpartition(".")
            if value is not None:
                _check_key(key, value, "", labels, _FIX_OPTION if labels else _FIX_FILE)
                value = _normal(key, value)
            (tables[table] if table else top)[name] = value
        sync = tables["sync"]
        try:
            sync_settings = SyncSettings(**sync)
        except InputError as exc:
            raise InputError(" ".join(str(exc).split())) from None
        gamma_file = self.gamma_file if top["gamma"] == self.gamma else None
        return dataclasses.replace(
            self,
            name=top["name"],
            gamma=None if top["gamma"] is None else float(top["gamma"]),
            gamma_file=gamma_file,
            projector=ProjectorConfig(**tables["projector"]),
            camera=CameraConfig(**tables["camera"]),
            sync=sync_settings,
        )

    # -- devices ------------------------------------------------------------------------------
    def _where(self) -> str:
        return self.source or "the rig configuration"

    def projector_device(self) -> Projector:
        """The (not yet open) projector, its size checked at opening when one is configured.

        Returns
        -------
        Projector

        Raises
        ------
        InputError
            No projector specification, or a malformed one.
        """
        spec = self.projector.spec
        if spec is None:
            raise InputError("no projector: give --projector SPEC or projector.spec (" + DOC + ")")
        size = self.projector.size
        if size is not None and spec.startswith("folder:") and "@" not in spec:
            spec = f"{spec}@{size[0]}x{size[1]}"  # the folder takes the configured size
        device = open_projector(spec)
        if size is None:
            return device
        return CheckedSizeProjector(device, size, spec, self._where())

    def camera_device(self) -> Camera:
        """The (not yet open) camera, with the configured trigger line.

        Returns
        -------
        Camera

        Raises
        ------
        InputError
            No camera specification, a malformed one, or a trigger line for a camera without
            a hardware trigger input.
        """
        spec = self.camera.spec
        if spec is None:
            raise InputError("no camera: give --camera SPEC or camera.spec (" + DOC + ")")
        device: CameraBase = open_camera(spec)
        if self.camera.trigger_line is not None:
            if not hasattr(device, "trigger_line"):
                raise InputError(
                    f"camera {spec}: no hardware trigger input, so camera.trigger_line "
                    f"{self.camera.trigger_line!r} cannot apply; remove it ({DOC})"
                )
            device.trigger_line = self.camera.trigger_line
        return device

    def rig(self, *, sleep: Callable[[float], None] | None = None) -> HardwareRig:
        """The (not yet open) hardware rig this configuration describes.

        Parameters
        ----------
        sleep : callable, optional
            ``time.sleep`` replacement (tests pass a fake clock).

        Returns
        -------
        HardwareRig
            Gamma pre-compensation ``gamma`` (1.0 when not set), the camera's exposure, gain
            and pixel format, the synchronisation.

        Raises
        ------
        InputError
            As :meth:`projector_device` and :meth:`camera_device`.

        Examples
        --------
        >>> import tempfile
        >>> from pathlib import Path
        >>> from hdrfringe.core.frames import UniformFrame
        >>> play = Path(tempfile.mkdtemp()) / "play"
        >>> cfg = RigConfig.from_dict({"gamma": 2.2,
        ...     "projector": {"spec": f"folder:{play}", "width": 64, "height": 48},
        ...     "camera": {"spec": "pylon:emu", "pixel_format": "Mono8"},
        ...     "sync": {"settle_s": 0.0, "verify": False}})
        >>> with cfg.rig() as rig:
        ...     images = rig.capture([UniformFrame(128.0)])
        >>> rig.projector.width, rig.projector.gamma_precompensation, images.dtype
        (64, 2.2, dtype('uint8'))
        """
        kwargs: dict[str, Any] = {} if sleep is None else {"sleep": sleep}
        return HardwareRig(
            self.projector_device(),
            self.camera_device(),
            self.sync,
            gamma_hat=1.0 if self.gamma is None else self.gamma,
            settings=self.camera.settings(),
            pixel_format=self.camera.pixel_format,
            **kwargs,
        )


def _check_table(table: Mapping[str, Any], prefix: str, where: str) -> None:
    allowed = _KEYS[prefix]
    for key in table:
        if key in allowed:
            continue
        path = f"{prefix}.{key}" if prefix else str(key)
        close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
        hint = f"did you mean '{close[0]}'?" if close else f"known keys: {', '.join(allowed)}"
        shown = path if len(path) <= 60 else f"{path[:40]}...{path[-12:]}"
        raise InputError(_bad(where, f"unknown key '{shown}'", f"{hint} ({DOC})"))
