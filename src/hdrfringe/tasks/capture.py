"""``hdrfringe capture``: a strategy run live on a hardware rig, written as a capture folder.

Also what every live command shares (``capture``, ``capture-gamma``, ``capture-poses``,
``measure --rig hardware``, ``rig check``): the rig configuration a command runs with
(:func:`resolve_rig_config`, the file's values and the options the user gave explicitly), the
rig itself (:func:`hardware_rig`), the record of a live run (:func:`live_record`) and its
folder (:func:`write_capture_output`).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hdrfringe.core import strict_json
from hdrfringe.errors import InputError, StoppedError

__all__ = [
    "CAPTURE_LOG",
    "OPTION_LABELS",
    "RIG_OPTION_KEYS",
    "CaptureReport",
    "LiveFringes",
    "announce_line",
    "capture",
    "hardware_options",
    "hardware_rig",
    "live_record",
    "resolve_rig_config",
    "strategy_record",
    "write_capture_output",
]

#: The timing log ``capture`` writes beside the manifest.
CAPTURE_LOG = "capture_log.json"
#: The hardware options (Python names) and the rig configuration key each one sets.
RIG_OPTION_KEYS: dict[str, str] = {
    "projector": "projector.spec",
    "camera": "camera.spec",
    "sync": "sync.mode",
    "settle": "sync.settle_s",
    "discard": "sync.discard",
    "max_grabs": "sync.max_grabs",
    "gamma": "gamma",
    "exposure_ms": "camera.exposure_ms",
    "gain_db": "camera.gain_db",
    "pixel_format": "camera.pixel_format",
    "view_check": "sync.view_check",
}
#: How messages name a key set from an option.
OPTION_LABELS = {key: "--" + name.replace("_", "-") for name, key in RIG_OPTION_KEYS.items()}


def _config_value(config: Any, key: str) -> Any:
    table, _, name = key.rpartition(".")
    return getattr(getattr(config, table) if table else config, name)


def resolve_rig_config(
    config_path: Path | None, given: Collection[str] = (), **options: Any
) -> Any:
    """The rig configuration a command runs with: the file's values, options given override.

    For each option (Python names of :data:`RIG_OPTION_KEYS`): a value the user gave
    explicitly (its name in ``given``; the CLI takes the set from click's parameter sources)
    wins; else the file's value; else, when the file leaves
    the key unset (or there is no file), the option's default (a ``[sync]`` key the file
    leaves out has :class:`~hdrfringe.hardware.rig.SyncSettings`' default, which is the
    options' default too). Options a command does not have are simply not passed: the file's
    value, or the configuration's "not set", applies.

    Parameters
    ----------
    config_path : Path or None
        ``--rig-config``.
    given : collection of str
        The options (Python names) given explicitly; the others are defaults, which the
        file's values override.
    **options
        The command's hardware options by Python name (``projector=...``, ``settle=...``).

    Returns
    -------
    RigConfig
        The resolved configuration (with the file's path and SHA-256 when one was read).

    Examples
    --------
    >>> config = resolve_rig_config(None, {"projector"}, projector="screen:1", settle=0.2)
    >>> config.projector.spec, config.sync.settle_s
    ('screen:1', 0.2)
    """
    from hdrfringe.hardware.config import RigConfig
    from hdrfringe.io.rig_config import load_rig_config

    base = RigConfig() if config_path is None else load_rig_config(config_path)
    values = {}
    for name, value in options.items():
        key = RIG_OPTION_KEYS[name]
        unset = config_path is None or _config_value(base, key) is None
        if unset or name in given:
            values[key] = value
    return base.replace(values, OPTION_LABELS)


def hardware_options(
    projector: str | None,
    camera: str | None,
    sync: str,
    settle: float,
    discard: int,
    max_grabs: int,
    gamma: float | None,
    exposure_ms: float | None,
    gain_db: float | None,
    pixel_format: str | None,
    config: Any = None,
) -> Any:
    """The (not yet open) :class:`~hdrfringe.hardware.rig.HardwareRig` the options describe.

    Parameters
    ----------
    projector, camera : str or None
        The device specs (both required).
    sync : str
        ``software`` or ``hardware``.
    settle : float
        Seconds to wait after a frame is shown.
    discard : int
        Grabs dropped after a frame is shown.
    max_grabs : int
        Grabs tried per frame before a sync error.
    gamma : float or None
        The projector's gamma pre-compensation.
    exposure_ms, gain_db : float or None
        Camera settings (None: the camera's own).
    pixel_format : str or None
        Camera pixel format.
    config : RigConfig, optional
        Supplies what the options do not: the projector size check, the trigger line, sync
        fields without an option.

    Returns
    -------
    HardwareRig
        Not yet open.

    Examples
    --------
    >>> hardware_options(None, "pylon:emu", "software", 0.1, 0, 5, None, None, None, None)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: give both --projector SPEC and --camera SPEC, or a ...ardware.md)
    """
    from hdrfringe.hardware.config import RigConfig

    if projector is None or camera is None:
        raise InputError(
            "give both --projector SPEC and --camera SPEC, or a --rig-config file that names "
            "them (docs/hardware.md)"
        )
    values = {
        RIG_OPTION_KEYS[name]: value
        for name, value in (
            ("projector", projector), ("camera", camera), ("sync", sync), ("settle", settle),
            ("discard", discard), ("max_grabs", max_grabs), ("gamma", gamma),
            ("exposure_ms", exposure_ms), ("gain_db", gain_db), ("pixel_format", pixel_format),
        )
    }  # fmt: skip
    resolved = (RigConfig() if config is None else config).replace(values, OPTION_LABELS)
    return resolved.rig()


def hardware_rig(
    config_path: Path | None, given: Collection[str] = (), **options: Any
) -> tuple[Any, Any]:
    """The rig a hardware command runs on, from ``--rig-config`` and its options.

    The one entry point of ``capture``, ``measure --rig hardware`` and every command that
    captures on hardware: :func:`resolve_rig_config`, then :func:`hardware_options` (the rig
    is not opened).

    Parameters
    ----------
    config_path : Path or None
        ``--rig-config``.
    given : collection of str
        The options (Python names) given explicitly (:func:`resolve_rig_config`).
    **options
        The command's hardware options by Python name (keys of :data:`RIG_OPTION_KEYS`).

    Returns
    -------
    rig : HardwareRig
        Not yet open.
    config : RigConfig
        The resolved configuration (record it: :func:`live_record`).

    Examples
    --------
    >>> hardware_rig(None, camera="pylon:emu")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: give both --projector SPEC and --camera SPEC, or a ...
    """
    config = resolve_rig_config(config_path, given, **options)
    rig = hardware_options(
        config.projector.spec, config.camera.spec, config.sync.mode, config.sync.settle_s,
        config.sync.discard, config.sync.max_grabs, config.gamma, config.camera.exposure_ms,
        config.camera.gain_db, config.camera.pixel_format, config,
    )  # fmt: skip
    return rig, config


def announce_line(strategy: str, rig: Any, config: Any) -> str:
    """The line a live hardware command says once the rig is open.

    Parameters
    ----------
    strategy : str
        The strategy run.
    rig : HardwareRig
        The open rig (its projector and image sizes).
    config : RigConfig
        The resolved configuration (its name and device specs).

    Returns
    -------
    str

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> rig = NS(projector=NS(width=1024, height=768), image_shape=(494, 648),
    ...          camera_bit_depth=8)
    >>> config = NS(name="bench", projector=NS(spec="screen:1"), camera=NS(spec="pylon:emu"))
    >>> announce_line("lpa", rig, config)
    'lpa live (bench): projector screen:1 (1024x768), camera pylon:emu (648x494, 8 bit)'
    """
    name = f" ({config.name})" if config.name else ""
    return (
        f"{strategy} live{name}: projector {config.projector.spec} ({rig.projector.width}x"
        f"{rig.projector.height}), camera {config.camera.spec} ({rig.image_shape[1]}x"
        f"{rig.image_shape[0]}, {rig.camera_bit_depth} bit)"
    )


def live_record(
    recorder: Any,
    rig: Any,
    config: Any,
    strategy: str | None,
    name: str,
    stopped: str | None = None,
    *,
    entries: Mapping[str, Any] | None = None,
    start: int = 0,
) -> tuple[Any, dict[str, Any], dict[str, Any]]:
    """What a live run writes: its captures, the manifest's ``capture`` entry, the timing log.

    Parameters
    ----------
    recorder : Recorder
        What the run captured.
    rig : HardwareRig
        The rig it ran on (its noise variance and timing log).
    config : RigConfig
        The resolved configuration (:func:`hardware_rig`).
    strategy : str or None
        The strategy; None for a fixed program (``capture-gamma``, ``capture-poses``), which
        says what it was in ``entries``.
    name : str
        The captures' name.
    stopped : str, optional
        Why the run stopped before the end (the record is then incomplete).
    entries : mapping, optional
        A program's own entries of the record, after the strategy's (its name, levels, pose).
    start : int
        The first entry of ``rig.log`` that belongs to this record (``capture-poses`` writes
        one record per pose).

    Returns
    -------
    captures : Captures
        Every complete set recorded, in capture order.
    state : dict
        The strategy (key ``method``), completeness, devices, sync settings and the resolved
        rig configuration (``rig``, with ``config_file``: path and SHA-256 when a file was
        read).
    log : dict
        ``state`` plus the noise variance, the view check's change ratio (``view_change``,
        None when it was off) and the per-frame timing.

    Examples
    --------
    >>> from types import SimpleNamespace as NS
    >>> recorder = NS(captures=lambda name, camera: f"{name}: {camera}")
    >>> rig = NS(log=[], noise_var=0.5)
    >>> sync = NS(mode="software", settle_s=0.1, discard=0, max_grabs=5)
    >>> config = NS(camera=NS(spec="pylon:emu", read_noise_dn=None), projector=NS(spec="screen:1"),
    ...             sync=sync, to_record=lambda: {"name": "bench"})
    >>> caps, state, log = live_record(recorder, rig, config, "lpa", "caps")
    >>> caps, state["method"], state["complete"], log["noise_variance"]
    ("caps: {'spec': 'pylon:emu'}", 'lpa', True, 0.5)
    """
    camera: dict[str, Any] = {"spec": config.camera.spec}
    if config.camera.read_noise_dn is not None:  # rig check's, for the predicted std
        camera["read_noise_dn"] = config.camera.read_noise_dn
    caps = recorder.captures(name=name, camera=camera)
    sync = config.sync
    state: dict[str, Any] = {} if strategy is None else {"method": strategy}
    state.update(entries or {})
    state.update(
        {
            "complete": stopped is None,
            "projector": config.projector.spec,
            "camera": config.camera.spec,
            "sync": {
                "mode": sync.mode,
                "settle_s": sync.settle_s,
                "discard": sync.discard,
                "max_grabs": sync.max_grabs,
            },
            "rig": config.to_record(),
        }
    )
    if stopped is not None:
        state["stopped"] = stopped
    frames = [t.to_dict() for t in rig.log[start:]]
    log = {
        **state,
        "noise_variance": rig.noise_var,
        "view_change": getattr(rig, "view_ratio", None),
        "frames": frames,
    }
    return caps, state, log


def strategy_record(given: Mapping[str, Any]) -> dict[str, Any]:
    """The capture record's ``strategy_options``: the strategy options the user gave, by
    option name (a file as its absolute path), which ``measure FOLDER`` replays with.

    Parameters
    ----------
    given : mapping
        The strategy options given explicitly, by option name (``{"--step": 100}``).

    Returns
    -------
    dict
        ``{"strategy_options": {option: value}}``.

    Examples
    --------
    >>> strategy_record({"--step": 100, "--correction": Path("/c.json")})
    {'strategy_options': {'--step': 100, '--correction': '/c.json'}}
    """
    return {
        "strategy_options": {
            k: str(v.resolve()) if isinstance(v, Path) else v for k, v in given.items()
        }
    }


def write_capture_output(
    folder: Path, captures: Any, state: dict[str, Any], log: dict[str, Any]
) -> None:
    """Write a live run's capture folder and its ``capture_log.json`` into ``folder``.

    Parameters
    ----------
    folder : Path
        Inside a staged output: a new or empty folder.
    captures : Captures
        What the run captured (:func:`live_record`).
    state : dict
        The manifest's ``capture`` entry.
    log : dict
        The timing log.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from hdrfringe.core.captures import Captures
    >>> from hdrfringe.core.frames import UniformFrame
    >>> caps = Captures([UniformFrame(255.0)], np.zeros((1, 4, 6)), 8)
    >>> folder = Path(tempfile.mkdtemp())
    >>> write_capture_output(folder, caps, {"complete": True}, {"frames": []})
    >>> sorted(p.name for p in folder.iterdir())
    ['capture_log.json', 'gray_255.png', 'manifest.json']
    """
    from hdrfringe.io.captures import write_capture_folder

    write_capture_folder(folder, captures, extra={"capture": state}, force=True)
    (folder / CAPTURE_LOG).write_text(strict_json.dumps(log) + "\n", encoding="utf-8")




@dataclass(frozen=True)
class LiveFringes:
    """The fringe options of a live run: the vertical sets, one per pitch, and a centerline.

    Parameters
    ----------
    pattern : str
        ``sinusoidal`` or ``triangular``.
    steps : int
        Phase shifts per set.
    pitches : sequence of float
        Pitches in projector px (any order; repeats are dropped, coarsest first).
    imin, migl : float
        Lowest and highest input gray level.
    centerline : bool
        Whether to capture a centerline.

    Examples
    --------
    >>> LiveFringes("sinusoidal", 4, [8, 1024, 64], 40.0, 255.0, True).pitches
    [8, 1024, 64]
    """

    pattern: str
    steps: int
    pitches: Sequence[float]
    imin: float
    migl: float
    centerline: bool

    def build(self, projector: Any) -> tuple[list[Any], Any]:
        """The sets (coarsest first) and the centerline (or None) for the rig's projector.

        Parameters
        ----------
        projector : ProjectorInfo
            The rig's projector (the centerline sits at its middle column, at full white).

        Returns
        -------
        specs : list of FringeSpec
        line : CenterlineFrame or None

        Examples
        --------
        >>> from hdrfringe.core.captures import ProjectorInfo
        >>> specs, line = LiveFringes("sinusoidal", 4, [8, 64, 8], 40, 255, True).build(
        ...     ProjectorInfo(1024, 768, 8))
        >>> [s.pitch_px for s in specs], line.position
        ([64, 8], 512)
        """
        from hdrfringe.core.programs import centerline_frame, fringe_specs

        pitches = sorted(set(self.pitches), reverse=True)
        specs = fringe_specs(self.pattern, self.steps, pitches, "vertical", self.imin, self.migl)
        return specs, centerline_frame(projector) if self.centerline else None

    def to_record(self) -> dict[str, Any]:
        """The capture record's ``fringes`` entry: what the run measured, so that ``measure
        FOLDER`` replays the strategy on these sets (not on the folder's other sets, e.g. an
        adaptive run's mapping ladders at a low MIGL).

        Returns
        -------
        dict
            ``{"fringes": {pattern, steps, pitches, imin, migl, centerline}}``.

        Examples
        --------
        >>> rec = LiveFringes("sinusoidal", 4, [8, 1024], 40.0, 255.0, True).to_record()
        >>> rec["fringes"]["pitches"], LiveFringes.from_record(rec["fringes"], "log").pitches
        ([8.0, 1024.0], [8.0, 1024.0])
        """
        return {
            "fringes": {
                "pattern": self.pattern,
                "steps": int(self.steps),
                "pitches": [float(p) for p in self.pitches],
                "imin": float(self.imin),
                "migl": float(self.migl),
                "centerline": bool(self.centerline),
            }
        }

    @classmethod
    def from_record(cls, entry: Any, where: str) -> LiveFringes:
        """The fringes a capture record's ``fringes`` entry names (:meth:`to_record`).

        Parameters
        ----------
        entry : Any
            The entry as read.
        where : str
            The file it was read from, for the message.

        Returns
        -------
        LiveFringes

        Raises
        ------
        InputError
            An entry that is not what :meth:`to_record` writes.
        """
        keys = ("pattern", "steps", "pitches", "imin", "migl", "centerline")
        try:
            assert isinstance(entry, dict) and set(entry) == set(keys)
            pitches = [float(p) for p in entry["pitches"]]
            assert pitches and entry["pattern"] in ("sinusoidal", "triangular")
            return cls(
                str(entry["pattern"]),
                int(entry["steps"]),
                pitches,
                float(entry["imin"]),
                float(entry["migl"]),
                bool(entry["centerline"]),
            )
        except (AssertionError, TypeError, ValueError):
            raise InputError(
                f"{where}: fringes is not a record of {', '.join(keys)}; fix or remove it"
            ) from None


@dataclass(frozen=True)
class CaptureReport:
    """What ``capture`` wrote.

    Parameters
    ----------
    output : Path
        The capture folder.
    images : int
        Images written.
    sets : int
        Complete sets written.
    rejected : int
        Stale grabs the synchronisation rejected.

    Examples
    --------
    >>> CaptureReport(Path("caps"), images=53, sets=13, rejected=0).sets
    13
    """

    output: Path
    images: int
    sets: int
    rejected: int


def stop_reason(stop: KeyboardInterrupt) -> tuple[str, int]:
    """Why a live capture stopped early, as its manifest records it, and the exit code:
    Ctrl-C (2, as before: the command reports the kept sets as an error), or SIGTERM (143) /
    SIGHUP (129) turned into a :class:`~hdrfringe.io.results.SignalStop`.

    Parameters
    ----------
    stop : KeyboardInterrupt
        What the capture raised.

    Returns
    -------
    (str, int)

    Examples
    --------
    >>> import signal
    >>> from hdrfringe.io.results import SignalStop
    >>> stop_reason(KeyboardInterrupt()), stop_reason(SignalStop(signal.SIGTERM))
    (('interrupted (Ctrl-C)', 2), ('stopped by SIGTERM', 143))
    """
    name = getattr(stop, "name", None)
    if name is None:
        return "interrupted (Ctrl-C)", 2
    return f"stopped by {name}", int(getattr(stop, "exit_code", 2))


def capture(
    output: Path,
    rig_config: Path | None,
    hardware: Mapping[str, Any],
    fringes: LiveFringes,
    *,
    given: Collection[str] = (),
    strategy: str = "conventional",
    params: Any = None,
    sources: Mapping[str, str] | None = None,
    strategy_options: Mapping[str, Any] | None = None,
    force: bool = False,
    say: Callable[[str], Any] | None = None,
) -> CaptureReport:
    """Run a strategy live on the hardware rig and write every set it captured.

    The output is checked (not an input, new or empty, or ``force``) before the rig opens; it
    appears only when complete. Ctrl-C after the first set writes the complete sets, marks the
    folder incomplete and raises :class:`~hdrfringe.errors.HdrFringeError`; SIGTERM and SIGHUP
    do the same and raise :class:`~hdrfringe.errors.StoppedError` with exit code 143 / 129;
    before the first set, the ``KeyboardInterrupt`` (:class:`~hdrfringe.io.results.SignalStop`)
    propagates and nothing is written.

    Parameters
    ----------
    output : Path
        The capture folder to write.
    rig_config : Path or None
        The rig configuration file.
    hardware : mapping
        Hardware options by Python name (keys of :data:`RIG_OPTION_KEYS`).
    fringes : LiveFringes
        What to project.
    given : collection of str
        The hardware options given explicitly (:func:`resolve_rig_config`).
    strategy : str
        The strategy.
    params : Params, optional
        The strategy's parameters.
    sources : mapping, optional
        Files the strategy options named (field -> path): not to be overwritten.
    strategy_options : mapping, optional
        The strategy options given, by option name, recorded for ``measure FOLDER``.
    force : bool
        Replace an existing output folder.
    say : callable, optional
        Called with the line saying the rig is open.

    Returns
    -------
    CaptureReport

    Examples
    --------
    >>> fringes = LiveFringes("sinusoidal", 4, [1024, 64, 8], 40.0, 255.0, True)
    >>> capture(Path("caps"), None, {"camera": "pylon:emu"}, fringes, given={"camera"})
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: give both --projector SPEC and --camera SPEC, or a ...
    """
    from hdrfringe import pipeline
    from hdrfringe.hardware.rig import Recorder
    from hdrfringe.io.results import (
        check_output_against_inputs,
        check_output_dir,
        signals_as_interrupt,
        staged_output_dir,
    )

    rig, config = hardware_rig(rig_config, given, **hardware)
    inputs = [*(sources or {}).values(), rig_config, config.gamma_file]
    check_output_against_inputs(output, inputs)
    checked = check_output_dir(output, force)
    recorder = Recorder(rig)
    stopped: str | None = None
    code = 2
    with rig:
        specs, line = fringes.build(rig.projector)
        if say is not None:
            say(announce_line(strategy, rig, config))
        try:
            with signals_as_interrupt():  # SIGTERM, SIGHUP: kept as for Ctrl-C (issue 31)
                pipeline.composite_captures(
                    recorder, specs, strategy, params, centerline=line,
                    description=pipeline.RigDescription("capture", {}, {}),
                )  # fmt: skip
        except KeyboardInterrupt as stop:
            if not recorder.calls:
                raise
            stopped, code = stop_reason(stop)
    caps, state, log = live_record(
        recorder, rig, config, strategy, output.name, stopped,
        entries=strategy_record(strategy_options or {}) | fringes.to_record(),
    )  # fmt: skip
    with staged_output_dir(checked, force=force) as tmp:
        write_capture_output(tmp, caps, state, log)
    sets = len(caps.sets)
    if stopped is not None:
        raise StoppedError(
            f"capture {stopped} after {sets} complete sets; {output} holds those sets only "
            '(manifest "capture": {"complete": false}); capture again for a complete folder',
            code,
        )
    rejected = sum(t.rejected for t in rig.log)
    return CaptureReport(output, len(caps.frames), sets, rejected)
