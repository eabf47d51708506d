"""One table-driven bad-input suite across every command (issue 11, "fuzz suite").

Each case runs the command line on hostile input: bad numbers (nan, inf, huge, negative,
400 digits), bad paths (missing, a file for a folder, output equal to or inside an input),
damaged manifests, images and calibration files, and resource limits. Every case must give
exit code 2, exactly one non-empty stderr line starting with ``error:``, no traceback, and leave
the whole working tree (inputs, existing outputs) byte-identical with nothing new written.
The cases run the CLI's entry point in the test process (``conftest.run_cli_in_process``: the
same ``app()`` call as ``python -m hdrfringe.cli``, with the exit code, an escaping exception's
traceback and warnings reported as the interpreter would; tests/test_cli_runner.py checks that
it agrees with a real process), which saves a new interpreter per case.
The per-class tests (test_output_safety, test_input_limits, test_damaged_inputs,
test_cli_errors) check the messages; this suite checks the contract over every command.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from pathlib import Path

import cv2
import h5py
import imageio.v3 as iio
import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.frames import CenterlineFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.io.calibration_file import save_calibration
from hdrfringe.io.captures import write_capture_folder
from tests.conftest import run_cli_in_process, synthetic_set
from tests.test_damaged_inputs import _synthetic_cal


def _write_caps(path: Path) -> None:
    spec = FringeSpec("sinusoidal", 4, 8.0, "vertical", 40, 255)
    imgs, x = synthetic_set(spec, (30, 40))
    line = np.where(np.abs(x - 20.0) < 0.5, 230, 10).astype(np.uint8)
    write_capture_folder(
        path,
        Captures(
            [*spec.frames(), CenterlineFrame(20.0, "vertical", 255)],
            np.concatenate([imgs, line[None]]),
            8,
            projector=ProjectorInfo(1024, 768, 8, 2.812),
            scene={"depth_mm": 0.0},
        ),
    )


def _manifest_text(folder: Path) -> str:
    return (folder / "manifest.json").read_text()


def _damaged_caps(root: Path, name: str, manifest: str | None = None) -> Path:
    folder = root / name
    _write_caps(folder)
    if manifest is not None:
        (folder / "manifest.json").write_text(manifest)
    return folder


def _first_image(folder: Path) -> Path:
    m = json.loads(_manifest_text(folder))
    return folder / m["frames"][0]["file"]


@pytest.fixture(scope="module")
def root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Every input of the suite, built once: captures (good and damaged), calibrations, files."""
    r = tmp_path_factory.mktemp("fuzz")
    _write_caps(r / "caps")
    good = json.loads(_manifest_text(r / "caps"))

    _damaged_caps(r, "trunc_json", _manifest_text(r / "caps")[:57])
    _damaged_caps(r, "frames_str", json.dumps({**good, "frames": "all of them"}))
    _damaged_caps(r, "bitdepth_str", json.dumps({**good, "camera": {"bit_depth": "eight"}}))
    _damaged_caps(r, "deep", "[" * 200_000 + "]" * 200_000)
    _damaged_caps(
        r,
        "big_int",
        _manifest_text(r / "caps").replace('"bit_depth": 8', '"bit_depth": ' + "9" * 5000, 1),
    )
    _damaged_caps(r, "not_object", "[1, 2, 3]")
    _damaged_caps(r, "empty_json", "")
    trunc = _damaged_caps(r, "trunc_image")
    img = _first_image(trunc)
    img.write_bytes(img.read_bytes()[:40])
    text = _damaged_caps(r, "text_image")
    _first_image(text).write_text("not an image at all\n")
    neg = _damaged_caps(r, "nan_pitch")
    m = json.loads(_manifest_text(neg))
    m["frames"][0]["pitch"] = float("nan")
    (neg / "manifest.json").write_text(json.dumps(m))

    cal = save_calibration(r / "good.h5", _synthetic_cal())
    (r / "trunc.h5").write_bytes(cal.read_bytes()[: cal.stat().st_size // 2])
    (r / "wrong_model.h5").write_bytes(cal.read_bytes())
    with h5py.File(r / "wrong_model.h5", "r+") as f:
        f.attrs["model"] = "quartic"
    (r / "notes.txt").write_text("a file, not a folder\n")
    (r / "existing").mkdir()
    (r / "existing" / "keep.txt").write_text("user data\n")
    (r / "corr.json").write_text('{"order": 3, "coeff')
    _import_inputs(r)
    _version3_manifests(r, good)
    _stereo_inputs(r)
    _rig_config_inputs(r)
    return r


# --- import: a folder of camera images and descriptions that each break one rule ------------
_IMPORT_OK = '[camera]\nbit_depth = 8\n[[fringe]]\nfiles = "s{step}.png"\nsteps = 3\npitch = 16\n'
_GRAY = '[camera]\nbit_depth = 8\n[[graycode]]\nfiles = "gc{bit}.png"\nbits = 3\nstripe = 8\n'
IMPORT_DESCRIPTIONS: dict[str, str] = {
    "ok": _IMPORT_OK,
    "missing_files": _IMPORT_OK.replace('"s{step}.png"', '["s0.png", "s1.png", "s9.png"]'),
    "shift_count": _IMPORT_OK.replace("steps = 3", "steps = 4\nshifts_deg = [0, 120, 240]"),
    "gray_missing_bit": _GRAY,  # the images folder holds gc0.png and gc2.png only
    "unknown_key": _IMPORT_OK.replace("pitch = 16", "perods = 4"),
    "malformed": _IMPORT_OK.replace("bit_depth = 8", "bit_depth = "),
    "big_int": _IMPORT_OK.replace("bit_depth = 8", "bit_depth = " + "9" * 5000),
    "big_float": _IMPORT_OK.replace("pitch = 16", "pitch = " + "4" * 400 + ".0"),
    "nan_pitch": _IMPORT_OK.replace("pitch = 16", "pitch = nan"),
    "inf_shift": _IMPORT_OK + "shifts_deg = [0, inf, 240]\n",
    "huge_steps": _IMPORT_OK.replace("steps = 3", "steps = 100000"),
    "huge_bits": _GRAY.replace("bits = 3", "bits = 1000000"),
    "deep": "a = " + "[" * 100_000 + "]" * 100_000 + "\n",
    "huge_width": _IMPORT_OK.replace("s{step}.png", "s{step:99999999999d}.png"),
}


def _import_inputs(r: Path) -> None:
    spec = FringeSpec("sinusoidal", 3, 16.0, "vertical", 40, 255)
    imgs, _ = synthetic_set(spec, (24, 40))
    cam = r / "imp"
    cam.mkdir()
    for k, img in enumerate(imgs):
        iio.imwrite(cam / f"s{k}.png", img)
    for b in (0, 2):  # bit 1 of a 3-bit code is missing
        iio.imwrite(cam / f"gc{b}.png", imgs[b])
    for name, text in IMPORT_DESCRIPTIONS.items():
        (r / f"imp_{name}.toml").write_text(text)


# --- phase: version-3 manifest fields, each broken one way ------------------------------------
def _version3_manifests(r: Path, good: dict) -> None:
    def edited(name: str, version: int, edit: Callable[[list[dict]], None]) -> None:
        m = json.loads(json.dumps(good))
        m["version"] = version
        edit(m["frames"])
        folder = _damaged_caps(r, name, json.dumps(m))
        if any(f["file"] == "gc.png" for f in m["frames"]):
            (folder / "gc.png").write_bytes(_first_image(r / "caps").read_bytes())

    def fringes(frames: list[dict]) -> list[dict]:
        return [f for f in frames if f["kind"] == "fringe"]

    def shifts(angles: list[float]) -> Callable[[list[dict]], None]:
        def edit(frames: list[dict]) -> None:
            for f, a in zip(fringes(frames), angles, strict=True):
                f["shift_deg"] = a

        return edit

    def mixed_offsets(frames: list[dict]) -> None:
        for f in fringes(frames):
            f["set"] = "a"
        fringes(frames)[0]["phase_offset_deg"] = -90

    def offset(value: object) -> Callable[[list[dict]], None]:
        def edit(frames: list[dict]) -> None:
            for f in fringes(frames):
                f["phase_offset_deg"] = value

        return edit

    def graycode(**fields: object) -> Callable[[list[dict]], None]:
        def edit(frames: list[dict]) -> None:
            entry = {"kind": "graycode", "orientation": "vertical", "bit": 0, "bits": 1}
            frames.append({"file": "gc.png", **entry, "stripe": 8, **fields})

        return edit

    edited("v2_shift_deg", 2, shifts([0, 90, 180, 270]))
    edited("v3_duplicate_shifts", 3, shifts([0, 90, 90, 270]))
    edited("v3_nan_shift", 3, shifts([0, float("nan"), 180, 270]))
    edited("v3_huge_shift", 3, shifts([0, 90, 180, 1e308]))
    edited("v3_mixed_offsets", 3, mixed_offsets)
    edited("v3_inf_offset", 3, offset(float("inf")))
    edited("v3_big_offset", 3, offset(int("4" * 400)))
    edited("v3_gray_bits_0", 3, graycode(bits=0))
    edited("v3_gray_bit_ge_bits", 3, graycode(bit=1))
    edited("v3_gray_unknown_code", 3, graycode(code="ternary"))
    edited("v3_gray_huge_bits", 3, graycode(bits=10**9, bit=10**9 - 1))


# --- calibrate-stereo: calibration files and pose folders -------------------------------------
def _filestorage(path: Path, **values: object) -> None:
    base: dict[str, object] = {
        "cam_K": np.array([[1000.0, 0, 320], [0, 1000, 240], [0, 0, 1]]),
        "proj_K": np.array([[1500.0, 0, 456], [0, 1500, 570], [0, 0, 1]]),
        "cam_kc": np.zeros((1, 5)),
        "proj_kc": np.zeros((1, 5)),
        "R": np.eye(3),
        "T": np.array([[-150.0], [0], [0]]),
        "image_width": 640,
        "image_height": 480,
        "proj_width": 912,
        "proj_height": 1140,
    }
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for key, value in {**base, **values}.items():
        fs.write(key, value)
    fs.release()


def _stereo_inputs(r: Path) -> None:
    _filestorage(r / "cal_ok.yml")
    _filestorage(r / "cal_shape.yml", cam_K=np.eye(2))
    _filestorage(r / "cal_nan.yml", proj_K=np.full((3, 3), np.nan))
    _filestorage(r / "cal_inf_t.yml", T=np.array([[np.inf], [0], [0]]))
    _filestorage(r / "cal_not_rotation.yml", R=2 * np.eye(3))
    _filestorage(r / "cal_mirror.yml", R=np.diag([1.0, 1.0, -1.0]))
    np.savez(
        r / "cal_shape.npz",
        **{"Kc": np.eye(3), "dist_c": np.zeros(5), "Kp": np.eye(4), "dist_p": np.zeros(5)},
        **{"R": np.eye(3), "T": np.array([0.15, 0, 0])},
    )
    (r / "cal_garbage.yml").write_text("%YAML:1.0\n---\ncam_K: [1, 2\n  ::: {\n")
    (r / "cal.unknown").write_text("K = 1 0 0\n")
    (r / "cal_text").mkdir()  # kimthyung's plain-text layout, one matrix not numbers
    for name, text in {
        "CamIntrinsicMatrixRight": "1000 0 320\n0 1000 240\n0 0 1\n",
        "CamDistortionCoefficientsRight": "0 0 0 0 0\n",
        "ProjIntrinsicMatrix": "fx 0 cx\n0 fy cy\n0 0 1\n",
        "ProjDistortionCoefficients": "0 0 0 0 0\n",
        "ProjRotationMatrix": "1 0 0\n0 1 0\n0 0 1\n",
        "ProjTranslationVector": "100 0 0\n",
    }.items():
        (r / "cal_text" / f"{name}.txt").write_text(text)
    (r / "cal_empty").mkdir()
    for name in ("pose_a", "pose_b", "pose_c"):  # no board anywhere in them
        _write_caps(r / name)


# --- measure --rig hardware: rig configuration files that each break one rule ----------------
_RIG_OK = '[projector]\nspec = "screen:0"\n[camera]\nspec = "pylon:emu"\n[sync]\ndiscard = 1\n'
RIG_CONFIGS: dict[str, str] = {
    "ok": _RIG_OK,
    "unknown_key": _RIG_OK.replace("discard = 1", "discrad = 1"),
    "bad_type": _RIG_OK.replace("discard = 1", 'discard = "one"'),
    "huge_int": _RIG_OK.replace("discard = 1", "discard = " + "9" * 5000),
    "huge_float": "gamma = 1e999\n" + _RIG_OK,
    "deep": "a = " + "[" * 20_000 + "]" * 20_000 + "\n",  # within the size limit
}


def _rig_config_inputs(r: Path) -> None:
    for name, text in RIG_CONFIGS.items():
        (r / f"rig_{name}.toml").write_text(text)
    (r / "rig_latin1.toml").write_bytes('name = "caf\u00e9"\n'.encode("latin-1"))


def _hw(config: str, *args: str) -> list[str]:
    """``measure --rig hardware`` with the rig configuration ``config``."""
    return ["measure", "--rig", "hardware", "--rig-config", config, *args, "-o", "{o}"]


def _live(command: str, config: str, *, out: str = "{o}", force: bool = False) -> list[str]:
    """A live hardware command (``capture``, ``rig check``, ...) with the rig configuration
    ``config``: the file is refused before any device opens."""
    return [*command.split(), "--rig-config", config, "-o", out] + ["--force"] * force


def _tree(root: Path) -> dict[str, str]:
    """Every path under root (folders too) with the SHA-256 of each file's bytes."""
    return {
        str(p.relative_to(root)): (
            hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        )
        for p in sorted(root.rglob("*"))
    }


def _imp(name: str, *, out: str = "{o}", force: bool = False) -> list[str]:
    """``import`` of the images folder with description ``imp_<name>.toml``."""
    return ["import", "{r}/imp", "-d", f"{{r}}/imp_{name}.toml", "-o", out] + ["--force"] * force


_POSES = ("{r}/pose_a", "{r}/pose_b", "{r}/pose_c")


def _cs(*args: str, out: str = "{r}/s.h5", force: bool = False) -> list[str]:
    """``calibrate-stereo`` with the given arguments writing ``out``."""
    return ["calibrate-stereo", *args, "-o", out] + ["--force"] * force


N400 = "4" * 400
# (id, argv); "{r}" is the suite's input folder, "{o}" a fresh output path inside it.
# Cases with a third element must also name their reason: the error line contains that text
# (so each fails on purpose for the one reason it was written for, not an earlier one).
CASES: list[tuple[str, list[str]] | tuple[str, list[str], str]] = [
    # --- patterns -----------------------------------------------------------------------
    ("patterns-steps-2", ["patterns", "-o", "{o}", "--steps", "2"]),
    ("patterns-steps-huge", ["patterns", "-o", "{o}", "--steps", "100000"]),
    ("patterns-pitch-nan", ["patterns", "-o", "{o}", "--pitch", "nan"]),
    ("patterns-pitch-inf", ["patterns", "-o", "{o}", "--pitch", "inf"]),
    ("patterns-pitch-negative", ["patterns", "-o", "{o}", "--pitch", "-8"]),
    ("patterns-pitch-400-digits", ["patterns", "-o", "{o}", "--pitch", N400]),
    ("patterns-width-huge", ["patterns", "-o", "{o}", "--width", "1000000", "--height", "1000000"]),
    ("patterns-width-negative", ["patterns", "-o", "{o}", "--width", "-5"]),
    ("patterns-migl-nan", ["patterns", "-o", "{o}", "--migl", "nan"]),
    ("patterns-gamma-inf", ["patterns", "-o", "{o}", "--gamma", "inf"]),
    ("patterns-bit-depth-0", ["patterns", "-o", "{o}", "--bit-depth", "0"]),
    ("patterns-out-is-file", ["patterns", "-o", "{r}/notes.txt"]),
    ("patterns-out-existing", ["patterns", "-o", "{r}/existing"]),
    ("patterns-parent-is-file", ["patterns", "-o", "{r}/notes.txt/pat"]),
    # --- simulate -----------------------------------------------------------------------
    ("simulate-unknown-scene", ["simulate", "moon", "-o", "{o}"]),
    ("simulate-steps-huge", ["simulate", "white_plate", "-o", "{o}", "--steps", "1001"]),
    ("simulate-series-huge", ["simulate", "white_plate", "-o", "{o}", "--series", "0:1e9:1"]),
    (
        "simulate-sweep-tiny-step",
        ["simulate", "white_plate", "-o", "{o}", "--migl-sweep", "255:0:1e-6"],
    ),
    ("simulate-pitch-400-digits", ["simulate", "white_plate", "-o", "{o}", "--pitch", N400]),
    ("simulate-migl-nan", ["simulate", "white_plate", "-o", "{o}", "--migl", "nan"]),
    ("simulate-depth-inf", ["simulate", "plate", "-o", "{o}", "--depth-mm", "inf"]),
    ("simulate-noise-negative", ["simulate", "white_plate", "-o", "{o}", "--noise", "-1"]),
    ("simulate-seed-negative", ["simulate", "white_plate", "-o", "{o}", "--seed", "-1"]),
    ("simulate-bit-depth-99", ["simulate", "white_plate", "-o", "{o}", "--bit-depth", "99"]),
    ("simulate-out-existing", ["simulate", "white_plate", "-o", "{r}/existing"]),
    # --- modify -------------------------------------------------------------------------
    ("modify-missing-folder", ["modify", "{r}/nowhere", "-o", "{o}", "--noise", "1"]),
    ("modify-folder-is-file", ["modify", "{r}/notes.txt", "-o", "{o}", "--noise", "1"]),
    (
        "modify-out-equals-input",
        ["modify", "{r}/caps", "-o", "{r}/caps", "--force", "--noise", "1"],
    ),
    ("modify-out-inside-input", ["modify", "{r}/caps", "-o", "{r}/caps/m", "--noise", "1"]),
    ("modify-seed-negative", ["modify", "{r}/caps", "-o", "{o}", "--seed", "-1", "--noise", "1"]),
    ("modify-noise-nan", ["modify", "{r}/caps", "-o", "{o}", "--noise", "nan"]),
    ("modify-add-dn-inf", ["modify", "{r}/caps", "-o", "{o}", "--add-dn", "inf"]),
    ("modify-truncated-manifest", ["modify", "{r}/trunc_json", "-o", "{o}", "--noise", "1"]),
    # --- gamma --------------------------------------------------------------------------
    ("gamma-missing-folder", ["gamma", "{r}/nowhere", "-o", "{o}"]),
    ("gamma-deep-nesting", ["gamma", "{r}/deep", "-o", "{o}"]),
    ("gamma-text-image", ["gamma", "{r}/text_image", "-o", "{o}"]),
    ("gamma-out-inside-input", ["gamma", "{r}/caps", "-o", "{r}/caps/g"]),
    # --- phase --------------------------------------------------------------------------
    ("phase-missing-folder", ["phase", "{r}/nowhere", "-o", "{o}"]),
    ("phase-folder-is-file", ["phase", "{r}/notes.txt", "-o", "{o}"]),
    ("phase-out-equals-input", ["phase", "{r}/caps", "-o", "{r}/caps", "--force"]),
    ("phase-out-inside-input", ["phase", "{r}/caps", "-o", "{r}/caps/out"]),
    ("phase-out-existing", ["phase", "{r}/caps", "-o", "{r}/existing"]),
    ("phase-min-modulation-nan", ["phase", "{r}/caps", "-o", "{o}", "--min-modulation", "nan"]),
    ("phase-min-modulation-negative", ["phase", "{r}/caps", "-o", "{o}", "--min-modulation", "-3"]),
    ("phase-truncated-manifest", ["phase", "{r}/trunc_json", "-o", "{o}"]),
    ("phase-empty-manifest", ["phase", "{r}/empty_json", "-o", "{o}"]),
    ("phase-manifest-not-object", ["phase", "{r}/not_object", "-o", "{o}"]),
    ("phase-frames-wrong-type", ["phase", "{r}/frames_str", "-o", "{o}"]),
    ("phase-bit-depth-wrong-type", ["phase", "{r}/bitdepth_str", "-o", "{o}"]),
    ("phase-deep-nesting", ["phase", "{r}/deep", "-o", "{o}"]),
    ("phase-5000-digit-int", ["phase", "{r}/big_int", "-o", "{o}"]),
    ("phase-nan-pitch", ["phase", "{r}/nan_pitch", "-o", "{o}"]),
    ("phase-truncated-image", ["phase", "{r}/trunc_image", "-o", "{o}"]),
    ("phase-text-image", ["phase", "{r}/text_image", "-o", "{o}"]),
    # --- calibrate ----------------------------------------------------------------------
    ("calibrate-missing-folder", ["calibrate", "{r}/nowhere", "-o", "{r}/c.h5"]),
    ("calibrate-window-huge", ["calibrate", "{r}/caps", "-o", "{r}/c.h5", "--window", "100001"]),
    ("calibrate-window-negative", ["calibrate", "{r}/caps", "-o", "{r}/c.h5", "--window", "-1"]),
    ("calibrate-border-400-digits", ["calibrate", "{r}/caps", "-o", "{r}/c.h5", "--border", N400]),
    ("calibrate-unknown-model", ["calibrate", "{r}/caps", "-o", "{r}/c.h5", "--model", "quartic"]),
    ("calibrate-out-existing", ["calibrate", "{r}/caps", "-o", "{r}/good.h5"]),
    ("calibrate-out-inside-input", ["calibrate", "{r}/caps", "-o", "{r}/caps/c.h5"]),
    ("calibrate-truncated-manifest", ["calibrate", "{r}/trunc_json", "{r}/caps", "-o", "{r}/c.h5"]),
    # --- measure (folder) ---------------------------------------------------------------
    ("measure-missing-calibration", ["measure", "{r}/caps", "-c", "{r}/none.h5", "-o", "{o}"]),
    ("measure-truncated-calibration", ["measure", "{r}/caps", "-c", "{r}/trunc.h5", "-o", "{o}"]),
    ("measure-wrong-model-attr", ["measure", "{r}/caps", "-c", "{r}/wrong_model.h5", "-o", "{o}"]),
    ("measure-calibration-not-hdf5", ["measure", "{r}/caps", "-c", "{r}/notes.txt", "-o", "{o}"]),
    (
        "measure-calibration-is-output",
        ["measure", "{r}/caps", "-c", "{r}/good.h5", "-o", "{r}/good.h5", "--force"],
    ),
    (
        "measure-out-equals-input",
        ["measure", "{r}/caps", "-c", "{r}/good.h5", "-o", "{r}/caps", "--force"],
    ),
    ("measure-missing-folder", ["measure", "{r}/nowhere", "-c", "{r}/good.h5", "-o", "{o}"]),
    ("measure-deep-nesting", ["measure", "{r}/deep", "-c", "{r}/good.h5", "-o", "{o}"]),
    (
        "measure-unknown-method",
        ["measure", "{r}/caps", "-c", "{r}/good.h5", "-o", "{o}", "--strategy", "magic"],
    ),
    (
        "measure-tolerance-nan",
        [
            "measure",
            "{r}/caps",
            "-c",
            "{r}/good.h5",
            "-o",
            "{o}",
            "--strategy",
            "uniform",
            "--tolerance",
            "nan",
        ],
    ),
    (
        "measure-option-of-another-method",
        ["measure", "{r}/caps", "-c", "{r}/good.h5", "-o", "{o}", "--tolerance", "nan"],
    ),
    # --- measure --rig sim --------------------------------------------------------------
    ("measure-rig-unknown", ["measure", "--rig", "laser", "-c", "{r}/good.h5", "-o", "{o}"]),
    (
        "measure-rig-steps-huge",
        ["measure", "--rig", "sim", "-c", "{r}/good.h5", "-o", "{o}", "--steps", "100000"],
    ),
    (
        "measure-rig-pitch-inf",
        ["measure", "--rig", "sim", "-c", "{r}/good.h5", "-o", "{o}", "--pitch", "inf"],
    ),
    (
        "measure-rig-seed-negative",
        ["measure", "--rig", "sim", "-c", "{r}/good.h5", "-o", "{o}", "--seed", "-1"],
    ),
    (
        "measure-rig-and-folder",
        ["measure", "{r}/caps", "--rig", "sim", "-c", "{r}/good.h5", "-o", "{o}"],
    ),
    (
        "measure-rig-truncated-calibration",
        ["measure", "--rig", "sim", "-c", "{r}/trunc.h5", "-o", "{o}"],
    ),
    # --- train-correction ---------------------------------------------------------------
    ("train-missing-folder", ["train-correction", "{r}/nowhere", "-o", "{r}/k.json"]),
    (
        "train-order-negative",
        ["train-correction", "--rig", "sim", "-o", "{r}/k.json", "--order", "-1"],
    ),
    (
        "train-order-huge",
        ["train-correction", "--rig", "sim", "-o", "{r}/k.json", "--order", "9" * 400],
    ),
    ("train-pitch-nan", ["train-correction", "--rig", "sim", "-o", "{r}/k.json", "--pitch", "nan"]),
    (
        "train-unknown-truth",
        ["train-correction", "--rig", "sim", "-o", "{r}/k.json", "--truth", "oracle"],
    ),
    ("train-out-existing", ["train-correction", "--rig", "sim", "-o", "{r}/corr.json"]),
    ("train-out-inside-input", ["train-correction", "{r}/caps", "-o", "{r}/caps/k.json"]),
    ("train-truncated-manifest", ["train-correction", "{r}/trunc_json", "-o", "{r}/k.json"]),
    # --- demo ---------------------------------------------------------------------------
    ("demo-out-is-file", ["demo", "-o", "{r}/notes.txt"]),
    ("demo-out-existing", ["demo", "-o", "{r}/existing"]),
    ("demo-seed-negative", ["demo", "-o", "{o}", "--seed", "-1"]),
    # --- import -------------------------------------------------------------------------
    ("import-files-do-not-exist", _imp("missing_files"), "'s9.png' does not exist"),
    ("import-inconsistent-shift-count", _imp("shift_count"), "shifts_deg lists 3 angles"),
    ("import-graycode-missing-bit", _imp("gray_missing_bit"), "graycode vertical bit 1"),
    ("import-unknown-key", _imp("unknown_key"), "unknown key 'perods'"),
    ("import-malformed-toml", _imp("malformed"), "not a valid TOML description"),
    ("import-5000-digit-int", _imp("big_int"), "too many digits"),
    ("import-400-digit-pitch", _imp("big_float"), "'pitch' must be a finite number, got inf"),
    ("import-nan-pitch", _imp("nan_pitch"), "'pitch' must be a finite number, got nan"),
    ("import-inf-shift", _imp("inf_shift"), "'shifts_deg' must be a finite number, got inf"),
    ("import-steps-huge", _imp("huge_steps"), "'steps' must be an integer in 3..1000, got 100000"),
    ("import-bits-huge", _imp("huge_bits"), "'bits' must be an integer in 1..24, got 1000000"),
    ("import-deep-nesting", _imp("deep"), "nested too deep"),
    ("import-format-width-huge", _imp("huge_width"), "bad format spec '99999999999d'"),
    ("import-out-inside-input", _imp("ok", out="{r}/imp/caps"), "output is inside the input"),
    ("import-out-equals-input", _imp("ok", out="{r}/imp", force=True), "output is the input"),
    (
        "import-out-is-description",
        _imp("ok", out="{r}/imp_ok.toml", force=True),
        "output is the input",
    ),
    ("import-out-existing", _imp("ok", out="{r}/existing"), "exists and is not empty"),
    (
        "import-missing-images",
        ["import", "{r}/nowhere", "-d", "{r}/imp_ok.toml", "-o", "{o}"],
        "images folder does not exist",
    ),
    (
        "import-missing-description",
        ["import", "{r}/imp", "-d", "{r}/none.toml", "-o", "{o}"],
        "description file does not exist",
    ),
    # --- phase on version-3 manifests ---------------------------------------------------
    (
        "phase-v2-shift-deg",
        ["phase", "{r}/v2_shift_deg", "-o", "{o}"],
        "needs capture format version 3",
    ),
    (
        "phase-v3-duplicate-shifts",
        ["phase", "{r}/v3_duplicate_shifts", "-o", "{o}"],
        "repeats an angle",
    ),
    (
        "phase-v3-nan-shift",
        ["phase", "{r}/v3_nan_shift", "-o", "{o}"],
        "'shift_deg' must be a finite number, got nan",
    ),
    (
        "phase-v3-huge-shift",
        ["phase", "{r}/v3_huge_shift", "-o", "{o}"],
        "shifts_deg must hold finite angles within +-1e+06 degrees",
    ),
    (
        "phase-v3-mixed-offsets",
        ["phase", "{r}/v3_mixed_offsets", "-o", "{o}"],
        "must agree on the offset",
    ),
    (
        "phase-v3-inf-offset",
        ["phase", "{r}/v3_inf_offset", "-o", "{o}"],
        "'phase_offset_deg' must be a finite number, got inf",
    ),
    (
        "phase-v3-400-digit-offset",
        ["phase", "{r}/v3_big_offset", "-o", "{o}"],
        "phase_offset_deg' holds a number of 400 characters",
    ),
    (
        "phase-v3-graycode-bits-0",
        ["phase", "{r}/v3_gray_bits_0", "-o", "{o}"],
        "'bits' must be an integer in 1..24, got 0",
    ),
    (
        "phase-v3-graycode-bit-ge-bits",
        ["phase", "{r}/v3_gray_bit_ge_bits", "-o", "{o}"],
        "'bit' must be an integer in 0..0, got 1",
    ),
    (
        "phase-v3-graycode-unknown-code",
        ["phase", "{r}/v3_gray_unknown_code", "-o", "{o}"],
        "unknown code 'ternary'",
    ),
    (
        "phase-v3-graycode-huge-bits",
        ["phase", "{r}/v3_gray_huge_bits", "-o", "{o}"],
        "'bits' must be an integer in 1..24, got 1000000000",
    ),
    # --- measure --rig hardware: the rig configuration ---------------------------------
    ("measure-hw-config-unknown-key", _hw("{r}/rig_unknown_key.toml"), "'sync.discrad'"),
    (
        "measure-hw-config-bad-type",
        _hw("{r}/rig_bad_type.toml"),
        "'sync.discard' must be an integer in 0..1000000, got 'one'",
    ),
    ("measure-hw-config-5000-digit-int", _hw("{r}/rig_huge_int.toml"), "too many digits"),
    (
        "measure-hw-config-huge-float",
        _hw("{r}/rig_huge_float.toml"),
        "'gamma' must be a positive number (the pre-compensation exponent, e.g. 2.2), got inf",
    ),
    ("measure-hw-config-deep-nesting", _hw("{r}/rig_deep.toml"), "nested too deep"),
    ("measure-hw-config-missing", _hw("{r}/none.toml"), "rig configuration file does not exist"),
    ("measure-hw-config-is-folder", _hw("{r}/existing"), "is a folder, not a rig configuration"),
    ("measure-hw-config-not-utf8", _hw("{r}/rig_latin1.toml"), "'utf-8' codec can't decode"),
    (
        "measure-hw-settle-nan",
        _hw("{r}/rig_ok.toml", "--settle", "nan"),
        "--settle must be a number of seconds in 0..3600, got nan",
    ),
    (
        "measure-hw-out-is-config",
        [
            "measure",
            "--rig",
            "hardware",
            "--rig-config",
            "{r}/rig_ok.toml",
            "-o",
            "{r}/rig_ok.toml",
            "--force",
        ],
        "output is the input",
    ),
    (
        "measure-hw-scene-option",
        _hw("{r}/rig_ok.toml", "--scene", "plate"),
        "--scene only applies to the live virtual rig (--rig sim)",
    ),
    # --- the other hardware commands: the same rig configuration, refused the same way ----
    (
        "capture-config-bad-type",
        _live("capture", "{r}/rig_bad_type.toml"),
        "'sync.discard' must be an integer in 0..1000000, got 'one'",
    ),
    (
        "rig-check-config-unknown-key",
        _live("rig check", "{r}/rig_unknown_key.toml"),
        "unknown key 'sync.discrad'; did you mean 'discard'?",
    ),
    (
        "capture-gamma-config-huge-float",
        _live("capture-gamma", "{r}/rig_huge_float.toml"),
        "'gamma' must be a positive number (the pre-compensation exponent, e.g. 2.2), got inf",
    ),
    (
        "capture-gamma-out-is-config",
        _live("capture-gamma", "{r}/rig_ok.toml", out="{r}/rig_ok.toml", force=True),
        "output is the input",
    ),
    (
        "capture-poses-config-deep-nesting",
        _live("capture-poses", "{r}/rig_deep.toml"),
        "nested too deep",
    ),
    (
        "capture-poses-out-is-config",
        _live("capture-poses", "{r}/rig_ok.toml", out="{r}/rig_ok.toml", force=True),
        "output is the input",
    ),
    # --- calibrate-stereo ---------------------------------------------------------------
    ("stereo-from-wrong-shape", _cs("--from", "{r}/cal_shape.yml"), "(3, 3)"),
    ("stereo-from-npz-wrong-shape", _cs("--from", "{r}/cal_shape.npz"), "'Kp' has shape (4, 4)"),
    ("stereo-from-nan-matrix", _cs("--from", "{r}/cal_nan.yml"), "'proj_K' holds NaN or infinite"),
    (
        "stereo-from-inf-translation",
        _cs("--from", "{r}/cal_inf_t.yml"),
        "'T' holds NaN or infinite",
    ),
    ("stereo-from-not-rotation", _cs("--from", "{r}/cal_not_rotation.yml"), "not a rotation"),
    ("stereo-from-reflection", _cs("--from", "{r}/cal_mirror.yml"), "not a rotation"),
    ("stereo-from-missing", _cs("--from", "{r}/none.yml"), "none.yml: not found"),
    (
        "stereo-from-unknown-format",
        _cs("--from", "{r}/cal.unknown"),
        "unknown calibration format '.unknown'",
    ),
    ("stereo-from-garbage-yml", _cs("--from", "{r}/cal_garbage.yml"), "cal_garbage.yml"),
    (
        "stereo-from-text-not-numbers",
        _cs("--from", "{r}/cal_text"),
        "ProjIntrinsicMatrix.txt: not a matrix of numbers",
    ),
    ("stereo-from-empty-folder", _cs("--from", "{r}/cal_empty"), "a folder with neither"),
    ("stereo-from-height-calibration", _cs("--from", "{r}/good.h5"), "not a stereo one"),
    (
        "stereo-from-camera-size-0",
        _cs("--from", "{r}/cal_ok.yml", "--camera-size", "0x480"),
        "--camera-size",
    ),
    (
        "stereo-out-equals-from",
        _cs("--from", "{r}/cal_ok.yml", out="{r}/cal_ok.yml", force=True),
        "output is the input",
    ),
    (
        "stereo-out-existing",
        _cs("--from", "{r}/cal_ok.yml", out="{r}/good.h5"),
        "calibration file exists",
    ),
    (
        "stereo-out-inside-pose",
        _cs(*_POSES, "--board", "checkerboard:9x6:25", out="{r}/pose_a/s.h5"),
        "output is inside the input",
    ),
    (
        "stereo-board-does-not-parse",
        _cs(*_POSES, "--board", "checkerboard:9by6:25"),
        "PATTERN:COLSxROWS",
    ),
    (
        "stereo-board-5000-digit-cols",
        _cs(*_POSES, "--board", "checkerboard:" + "9" * 5000 + "x6:25"),
        "board cols must be a whole number 2..100",
    ),
    (
        "stereo-board-spacing-inf",
        _cs(*_POSES, "--board", "checkerboard:9x6:1e999"),
        "spacing must be a positive number",
    ),
    (
        "stereo-board-not-detected",
        _cs(*_POSES, "--board", "checkerboard:9x6:25"),
        "not found in any",
    ),
    ("stereo-fewer-poses", _cs(*_POSES[:2], "--board", "checkerboard:9x6:25"), "at least 3"),
    (
        "stereo-pose-missing",
        _cs(*_POSES[:2], "{r}/nowhere", "--board", "checkerboard:9x6:25"),
        "nowhere: not a folder",
    ),
    (
        "stereo-pose-damaged",
        _cs(*_POSES[:2], "{r}/trunc_json", "--board", "checkerboard:9x6:25"),
        "trunc_json/manifest.json: not valid JSON",
    ),
    ("stereo-no-source", _cs("--board", "checkerboard:9x6:25"), "exactly one source"),
    ("stereo-two-sources", _cs(*_POSES, "--from", "{r}/cal_ok.yml"), "exactly one source"),
    (
        "stereo-window-0",
        _cs(*_POSES, "--board", "checkerboard:9x6:25", "--window", "0"),
        "--window",
    ),
    (
        "stereo-unknown-distortion",
        _cs(*_POSES, "--board", "checkerboard:9x6:25", "--distortion", "wavy"),
        "--distortion",
    ),
    (
        "stereo-rig-poses-2",
        _cs("--rig", "sim", "--board", "checkerboard:9x6:25", "--poses", "2"),
        "--poses 2",
    ),
    (
        "stereo-rig-poses-huge",
        _cs("--rig", "sim", "--board", "checkerboard:9x6:25", "--poses", "100000"),
        "give 1..100, got 100000",
    ),
    (
        "stereo-rig-noise-nan",
        _cs(
            "--rig",
            "sim",
            "--board",
            "checkerboard:9x6:25",
            "--noise",
            "nan",
        ),
        "read_noise_dn8 must be a finite number",
    ),
    (
        "stereo-rig-seed-negative",
        _cs(
            "--rig",
            "sim",
            "--board",
            "checkerboard:9x6:25",
            "--seed",
            "-1",
        ),
        "seed must be a non-negative integer",
    ),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(root: Path, case: tuple) -> None:
    argv, reason = case[1], (case[2] if len(case) == 3 else None)
    before = _tree(root)
    args = [a.format(r=root, o=root / "out") for a in argv]
    res = run_cli_in_process(*args)  # the CLI's entry point in-process (conftest says how)
    assert res.returncode == 2, (res.returncode, res.stderr[-2000:])
    assert "Traceback" not in res.stderr, res.stderr[-2000:]
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr[-2000:]
    if reason is not None:
        assert reason.format(r=root) in lines[0], lines[0]
    assert _tree(root) == before  # nothing new, nothing removed, every byte the same


def test_suite_covers_every_command() -> None:
    commands = {case[1][0] for case in CASES}
    assert commands == {
        "patterns", "simulate", "modify", "gamma", "phase", "calibrate", "measure",
        "train-correction", "demo", "import", "calibrate-stereo",
        "capture", "rig", "capture-gamma", "capture-poses",  # with a bad rig configuration
    }  # fmt: skip
    # reproduce (the research package's command): research/tests/test_reproduce_errors.py
    assert len(CASES) >= 60 and len({case[0] for case in CASES}) == len(CASES)
    for command in ("import", "calibrate-stereo"):  # issue 12's commands: 8 or more each
        assert sum(case[1][0] == command for case in CASES) >= 8
