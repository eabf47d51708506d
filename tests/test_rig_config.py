"""Rig configuration files (issue 13 item 5): reading, checking, writing, and how the hardware
commands resolve them against their options. No device is opened here except Basler's
emulated camera and a folder projector; the loop-rig runs are in test_measure_hardware.py."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from hdrfringe.errors import HdrFringeError, InputError
from hdrfringe.hardware.config import CheckedSizeProjector, RigConfig
from hdrfringe.hardware.rig import SyncSettings
from hdrfringe.io.rig_config import (
    MAX_RIG_CONFIG_BYTES,
    gamma_from_report,
    load_rig_config,
    rig_config_toml,
    write_rig_config,
)

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "docs" / "examples" / "rig.toml"


def write(tmp_path: Path, text: str, name: str = "rig.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def refusal(tmp_path: Path, text: str) -> str:
    with pytest.raises(InputError) as err:
        load_rig_config(write(tmp_path, text))
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(tmp_path / "rig.toml"))
    return msg


# --- the documented example -------------------------------------------------------------------
def test_the_documented_example_loads_as_written() -> None:
    raw = tomllib.loads(EXAMPLE.read_text(encoding="utf-8"))  # the reference: tomllib itself
    cfg = load_rig_config(EXAMPLE)
    table = cfg.to_dict()
    assert table["name"] == raw["name"] and table["gamma"] == raw["gamma"]
    assert table["projector"] == raw["projector"] and table["camera"] == raw["camera"]
    assert {k: table["sync"][k] for k in raw["sync"]} == raw["sync"]
    # what the file leaves out of [sync] is SyncSettings' default, the options' default too
    assert table["sync"]["threshold"] == SyncSettings().threshold
    assert cfg.source == str(EXAMPLE) and len(cfg.sha256 or "") == 64
    assert cfg.projector.size == (1920, 1080)


def test_the_example_round_trips_through_the_writer(tmp_path: Path) -> None:
    cfg = load_rig_config(EXAMPLE)
    out = write_rig_config(tmp_path / "copy.toml", cfg, header="a copy\nof the example")
    again = load_rig_config(out)
    assert again.to_dict() == cfg.to_dict()
    assert out.read_text().startswith("# a copy\n# of the example\n")
    with pytest.raises(HdrFringeError, match="exists"):  # like every output: no overwrite
        write_rig_config(out, cfg)
    write_rig_config(out, cfg.replace({"sync.discard": 4}), force=True)
    assert load_rig_config(out).sync.discard == 4


@pytest.mark.parametrize(
    "text",
    ['quote " and back\\slash', "tab\tnewline\nunicode \u00e9\u6f22 \U0001f600", "del \x7f end"],
)
def test_text_with_special_characters_round_trips(tmp_path: Path, text: str) -> None:
    cfg = RigConfig.from_dict({"name": text, "camera": {"spec": "pylon:emu"}})
    path = write(tmp_path, rig_config_toml(cfg))
    assert load_rig_config(path).name == text


# --- refusals: unknown keys, types, ranges ----------------------------------------------------
@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ('projektor = "screen:0"\n', "unknown key 'projektor'; did you mean 'projector'?"),
        ("[camera]\nexposure = 20\n", "unknown key 'camera.exposure'; did you mean 'exposure_ms'?"),
        ("[sync]\nsettle = 0.1\n", "unknown key 'sync.settle'; did you mean 'settle_s'?"),
        ("[projector]\nscreen = 1\n", "unknown key 'projector.screen'; known keys: spec, width"),
        ("[lens]\nf = 8\n", "unknown key 'lens'"),
        ('camera = "pylon:emu"\n', "'camera' must be a table ([camera])"),
        ('[camera]\nexposure_ms = "fast"\n', "'camera.exposure_ms' must be a positive number"),
        ("[camera]\nexposure_ms = -5\n", "'camera.exposure_ms' must be a positive number"),
        ("[camera]\nexposure_ms = nan\n", "got nan"),
        ("[camera]\ngain_db = inf\n", "'camera.gain_db' must be a finite number of dB, got inf"),
        ('[camera]\npixel_format = "Mono12p"\n', "'camera.pixel_format' must be one of Mono8"),
        (
            "[camera]\nread_noise_dn = -0.5\n",
            "'camera.read_noise_dn' must be a finite number of DN >= 0",
        ),
        (
            '[camera]\nread_noise_dn = "low"\n',
            "'camera.read_noise_dn' must be a finite number of DN",
        ),
        (
            "[camera]\nread_noise = 2\n",
            "unknown key 'camera.read_noise'; did you mean 'read_noise_dn'?",
        ),
        ("[camera]\nspec = 5\n", "'camera.spec' must be non-empty text"),
        ('[camera]\nspec = ""\n', "'camera.spec' must be non-empty text"),
        ("[projector]\nwidth = 1920\n", "projector width and height go together"),
        ("[projector]\nwidth = 0\nheight = 10\n", "'projector.width' must be an integer in 1.."),
        ("[projector]\nwidth = 19.5\nheight = 10\n", "'projector.width' must be an integer"),
        ("[projector]\nwidth = true\nheight = 10\n", "'projector.width' must be an integer"),
        ("[sync]\ndiscard = -1\n", "'sync.discard' must be an integer in 0..1000000, got -1"),
        ("[sync]\ndiscard = 99999999999999\n", "'sync.discard' must be an integer in 0.."),
        ("[sync]\nmax_grabs = 0\n", "sync max_grabs must be an integer >= 1, got 0"),
        ('[sync]\nmode = "radio"\n', "sync mode 'radio' is unknown; use software or hardware"),
        ("[sync]\nsettle_s = 1e300\n", "'sync.settle_s' must be a number of seconds in 0..3600"),
        ('[sync]\nverify = "yes"\n', "'sync.verify' must be true or false"),
        ("[sync]\nthreshold = 0.5\n", "sync threshold must be a number > 1"),
        ("gamma = 0\n", "'gamma' must be a positive number"),
        ("gamma = -2.2\n", "'gamma' must be a positive number"),
        ("gamma = true\n", "'gamma' must be a positive number"),
        ('name = ""\n', "'name' must be non-empty text"),
        ("name = " + "9" * 5000 + "\n", "a number with too many digits"),
        ("a = " + "[" * 5000 + "]" * 5000 + "\n", "nested too deep"),
        ("gamma = " + "4" * 400 + ".0\n", "'gamma' must be a positive number"),
        ("[camera\n", "not a valid TOML rig configuration"),
    ],
)
def test_bad_configurations_are_refused_in_one_line(tmp_path: Path, text: str, reason: str) -> None:
    assert reason in refusal(tmp_path, text)


def test_missing_folder_oversized_and_non_utf8_files(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="rig configuration file does not exist"):
        load_rig_config(tmp_path / "none.toml")
    with pytest.raises(InputError, match="is a folder, not a rig configuration file"):
        load_rig_config(tmp_path)
    big = write(tmp_path, "# " + "x" * MAX_RIG_CONFIG_BYTES + "\n", "big.toml")
    with pytest.raises(InputError, match=f"larger than {MAX_RIG_CONFIG_BYTES} bytes"):
        load_rig_config(big)
    latin = tmp_path / "latin.toml"
    latin.write_bytes('name = "caf\u00e9"\n'.encode("latin-1"))
    with pytest.raises(InputError, match="'utf-8' codec can't decode"):
        load_rig_config(latin)


# --- gamma from the gamma command's report ----------------------------------------------------
def gamma_json(folder: Path, **fits: dict[str, Any]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "gamma.json"
    path.write_text(json.dumps({"source": "caps", **fits, "warnings": []}))
    return path


def test_gamma_from_the_gamma_commands_report(tmp_path: Path) -> None:
    good = {"gamma": 2.41, "degenerate": False}
    gamma_json(tmp_path / "g", uniform=good, fringes={"gamma": 2.6, "degenerate": False})
    cfg = load_rig_config(write(tmp_path, 'gamma = "g/gamma.json"\n'))  # relative to the file
    assert cfg.gamma == 2.41 and cfg.gamma_file == str(tmp_path / "g" / "gamma.json")
    assert cfg.to_record()["gamma_file"] == cfg.gamma_file
    # written back as the file, relative to the new configuration's folder
    out = write_rig_config(tmp_path / "sub" / "rig.toml", cfg)
    assert tomllib.loads(out.read_text())["gamma"] == "../g/gamma.json"
    assert load_rig_config(out).gamma == 2.41
    # a degenerate uniform fit gives way to the fringe fit; neither usable: refused
    bad = gamma_json(tmp_path / "d", uniform={"gamma": 9.0, "degenerate": True},
                     fringes={"gamma": 2.6, "degenerate": False})  # fmt: skip
    assert gamma_from_report(bad) == 2.6
    none = gamma_json(tmp_path / "n", uniform={"gamma": 9.0, "degenerate": True})
    with pytest.raises(InputError, match="no usable gamma fit"):
        gamma_from_report(none)
    with pytest.raises(InputError, match=r"gamma: .*gamma file does not exist"):
        load_rig_config(write(tmp_path, 'gamma = "nowhere/gamma.json"\n'))
    (tmp_path / "t.json").write_text("{not json")
    with pytest.raises(InputError, match=r"gamma: .*not valid JSON"):
        load_rig_config(write(tmp_path, 'gamma = "t.json"\n'))


# --- devices from a configuration -------------------------------------------------------------
def test_a_folder_projector_takes_the_configured_size_and_is_checked(tmp_path: Path) -> None:
    cfg = RigConfig.from_dict(
        {"projector": {"spec": f"folder:{tmp_path / 'a'}", "width": 64, "height": 48}}
    )
    with cfg.projector_device() as projector:
        assert projector.size == (64, 48)
    wrong = RigConfig.from_dict(
        {"projector": {"spec": f"folder:{tmp_path / 'b'}@32x24", "width": 64, "height": 48}},
        source="lab.toml",
    )
    device = wrong.projector_device()
    assert isinstance(device, CheckedSizeProjector)
    with pytest.raises(InputError, match=r"is 32x24 but lab\.toml expects 64x48"):
        device.open()


def test_the_trigger_line_reaches_the_camera_and_is_refused_without_one() -> None:
    cfg = RigConfig.from_dict({"camera": {"spec": "pylon:emu", "trigger_line": "Line3"}})
    assert cfg.camera_device().trigger_line == "Line3"  # type: ignore[attr-defined]
    uvc = RigConfig.from_dict({"camera": {"spec": "opencv:0", "trigger_line": "Line1"}})
    with pytest.raises(InputError, match="no hardware trigger input"):
        uvc.camera_device()


# --- the commands: the file, and options given on the command line override it ----------------
class Stop(HdrFringeError):
    """Raised by the fake rig builder once it has recorded its arguments."""


@pytest.fixture
def built(monkeypatch: pytest.MonkeyPatch) -> list[tuple]:
    """Every call of tasks.capture.hardware_options (positional, as the commands make it)."""
    from hdrfringe.tasks import capture

    calls: list[tuple] = []

    def record(*args: Any) -> Any:
        calls.append(args)
        raise Stop("recorded")

    monkeypatch.setattr(capture, "hardware_options", record)
    return calls


def invoke(*args: str) -> Any:
    from hdrfringe.cli import app

    return CliRunner().invoke(app, list(args))


CFG = """name = "bench"
gamma = 2.2
[projector]
spec = "screen:1"
[camera]
spec = "pylon:emu"
exposure_ms = 20
[sync]
settle_s = 0.05
discard = 2
"""


@pytest.mark.parametrize("command", [["capture"], ["measure", "--rig", "hardware"]])
def test_options_given_override_the_file_and_defaults_do_not(
    command: list[str], built: list[tuple], tmp_path: Path
) -> None:
    cfg = write(tmp_path, CFG)
    out = str(tmp_path / "out")
    r = invoke(*command, "--rig-config", str(cfg), "-o", out)
    assert r.exit_code == 2 and "recorded" in r.stderr
    projector, camera, sync, settle, discard, max_grabs, gamma, exposure, gain, fmt, config = built[
        -1
    ]
    assert (projector, camera, settle, discard, gamma, exposure) == (
        "screen:1", "pylon:emu", 0.05, 2, 2.2, 20.0,
    )  # fmt: skip
    assert (sync, max_grabs, gain, fmt) == ("software", 5, None, None)
    assert config.source == str(cfg) and config.name == "bench"
    # given on the command line, even at the option's default value: the option wins
    r = invoke(*command, "--rig-config", str(cfg), "--settle", "0.1", "--discard", "0",
               "--gamma", "2.812", "--camera", "pylon:other", "-o", out)  # fmt: skip
    assert r.exit_code == 2 and "recorded" in r.stderr
    _, camera, _, settle, discard, _, gamma, exposure, *_ = built[-1]
    assert (camera, settle, discard, gamma, exposure) == ("pylon:other", 0.1, 0, 2.812, 20.0)
    assert not (tmp_path / "out").exists()


def test_the_merge_takes_the_options_given_from_python(tmp_path: Path) -> None:
    """tasks.capture.resolve_rig_config needs no typer.Context: a Python caller names the
    options it sets. The same values as the command line's: an option not named loses to the
    file (even away from its default), one named wins (even at its default), and a key the
    file leaves out takes the option's value either way. A merge that ignored ``given`` (the
    options always, or the file always) fails one of the two calls."""
    from hdrfringe.tasks.capture import resolve_rig_config

    cfg = write(tmp_path, CFG)
    options = {"settle": 0.3, "discard": 0, "camera": "pylon:other", "gain_db": 6.0}
    config = resolve_rig_config(cfg, set(), **options)
    assert (config.sync.settle_s, config.sync.discard, config.camera.spec) == (
        0.05, 2, "pylon:emu",
    )  # fmt: skip
    assert config.camera.gain_db == 6.0 and config.source == str(cfg)  # the file has none
    config = resolve_rig_config(cfg, {"settle", "discard"}, **options)
    assert (config.sync.settle_s, config.sync.discard, config.camera.spec) == (
        0.3, 0, "pylon:emu",
    )  # fmt: skip


def test_without_a_file_the_options_and_their_defaults_apply(built: list[tuple]) -> None:
    r = invoke("capture", "--projector", "screen:0", "--camera", "pylon:emu", "-o", "never")
    assert r.exit_code == 2 and "recorded" in r.stderr
    assert built[-1][:10] == ("screen:0", "pylon:emu", "software", 0.1, 0, 5, 2.812, None, None,
                              None)  # fmt: skip
    assert built[-1][10].source is None


@pytest.mark.parametrize(
    ("args", "reason"),
    [
        (["--settle", "nan"], "--settle must be a number of seconds in 0..3600, got nan"),
        (["--exposure-ms", "-1"], "--exposure-ms must be a positive number of milliseconds"),
        (["--pixel-format", "RGB8"], "--pixel-format must be one of Mono8"),
        (["--gamma", "0"], "--gamma must be a positive number"),
        (["--discard", "-2"], "--discard must be an integer in 0..1000000, got -2"),
    ],
)
def test_bad_options_are_named_as_options(args: list[str], reason: str, tmp_path: Path) -> None:
    r = invoke("capture", "--projector", "screen:0", "--camera", "pylon:emu", *args,
               "-o", str(tmp_path / "out"))  # fmt: skip
    assert r.exit_code == 2 and reason in " ".join(r.stderr.split()), r.stderr
    assert r.stderr.count("error:") == 1 and not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("args", "reason"),
    [
        (["--rig", "laser"], "unknown rig 'laser'; use --rig sim (the virtual rig) or --rig hard"),
        (["--rig", "hardware"], "give both --projector SPEC and --camera SPEC, or a --rig-config"),
        (["{caps}", "--camera", "pylon:emu"], "--camera only applies to --rig hardware"),
        (["--rig", "sim", "--settle", "0.2"], "--settle only applies to --rig hardware"),
        (["--rig", "hardware", "--scene", "plate", "--camera", "pylon:emu"],
         "--scene only applies to the live virtual rig (--rig sim)"),
        ([], "no source: give a capture FOLDER or --rig sim (live virtual rig) or --rig hardware"),
        (["--rig", "hardware", "--rig-config", "{tmp}/none.toml"],
         "rig configuration file does not exist"),
        (["--rig", "hardware", "--rig-config", "{tmp}/rig.toml", "-o", "{tmp}/rig.toml", "--force"],
         "output is the input"),
    ],
)  # fmt: skip
def test_measure_sources_and_hardware_options(args: list[str], reason: str, tmp_path: Path) -> None:
    write(tmp_path, CFG)
    (tmp_path / "caps").mkdir()
    fill = {"tmp": str(tmp_path), "caps": str(tmp_path / "caps")}
    argv = [a.format(**fill) for a in args]
    if "-o" not in argv:
        argv += ["-o", str(tmp_path / "out")]
    before = sorted(p.name for p in tmp_path.iterdir())
    r = invoke("measure", *argv)
    assert r.exit_code == 2 and reason in " ".join(r.stderr.split()), r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == before


# --- measure --rig hardware on a fake rig: a complete run, and Ctrl-C mid-capture -------------
class _Screen:
    """A projector that only counts frames (64x48)."""

    def __init__(self) -> None:
        self.frame_counter = 0

    size = (64, 48)

    def open(self) -> None:
        self.frame_counter = 0

    def close(self) -> None:
        pass

    def __enter__(self) -> _Screen:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def show(self, image: Any) -> int:
        self.frame_counter += 1
        self.image = image
        return self.frame_counter


def _fake_rig(screen: _Screen, interrupt_at: int) -> Any:
    import numpy as np

    from hdrfringe.hardware.camera import CameraBase
    from hdrfringe.hardware.rig import HardwareRig

    class Camera(CameraBase):  # sees the projected image, Ctrl-C at grab `interrupt_at`
        name = "fake"
        grabs = 0

        def _grab(self, timeout_s: float) -> Any:
            self.grabs += 1
            if self.grabs == interrupt_at:
                raise KeyboardInterrupt
            return (np.asarray(screen.image)[::2, ::2] // 2 + 20).astype(np.uint8)

    sync = SyncSettings(settle_s=0.0, verify=False)
    return HardwareRig(screen, Camera(), sync, gamma_hat=2.812, sleep=lambda s: None)  # type: ignore[arg-type]


@pytest.mark.parametrize("interrupt_at", [10**6, 2 * 7 + 4 + 2])  # open: 2 x (0 + 5 + 2) grabs
def test_measure_hardware_writes_all_or_nothing(
    interrupt_at: int, monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    from hdrfringe.tasks import capture

    monkeypatch.setattr(capture, "hardware_options", lambda *a: _fake_rig(_Screen(), interrupt_at))
    out = tmp_path / "out"
    r = invoke("measure", "--rig", "hardware", "--projector", "fake", "--camera", "fake",
               "--pitch", "1024,64", "--no-centerline", "-o", str(out))  # fmt: skip
    if interrupt_at > 100:  # the fake rig measures: OUT holds the measurement and the captures
        assert r.exit_code == 0, r.stderr
        manifest = json.loads((out / "captures" / "manifest.json").read_text())
        assert len(manifest["frames"]) == 8 and manifest["capture"]["complete"] is True
        assert (out / "captures" / "capture_log.json").is_file()
        assert (out / "unwrapped_phase_vertical.tiff").is_file()
    else:  # Ctrl-C in the second set: nothing written, no staging left, the shell's 130
        assert r.exit_code == 130 and "nothing was written" in r.stderr
        assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_the_recorded_sha256_is_of_the_bytes_parsed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The config's digest comes from the one read that was parsed (a second read could see a
    file changed in between): a reader whose on_bytes is never called, or that hashes a second
    read, gives another digest here, where the file changes right after the parse."""
    import hashlib

    import hdrfringe.io.rig_config as rc

    path = tmp_path / "rig.toml"
    original = b'name = "bench"\n[projector]\nspec = "folder:/tmp/p@64x48"\n'
    path.write_bytes(original)
    real = rc.load_toml_bounded

    def parse_then_change(*args: Any, **kwargs: Any) -> dict[str, Any]:
        table = real(*args, **kwargs)
        path.write_bytes(original + b"# edited meanwhile\n")
        return table

    monkeypatch.setattr(rc, "load_toml_bounded", parse_then_change)
    cfg = rc.load_rig_config(path)
    assert cfg.sha256 == hashlib.sha256(original).hexdigest()
