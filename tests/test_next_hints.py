"""Every ``next:`` hint a command prints is a command that runs (issue 24): ``import`` suggests
``phase`` for fringe sets that decode as families and ``gamma`` for a gamma capture (the
kamino410 gamma sheet's sets differ only in their pre-distortion: ``gamma`` fits it, ``phase``
decodes each set).

The hints of the real data imports run in tests/test_import_realdata.py (each import's printed
hint replaces the ``phase`` call); here, synthetic and simulated folders.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np

from tests.conftest import run_cli


def run_hint(stdout: str, out: Path, *extra: str):  # type: ignore[no-untyped-def]
    """The ``next:`` command printed in ``stdout`` run with OUT replaced by ``out`` (and the
    options ``extra`` added)."""
    found = re.findall(r"next: (hdrfringe .*)$", stdout, flags=re.MULTILINE)
    assert len(found) == 1, stdout
    args = [str(out) if a == "OUT" else a for a in shlex.split(found[0])]
    assert args[0] == "hdrfringe"
    return args[1], run_cli(*args[1:], *extra, timeout=600)


def test_import_of_fringes_suggests_phase_and_it_runs(tmp_path: Path) -> None:
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.rig.simulated import CameraModel, SimulatedRig

    rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48))
    frames = [f for p in (64.0, 8.0) for f in FringeSpec("sinusoidal", 4, p).frames()]
    caps = rig.capture_folder(frames)
    cam = tmp_path / "cam"
    cam.mkdir()
    import cv2

    for i, img in enumerate(caps.images):
        cv2.imwrite(str(cam / f"i{i}.png"), img)
    desc = tmp_path / "d.toml"
    desc.write_text(
        "[camera]\nbit_depth = 8\n"
        '[[fringe]]\nfiles = ["i0.png", "i1.png", "i2.png", "i3.png"]\npitch = 64\nsteps = 4\n'
        '[[fringe]]\nfiles = ["i4.png", "i5.png", "i6.png", "i7.png"]\npitch = 8\nsteps = 4\n'
    )
    res = run_cli("import", str(cam), "-d", str(desc), "-o", str(tmp_path / "caps"))
    assert res.returncode == 0, res.stderr
    command, ran = run_hint(res.stdout, tmp_path / "phase")
    assert command == "phase" and ran.returncode == 0, ran.stderr
    assert (tmp_path / "phase" / "phase_summary.json").is_file()


def test_gamma_capture_suggests_gamma_and_it_runs(tmp_path: Path) -> None:
    """Uniform grays only (a projector response g^2.2 seen by an 8-bit camera): no fringes
    for ``phase``; the hint is ``gamma`` and it fits."""
    import cv2

    levels = np.arange(0, 256, 32)
    cam = tmp_path / "cam"
    cam.mkdir()
    for k, g in enumerate(levels):
        dn = 10 + 200 * (g / 255) ** 2.2
        cv2.imwrite(str(cam / f"g{k}.png"), np.full((24, 32), round(dn), np.uint8))
    desc = tmp_path / "d.toml"
    desc.write_text(
        "[camera]\nbit_depth = 8\n"
        + "".join(f'[[uniform]]\nfiles = "g{k}.png"\nlevel = {g}\n' for k, g in enumerate(levels))
    )
    res = run_cli("import", str(cam), "-d", str(desc), "-o", str(tmp_path / "caps"))
    assert res.returncode == 0, res.stderr
    command, ran = run_hint(res.stdout, tmp_path / "gamma")
    assert command == "gamma" and ran.returncode == 0, ran.stderr
    assert (tmp_path / "gamma" / "gamma.json").is_file()


def test_simulated_folder_gets_a_hint_that_runs(tmp_path: Path) -> None:
    """``next_step`` of a folder written by ``simulate`` (a MIGL sweep: one set per MIGL) is a
    ``phase`` command that runs."""
    from hdrfringe.tasks.import_ import next_step

    folder = tmp_path / "sweep"
    res = run_cli(
        "simulate", "white_plate", "-o", str(folder), "--pitch", "8", "--steps", "3",
        "--migl-sweep", "255:205:50",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    hint = next_step(folder)
    assert hint == f"hdrfringe phase {folder} -o OUT"
    _, ran = run_hint(f"next: {hint}", tmp_path / "phase")
    assert ran.returncode == 0, ran.stderr


def test_no_hint_for_a_folder_with_nothing_to_decode(tmp_path: Path) -> None:
    """A single uniform frame: neither phase nor gamma can use it; no hint is printed."""
    import cv2

    cam = tmp_path / "cam"
    cam.mkdir()
    cv2.imwrite(str(cam / "w.png"), np.full((24, 32), 200, np.uint8))
    desc = tmp_path / "d.toml"
    desc.write_text('[camera]\nbit_depth = 8\n[[uniform]]\nfiles = "w.png"\nlevel = 255\n')
    res = run_cli("import", str(cam), "-d", str(desc), "-o", str(tmp_path / "caps"))
    assert res.returncode == 0, res.stderr
    assert "next:" not in res.stdout and "wrote" in res.stdout


def _same_pitch_folder(tmp_path: Path) -> Path:
    """Two vertical 4-step sets of one pitch (64 px, the same images), the second
    pre-distorted with exponent 2 (``gamma_precompensation``), imported."""
    import cv2

    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.rig.simulated import CameraModel, SimulatedRig

    rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48))
    caps = rig.capture_folder(FringeSpec("sinusoidal", 4, 64.0).frames())
    cam = tmp_path / "cam"
    cam.mkdir()
    for i, img in enumerate([*caps.images, *caps.images]):
        cv2.imwrite(str(cam / f"i{i}.png"), img)
    desc = tmp_path / "d.toml"
    desc.write_text(
        "[camera]\nbit_depth = 8\n"
        '[[fringe]]\nfiles = ["i0.png", "i1.png", "i2.png", "i3.png"]\npitch = 64\nsteps = 4\n'
        '[[fringe]]\nfiles = ["i4.png", "i5.png", "i6.png", "i7.png"]\npitch = 64\nsteps = 4\n'
        "gamma_precompensation = 2.0\n"
    )
    out = tmp_path / "caps"
    res = run_cli("import", str(cam), "-d", str(desc), "-o", str(out))
    assert res.returncode == 0, res.stderr
    return out


def test_phase_on_sets_of_one_pitch_says_what_the_folder_is(tmp_path: Path) -> None:
    """Two sets of one pitch pre-distorted with two exponents (a gamma capture, what
    docs/gamma.md asks users to capture) decode: each is its own family (issue 31, root cause
    7: ``phase`` refused it, "pitches must be strictly decreasing" and then "a gamma
    capture"); both sets' wrapped phases are written, each family unwrapped within itself
    (the second named by its set), a note names the other set. The same two sets told apart
    by a label only (no exponents) are no pitch ladder: ``phase`` refuses in one line, exit 2,
    nothing written, naming the sets to keep one of."""
    import json
    import shutil

    gamma = _same_pitch_folder(tmp_path)
    res = run_cli("phase", str(gamma), "-o", str(tmp_path / "p1"), "--per-set-maps")
    assert res.returncode == 0, res.stderr
    summary = json.loads((tmp_path / "p1" / "phase_summary.json").read_text())
    labels = [s["label"] for s in summary["sets"]]
    assert len(labels) == 2 and [f["sets"] for f in summary["families"]] == [labels[:1]]
    assert f"wrapped_phase__{labels[1]}.tiff" in summary["files"]  # every set's maps on request
    assert any(f"{labels[1]} (gamma pre-compensation 2)" in n for n in summary["notes"])
    assert [f["sets"] for f in summary["gamma_families"]] == [labels[1:]]
    assert f"unwrapped_phase_vertical__{labels[1]}.tiff" in summary["files"]
    labelled = tmp_path / "labelled"
    shutil.copytree(gamma, labelled)
    manifest = json.loads((labelled / "manifest.json").read_text())
    for k, frame in enumerate(manifest["frames"]):
        frame.pop("gamma_precompensation", None)
        frame["set"] = "ab"[k // 4]
    (labelled / "manifest.json").write_text(json.dumps(manifest))
    res = run_cli("phase", str(labelled), "-o", str(tmp_path / "p2"))
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert "sets a, b all have pitch 64 px, so they do not form a pitch ladder" in lines[0]
    assert "gamma" not in lines[0] and not (tmp_path / "p2").exists()
