"""Issue 26 on the loop rig: a highlight measured inside twelve images through a real window.

The loop rig (tests/test_hardware_rig.py: the projector window on Xvfb, the loop camera grabbing
it through the virtual scene) measures the specular part with ``--max-images 12`` and the
rig's stereo calibration (``--calibration STEREO.h5 --adaptive-epipolar``: one mapping ladder).
The probe clips on the highlight, so the 64 px mapping set is dimmed there and the adapted set
lowers its floor under the lowest usable MIGL: both are projector images no fringe frame
describes, recorded as ``image`` frames.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli, xvfb_display
from tests.test_hardware_rig import LOOP_CAMERA, LOOP_H, LOOP_SIZE, LOOP_W, cli


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    """A private Xvfb server at the virtual rig's projector size, killed at the end."""
    with xvfb_display(LOOP_W, LOOP_H) as display:
        yield display


@pytest.mark.parametrize(
    ("pitches", "budget", "extra", "kinds"),
    [
        ("1024,64,16", 12, (), ["fringe"] * 4 + ["image"] * 8),
        # two pitches, the 64 px set ordered from the calibration and the depth range: the
        # probe's shots are no complete set (its first shift at the full MIGL, the others
        # dimmed), recorded as the images they showed, like the floored adapted set
        ("64,16", 8, ("--depth-range", "1850:1910"), ["image"] * 8),
    ],
    ids=["three-pitches-12", "two-pitches-8"],
)
def test_a_highlight_in_twelve_images_on_the_loop_rig(
    xdisplay: str,
    tmp_path: Path,
    pitches: str,
    budget: int,
    extra: tuple[str, ...],
    kinds: list[str],
) -> None:
    """The live run captures what the virtual rig's own budget run captures (12 images: the
    probe as a fringe set, the dimmed 64 px set and the floored adapted set as 8 ``image``
    frames), reaches the highlight (it clips in the probe; at least 99 % of the pixels the
    run saw have a phase, where the budget without the dimmed set and the lowered floor
    reached 98.6 % at 160 x 120), agrees with the virtual rig within noise (two virtual runs with
    different noise seeds set it), and ``measure`` of the recorded folder with the same
    calibration replays to the live maps exactly. Rejects a floored or dimmed frame shown
    wrongly (the phase would differ beyond noise), one recorded as a fringe set (refused or
    replayed to other maps), a replay that re-plans without the recorded images (the
    ReplayRig would lack the frame) and one that does not offer the strategy the given
    calibration's geometry (refused: the epipolar mapping had none, before this test). With
    two pitches and ``--depth-range`` the same in 8 images (the depth range reaches the
    strategy through the measurement, and its replay)."""
    from hdrfringe import pipeline
    from hdrfringe.io.results import read_map_tiff
    from hdrfringe.io.stereo_file import save_stereo_calibration
    from hdrfringe.rig.factory import virtual_rig
    from hdrfringe.strategies import make_params
    from hdrfringe.tasks.capture import LiveFringes

    stereo = save_stereo_calibration(
        tmp_path / "stereo.h5",
        virtual_rig("specular_part", resolution=LOOP_SIZE, seed=0).stereo_calibration(),
    )
    out = tmp_path / "out"
    camera = f"loop:specular_part?display={xdisplay}&latency=1&{LOOP_CAMERA}"
    r = cli("measure", "--rig", "hardware", "--projector", f"screen:0@{xdisplay}", "--camera",
            camera, "--settle", "0", "--strategy", "adaptive", "--adaptive-epipolar",
            "--max-images", str(budget), "--exposure-ms", "10", "--pitch", pitches,
            "--calibration", str(stereo), "--no-previews", "--no-report",
            *extra, "-o", str(out))  # fmt: skip
    assert r.returncode == 0, r.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    record = metrics["adaptive"]["vertical"]["budget"]
    assert metrics["images_captured"] == record["images"] == budget and record["epipolar"]
    assert 0 < record["probe_clipped_fraction"] < 0.05  # the highlight clipped in the probe
    assert record["unreached"]["reached_fraction"] >= 0.99
    assert record["probe_dimmed"] == bool(extra)
    manifest = json.loads((out / "captures" / "manifest.json").read_text())
    shown = [f["kind"] for f in manifest["frames"]]
    assert shown == [*kinds, "centerline"], shown
    # the dimmed and floored shifts (all but the probe's full-MIGL ones)
    floored = [f.get("name", "").endswith("_floored") for f in manifest["frames"][:budget]]
    full_migl = 4 if budget == 12 else 1
    assert floored == [False] * full_migl + [True] * (budget - full_migl), floored
    measured = read_map_tiff(out / "absolute_phase_vertical.tiff")

    def sim(seed: int) -> np.ndarray:
        rig = virtual_rig("specular_part", seed=seed, resolution=LOOP_SIZE)
        steps = [float(p) for p in pitches.split(",")]
        specs, line = LiveFringes("sinusoidal", 4, steps, 40.0, 255.0, True).build(
            rig.projector
        )
        given = {"depth_range_mm": (1850.0, 1910.0)} if extra else {}
        params = make_params("adaptive", max_images=budget, **given)  # the rig's calibration
        res = pipeline.measure(rig, None, strategy="adaptive", params=params, specs=specs,
                               centerline=line)  # fmt: skip
        assert res.metrics.strategy is not None and res.decoded.primary is not None
        assert res.metrics.strategy.images_captured == budget
        return np.asarray(res.decoded.primary.absolute_phase)

    ref, other = sim(0), sim(1)
    both = np.isfinite(ref) & np.isfinite(other) & np.isfinite(measured)
    assert both.mean() > 0.5
    noise = np.abs(ref - other)[both]
    live = np.abs(measured - ref)[both]
    assert np.median(live) <= 1.5 * np.median(noise) + 1e-3
    assert np.percentile(live, 99) <= 1.5 * np.percentile(noise, 99) + 1e-3

    replay = tmp_path / "replay"
    r = run_cli("measure", str(out / "captures"), "--calibration", str(stereo),
                "--no-previews", "--no-report", *extra, "-o", str(replay))  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "replayed" in r.stdout
    for name in sorted(p.name for p in out.glob("*.tiff")):
        np.testing.assert_array_equal(
            read_map_tiff(replay / name), read_map_tiff(out / name), err_msg=name
        )
