"""``hdrfringe run project.toml`` on tiny simulated captures (64 x 48): the stages give what the
commands give, a second run skips every stage and writes nothing, a change reruns exactly the
stage it feeds and those downstream, and a bad project file is refused in one line with nothing
written (docs/project_file.md).

The project: ``import`` (the images of ``hdrfringe simulate`` and an import description) ->
``phase`` -> ``calibrate`` (a simulated plate series) -> ``measure`` (the imported captures with
the calibration). The reference is the same four commands typed one by one.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from hdrfringe.core.strict_json import loads_strict
from hdrfringe.io.results import read_map_tiff
from tests.conftest import run_cli

SIM = ["--steps", "4", "--pitch", "1024,64,8", "--resolution", "64x48", "--no-centerline"]
DESCRIPTION = """\
[camera]
bit_depth = 8
[projector]
width = 1024
height = 768
[[fringe]]
files = "s4_p{pitch}_v_i40_g255_{step}.png"
orientation = "vertical"
pitch = [1024, 64, 8]
steps = 4
imin = 40
migl = 255
"""
PROJECT = """\
[paths]
sim = "inputs"

[project]
output = "out"

[import]
images = "{sim}/part"
description = "part.toml"

[phase]
previews = false
uncertainty = false

[calibrate]
folders = ["{sim}/plates"]
window = 5
border = 2

[measure]
previews = false
"""
STAGES = ["import", "phase", "calibrate", "measure"]


def _ok(*args: str) -> str:
    res = run_cli(*args)
    assert res.returncode == 0, res.stderr
    return res.stdout


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The inputs simulated, the project written and run once; the same stages run as the four
    commands (``ref``)."""
    root = tmp_path_factory.mktemp("run")
    sim = root / "inputs"
    _ok("simulate", "white_plate", "-o", str(sim / "part"), "--depth-mm", "2", *SIM)
    _ok("simulate", "white_plate", "-o", str(sim / "plates"), "--series", "0,4,8", *SIM)
    (root / "part.toml").write_text(DESCRIPTION)
    (root / "project.toml").write_text(PROJECT)
    first = _ok("run", str(root / "project.toml"))
    ref = root / "ref"
    _ok("import", str(sim / "part"), "-d", str(root / "part.toml"), "-o", str(ref / "caps"))
    _ok("phase", str(ref / "caps"), "-o", str(ref / "phase"), "--no-previews", "--no-uncertainty")
    _ok("calibrate", str(sim / "plates"), "-o", str(ref / "cal.h5"), "--window", "5",
        "--border", "2")  # fmt: skip
    _ok("measure", str(ref / "caps"), "-c", str(ref / "cal.h5"), "-o", str(ref / "measure"),
        "--no-previews")  # fmt: skip
    return {"root": root, "out": root / "out", "ref": ref, "stdout": first}


def _summary(out: Path) -> dict[str, dict]:
    data = json.loads((out / "run_summary.json").read_text())
    return {s["stage"]: s for s in data["stages"]}


def _snapshot(out: Path) -> dict[str, tuple[int, int]]:
    """Every file of the run folder but the run summary: size and modification time."""
    return {
        str(p.relative_to(out)): (p.stat().st_size, p.stat().st_mtime_ns)
        for p in sorted(out.rglob("*"))
        if p.is_file() and p.name != "run_summary.json"
    }


def _run(project: dict) -> dict[str, str]:
    """Run the project again; each stage's status as the CLI and the summary say it."""
    stdout = _ok("run", str(project["root"] / "project.toml"))
    summary = _summary(project["out"])
    for stage, entry in summary.items():
        said = "skipped (inputs unchanged)" if entry["status"] == "skipped" else "ran ("
        assert f"{stage}: {said}" in stdout, stdout
    return {stage: f"{e['status']}: {e['reason']}" for stage, e in summary.items()}


