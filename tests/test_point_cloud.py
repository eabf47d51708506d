"""Coloured point clouds with normals (issue 27 item 2): ``points.ply`` read back by trimesh.

Normals against closed forms (a tilted plane, a sphere cap), colours against the mean intensity
scaled by hand, the file against trimesh's and plyfile's readers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from plyfile import PlyData

from hdrfringe.io.point_cloud import grid_normals, intensity_colour, write_ply


def test_normals_of_a_tilted_plane_and_a_sphere_cap_are_the_closed_forms() -> None:
    """Plane z = a x + b y: n = (-a, -b, 1) / |.| everywhere, holes and edges included (one-sided
    differences there). Sphere: n = (P - C) / R, to the grid's second-order error. Rejects a
    swapped cross product (n flips to -z), unnormalised or one-sided-everywhere normals."""
    rows, cols = np.mgrid[0:24, 0:32].astype(float)
    x, y = 0.5 * cols, -0.5 * rows  # mm; y up the image, as measure's height points
    a, b = 0.3, -0.2
    z = a * x + b * y
    z[5:8, 10:14] = np.nan  # a hole
    n = grid_normals(x, y, z)
    want = np.array([-a, -b, 1.0]) / np.sqrt(a * a + b * b + 1.0)
    ok = np.isfinite(z)
    assert np.isnan(n[~ok]).all()
    np.testing.assert_allclose(n[ok], np.broadcast_to(want, n[ok].shape), atol=1e-12)
    # a sphere cap of radius 40 mm, centre below the grid: normals point up, out of the sphere
    r, c = 40.0, np.array([8.0, -6.0, -30.0])
    z = c[2] + np.sqrt(r * r - (x - c[0]) ** 2 - (y - c[1]) ** 2)
    n = grid_normals(x, y, z)
    radial = (np.dstack([x, y, z]) - c) / r
    inner = (slice(1, -1), slice(1, -1))  # central differences: O(h^2 / R^2)
    assert np.abs(n[inner] - radial[inner]).max() < 2e-3
    assert np.abs(n - radial).max() < 2e-2  # one-sided at the border: O(h / R)
    with pytest.raises(ValueError, match="organised"):
        grid_normals([1.0, 2.0], [0.0, 0.0], [0.0, 1.0])


def test_coloured_ply_loads_in_trimesh_with_its_points_colours_and_normals(tmp_path: Path) -> None:
    import trimesh  # a test dependency (pyproject dev extra): a missing one fails, not skips
    rng = np.random.default_rng(5)
    rows, cols = np.mgrid[0:12, 0:16].astype(float)
    x, y = 0.5 * cols, -0.5 * rows
    z = 0.1 * x + rng.normal(0.0, 1e-3, x.shape)
    z[rng.random(z.shape) < 0.2] = np.nan
    mean = rng.uniform(0.0, 4095.0, z.shape)  # 12-bit mean intensity, DN
    gray = intensity_colour(mean, 12)
    ok = np.isfinite(z)
    # the colour by hand: 255 * I / 4095, rounded
    np.testing.assert_array_equal(gray, np.rint(mean * 255.0 / 4095.0).astype(np.uint8))
    path = tmp_path / "points.ply"
    assert write_ply(path, x, y, z, colour=gray, normals=True) == ok.sum()
    cloud = trimesh.load(path)
    assert isinstance(cloud, trimesh.PointCloud)
    assert len(cloud.vertices) == ok.sum()
    np.testing.assert_allclose(cloud.vertices[:, 2], z[ok].astype(np.float32))
    colours = np.asarray(cloud.colors)  # RGBA
    np.testing.assert_array_equal(colours[:, :3], np.repeat(gray[ok][:, None], 3, axis=1))
    v = PlyData.read(str(path))["vertex"]
    normals = np.stack([v["nx"], v["ny"], v["nz"]], axis=1)
    has = np.any(normals != 0, axis=1)
    # a normal needs a valid neighbour along the row and along the column; else 0, 0, 0
    pad = np.pad(ok, 1)
    rowwise = pad[1:-1, :-2] | pad[1:-1, 2:]
    colwise = pad[:-2, 1:-1] | pad[2:, 1:-1]
    np.testing.assert_array_equal(has, (rowwise & colwise)[ok])
    assert has.mean() > 0.8
    np.testing.assert_allclose(np.linalg.norm(normals[has], axis=1), 1.0, atol=1e-6)
    assert (normals[has, 2] > 0.9).all()  # toward the camera (+z), slope 0.1
    # RGB given as such; a wrong size is refused
    rgb = np.dstack([gray, 255 - gray, np.zeros_like(gray)])
    write_ply(path, x, y, z, colour=rgb)
    v = PlyData.read(str(path))["vertex"]
    np.testing.assert_array_equal(v["green"], 255 - gray[ok])
    assert "nx" not in v.data.dtype.names
    with pytest.raises(ValueError, match="gray or RGB"):
        write_ply(path, x, y, z, colour=gray[:5])


def test_measure_colours_its_points_by_the_mean_intensity(tmp_path: Path) -> None:
    """write_measurement's points.ply: the valid pixels, coloured by the finest set's mean
    intensity scaled by hand (8-bit camera: the DN rounded), normals up (a plane)."""
    from hdrfringe.core.reconstruct import CameraGeometry
    from hdrfringe.pipeline import measure
    from hdrfringe.tasks.measure import _point_colour, write_height_outputs
    from tests.test_phase_outputs import _captures

    result = measure(_captures())
    finest = result.decoded.set_results[result.decoded.primary.sets[-1].label]
    gray = _point_colour(result)
    assert gray is not None
    mean = np.nan_to_num(finest.mean_intensity, nan=0.0)
    np.testing.assert_array_equal(gray, np.clip(np.rint(mean), 0, 255).astype(np.uint8))
    height = np.full(gray.shape, 2.0)
    height[:, :3] = np.nan
    write_height_outputs(tmp_path, height, CameraGeometry(800.0, 500.0), colour=gray)
    v = PlyData.read(str(tmp_path / "points.ply"))["vertex"]
    ok = np.isfinite(height)
    assert v.count == ok.sum()
    np.testing.assert_array_equal(v["red"], gray[ok])
    np.testing.assert_allclose(v["nz"], 1.0, atol=1e-6)  # a flat plate faces the camera
