"""``hdrfringe fit plane|sphere RESULT --roi ...`` (issue 27 item 3) against closed forms.

Synthetic result folders as ``measure`` writes them (``height.tiff`` + ``points.ply``, or a
stereo ``xyz.tiff``) hold surfaces whose fits are known in closed form: a bowed plate
``z = c (x^2 + y^2)`` on a symmetric grid (least-squares plane ``z = mean``, F = ``2 c R^2``,
residuals ``c (x^2 + y^2 - mean)``), an exact tilted plane with one spike (the trimming rule
drops it: F = 0), a sphere cap (radius and centre exact). One end-to-end run measures a
simulated plate at 4 mm and fits it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import tifffile

from hdrfringe.core.strict_json import loads_strict
from hdrfringe.io.point_cloud import write_ply
from hdrfringe.io.results import read_map_tiff, write_map_tiff
from tests.conftest import run_cli_in_process

BOW = 1e-4  # 1/mm: z = BOW (x^2 + y^2) over |x|, |y| <= 40 mm -> F = 2 * BOW * 40^2 = 0.32 mm
TILT = (0.2, -0.1)  # dz/dx, dz/dy of the exact plane


def _plates() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 20x40 grid: columns 0-19 an exact tilted plane (400 points, a 1 mm spike at row 5,
    column 5), columns 22-38 rows 0-16 a bowed plate (17x17 = 289 points: no trimming), the
    rest invalid (columns 20-21 keep the two regions apart)."""
    h, w = 20, 40
    x, y, z = (np.full((h, w), np.nan) for _ in range(3))
    rows, cols = np.mgrid[0:20, 0:20].astype(float)
    x[:, :20], y[:, :20] = 5.0 * cols, -5.0 * rows
    z[:, :20] = 100.0 + TILT[0] * x[:, :20] + TILT[1] * y[:, :20]
    z[5, 5] += 1.0
    rows, cols = np.mgrid[0:17, 0:17].astype(float)
    bx, by = -40.0 + 5.0 * cols, 40.0 - 5.0 * rows
    x[:17, 22:39], y[:17, 22:39] = bx, by
    z[:17, 22:39] = 500.0 + BOW * (bx**2 + by**2)
    return x, y, z