def test_stages_give_what_the_commands_give(project: dict) -> None:
    """Every stage ran once, in order, and wrote what the command with the same options
    writes: the same capture folder, phase maps, calibration's heights and measurement."""
    out, ref = project["out"], project["ref"]
    assert [s for s, e in _summary(out).items() if e["status"] == "ran"] == STAGES
    assert sorted(p.name for p in (out / "manifests").iterdir()) == sorted(
        f"{s}.json" for s in STAGES
    )
    for path in [out / "run_summary.json", *(out / "manifests").iterdir()]:
        loads_strict(path.read_text())  # strict JSON: a bare NaN would be refused
    for f in (ref / "caps").iterdir():
        if f.suffix == ".png":
            assert (out / "import" / f.name).read_bytes() == f.read_bytes()
    assert sorted(p.name for p in (out / "phase").iterdir()) == sorted(
        p.name for p in (ref / "phase").iterdir()
    )
    for name in ("absolute_phase_vertical.tiff", "modulation.tiff"):
        a, b = read_map_tiff(out / "phase" / name), read_map_tiff(ref / "phase" / name)
        assert np.array_equal(a, b, equal_nan=True), name
    height = read_map_tiff(out / "measure" / "height.tiff")
    assert np.isfinite(height).mean() > 0.9  # the calibration was used: heights, not NaN
    assert np.array_equal(height, read_map_tiff(ref / "measure" / "height.tiff"), equal_nan=True)
    metrics = json.loads((out / "measure" / "metrics.json").read_text())
    assert (
        metrics["valid_fraction"]
        == json.loads((ref / "measure" / "metrics.json").read_text())["valid_fraction"]
    )


def test_second_run_skips_and_changes_rerun_only_downstream(project: dict) -> None:
    """Nothing changed: every stage skipped, no file but the run summary rewritten. An input's
    time alone is no change (content hashes). One image of the part changed: import and what
    reads it (phase, measure) rerun, calibrate not; the description's comment: import reruns and
    writes the same folder, so nothing downstream does; one plate image: calibrate and measure;
    an option: that stage; a deleted output file: that stage."""
    out, root = project["out"], project["root"]
    before = _snapshot(out)
    assert set(_run(project).values()) == {"skipped: inputs unchanged"}
    assert _snapshot(out) == before  # nothing written

    image = root / "inputs" / "part" / "s4_p8_v_i40_g255_1.png"
    os.utime(image, ns=(image.stat().st_atime_ns, image.stat().st_mtime_ns + 10**10))
    assert set(_run(project).values()) == {"skipped: inputs unchanged"}

    pixels = iio.imread(image)
    pixels[10, 10] = 255 - pixels[10, 10]
    iio.imwrite(image, pixels)
    assert _run(project) == {
        "import": "ran: input images changed",
        "phase": "ran: import output changed",
        "calibrate": "skipped: inputs unchanged",
        "measure": "ran: import output changed",
    }

    (root / "part.toml").write_text("# a comment changes the file, not the import\n" + DESCRIPTION)
    assert _run(project) == {
        "import": "ran: input description changed",
        "phase": "skipped: inputs unchanged",  # the import wrote the same bytes
        "calibrate": "skipped: inputs unchanged",
        "measure": "skipped: inputs unchanged",
    }

    plate = next((root / "inputs" / "plates").iterdir()) / "s4_p8_v_i40_g255_0.png"
    pixels = iio.imread(plate)
    pixels[5, 5] = 255 - pixels[5, 5]
    iio.imwrite(plate, pixels)
    statuses = _run(project)
    assert [s for s, v in statuses.items() if v.startswith("ran")] == ["calibrate", "measure"]
    assert statuses["measure"] == "ran: calibrate output changed"

    text = (root / "project.toml").read_text()
    (root / "project.toml").write_text(text.replace("[phase]\n", "[phase]\nmin_modulation = 2.0\n"))
    statuses = _run(project)
    assert statuses.pop("phase") == "ran: options changed (min_modulation)"
    assert set(statuses.values()) == {"skipped: inputs unchanged"}

    (out / "measure" / "metrics.json").unlink()
    statuses = _run(project)
    assert statuses.pop("measure") == "ran: output metrics.json is missing"
    assert set(statuses.values()) == {"skipped: inputs unchanged"}
    assert (out / "measure" / "metrics.json").is_file()
    assert (out / "measure" / "report.html").is_file()
    assert not (out / "measure" / "mesh.ply").exists()

    text = (root / "project.toml").read_text()
    (root / "project.toml").write_text(
        text.replace("[measure]\n", '[measure]\nreport = false\nmesh = "ply"\n')
    )
    statuses = _run(project)
    assert statuses.pop("measure").startswith("ran: options changed (")
    assert set(statuses.values()) == {"skipped: inputs unchanged"}
    assert (out / "measure" / "mesh.ply").is_file()  # the keys reach measure
    assert not (out / "measure" / "report.html").exists()


