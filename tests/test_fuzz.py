"""One table-driven bad-input suite across every command (issue 11, "fuzz suite").

Each case runs the command line on hostile input: bad numbers (nan, inf, huge, negative,
400 digits), bad paths (missing, a file for a folder, output equal to or inside an input),
damaged manifests, images and calibration files, and resource limits. Every case must give
exit code 2, exactly one non-empty stderr line starting with ``error:``, no traceback, and leave
the whole working tree (inputs, existing outputs) byte-identical with nothing new written.
The per-class tests (test_output_safety, test_input_limits, test_damaged_inputs,
test_cli_errors) check the messages; this suite checks the contract over every command.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from hdrfringe.captures import Captures, ProjectorInfo
from hdrfringe.frames import CenterlineFrame
from hdrfringe.io.calibration_file import save_calibration
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.patterns import FringeSpec
from tests.conftest import run_cli, synthetic_set
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
    return r


def _tree(root: Path) -> dict[str, str]:
    """Every path under root (folders too) with the SHA-256 of each file's bytes."""
    return {
        str(p.relative_to(root)): (
            hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        )
        for p in sorted(root.rglob("*"))
    }


N400 = "4" * 400
# (id, argv); "{r}" is the suite's input folder, "{o}" a fresh output path inside it.
CASES: list[tuple[str, list[str]]] = [
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
        ["measure", "{r}/caps", "-c", "{r}/good.h5", "-o", "{o}", "--method", "magic"],
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
            "--method",
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
    # --- reproduce (argument errors only: no cluster is started) ------------------------
    ("reproduce-unknown-chapter", ["reproduce", "ch9", "-o", "{o}"]),
    ("reproduce-workers-0", ["reproduce", "ch4", "-o", "{o}", "--workers", "0"]),
    ("reproduce-workers-negative", ["reproduce", "ch4", "-o", "{o}", "--workers", "-4"]),
    ("reproduce-workers-400-digits", ["reproduce", "ch4", "-o", "{o}", "--workers", N400]),
    ("reproduce-out-is-file", ["reproduce", "ch4", "-o", "{r}/notes.txt"]),
    ("reproduce-bad-scheduler", ["reproduce", "ch4", "-o", "{o}", "--scheduler", "not an address"]),
    (
        "reproduce-scheduler-bad-port",
        ["reproduce", "ch4", "-o", "{o}", "--scheduler", "tcp://127.0.0.1:99999"],
    ),
    # --- demo ---------------------------------------------------------------------------
    ("demo-out-is-file", ["demo", "-o", "{r}/notes.txt"]),
    ("demo-out-existing", ["demo", "-o", "{r}/existing"]),
    ("demo-seed-negative", ["demo", "-o", "{o}", "--seed", "-1"]),
]


@pytest.mark.parametrize("argv", [c[1] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(root: Path, argv: list[str]) -> None:
    before = _tree(root)
    args = [a.format(r=root, o=root / "out") for a in argv]
    res = run_cli(*args, timeout=60)
    assert res.returncode == 2, (res.returncode, res.stderr[-2000:])
    assert "Traceback" not in res.stderr, res.stderr[-2000:]
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr[-2000:]
    assert _tree(root) == before  # nothing new, nothing removed, every byte the same


def test_suite_covers_every_command() -> None:
    commands = {argv[0] for _, argv in CASES}
    assert commands == {
        "patterns", "simulate", "modify", "gamma", "phase", "calibrate", "measure",
        "train-correction", "reproduce", "demo",
    }  # fmt: skip
    assert len(CASES) >= 60 and len({name for name, _ in CASES}) == len(CASES)
