"""kimthyung_sphere with the default ``measure -c`` (``--stereo-directions auto``): the check
finds the vertical set's columns far off the calibration's epipolar lines and keeps the rows
(docs/stereo.md, "Choosing the directions"), so the sphere is the one the rows alone give; the
reference plane is the wall. Skips when ``../shared/realdata`` is absent.

References the code under test did not choose: the rows triangulated directly
(:func:`hdrfringe.core.stereo.triangulate` with ``v_proj`` alone, every 2nd pixel) for the sphere,
and the wall selected by geometry (the robust plane of the points beyond the median depth,
:func:`tests.test_sphere_realdata.wall_plane`) for the reference plane.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import run_cli
from tests.test_sphere_realdata import PITCH, sphere_fit, wall_plane

pytestmark = [pytest.mark.realdata, pytest.mark.xdist_group("sphere-realdata")]


def _measured(what: str, value: object) -> None:
    print(f"[realdata] {what}: {value}")


@pytest.fixture(scope="module")
def auto(kimthyung_stereo: dict) -> dict:
    """import -> calibrate-stereo --from (shared, conftest) -> measure -c (no
    --stereo-directions), once."""
    import tifffile

    cal, out = kimthyung_stereo["cal"], kimthyung_stereo["tmp"] / "auto"
    res = run_cli(
        "measure", str(kimthyung_stereo["caps"]), "-c", str(cal), "--no-previews", "-o",
        str(out), timeout=600,
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    xyz = tifffile.imread(out / "xyz.tiff").astype(np.float64)
    metrics = json.loads((out / "metrics.json").read_text())
    return {"cal": cal, "out": out, "stdout": res.stdout, "xyz": xyz, "metrics": metrics}


def test_auto_drops_the_columns(auto: dict) -> None:
    """The rays miss by tens of projector px, hundreds of times the noise (the maps' roughness:
    3-step sets, no noise model); a column error of that size explains it, a row error would
    need over ten times more: u dropped, printed on one line and recorded."""
    check = auto["metrics"]["stereo"]["direction_check"]
    _measured("direction check", {k: check[k] for k in ("miss_px", "miss_ratio", "sigma_px")})
    assert auto["metrics"]["stereo"]["directions"] == "v"
    assert check["verdict"] == "u dropped" and check["sigma_source"].startswith("measured")
    assert check["miss_ratio"] > 100  # measured 425 (57 px against 0.2 px)
    assert check["error_needed_sigma"]["v"] > 10 * check["error_needed_sigma"]["u"]
    lines = [ln for ln in auto["stdout"].splitlines() if ln.startswith("stereo directions auto")]
    assert len(lines) == 1 and lines[0].startswith("stereo directions auto: v (rays miss by")
    assert lines[0].endswith("u dropped)") and "warning" not in auto["stdout"]


def test_auto_sphere_is_the_rows_sphere(auto: dict) -> None:
    """The default's sphere within 2 % of the radius the rows alone give (triangulated here,
    every 2nd pixel, from the absolute phase measure wrote). Ray against ray (what auto did
    before the check) fits the sphere 1.5 times worse."""
    from hdrfringe.core.stereo import projector_coordinate, triangulate
    from hdrfringe.io.results import read_map_tiff
    from hdrfringe.io.stereo_file import load_stereo_calibration

    fit = sphere_fit(auto["xyz"], wall_plane(auto["xyz"])[0])[0]
    phase = read_map_tiff(auto["out"] / "absolute_phase_horizontal.tiff")[::2, ::2]
    v = projector_coordinate(phase, PITCH)
    phase = read_map_tiff(auto["out"] / "absolute_phase_vertical.tiff")[::2, ::2]
    u = projector_coordinate(phase, PITCH)
    rows, cols = np.mgrid[0 : 2 * v.shape[0] : 2, 0 : 2 * v.shape[1] : 2].astype(float)
    cal = load_stereo_calibration(auto["cal"])
    xyz = triangulate(cal, cols, rows, v_proj=v).xyz
    rows_only = sphere_fit(xyz, wall_plane(xyz)[0])[0]
    xyz = triangulate(cal, cols, rows, u_proj=u, v_proj=v).xyz
    ray_ray = sphere_fit(xyz, wall_plane(xyz)[0])[0]
    _measured(
        "sphere radius / RMS, auto, rows alone, ray against ray",
        [(round(f.radius, 3), round(f.rms_mm, 3)) for f in (fit, rows_only, ray_ray)],
    )
    assert fit.radius == pytest.approx(rows_only.radius, rel=0.02)  # measured 51.12 / 50.89
    assert ray_ray.rms_mm > 1.3 * rows_only.rms_mm  # measured 1.55 / 1.05 mm


def test_reference_plane_is_the_wall(auto: dict) -> None:
    """The reference plane (height.tiff's) within 2 degrees of the wall selected by geometry
    and its printed RMS within 10 % of the wall's 3.40 mm; the robust least-squares fit used
    before ran through the sphere's bulk, 47 degrees from the wall (61.15 mm RMS)."""
    ref = auto["metrics"]["stereo"]["reference_plane"]
    wall, _ = wall_plane(auto["xyz"])
    angle = float(np.degrees(np.arccos(min(1.0, abs(np.dot(ref["normal"], wall.normal))))))
    printed = re.search(r"reference plane RMS ([0-9.]+) mm", auto["stdout"])
    assert printed is not None
    _measured("reference plane", f"{angle:.2f} deg from the wall, RMS {printed.group(1)} mm")
    assert angle < 2.0  # measured 0.59
    assert float(printed.group(1)) == pytest.approx(3.40, rel=0.10)  # measured 3.246
    assert wall.rms_mm == pytest.approx(3.40, abs=0.01)
    from hdrfringe.core.stereo import fit_plane

    old = fit_plane(auto["xyz"], robust=True)  # the reference plane before: through the bulk
    tilt = float(np.degrees(np.arccos(min(1.0, abs(old.normal @ wall.normal)))))
    _measured("robust least-squares plane", f"{tilt:.1f} deg from the wall, RMS {old.rms_mm:.2f}")
    assert tilt > 45 and old.rms_mm > 10 * float(printed.group(1))
    height = Path(auto["out"]) / "height.tiff"
    from hdrfringe.io.results import read_map_tiff

    h = read_map_tiff(height)
    assert np.nanpercentile(np.abs(h), 50) < 5  # the wall near 0 (before: a -108..+100 ramp)


def test_reference_plane_with_the_rows_named(kimthyung_rows: dict) -> None:
    """The same with ``--stereo-directions v`` given (issue 24's wording; the shared rows
    measurement of conftest): reference plane within 2 degrees of the wall, printed RMS
    within 10 % of 3.40 mm."""
    import tifffile

    out = Path(kimthyung_rows["out"])
    xyz = tifffile.imread(out / "xyz.tiff").astype(np.float64)
    ref = json.loads((out / "metrics.json").read_text())["stereo"]["reference_plane"]
    wall, _ = wall_plane(xyz)
    angle = float(np.degrees(np.arccos(min(1.0, abs(np.dot(ref["normal"], wall.normal))))))
    printed = re.search(r"reference plane RMS ([0-9.]+) mm", kimthyung_rows["stdout"])
    assert printed is not None
    _measured("reference plane (v)", f"{angle:.2f} deg from the wall, RMS {printed.group(1)} mm")
    assert angle < 2.0
    assert float(printed.group(1)) == pytest.approx(3.40, rel=0.10)
