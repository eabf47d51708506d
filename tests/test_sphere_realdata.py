"""kimthyung_sphere end to end, as a user would run it (docs/stereo.md, "kimthyung"):

    hdrfringe import ../shared/realdata/kimthyung_sphere \\
        -d docs/examples/import/kimthyung_sphere.toml -o caps
    hdrfringe calibrate-stereo \\
        --from ../shared/realdata/kimthyung_sphere/CalibrationDataDistortion -o s.h5
    hdrfringe measure caps -c s.h5 --stereo-directions v -o out

then a sphere fitted to the glossy sphere in ``out/xyz.tiff`` and a plane to the flat wall
behind it. The horizontal fringes (projector rows, ``v``) carry the depth (the baseline is
mostly vertical) and their convention is checked against the Gray code; the vertical set's
column convention in the shipped calibration is unresolved, so ``measure`` triangulates with
``v`` alone.

How the surfaces are selected (no pixel boxes): the wall is the robust plane
(:func:`hdrfringe.core.stereo.fit_plane`, ``robust=True``) of the valid points farther than the
median depth (the wall fills most of the far half of the scene); the sphere is the largest
8-connected image region of points more than 20 mm in front of that plane (the sphere's
radius is about 50 mm; the pedestal under it is mostly unlit and breaks off), fitted with
:func:`hdrfringe.core.stereo.fit_sphere` and refitted on the points within 3 robust standard
deviations (1.4826 x MAD) of its residuals until that set stops changing (drops the specular
spot and the silhouette edge). Skips when ``../shared/realdata`` is absent.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

# one worker computes the module fixtures (the measured sphere, the decoded board) once
pytestmark = [pytest.mark.realdata, pytest.mark.xdist_group("sphere-realdata")]

ROOT = Path(__file__).resolve().parents[1]
DESCRIPTION = ROOT / "docs" / "examples" / "import" / "kimthyung_sphere.toml"
TWO_PI = 2 * np.pi
PITCH = 114.0  # projector px (rows for the horizontal set) per fringe period = Gray stripe


def _measured(what: str, value: object) -> None:
    print(f"[realdata] {what}: {value}")


def wall_plane(xyz: np.ndarray):
    """Robust plane of the valid points beyond the median depth (the wall)."""
    from hdrfringe.core.stereo import fit_plane

    z = xyz[..., 2]
    far = np.isfinite(z) & (z > np.nanmedian(z))
    return fit_plane(np.where(far[..., None], xyz, np.nan), robust=True), far


def sphere_fit(xyz: np.ndarray, plane):
    """The largest connected region 20 mm in front of the wall, fitted with 3-MAD refits."""
    import cv2

    from hdrfringe.core.stereo import fit_sphere

    ok = np.all(np.isfinite(xyz), axis=-1)
    height = np.full(xyz.shape[:2], -np.inf)
    height[ok] = xyz[ok] @ plane.normal - plane.offset
    n, labels, stats, _ = cv2.connectedComponentsWithStats(
        (height > 20).astype(np.uint8), connectivity=8
    )
    assert n > 1, "nothing in front of the wall"
    region = labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    pts = xyz[region]
    keep = np.ones(len(pts), bool)
    for _ in range(10):
        fit = fit_sphere(pts[keep])
        d = np.linalg.norm(pts - fit.centre, axis=1) - fit.radius
        med = np.median(d[keep])
        new = np.abs(d - med) < 3 * 1.4826 * np.median(np.abs(d[keep] - med))
        if np.array_equal(new, keep):
            break
        keep = new
    return fit_sphere(pts[keep]), int(region.sum()), int(keep.sum())


@pytest.fixture(scope="session")
def measured(kimthyung_rows: dict) -> dict:
    """import -> calibrate-stereo --from -> measure --stereo-directions v, once (conftest)."""
    return kimthyung_rows


def test_description_declares_the_shipped_patterns() -> None:
    """Sine profile, the README's shift angles, the Gray code least significant bit first."""
    import tomllib

    desc = tomllib.loads(DESCRIPTION.read_text())
    vert, hori = desc["fringe"]
    assert vert["profile"] == hori["profile"] == "sine"
    assert vert["shifts_deg"] == [0, 120, 240]
    assert hori["shifts_deg"] == [-90, 30, -210]  # -pi/2, 2pi/3 - pi/2, -2pi/3 - pi/2
    assert [g["bit_order"] for g in desc["graycode"]] == ["lsb_first", "lsb_first"]


