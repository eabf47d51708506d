"""Coloured point clouds with normals (issue 27 item 2): ``points.ply`` read back by trimesh.

Normals against closed forms (a tilted plane, a sphere cap), colours against the mean intensity
scaled by hand, the file against trimesh's and plyfile's readers.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from plyfile import PlyData

from hdrfringe.errors import InputError
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


def _step_scene() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A 7x9 grid, 0.5 mm pitch: z = 0 left of column 5, a 3 mm step up from column 5 on;
    four invalid pixels (two single holes, a hole on the step's edge, a corner)."""
    rows, cols = np.mgrid[0:7, 0:9].astype(float)
    x, y = 0.5 * cols, -0.5 * rows
    z = np.where(cols >= 5, 3.0, 0.0)
    for r, c in ((1, 1), (3, 6), (5, 4), (6, 8)):
        z[r, c] = np.nan
    gray = (10 * rows + cols).astype(np.uint8)
    return x, y, z, gray


def _expected_triangles(x, y, z, step_col: int) -> list[tuple[tuple[float, ...], ...]]:
    """The grid mesh's triangles by their corner coordinates, by loops over the pixels: two
    per 2x2 block of valid pixels, none in a block across the step; sorted for comparison."""
    p = np.dstack([x, y, z]).astype(np.float32)
    tris = []
    for r in range(x.shape[0] - 1):
        for c in range(x.shape[1] - 1):
            corners = [(r, c), (r, c + 1), (r + 1, c), (r + 1, c + 1)]
            if any(np.isnan(z[q]) for q in corners) or c + 1 == step_col:
                continue
            a, b, cc, d = (tuple(p[q].tolist()) for q in corners)
            tris += [(a, cc, b), (b, cc, d)]
    return sorted(tris)


def test_grid_mesh_reads_back_in_trimesh_and_leaves_the_step_open(tmp_path: Path) -> None:
    """measure's mesh (write_cloud, CloudOptions(mesh=...)) on a step scene, read by trimesh:
    the vertices are points.ply's (count, coordinates, colours), the triangles are those of
    loops over the pixels (two per valid 2x2 block, none across the 3 mm step: 6 pitches, above
    the default 4x the median pitch), all facing the camera (+z); the STL holds the same
    triangles. Rejects: a mesh bridging the step, a vertex index off by one (cumsum without
    -1: other coordinates), triangles wound away from the camera, blocks with a hole meshed."""
    import trimesh

    from hdrfringe.tasks.measure import CloudOptions, write_cloud

    x, y, z, gray = _step_scene()
    ok = np.isfinite(z)
    want = _expected_triangles(x, y, z, step_col=5)
    # by hand: 8 x 6 = 48 blocks; 6 across the step (block column 4); the holes spoil
    # 4 + 4 + 4 + 1 = 13 blocks, 2 of them ((4, 4), (5, 4)) across the step already: 31 blocks
    assert len(want) == 2 * 31
    files = write_cloud(tmp_path, x, y, z, colour=gray, cloud=CloudOptions(mesh="ply"))
    assert files == ["points.ply", "mesh.ply"]
    mesh = trimesh.load(tmp_path / "mesh.ply", process=False)
    points = PlyData.read(str(tmp_path / "points.ply"))["vertex"]
    assert len(mesh.vertices) == ok.sum() == points.count
    np.testing.assert_array_equal(mesh.vertices[:, 2], z[ok].astype(np.float32))
    np.testing.assert_array_equal(np.asarray(mesh.visual.vertex_colors)[:, 0], gray[ok])
    got = sorted(tuple(tuple(v) for v in tri.tolist()) for tri in mesh.vertices[mesh.faces])
    assert len(mesh.faces) == len(want) and got == want
    assert (mesh.face_normals[:, 2] > 0.99).all()  # toward the camera, as the points' normals
    tz = mesh.vertices[mesh.faces][..., 2]
    assert (np.ptp(tz, axis=1) == 0).all()  # no triangle spans the step
    write_cloud(tmp_path, x, y, z, cloud=CloudOptions(mesh="stl"))
    stl = trimesh.load(tmp_path / "mesh.stl", process=False)
    got_stl = sorted(tuple(tuple(v) for v in tri.tolist()) for tri in stl.triangles)
    assert got_stl == want
    # a threshold above the step bridges it: the default is what leaves it open
    from hdrfringe.core.cloud import grid_mesh

    assert len(grid_mesh(x, y, z, max_edge=10.0)) == len(want) + 2 * (6 - 2)
    with pytest.raises(InputError, match="--mesh 'obj'"):
        CloudOptions(mesh="obj")


def test_outlier_removal_takes_out_the_spikes_only(tmp_path: Path) -> None:
    """The mean-k-neighbour rule (k 20, 2 std) on a 24x24 plane at 1 mm pitch with three 25 mm
    spikes: exactly the spikes go (the plane's edge and corner points, whose neighbours are
    farther, stay); write_cloud leaves them out of points.ply and the mesh, maps them in
    outliers.tiff, and the normals next to them are the plane's. Rejects: no removal, the
    threshold's sign flipped (most points removed), the point counted as its own neighbour
    (a zero distance in every mean: checked on the k = 1 closed form)."""
    import trimesh

    from hdrfringe.core.cloud import statistical_outliers
    from hdrfringe.io.results import read_map_tiff
    from hdrfringe.tasks.measure import CloudOptions, write_cloud

    rows, cols = np.mgrid[0:24, 0:24].astype(float)
    x, y, z = cols, -rows, np.zeros((24, 24))
    spikes = [(3, 4), (12, 12), (20, 2)]
    for s in spikes:
        z[s] = 25.0
    out = statistical_outliers(np.c_[x.ravel(), y.ravel(), z.ravel()])
    want = [np.ravel_multi_index(s, z.shape) for s in spikes]
    np.testing.assert_array_equal(np.flatnonzero(out), want)
    # k = 1 on a line 0, 1, 2, 3, 100: d = 1, 1, 1, 1, 97; mean 20.2, std 38.4; at 1.5 std the
    # threshold is 77.8: only 100 goes; at 2.5 std (116.2) none
    line = np.c_[[0.0, 1, 2, 3, 100], np.zeros(5), np.zeros(5)]
    assert statistical_outliers(line, k=1, std_ratio=1.5).tolist() == [False] * 4 + [True]
    assert not statistical_outliers(line, k=1, std_ratio=2.5).any()
    files = write_cloud(tmp_path, x, y, z, cloud=CloudOptions(mesh="ply", remove_outliers=True))
    assert files == ["outliers.tiff", "points.ply", "mesh.ply"]
    removed = read_map_tiff(tmp_path / "outliers.tiff")
    assert removed.dtype == np.uint8 and removed.sum() == 3
    assert all(removed[s] == 1 for s in spikes)
    v = PlyData.read(str(tmp_path / "points.ply"))["vertex"]
    assert v.count == 24 * 24 - 3 and v["z"].max() == 0.0
    np.testing.assert_allclose(v["nz"][v["nz"] != 0], 1.0)  # no normal bent by a spike
    mesh = trimesh.load(tmp_path / "mesh.ply", process=False)
    # 23 x 23 blocks, each spike (none on the border) spoils 4
    assert len(mesh.faces) == 2 * (23 * 23 - 4 * 3)
