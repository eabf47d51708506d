"""``measure`` takes ``phase``'s saturation options, and a replayed strategy keeps every family
and the Gray code of the folder (issue 24, item 4).

References: ``hdrfringe phase`` with the same options on the same folder (the command whose
options these are), and the virtual rig's own projector coordinates for the replay's absolute
phases.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.io.results import read_map_tiff
from tests.conftest import run_cli


@pytest.fixture(scope="module")
def sweep():  # type: ignore[no-untyped-def]
    """A MIGL sweep (255, 205, 155) of vertical and horizontal 4-step sets (pitch 32 and 8),
    then OpenCV's Gray code (32 px cells) with white and black: the mask scene under 1200 lx,
    which saturates the top MIGL."""
    from hdrfringe.core.frames import UniformFrame, opencv_graycode_frames
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.rig.scenes import mask
    from hdrfringe.rig.simulated import CameraModel, Lighting, ProjectorModel, SimulatedRig

    rig = SimulatedRig(
        mask(), camera=CameraModel(width=96, height=72),
        projector_model=ProjectorModel(width=256, height=192), lighting=Lighting(ambient_lux=1200),
    )  # fmt: skip
    frames = [
        f
        for migl in (255.0, 205.0, 155.0)
        for o in ("vertical", "horizontal")
        for p in (32.0, 8.0)
        for f in FringeSpec("sinusoidal", 4, p, o, 40.0, migl).frames()  # type: ignore[arg-type]
    ]
    frames += [*opencv_graycode_frames(256, 192, 32.0), UniformFrame(255.0), UniformFrame(0.0)]
    return rig, rig.capture_folder(frames)


def test_replay_keeps_every_family_and_the_gray_code(sweep) -> None:  # type: ignore[no-untyped-def]
    """``--strategy tolerant`` on the sweep replays both orientations and takes the Gray code
    along (patterns and inverses): both families are absolute by the Gray code and match the
    rig's projector columns and rows. Before, the vertical family alone was replayed, without
    its Gray code."""
    from hdrfringe.pipeline import measure

    rig, caps = sweep
    res = measure(caps, strategy="tolerant")
    fams = {f.orientation: f for f in res.decoded.families}
    assert set(fams) == {"vertical", "horizontal"}
    assert res.metrics.strategy is not None and res.metrics.strategy.sets_captured == 4
    assert len(res.captures.graycode_sets()) == 2
    truth = rig.truth()
    for orient, coord in (("vertical", truth.u), ("horizontal", truth.v)):
        fam = fams[orient]
        assert fam.absolute_method is not None and "Gray code" in fam.absolute_method
        assert "pattern/inverse pairs" in fam.method  # the inverses replayed too
        x = fam.absolute_phase * fam.pitch_px / (2 * np.pi)
        ok = np.isfinite(x) & truth.valid
        assert ok.mean() > 0.5
        assert np.median(np.abs(x - coord)[ok]) < 0.1  # projector px; no order error
        assert np.mean(np.abs(x - coord)[ok] > 4) < 0.01


def test_measure_takes_the_saturation_options_of_phase(sweep, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """On the top MIGL alone (saturated): ``measure --saturated exclude --min-shifts 3`` and
    ``--keep-saturated`` give the absolute phase ``phase`` gives with the same options; the
    default flags the saturated pixels."""
    from hdrfringe.core.captures import Captures
    from hdrfringe.core.frames import FringeFrame
    from hdrfringe.io.captures import write_capture_folder

    _, caps = sweep
    keep = [
        i for i, f in enumerate(caps.frames) if not isinstance(f, FringeFrame) or f.spec.migl == 255
    ]
    top = Captures([caps.frames[i] for i in keep], caps.images[keep], caps.camera_bit_depth,
                   projector=caps.projector)  # fmt: skip
    folder = write_capture_folder(tmp_path / "caps", top)
    valid = {}
    for name, opts in (
        ("flag", []),
        ("exclude", ["--saturated", "exclude", "--min-shifts", "3"]),
        ("keep", ["--keep-saturated"]),
    ):
        m, p = tmp_path / f"m_{name}", tmp_path / f"p_{name}"
        r = run_cli("measure", str(folder), *opts, "--no-previews", "-o", str(m))
        assert r.returncode == 0, r.stderr
        # measure decodes into float64 maps; phase stores float32 unless told (issue 30)
        r = run_cli("phase", str(folder), *opts, "--no-previews", "--map-dtype", "float64",
                    "-o", str(p))  # fmt: skip
        assert r.returncode == 0, r.stderr
        for map_name in ("absolute_phase_vertical.tiff", "absolute_phase_horizontal.tiff"):  # v, h
            a = read_map_tiff(m / map_name)
            np.testing.assert_array_equal(a, read_map_tiff(p / map_name), err_msg=name)
        valid[name] = float(np.isfinite(read_map_tiff(m / "absolute_phase_vertical.tiff")).mean())
        metrics = json.loads((m / "metrics.json").read_text())
        assert ("decoder" in metrics) == (name == "exclude")
    assert valid["flag"] < 0.9 * valid["exclude"] and valid["flag"] < 0.9 * valid["keep"]


@pytest.mark.parametrize(
    ("opts", "needle"),
    [
        (["--saturated", "clip"], "--saturated 'clip' is unknown; give one of flag, exclude"),
        (["--saturated", "exclude", "--keep-saturated"], "give one of them"),
        (["--min-shifts", "4"], "--min-shifts applies to --saturated exclude"),
    ],
)
def test_measure_refuses_saturation_options_as_phase_does(
    sweep, tmp_path: Path, opts: list[str], needle: str
) -> None:  # type: ignore[no-untyped-def]
    from hdrfringe.io.captures import write_capture_folder

    folder = write_capture_folder(tmp_path / "caps", sweep[1])
    for command in ("measure", "phase"):
        out = tmp_path / command
        r = run_cli(command, str(folder), *opts, "-o", str(out))
        assert r.returncode == 2, (command, r.stderr)
        lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and needle in lines[0], (command, r.stderr)
        assert not out.exists()