def test_phase_is_zero_on_the_gray_code_stripe_edges(measured: dict) -> None:
    """The description's phase offsets put the decoded phase 0 on the Gray-code stripe edges
    (rows 114 m, columns 114 m: 10 x 114 rows and 8 x 114 columns fill the projector), so Gray
    code + phase gives the absolute projector row and column. Without the offsets (the README's
    formulas alone) the edges sit at phase pi (rows) and 1.04 rad (columns): half a period
    off, where the phase-guided fringe order is ambiguous."""
    from hdrfringe.core.graycode import decode_graycode
    from hdrfringe.io.captures import read_capture_folder
    from hdrfringe.io.results import read_map_tiff

    caps = read_capture_folder(measured["caps"])
    images = caps.images.astype(float)
    summary = json.loads((measured["out"] / "phase_summary.json").read_text())
    for g in caps.graycode_sets():
        (s,) = [s for s in summary["sets"] if s["orientation"] == g.orientation]
        mean = read_map_tiff(measured["out"] / f"mean_intensity__{s['label']}.tiff")
        wrapped = read_map_tiff(measured["out"] / f"wrapped_phase__{s['label']}.tiff")
        mod = read_map_tiff(measured["out"] / f"modulation__{s['label']}.tiff")  # b, DN
        code = decode_graycode(images[list(g.frame_indices)], threshold=mean, min_contrast=0)
        index = np.where(mod > 10, code.index, np.nan)
        axis = 1 if g.orientation == "vertical" else 0
        a, p = np.moveaxis(index, axis, 0), np.moveaxis(wrapped, axis, 0)
        step = a[1:] - a[:-1]
        edge = (step == 1) & np.isfinite(p[1:]) & np.isfinite(p[:-1])
        assert edge.sum() > 3000 and np.mean(step[np.isfinite(step) & (step != 0)] == 1) > 0.9
        z = np.exp(1j * p[1:][edge]) + np.exp(1j * p[:-1][edge])
        at_edge = float(np.angle(np.mean(z / np.abs(z))))
        _measured(f"{g.orientation} phase on the Gray-code edges (rad)", round(at_edge, 3))
        assert abs(at_edge) < 0.15  # measured -0.032 (rows), -0.004 (columns)
    rows = summary["families"][1]
    assert rows["orientation"] == "horizontal" and rows["order_from"] == "graycode"
    v = read_map_tiff(measured["out"] / "absolute_phase_horizontal.tiff") * PITCH / TWO_PI
    # the wall spans rows 380..1140 of the 1140 projector rows
    assert 300 < np.nanpercentile(v, 1) and np.nanpercentile(v, 99.9) < 1141.5


def test_sphere_and_wall(measured: dict, kimthyung_sphere: dict) -> None:
    """The wall and the sphere, :func:`wall_plane` and :func:`sphere_fit` on ``xyz.tiff``
    (computed once: conftest ``kimthyung_sphere``)."""
    metrics = json.loads((measured["out"] / "metrics.json").read_text())
    assert metrics["stereo"]["directions"] == "v"
    plane, far = kimthyung_sphere["plane"], kimthyung_sphere["far"]
    _measured("wall plane", f"RMS {plane.rms_mm:.3f} mm, {plane.inliers.sum()} of {far.sum()}")
    fit, n_region, n_kept = (kimthyung_sphere[k] for k in ("fit", "n_region", "n_kept"))
    _measured(
        "sphere",
        f"radius {fit.radius:.3f} mm, RMS {fit.rms_mm:.3f} mm, centre "
        f"{np.round(fit.centre, 1).tolist()}, {n_kept} of {n_region} points",
    )
    assert n_region > 150000 and n_kept > 0.95 * n_region
    assert 49.0 < fit.radius < 53.0  # measured 51.12 mm
    assert fit.rms_mm < 1.3  # measured 1.02 mm (3-step ripple of near-square fringes)
    assert plane.rms_mm < 4.5  # measured 3.40 mm
    assert plane.inliers.sum() > 0.95 * far.sum()


def test_broken_conventions_fail_the_tolerances(measured: dict) -> None:
    """The same rows triangulated with a broken convention (every 2nd camera pixel): the
    calibration's row unit taken as one pattern row instead of two, or the rows of the
    README's formula without the measured half-period offset (v + 57: the phase's own origin
    instead of the Gray code's); each gives a sphere outside the tolerances above."""
    from hdrfringe.core.stereo import projector_coordinate, triangulate
    from hdrfringe.io.results import read_map_tiff
    from hdrfringe.io.stereo_file import convert_calibration, load_stereo_calibration

    phase = read_map_tiff(measured["out"] / "absolute_phase_horizontal.tiff")[::2, ::2]
    v = projector_coordinate(phase, PITCH)
    rows, cols = np.mgrid[0 : 2 * v.shape[0] : 2, 0 : 2 * v.shape[1] : 2].astype(float)
    good = load_stereo_calibration(measured["cal"])
    folder = measured["root"] / "CalibrationDataDistortion"
    variants = {
        "as measured": (good, v),
        "row scale 1": (convert_calibration(folder, projector_row_scale=1), v),
        "no half-period offset": (good, v + PITCH / 2),
    }
    result = {}
    for name, (cal, vv) in variants.items():
        xyz = triangulate(cal, cols, rows, v_proj=vv).xyz
        fit = sphere_fit(xyz, wall_plane(xyz)[0])[0]
        result[name] = (fit.radius, fit.rms_mm)
        _measured(f"sphere, {name}", f"radius {fit.radius:.2f} mm, RMS {fit.rms_mm:.3f} mm")
    radius, rms = result["as measured"]
    assert 49.0 < radius < 53.0 and rms < 1.3  # the subsample agrees with the full map
    for name in ("row scale 1", "no half-period offset"):
        r, e = result[name]
        assert not (49.0 < r < 53.0 and e < 1.3), name
