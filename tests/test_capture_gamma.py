"""``hdrfringe capture-gamma`` (issue 13) on the loop rig: a projector window on Xvfb and the loop
camera, whose virtual projector has a known gamma (the virtual rig's ``ProjectorModel``).

The reference gamma is the virtual rig's projector model, which the commands under test never
report; the estimate comes from ``hdrfringe gamma FOLDER``, which reads the folder unchanged.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from hdrfringe.rig.simulated import ProjectorModel
from tests.conftest import run_cli, xvfb_display

# The Xvfb tests share one group: one worker runs them (make test: --dist loadgroup).
pytestmark = pytest.mark.xdist_group("xvfb")

WIDTH, HEIGHT = 640, 480
TRUE_GAMMA = ProjectorModel().gamma  # the loop camera's virtual projector
#: Stated tolerances: the uniform-gray fit within 0.5 %, the fringe-shape fit within 1 % (its
#: wide fringes are still slightly reshaped by projector defocus and camera blur).
UNIFORM_TOLERANCE, FRINGE_TOLERANCE = 0.005, 0.01


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    with xvfb_display(WIDTH, HEIGHT) as display:
        yield display


def live(display: str, out: Path, *args: str) -> list[str]:
    camera = f"loop:white_plate?display={display}&latency=1&size=160x120"
    return ["capture-gamma", "--projector", f"screen:0@{display}", "--camera", camera,
            "--settle", "0", "-o", str(out), *args]  # fmt: skip


def test_capture_gamma_writes_what_gamma_fits_to_the_projectors_gamma(
    xdisplay: str, tmp_path: Path
) -> None:
    caps = tmp_path / "caps"
    r = run_cli(*live(xdisplay, caps, "--gamma", f"{TRUE_GAMMA}"))
    assert r.returncode == 0, r.stderr
    text = " ".join(r.stdout.split())
    assert "suits this projector" in text and "warning" not in text
    manifest = json.loads((caps / "manifest.json").read_text())
    assert manifest["capture"]["complete"] is True
    assert manifest["projector"]["gamma_precompensation"] == TRUE_GAMMA  # the grays' exponent
    frames = manifest["frames"]
    uniform = [f for f in frames if f["kind"] == "uniform"]
    fringes = [f for f in frames if f["kind"] == "fringe"]
    assert len(uniform) == 18 and len(fringes) == 8
    # each fringe set records the exponent it was really sent with
    assert [f.get("gamma_precompensation") for f in fringes] == [0.75] * 4 + [1.25] * 4
    log = json.loads((caps / "capture_log.json").read_text())
    # latency 1 and every frame differs from the one before: exactly one stale grab each
    assert [f["rejected"] for f in log["frames"]] == [1] * len(frames)

    out = tmp_path / "fit"
    r = run_cli("gamma", str(caps), "-o", str(out))
    assert r.returncode == 0, r.stderr
    report = json.loads((out / "gamma.json").read_text())
    assert report["uniform"]["gamma"] == pytest.approx(TRUE_GAMMA, rel=UNIFORM_TOLERANCE)
    assert report["fringes"]["gamma"] == pytest.approx(TRUE_GAMMA, rel=FRINGE_TOLERANCE)
    assert report["warnings"] == []


def test_capture_gamma_from_a_rig_config_sends_its_own_gamma_and_judges_the_files(
    xdisplay: str, tmp_path: Path
) -> None:
    # The rig from a configuration file whose gamma (2.5) is wrong for the projector. The
    # grays are sent with the command's --gamma (default 1), not the file's: the manifest
    # says 1 (the file's gamma winning would say 2.5); the file's gamma is recorded, and both
    # verdicts are printed (1 and 2.5 are both wrong, the suggestion is the projector's gamma).
    config = tmp_path / "rig.toml"
    camera = f"loop:white_plate?display={xdisplay}&latency=1&size=160x120"
    config.write_text(
        f'gamma = 2.5\n[projector]\nspec = "screen:0@{xdisplay}"\n[camera]\nspec = "{camera}"\n'
        "[sync]\nsettle_s = 0.5\nmax_grabs = 3\n"
    )
    caps = tmp_path / "caps"
    args = ["--rig-config", str(config), "--settle", "0", "--no-fringes", "--gray", "0:255:51"]
    r = run_cli("capture-gamma", *args, "-o", str(caps))
    assert r.returncode == 0, r.stderr
    text = " ".join(r.stdout.split())
    assert "pre-compensation in use (--gamma 1) is wrong for this projector" in text
    # rich folds a long path across lines without a space: compare without any whitespace
    expected = f"the rig configuration's gamma 2.5 ({config}) is wrong for this projector"
    assert "".join(expected.split()) in "".join(text.split())
    for fix in ("pre-compensate with --gamma ", "set gamma = "):
        suggested = float(text.split(fix)[1].split()[0])
        assert suggested == pytest.approx(TRUE_GAMMA, rel=UNIFORM_TOLERANCE)
    manifest = json.loads((caps / "manifest.json").read_text())
    assert manifest["projector"]["gamma_precompensation"] == 1.0  # --gamma's default, sent
    log = json.loads((caps / "capture_log.json").read_text())
    digest = hashlib.sha256(config.read_bytes()).hexdigest()
    for record in (manifest["capture"], log):  # the resolved rig, and the file it came from
        assert record["gray_gamma_precompensation"] == 1.0 and record["camera"] == camera
        assert record["rig"]["gamma"] == 2.5  # the file's, recorded, not sent
        assert record["rig"]["config_file"] == {"path": str(config), "sha256": digest}
        assert record["rig"]["sync"]["settle_s"] == 0.0  # --settle overrides the file
        assert record["rig"]["sync"]["max_grabs"] == 3  # the file's
    assert [f["rejected"] for f in log["frames"]] == [1] * 6
    # `gamma` reads the same folder: the fit is the projector's, whatever was sent
    r = run_cli("gamma", str(caps))
    assert r.returncode == 0, r.stderr
    fitted = float(r.stdout.split("uniform grays: gamma = ")[1].split()[0])
    assert fitted == pytest.approx(TRUE_GAMMA, rel=UNIFORM_TOLERANCE)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--gray", "0,128,255"], "3 distinct levels; the fit needs at least 4"),
        (["--fringe-pitch", "16"], "--fringe-pitch 16: narrower than 32 px"),
        (["--fringe-gamma", "1", "--steps", "3"], "needs two different exponents or >= 4 steps"),
        (["--no-grays", "--no-fringes"], "nothing to project"),
        (["--fringe-gamma", "0,1"], "must be positive numbers"),
        (["--camera", "usb3:1"], "unknown back end 'usb3'"),
    ],
)
def test_capture_gamma_refuses_bad_input_in_one_line(
    args: list[str], message: str, tmp_path: Path
) -> None:
    from hdrfringe.cli import app

    out = tmp_path / "out"
    base = ["capture-gamma", "--projector", "screen:0@:4999", "--camera", "pylon:emu"]
    r = CliRunner().invoke(app, [*base, *args, "-o", str(out)])
    assert r.exit_code == 2
    assert message in " ".join(r.stderr.split()) and r.stderr.count("error:") == 1
    assert not out.exists()
