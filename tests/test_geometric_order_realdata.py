"""thomriiii checkerboard through the command line alone, the fringe order from the geometry
(issue 24, Done when; docs/stereo.md, "Fringe order from geometry"):

    hdrfringe import ../shared/realdata/thomriiii/dec2025_checkerboard_saturated_4step \\
        -d docs/examples/import/thomriiii_checkerboard.toml -o caps
    hdrfringe calibrate-stereo --from ../shared/realdata/thomriiii/calibration_dec2025 -o s.h5
    hdrfringe measure caps -c s.h5 --depth-range 550:800 --keep-saturated -o out

The set has no pitch spanning the projector (F = 4 periods at most), no Gray code and no
centerline: without ``--depth-range`` measure stops and names the option. With it, the flat
board is compared with what ``tests/test_stereo_realdata.py`` reaches by resolving the F = 4
order by hand (the board's squares must come out square): the same orders (k = 2 for both
orientations) and a plane of 0.83 mm RMS over the pixels inside the calibration's own
``uv_bbox``, clipped squares included. Skips when ``../shared/realdata`` is absent; prints
``[realdata]`` lines with the measured numbers (``pytest -s``).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import tifffile

from tests.conftest import realdata_path, run_cli

pytestmark = [pytest.mark.realdata, pytest.mark.xdist_group("geometric-realdata")]

CHECKER = ("thomriiii", "dec2025_checkerboard_saturated_4step")
CALIB = ("thomriiii", "calibration_dec2025")
TWO_PI = 2.0 * np.pi
#: The plane RMS the hand-resolved orders give (tests/test_stereo_realdata.py), mm.
HAND_RMS_MM = 0.83


def _measured(what: str, value: object) -> None:
    print(f"[realdata] {what}: {value}")


@pytest.fixture(scope="module")
def run(thomriiii_geometric: dict) -> dict:
    """import -> calibrate-stereo --from -> measure -c --depth-range, as a user would (once per
    session: conftest, shared with tests/test_acceptance_realdata.py)."""
    return thomriiii_geometric


def _coordinates(out: Path) -> dict[str, np.ndarray]:
    """Projector column and row from the absolute phases measure wrote, and the spatially
    unwrapped ones (relative: up to the F = 4 set's order)."""
    summary = json.loads((out / "phase_summary.json").read_text())
    maps = {}
    for fam in summary["families"]:
        key = "u" if fam["orientation"] == "vertical" else "v"
        scale = fam["pitch_px"] / TWO_PI
        assert fam["absolute_method"].startswith("geometric")
        maps[key] = tifffile.imread(out / fam["absolute_phase"]).astype(np.float64) * scale
        rel = tifffile.imread(out / fam["unwrapped_phase"]).astype(np.float64) * scale
        maps[f"{key}_relative"] = rel
    return maps


def test_thomriiii_flat_board_through_the_cli(run) -> None:  # type: ignore[no-untyped-def]
    """The board inside the calibration's uv_bbox (where the hand-resolved coordinates fall):
    every pixel is ordered, with the hand-resolved orders (k = 2 of the F = 4 sets), and the
    plane RMS over it, clipped squares included, is within 20 % of the hand-resolved 0.83 mm
    (measured 0.827 mm over 325109 pixels, 229436 of them clipped). The ambiguous pixels all
    lie outside it."""
    from hdrfringe.core.stereo import fit_plane

    out = run["out"]
    xyz = tifffile.imread(out / "xyz.tiff").astype(np.float64)
    c = _coordinates(out)
    with np.load(realdata_path(*CALIB, "projector_intrinsics.npz")) as z:
        u_lo, u_hi, v_lo, v_hi = (float(b) for b in z["uv_bbox"])
    # the orders by hand: k = 2 periods of the F = 4 sets (480 and 270 px) above the
    # spatially unwrapped phase, in both orientations
    hand = {key: c[f"{key}_relative"] + 2 * coarse for key, coarse in (("u", 480.0), ("v", 270.0))}
    with np.errstate(invalid="ignore"):
        inside = (hand["u"] > u_lo) & (hand["u"] < u_hi) & (hand["v"] > v_lo) & (hand["v"] < v_hi)
    valid = np.all(np.isfinite(xyz), axis=-1)
    assert valid[inside].all()
    for key in ("u", "v"):
        assert np.abs(c[key][inside] - hand[key][inside]).max() < 1e-3, key
        assert not np.any(inside & np.isnan(c[key]))
    clipped = np.zeros(valid.shape, bool)
    for path in out.glob("saturation_count__*.tiff"):
        clipped |= tifffile.imread(path) > 0
    fit = fit_plane(xyz[inside])
    r = fit.residuals
    clip_in = clipped[inside]
    metrics = json.loads((out / "metrics.json").read_text())["stereo"]
    _measured("depth range of the valid points, mm", metrics["depth_mm"])
    _measured("fringe order (u, v)", metrics["fringe_order"])
    _measured(
        "board inside uv_bbox: pixels (clipped), plane RMS all / clipped / unclipped",
        f"{inside.sum()} ({clip_in.sum()}), {fit.rms_mm:.3f} / "
        f"{np.sqrt(np.mean(r[clip_in] ** 2)):.3f} / {np.sqrt(np.mean(r[~clip_in] ** 2)):.3f} mm",
    )
    assert inside.sum() > 320_000 and clip_in.sum() > 200_000
    assert abs(fit.rms_mm / HAND_RMS_MM - 1) < 0.2
    for key in ("u", "v"):
        assert metrics["fringe_order"][key]["method"] == "geometric"
    assert metrics["depth_mm"]["min"] > 550 and metrics["depth_mm"]["max"] < 800
    printed = " ".join(run["stdout"].split())
    assert "absolute phase from the stereo calibration and the depth range 550..800 mm" in printed


def test_thomriiii_without_a_depth_range_names_the_option(run, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    """The captures alone cannot be triangulated: one line naming --depth-range, exit 2,
    nothing written."""
    out = tmp_path / "out"
    res = run_cli("measure", str(run["caps"]), "-c", str(run["calibration"]), "-o", str(out))
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert "measure --depth-range ZMIN:ZMAX" in lines[0]
    assert not out.exists()


def test_thomriiii_unambiguous_depth(run) -> None:  # type: ignore[no-untyped-def]
    """How deep a range the F = 4 pitches allow at the image centre from 550 mm, with the
    default margins (docs/stereo.md): the columns (480 px) to 1065 mm, the rows (270 px) to
    any depth (the baseline is nearly along the rows: they hardly move with depth)."""
    from hdrfringe.core.geometric_order import DEFAULT_MARGIN, unambiguous_depth_mm
    from hdrfringe.io.stereo_file import load_stereo_calibration

    cal = load_stereo_calibration(run["calibration"])
    share = 1 - 2 * DEFAULT_MARGIN
    centre = {"u_cam": 639.5, "v_cam": 359.5}
    u = float(unambiguous_depth_mm(cal, share * 480, "vertical", 550.0, **centre))
    v = float(unambiguous_depth_mm(cal, share * 270, "horizontal", 550.0, **centre))
    _measured("unambiguous from 550 mm at the centre (columns, rows)", f"{u:.0f}, {v} mm")
    assert u == pytest.approx(1065, abs=1) and np.isinf(v)
    assert u > 800  # the documented range is unambiguous at the centre


def test_thomriiii_rows_need_the_margin(run) -> None:  # type: ignore[no-untyped-def]
    """The rows hardly move along a ray here (the baseline is nearly horizontal: from 550 mm
    they never move by a pitch, test above), and the calibration places the decoded rows some
    10 px off the epipolar line (docs/stereo.md, "Fringe order of F = 4"): without the margin
    most pixels get no order (measured 11 % ordered), with the default eighth of a pitch
    (34 px) nearly all (99.7 %)."""
    from hdrfringe.core.geometric_order import geometric_order
    from hdrfringe.io.stereo_file import load_stereo_calibration

    cal = load_stereo_calibration(run["calibration"])
    (path,) = run["out"].glob("wrapped_phase__s4_p270_h_*.tiff")
    phi = tifffile.imread(path).astype(np.float64)
    kept = {}
    for margin in (0.0, 0.125):
        g = geometric_order(phi, 270.0, "horizontal", cal, (550.0, 800.0), margin=margin)
        kept[margin] = g.summary()["valid_fraction"]
    _measured("rows ordered without / with the margin", kept)
    assert kept[0.0] < 0.3 and kept[0.125] > 0.99
