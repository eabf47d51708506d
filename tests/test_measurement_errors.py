"""calibrate / measure bad input: one line, exit 2, no partial output, outputs kept w/o --force."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from tests.conftest import run_cli, run_cli_in_process


@pytest.fixture(scope="module")
def plates(white_plate_series: Path) -> Path:
    """The calibration series of conftest (simulated once per session; read-only here)."""
    return white_plate_series


@pytest.fixture(scope="module")
def calib(plates: Path) -> Path:
    out = plates.parent / "cal.h5"
    res = run_cli("calibrate", str(plates), "-o", str(out))
    assert res.returncode == 0, res.stderr
    return out


def _folders(root: Path) -> list[Path]:
    return sorted(p for p in root.iterdir() if p.is_dir())


def _one_line_failure(res, *needles: str) -> None:
    """Exit 2, one ``error:`` line holding the needles, no traceback. The failing runs go
    through ``run_cli_in_process`` (the CLI's entry point in this process, reporting what the
    process would: conftest); the successful ones stay real processes."""
    assert res.returncode == 2, res.stdout + res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    assert "Traceback" not in res.stderr
    for n in needles:
        assert n in lines[0], lines[0]


def test_calibrate_and_measure_work(plates: Path, calib: Path, tmp_path: Path) -> None:
    out = tmp_path / "m"
    res = run_cli("measure", str(_folders(plates)[1]), "-c", str(calib), "-o", str(out))
    assert res.returncode == 0, res.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["rmse_mm"] < 0.5 and metrics["valid_fraction"] > 0.99
    for name in ("height.tiff", "height.png", "points.ply", "wrapped_phase.tiff"):
        assert (out / name).is_file()


def test_measure_without_calibration_says_what_it_skipped(plates: Path, tmp_path: Path) -> None:
    out = tmp_path / "m"
    res = run_cli("measure", str(_folders(plates)[1]), "-o", str(out))
    assert res.returncode == 0, res.stderr
    assert "skipped: height" in res.stdout
    assert (out / "wrapped_phase.tiff").is_file() and not (out / "height.tiff").exists()


def test_one_position_only(plates: Path, tmp_path: Path) -> None:
    f = _folders(plates)
    out = tmp_path / "c.h5"
    _one_line_failure(
        run_cli_in_process("calibrate", str(f[0]), str(f[1]), "-o", str(out)),
        "at least 2 plate positions",
    )
    assert not out.exists()


def test_duplicate_depths(plates: Path, tmp_path: Path) -> None:
    f = _folders(plates)
    dup = tmp_path / "dup"
    shutil.copytree(f[1], dup)
    out = tmp_path / "c.h5"
    _one_line_failure(
        run_cli_in_process("calibrate", *map(str, f), str(dup), "-o", str(out)),
        "duplicate depth 4 mm",
    )
    assert not out.exists()


def test_missing_reference_plane(plates: Path, tmp_path: Path) -> None:
    f = _folders(plates)
    extra = tmp_path / "d12"
    shutil.copytree(f[2], extra)
    m = json.loads((extra / "manifest.json").read_text())
    m["scene"]["depth_mm"] = 12.0
    (extra / "manifest.json").write_text(json.dumps(m))
    out = tmp_path / "c.h5"
    _one_line_failure(
        run_cli_in_process("calibrate", str(f[1]), str(f[2]), str(extra), "-o", str(out)),
        "no reference plane",
    )
    assert not out.exists()


def test_mismatched_sizes(plates: Path, tmp_path: Path) -> None:
    f = _folders(plates)
    small = tmp_path / "small"
    shutil.copytree(f[2], small)
    for p in small.glob("*.png"):
        iio.imwrite(p, iio.imread(p)[:100, :120])
    for p in small.glob("*.tiff"):
        p.unlink()
    m = json.loads((small / "manifest.json").read_text())
    m.pop("maps", None)
    (small / "manifest.json").write_text(json.dumps(m))
    out = tmp_path / "c.h5"
    _one_line_failure(
        run_cli_in_process("calibrate", str(f[0]), str(f[1]), str(small), "-o", str(out)), "120x100"
    )
    assert not out.exists()


def test_corrupt_and_foreign_calibration_files(plates: Path, tmp_path: Path) -> None:
    import h5py

    corrupt = tmp_path / "corrupt.h5"
    corrupt.write_bytes(b"\x89HDF\r\n\x1a\n" + b"garbage" * 100)
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as h:
        h["data"] = np.zeros(3)
    for cal, needle in (
        (corrupt, "corrupt.h5"),
        (foreign, "foreign.h5"),
        (tmp_path / "missing.h5", "missing.h5"),
    ):
        out = tmp_path / f"m_{cal.stem}"
        _one_line_failure(
            run_cli_in_process("measure", str(_folders(plates)[1]), "-c", str(cal), "-o", str(out)),
            needle,
        )
        assert not out.exists()


def test_calibration_from_another_pattern_spec(calib: Path, tmp_path: Path) -> None:
    part = tmp_path / "part"
    assert (
        run_cli_in_process(  # the input (a part with another spec); the test is measure's refusal
            "simulate",
            "white_plate",
            "-o",
            str(part),
            "--depth-mm",
            "6",
            "--steps",
            "4",
            "--pitch",
            "8",
        ).returncode
        == 0
    )
    out = tmp_path / "m"
    _one_line_failure(
        run_cli_in_process("measure", str(part), "-c", str(calib), "-o", str(out)), "steps"
    )
    assert not out.exists()


def test_existing_outputs_kept_unless_force(plates: Path, calib: Path, tmp_path: Path) -> None:
    before = calib.read_bytes()
    res = run_cli_in_process("calibrate", str(plates), "-o", str(calib))
    _one_line_failure(res, "--force")
    assert calib.read_bytes() == before
    out = tmp_path / "m"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    _one_line_failure(
        run_cli_in_process("measure", str(_folders(plates)[1]), "-c", str(calib), "-o", str(out)),
        "--force",
    )
    assert (out / "keep.txt").read_text() == "mine"
    res = run_cli("measure", str(_folders(plates)[1]), "-c", str(calib), "-o", str(out), "--force")
    assert res.returncode == 0 and (out / "height.tiff").exists()