@pytest.fixture(scope="module")
def plates(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A phase-to-height result folder of :func:`_plates` (height.tiff, points.ply)."""
    folder = tmp_path_factory.mktemp("fit") / "plates"
    folder.mkdir()
    x, y, z = _plates()
    write_map_tiff(folder / "height.tiff", z)
    write_ply(folder / "points.ply", x, y, z, normals=True)
    (folder / "metrics.json").write_text('{"notes": []}\n')
    return folder


def _fit_json(out: Path) -> dict:
    return loads_strict((out / "fit.json").read_text())


def test_plane_fits_of_a_bowed_plate_and_a_tilted_plane_are_the_closed_forms(
    plates: Path, tmp_path: Path
) -> None:
    """Rectangle ROI on the bowed plate: F = 2 c R^2 = 0.32 mm, normal +z, offset the mean
    height, the residual map c (x^2 + y^2 - mean) inside the ROI and NaN outside, printed.
    Polygon ROI (JSON) on the tilted plane: normal (-a, -b, 1)/|.|, and the spike (1 of 400
    points: floor(0.003 * 400) = 1) left out, so F = 0. Rejects: no trimming (F ~ 0.98 mm),
    F as the RMS or the largest |residual| (0.32 is the range), the ROI taken as inclusive
    (x1, y1 counted: other points), the residual sign flipped, points of the other region."""
    out = tmp_path / "bow"
    res = run_cli_in_process("fit", "plane", str(plates), "--roi", "22,0,39,17", "-o", str(out))
    assert res.returncode == 0, res.stderr
    x, y, z = _plates()
    bow = np.zeros(z.shape, dtype=bool)
    bow[:17, 22:39] = True
    r2 = x[bow] ** 2 + y[bow] ** 2
    want_res = BOW * (r2 - r2.mean())
    f = _fit_json(out)
    assert f["roi"] == {"rule": "rectangle", "given": "22,0,39,17", "pixels": 289, "points": 289}
    assert f["n_points"] == 289 and f["n_dropped"] == 0
    assert f["f_mm"] == pytest.approx(2 * BOW * 40.0**2, abs=2e-5)  # float32 PLY coordinates
    assert f["rms_mm"] == pytest.approx(np.sqrt(np.mean(want_res**2)), abs=2e-5)
    np.testing.assert_allclose(f["normal"], [0.0, 0.0, 1.0], atol=1e-7)
    assert f["offset_mm"] == pytest.approx(500.0 + BOW * r2.mean(), abs=1e-4)
    residual = read_map_tiff(out / "residual.tiff")
    assert residual.dtype == np.float32 and residual.shape == z.shape
    assert np.isnan(residual[~bow]).all()
    np.testing.assert_allclose(residual[bow], want_res, atol=3e-5)
    # the lines docs/fit.md shows
    assert "normal (0, 0, 1), offset 500.12 mm\nRMS 0.0755 mm, flatness F 0.32 mm" in res.stdout
    assert "289 points of the rectangle region (289 valid, 0 left out" in res.stdout
    assert sorted(p.name for p in out.iterdir()) == ["fit.json", "residual.png", "residual.tiff"]
    # the tilted plane, by a polygon around columns 0-19 (vertices inside the image)
    poly = tmp_path / "roi.json"
    poly.write_text(json.dumps({"polygon": [[0, 0], [19, 0], [19, 19], [0, 19]]}))
    out = tmp_path / "tilt"
    res = run_cli_in_process("fit", "plane", str(plates), "--roi", str(poly), "-o", str(out))
    assert res.returncode == 0, res.stderr
    f = _fit_json(out)
    a, b = TILT
    np.testing.assert_allclose(f["normal"], np.array([-a, -b, 1.0]) / np.hypot(np.hypot(a, b), 1))
    assert f["roi"]["points"] == 400 and f["n_dropped"] == 1
    assert f["f_mm"] < 1e-4 and f["rms_mm"] < 1e-4
    residual = read_map_tiff(out / "residual.tiff")
    assert residual[5, 5] == pytest.approx(1.0 / np.hypot(np.hypot(a, b), 1), abs=1e-4)
    # auto: the larger region (400 > 289), the same fit as the polygon's
    out = tmp_path / "auto"
    assert run_cli_in_process("fit", "plane", str(plates), "-o", str(out)).returncode == 0
    assert _fit_json(out)["roi"]["points"] == 400
    assert _fit_json(out)["f_mm"] == pytest.approx(f["f_mm"], abs=1e-9)


def test_sphere_fit_of_a_cap_gives_its_radius_centre_and_size_error(tmp_path: Path) -> None:
    """A stereo result (xyz.tiff, camera at the origin) of the near cap of a sphere, radius
    12.5 mm, centre (3, -4, 650) mm, sampled at 1 mm: radius and centre exact (to float32),
    PF ~ 0, PS = 25 - 25.02 with --diameter 25.02, residuals positive outside. Rejects: the
    radius as the diameter, PS with the wrong sign, the far cap (z + sqrt)."""
    h, w = 30, 30
    rows, cols = np.mgrid[0:h, 0:w].astype(float)
    x, y = cols - 12.0, rows - 19.0
    c, r = np.array([3.0, -4.0, 650.0]), 12.5
    under = r**2 - (x - c[0]) ** 2 - (y - c[1]) ** 2
    with np.errstate(invalid="ignore"):
        z = np.where(under > 0, c[2] - np.sqrt(under), np.nan)
    xyz = np.dstack([x, y, z]).astype(np.float32)
    xyz[np.isnan(z)] = np.nan
    folder = tmp_path / "sphere"
    folder.mkdir()
    tifffile.imwrite(folder / "xyz.tiff", xyz, photometric="minisblack", planarconfig="contig")
    out = tmp_path / "fit"
    res = run_cli_in_process(
        "fit", "sphere", str(folder), "--roi", "auto", "--diameter", "25.02", "-o", str(out)
    )
    assert res.returncode == 0, res.stderr
    f = _fit_json(out)
    assert f["cloud"] == "stereo" and f["roi"]["points"] == int(np.isfinite(z).sum()) > 334
    assert f["radius_mm"] == pytest.approx(r, abs=1e-3)
    assert f["diameter_mm"] == pytest.approx(2 * r, abs=2e-3)
    np.testing.assert_allclose(f["centre_mm"], c, atol=2e-3)
    assert f["pf_mm"] < 2e-3 and f["ps_mm"] == pytest.approx(-0.02, abs=2e-3)
    assert "size PS -0.02" in res.stdout and "radius 12.5" in res.stdout
    # more than the calibrated radius: a point pushed out has a positive residual
    xyz[10, 12, 2] -= 0.5  # toward the camera: outside the sphere
    out2 = tmp_path / "fit2"
    tifffile.imwrite(folder / "xyz.tiff", xyz, photometric="minisblack", planarconfig="contig")
    assert run_cli_in_process("fit", "sphere", str(folder), "-o", str(out2)).returncode == 0
    assert read_map_tiff(out2 / "residual.tiff")[10, 12] > 0.4


def _refused(res, out: Path, *needles: str) -> None:
    """Exit 2, one ``error:`` line with the needles, nothing written."""
    assert res.returncode == 2, res.stdout + res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    assert not out.exists() and not list(out.parent.glob(f".{out.name}*"))


def test_bad_input_is_one_line_exit_2_and_nothing_written(plates: Path, tmp_path: Path) -> None:
    """No such folder, a folder without a cloud, a rectangle out of the image or not of
    integers, an empty ROI (only invalid pixels), 3 points for a sphere, malformed polygon
    files (JSON, CSV, too few vertices, a vertex outside), an unknown shape, --diameter with a
    plane, no -o, an existing output without --force (kept)."""
    out = tmp_path / "out"
    base = ("fit", "plane", str(plates), "-o", str(out))
    _refused(run_cli_in_process("fit", "plane", str(tmp_path / "nope"), "-o", str(out)), out,
             "no such result folder")  # fmt: skip
    (tmp_path / "empty").mkdir()
    _refused(run_cli_in_process("fit", "plane", str(tmp_path / "empty"), "-o", str(out)), out,
             "measure")  # fmt: skip
    _refused(run_cli_in_process(*base, "--roi", "0,0,41,5"), out, "not inside the 40x20 image")
    _refused(run_cli_in_process(*base, "--roi", "0,0,4.5,5"), out, "integer")
    _refused(run_cli_in_process(*base, "--roi", "20,0,22,20"), out, "no valid point")
    sphere = ("fit", "sphere", str(plates), "-o", str(out))
    _refused(run_cli_in_process(*sphere, "--roi", "0,0,3,1"), out, "at least 4")
    bad = {
        "bad.json": ("[[0, 0], [5, 0]", "not JSON"),
        "two.json": ("[[0, 0], [5, 0]]", "at least 3"),
        "text.json": ('[[0, 0], [5, "a"], [0, 5]]', "vertex 2"),
        "bad.csv": ("x,y\n0,0\n5;0\n0,5\n", "line 3"),
        "out.csv": ("0,0\n50,0\n0,5\n", "outside the 40x20 image"),
        "roi.txt": ("0,0\n5,0\n0,5\n", "polygon file"),
    }
    for name, (text, needle) in bad.items():
        (tmp_path / name).write_text(text)
        _refused(run_cli_in_process(*base, "--roi", str(tmp_path / name)), out, name, needle)
    _refused(run_cli_in_process(*base, "--roi", str(tmp_path / "none.csv")), out, "no such")
    _refused(run_cli_in_process("fit", "cone", str(plates), "-o", str(out)), out, "plane, sphere")
    _refused(run_cli_in_process(*base, "--diameter", "25"), out, "--diameter")
    _refused(run_cli_in_process("fit", "plane", str(plates)), out, "-o")
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    res = run_cli_in_process(*base, "--roi", "22,0,39,17")
    assert res.returncode == 2 and "--force" in res.stderr
    assert [p.name for p in out.iterdir()] == ["keep.txt"]


def test_measure_mesh_and_outliers_then_fit_the_plate_at_4_mm(tmp_path: Path) -> None:
    """End to end at 64x48: calibrate a plate series, measure the 4 mm plate with --mesh ply
    --remove-outliers, read the mesh back (trimesh): points.ply's vertices, two triangles per
    valid 2x2 block (a flat plate: no step), then `fit plane --roi auto`: normal +z and offset
    the plate's 4 mm (the simulated truth), F small. Rejects: --mesh or --remove-outliers not
    reaching write_cloud, the fit reading points.ply out of step with the grid."""
    import trimesh
    from plyfile import PlyData

    series, cal, out = tmp_path / "series", tmp_path / "cal.h5", tmp_path / "m"
    res = run_cli_in_process(
        "simulate", "white_plate", "-o", str(series), "--series", "0,4,8", "--steps", "3",
        "--pitch", "1024,64,8", "--resolution", "64x48",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert run_cli_in_process("calibrate", str(series), "-o", str(cal)).returncode == 0
    plate = sorted(p for p in series.iterdir() if p.is_dir())[1]
    res = run_cli_in_process("measure", str(plate), "-c", str(cal), "-o", str(out), "--mesh",
                             "ply", "--remove-outliers", "--no-previews")  # fmt: skip
    assert res.returncode == 0, res.stderr
    bad = tmp_path / "m-obj"
    res = run_cli_in_process("measure", str(plate), "-c", str(cal), "-o", str(bad), "--mesh", "obj")
    assert res.returncode == 2 and "--mesh 'obj'" in res.stderr and not bad.exists()
    valid = np.isfinite(read_map_tiff(out / "height.tiff"))
    valid &= read_map_tiff(out / "outliers.tiff") == 0
    mesh = trimesh.load(out / "mesh.ply", process=False)
    points = PlyData.read(str(out / "points.ply"))["vertex"]
    assert len(mesh.vertices) == valid.sum() == points.count
    blocks = valid[:-1, :-1] & valid[1:, :-1] & valid[:-1, 1:] & valid[1:, 1:]
    assert len(mesh.faces) == 2 * blocks.sum()
    fit = tmp_path / "f"
    res = run_cli_in_process("fit", "plane", str(out), "-o", str(fit))
    assert res.returncode == 0, res.stderr
    f = _fit_json(fit)
    assert f["n_points"] + f["n_dropped"] == f["roi"]["points"] == valid.sum()
    assert f["normal"][2] > 0.9999 and f["offset_mm"] == pytest.approx(4.0, abs=0.02)
    assert f["f_mm"] < 0.5


def test_residual_png_colours_span_the_kept_points(
    plates: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The tilted plane with its 1 mm spike: the spike is the point the 0.3 % rule leaves out,
    so the PNG's colour range is the kept points' (|residual| < 1e-4 mm), not +-0.99 mm, which
    would draw the whole plane in one colour (seen on the kimthyung sphere: +-241 mm from one
    stray point). Rejects the range taken over every residual of the region."""
    import hdrfringe.io.results as results

    seen: dict[str, float] = {}
    real = results.write_preview_png

    def spy(path: Path, data: np.ndarray, **kw: object) -> None:
        seen["vmax"] = float(kw["vmax"])  # type: ignore[arg-type]
        real(path, data, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(results, "write_preview_png", spy)
    poly = tmp_path / "roi.json"
    poly.write_text(json.dumps({"polygon": [[0, 0], [19, 0], [19, 19], [0, 19]]}))
    out = tmp_path / "tilt"
    res = run_cli_in_process("fit", "plane", str(plates), "--roi", str(poly), "-o", str(out))
    assert res.returncode == 0, res.stderr
    assert 0 < seen["vmax"] < 1e-3, seen
    assert (out / "residual.png").is_file()