#: A bad project file: (text replaced in PROJECT, its replacement, what the error line says).
BAD = {
    "unknown key": ("previews = false\nuncertainty", "prevewis = false\nuncertainty",
                    "[phase] 'prevewis' is not a key of [phase]; did you mean 'previews'?"),
    "wrong type": ("[measure]\n", "[measure]\nuncertainty = \"yes\"\n",
                   "[measure] 'uncertainty' must be true or false, got 'yes'"),
    "missing path": ("{sim}/part", "{sim}/nope", "[import] 'images' "),
    "unknown table": ("[measure]", "[mesure]",
                      "[mesure] is not a table of a project file; did you mean 'measure'?"),
    "unknown root": ("{sim}/plates", "{data}/plates",
                     "[calibrate] 'folders' starts with an unknown root '{data}'"),
    "contradiction": ("[phase]\n", "[phase]\nsaturated = \"exclude\"\nkeep_saturated = true\n",
                      "[phase] 'keep_saturated' and saturated = \"exclude\" contradict"),
    "strategy": ("[measure]\n", "[measure]\nstrategy = \"lpa\"\nstrategy_params = {stepp = 3}\n",
                 "[measure] 'strategy_params' lpa has no parameter 'stepp'"),
    "outside a table": ("[paths]", "output = \"x\"\n[paths]",
                        "'output' is a key outside any table"),
    "not TOML": ("[measure]", "[measure", "not a valid TOML project (Expected ']'"),
}  # fmt: skip


@pytest.mark.parametrize("case", BAD)
def test_bad_project_file_one_line_nothing_written(case: str, tmp_path: Path) -> None:
    """Each refusal: exit code 2, one line naming the file, the table and the key, and no
    output folder (the valid stages before the bad table did not run)."""
    old, new, expected = BAD[case]
    assert old in PROJECT
    (tmp_path / "inputs" / "part").mkdir(parents=True)
    (tmp_path / "inputs" / "plates").mkdir()
    (tmp_path / "part.toml").write_text(DESCRIPTION)
    project = tmp_path / "project.toml"
    project.write_text(PROJECT.replace(old, new, 1))
    before = sorted(tmp_path.rglob("*"))
    res = run_cli("run", str(project))
    assert res.returncode == 2, (res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and str(project) in lines[0], lines
    assert expected in lines[0], lines[0]
    assert sorted(tmp_path.rglob("*")) == before


def test_output_that_is_not_a_run_folder_is_refused(project: dict, tmp_path: Path) -> None:
    """A non-empty folder that no run wrote is not taken over (exit 2, left as it was)."""
    other = tmp_path / "other"
    other.mkdir()
    (other / "keep.txt").write_text("mine")
    shutil.copy(project["root"] / "project.toml", tmp_path / "project.toml")
    res = run_cli("run", str(project["root"] / "project.toml"), "-o", str(other))
    assert res.returncode == 2 and "is not the output of a project run" in res.stderr
    assert [p.name for p in other.iterdir()] == ["keep.txt"]


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (["{r}/missing.toml"], "missing.toml"),
        (["{r}/inputs"], "is a folder, not a project file"),
        (["{r}/project.toml", "-o", "{r}/inputs/part/out"], "output is inside the input"),
        (["{r}/project.toml", "-o", "{r}/part.toml"], "exists and is not a folder"),
    ],
    ids=["missing", "folder", "output-in-input", "output-a-file"],
)
def test_bad_command_line_one_line_nothing_written(
    args: list[str], expected: str, tmp_path: Path
) -> None:
    """A missing project file, a folder for it, an output inside an input or on a file: exit
    code 2, one line, nothing written."""
    (tmp_path / "inputs" / "part").mkdir(parents=True)
    (tmp_path / "inputs" / "plates").mkdir()
    (tmp_path / "part.toml").write_text(DESCRIPTION)
    (tmp_path / "project.toml").write_text(PROJECT)
    before = {p: p.read_bytes() if p.is_file() else None for p in tmp_path.rglob("*")}
    res = run_cli("run", *[a.format(r=tmp_path) for a in args])
    assert res.returncode == 2, (res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and expected in lines[0], lines
    assert {p: p.read_bytes() if p.is_file() else None for p in tmp_path.rglob("*")} == before
