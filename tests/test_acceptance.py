"""The acceptance library (issue 25): VDI/VDE 2634 Part 2 quantities, trimming, segmentation,
the acceptance file and the pass/fail table.

References are closed forms of synthetic point sets built here, not outputs of the code under
test: a sphere cap with a form deviation ``a cos(4 phi)`` whose least-squares sphere is, by
symmetry, the nominal one (PF = 2a, PS = the size error), a ball bar of known length, a plate
with a bow ``c (x^2 + y^2)`` whose least-squares plane is, by symmetry, ``z = mean(z)``
(F = 2 c L^2). Each block also runs a broken variant (a small alternative written here) and
shows that the same assertion rejects it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import least_squares

from hdrfringe.core.acceptance import (
    GUIDELINE_TRIM,
    ArtefactNotFoundError,
    Mpe,
    MpeSet,
    body_diagonal,
    check_position,
    flatness_error,
    probing_error,
    segment_ball_bar,
    segment_plane,
    segment_sphere,
    sphere_spacing_error,
    summarize,
    trim_count,
)
from hdrfringe.core.stereo import fit_plane, fit_sphere
from hdrfringe.errors import InputError
from hdrfringe.io.acceptance_file import load_acceptance_file, parse_acceptance

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "examples" / "acceptance.toml"


def _rotation_to(axis: np.ndarray) -> np.ndarray:
    """A rotation taking +z to ``axis`` (Rodrigues)."""
    z = np.array([0.0, 0.0, 1.0])
    a = axis / np.linalg.norm(axis)
    v, c = np.cross(z, a), float(z @ a)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


def sphere_cap(
    centre: tuple[float, float, float],
    radius: float,
    *,
    form: float = 0.0,
    rings: int = 5,
    per_ring: int = 64,
    max_angle_deg: float = 70.0,
) -> np.ndarray:
    """A cap facing the origin (the camera): rings of polar angle 10..max deg about the axis
    centre -> origin, ``per_ring`` azimuths each, radius ``R + form * cos(4 phi)``.

    Every ring's sums of ``cos(4 phi)``, ``cos(4 phi) cos(phi)`` and ``cos(4 phi) sin(phi)``
    vanish (64 even azimuths), so at the true centre and radius the residuals ``form cos 4phi``
    are orthogonal to the fit's Jacobian: the least-squares sphere is exactly (centre, R),
    and PF = 2 |form| (cos 4phi reaches +-1 on the grid).
    """
    c = np.asarray(centre, dtype=float)
    theta = np.deg2rad(np.linspace(10.0, max_angle_deg, rings))
    phi = 2 * np.pi * np.arange(per_ring) / per_ring
    t, p = (g.ravel() for g in np.meshgrid(theta, phi, indexing="ij"))
    local = np.c_[np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)]
    rho = radius + form * np.cos(4 * p)
    return c + (rho[:, None] * local) @ _rotation_to(-c).T


# --- probing error: PF and PS ---------------------------------------------------------------

R_TRUE, FORM = 12.51, 0.01  # a 25.02 mm sphere (calibrated 25.00) with a +-0.01 mm form error
D_CAL = 25.0
PF_EXACT, PS_EXACT = 2 * FORM, 2 * R_TRUE - D_CAL


def _pf_ps_match(pf: float, ps: float, tol: float) -> bool:
    return abs(pf - PF_EXACT) <= tol and abs(ps - PS_EXACT) <= tol


def _fixed_radius(points: np.ndarray) -> tuple[float, float]:
    """Broken: the radius fixed to the calibrated one, only the centre fitted."""
    r = D_CAL / 2
    c0 = points.mean(axis=0)
    fit = least_squares(lambda c: np.linalg.norm(points - c, axis=1) - r, c0, method="lm")
    res = np.linalg.norm(points - fit.x, axis=1) - r
    return float(np.ptp(res)), 0.0


def _centre_from_mean(points: np.ndarray) -> tuple[float, float]:
    """Broken: the centre taken as the mean of the points, the radius as the mean distance."""
    dist = np.linalg.norm(points - points.mean(axis=0), axis=1)
    return float(np.ptp(dist - dist.mean())), float(2 * dist.mean() - D_CAL)


def test_probing_error_of_a_cap_with_a_known_form_deviation_is_the_closed_form() -> None:
    pts = sphere_cap((30.0, -20.0, 650.0), R_TRUE, form=FORM)
    assert trim_count(len(pts)) == 0  # 320 points: the rule drops none, the answer is exact
    p = probing_error(pts, D_CAL)
    assert _pf_ps_match(p.form_mm, p.size_mm, 1e-9)
    np.testing.assert_allclose(p.sphere.centre, [30.0, -20.0, 650.0], atol=1e-9)
    # the broken variants give numbers the same check rejects
    assert not _pf_ps_match(*_fixed_radius(pts), 1e-3)
    assert not _pf_ps_match(*_centre_from_mean(pts), 1e-3)


def test_probing_error_with_noise_stays_within_the_noise() -> None:
    rng = np.random.default_rng(11)
    pts = sphere_cap((-40.0, 10.0, 700.0), R_TRUE, form=FORM, rings=8)
    sigma = 0.002
    normal = (pts - [-40.0, 10.0, 700.0]) / np.linalg.norm(pts - [-40.0, 10.0, 700.0], axis=1)[
        :, None
    ]
    noise = rng.normal(0, sigma, len(pts))
    p = probing_error(pts + noise[:, None] * normal, D_CAL, trim=0)
    assert abs(p.size_mm - PS_EXACT) < sigma  # the standard error is ~ 2 sigma / sqrt(512)
    assert PF_EXACT - 1e-3 <= p.form_mm <= PF_EXACT + 2 * np.abs(noise).max() + 1e-3


# --- sphere-spacing error ----------------------------------------------------------------------


def test_sphere_spacing_error_of_a_ball_bar_of_known_length() -> None:
    """Two caps facing the camera from different directions, centres 150.03 mm apart along a
    space diagonal: SD = +0.03 exactly; the centres from the means of the points do not."""
    direction = np.array([1.0, 1.0, 1.0]) / math.sqrt(3)
    mid = np.array([0.0, 0.0, 700.0])
    ca, cb = mid - 75.015 * direction, mid + 75.015 * direction
    a = sphere_cap(tuple(ca), 12.49, form=0.004)
    b = sphere_cap(tuple(cb), 12.52, form=0.006)
    s = sphere_spacing_error(a, b, 150.0)
    assert abs(s.spacing_mm - 0.03) <= 1e-9
    assert abs(s.spheres[0].diameter_mm - 24.98) <= 1e-9
    broken = np.linalg.norm(a.mean(axis=0) - b.mean(axis=0)) - 150.0
    assert abs(broken - 0.03) > 1e-3


# --- flatness ----------------------------------------------------------------------------------


def bowed_plate(c: float, half: float = 50.0, n: int = 17, tilt_deg: float = 25.0) -> np.ndarray:
    """``z = c (x^2 + y^2)`` on an odd n x n grid over [-half, half]^2, then tilted and moved.

    The grid's symmetries (x -> -x, y -> -y, x <-> y) make the least-squares plane's normal
    +-z before the tilt, so the plane is ``z = mean(z)`` and F = ``c * 2 half^2`` (corner
    minus centre), whatever the rigid motion after.
    """
    x, y = np.meshgrid(np.linspace(-half, half, n), np.linspace(-half, half, n))
    local = np.c_[x.ravel(), y.ravel(), c * (x**2 + y**2).ravel()]
    rot = _rotation_to(np.array([math.sin(math.radians(tilt_deg)), 0.0, -1.0]))
    return local @ rot.T + [5.0, -8.0, 600.0]


def test_flatness_of_a_bowed_plate_is_the_closed_form() -> None:
    pts = bowed_plate(2e-5)
    assert trim_count(len(pts)) == 0  # 289 points
    assert abs(flatness_error(pts).flatness_mm - 2e-5 * 2 * 50.0**2) <= 1e-9
    # broken: distances along the camera's z instead of orthogonal to the plane
    coef, *_ = np.linalg.lstsq(np.c_[pts[:, :2], np.ones(len(pts))], pts[:, 2], rcond=None)
    vertical = pts[:, 2] - np.c_[pts[:, :2], np.ones(len(pts))] @ coef
    assert abs(float(np.ptp(vertical)) - 0.1) > 1e-3


# --- the trimming rule at exactly 0.3 % ----------------------------------------------------------


def test_trim_count_rounds_down_without_losing_exact_products() -> None:
    assert [trim_count(n) for n in (333, 334, 666, 667, 999, 1000, 1001)] == [0, 1, 1, 2, 2, 3, 3]
    assert trim_count(100, 0.29) == 29  # 0.29 * 100 = 28.999999999999996 in floating point
    assert trim_count(1000, 0.0) == 0
    with pytest.raises(InputError, match="trim fraction"):
        trim_count(1000, 0.6)


def _unit_sphere_points(n: int, seed: int) -> np.ndarray:
    u = np.random.default_rng(seed).normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


@pytest.mark.parametrize("n", [1000, 1333])
@pytest.mark.parametrize("quantity", ["PF", "F"])
def test_trimming_drops_exactly_floor_0_3_percent(quantity: str, n: int) -> None:
    """k = floor(0.003 n) = 3 planted 2 mm outliers are ignored; with k + 1 one remains.

    n = 1000 is exactly 0.3 % (3.0); n = 1333 (3.999) rejects a count rounded to nearest or
    up (4), which would ignore the fourth outlier too. Broken variants: the fraction 0, and
    the range of a plain fit's residuals (no trimming), keep all outliers.
    """
    assert trim_count(n) == 3 == math.floor(GUIDELINE_TRIM * n) != round(GUIDELINE_TRIM * 1333)
    if quantity == "PF":
        clean = 12.5 * _unit_sphere_points(n, 3) + [0, 0, 600.0]

        def value(pts: np.ndarray, trim: float = GUIDELINE_TRIM) -> float:
            return probing_error(pts, 25.0, trim=trim).form_mm

        def untrimmed(pts: np.ndarray) -> float:
            return float(np.ptp(fit_sphere(pts).residuals))

        def plant(pts: np.ndarray, k: int) -> np.ndarray:
            out = pts.copy()
            out[:k] += 2.0 * (out[:k] - [0, 0, 600.0]) / 12.5  # 2 mm outward
            return out
    else:
        xy = np.random.default_rng(4).uniform(-100, 100, (n, 2))
        clean = np.c_[xy, 600 + 0.2 * xy[:, 0]]

        def value(pts: np.ndarray, trim: float = GUIDELINE_TRIM) -> float:
            return flatness_error(pts, trim=trim).flatness_mm

        def untrimmed(pts: np.ndarray) -> float:
            return float(np.ptp(fit_plane(pts).residuals))

        def plant(pts: np.ndarray, k: int) -> np.ndarray:
            out = pts.copy()
            out[:k, 2] += 2.0
            return out

    assert value(clean) < 1e-9
    assert value(plant(clean, 3)) < 1e-9  # all three dropped, the refit is exact
    assert value(plant(clean, 4)) > 1.5  # one of four stays
    assert value(plant(clean, 3), trim=0.0) > 1.5  # the fraction 0 keeps them all
    assert untrimmed(plant(clean, 3)) > 1.5  # so does a plain fit


def test_the_trimmed_points_are_marked_and_keep_their_residuals() -> None:
    pts = 12.5 * _unit_sphere_points(1000, 5)
    pts[7] *= 1.1
    m = probing_error(pts, 25.0).sphere
    assert m.n_dropped == 3 and m.n_points == 997 and not m.kept[7]
    assert abs(m.residuals[7] - 1.25) < 1e-6  # still reported (for residual maps)


# --- segmentation -------------------------------------------------------------------------------


def _scene(seed: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """A 25 mm sphere cap at (10, -5, 600) before a plane at 620 mm, noise 0.02 mm, as a
    40 x 100 "image" of points with a few invalid (NaN); and the truth mask of the sphere."""
    rng = np.random.default_rng(seed)
    cap = sphere_cap((10.0, -5.0, 600.0), 12.5, rings=10, max_angle_deg=80.0)  # 640 points
    xy = rng.uniform(-80, 80, (3360, 2))
    keep = np.linalg.norm(xy - [10, -5], axis=1) > 14  # the plane behind the sphere is hidden
    plane = np.c_[xy, np.full(len(xy), 620.0)][keep]
    cloud = np.r_[cap, plane] + rng.normal(0, 0.02, (len(cap) + len(plane), 3))
    truth = np.r_[np.ones(len(cap), bool), np.zeros(len(plane), bool)]
    pad = 4000 - len(cloud)
    cloud = np.r_[cloud, np.full((pad, 3), np.nan)]
    truth = np.r_[truth, np.zeros(pad, bool)]
    return cloud.reshape(40, 100, 3), truth.reshape(40, 100)


def test_segment_sphere_finds_the_cap_in_front_of_a_plane() -> None:
    cloud, truth = _scene()
    seg = segment_sphere(cloud, 25.0)
    assert np.array_equal(seg.mask, truth)
    np.testing.assert_allclose(seg.centre, [10.0, -5.0, 600.0], atol=0.01)
    p = probing_error(cloud[seg.mask], 25.0)
    assert abs(p.size_mm) < 0.01 and p.form_mm < 0.2
    # a position's rows and record are plain JSON
    mpes = MpeSet(Mpe(0.2), Mpe(0.01), Mpe(0.05), Mpe(0.04))
    assert [r.passed for r in p.rows("sphere-01", mpes)] == [True, True]
    record = json.loads(json.dumps(p.to_dict(), allow_nan=False))
    assert record["sphere"]["n_dropped"] == trim_count(int(truth.sum())) == 1  # 640 points
    assert record["sphere"]["n_points"] == 639 and record["ps_mm"] == p.size_mm
    near = segment_sphere(cloud, 25.0, expected_centre=(12.0, -4.0, 598.0))
    assert np.array_equal(near.mask, truth)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"nominal_diameter_mm": 50.0}, "sphere of diameter 50 mm not found"),
        (
            {"nominal_diameter_mm": 25.0, "expected_centre": (-60, 40, 600)},
            r"not found among 0 points within 25 mm of \[-60.0, 40.0, 600.0\]",
        ),
    ],
)
def test_segment_sphere_not_found_is_one_line(kwargs: dict, match: str) -> None:
    cloud, _ = _scene()
    with pytest.raises(ArtefactNotFoundError, match=match) as err:
        segment_sphere(cloud, **kwargs)
    assert "\n" not in str(err.value) and "acceptance file" in str(err.value)


def test_segment_sphere_on_a_plane_alone_is_not_found() -> None:
    xy = np.random.default_rng(9).uniform(-80, 80, (3000, 2))
    with pytest.raises(ArtefactNotFoundError, match="sphere of diameter 25 mm not found"):
        segment_sphere(np.c_[xy, np.full(3000, 620.0)], 25.0)


def test_segment_ball_bar_and_plane() -> None:
    direction = np.array([1.0, 0.3, 0.2]) / np.linalg.norm([1.0, 0.3, 0.2])
    ca, cb = np.array([0, 0, 650.0]) - 75 * direction, np.array([0, 0, 650.0]) + 75 * direction
    a, b = sphere_cap(tuple(ca), 12.5, rings=8), sphere_cap(tuple(cb), 10.0, rings=8)
    xy = np.random.default_rng(10).uniform(-150, 150, (3000, 2))
    plane = np.c_[xy, np.full(3000, 700.0)]
    cloud = np.r_[a, b, plane]
    sa, sb = segment_ball_bar(cloud, (25.0, 20.0), 150.0)
    assert sa.n_points == len(a) and sb.n_points == len(b) and sa.mask[: len(a)].all()
    s = sphere_spacing_error(cloud[sa.mask], cloud[sb.mask], 150.0)
    assert abs(s.spacing_mm) < 1e-9
    with pytest.raises(ArtefactNotFoundError, match=r"ball bar not found: .* 150\.000 mm apart"):
        segment_ball_bar(cloud, (25.0, 20.0), 145.0, distance_tolerance=0.01)
    with pytest.raises(ArtefactNotFoundError, match=r"^ball bar, sphere B: sphere of diameter 20"):
        segment_ball_bar(cloud, (25.0, 20.0), 120.0)
    seg = segment_plane(cloud, size_mm=(300.0, 300.0))
    assert seg.n_points == 3000 and seg.mask[-3000:].all()
    mpes = MpeSet(Mpe(0.03), Mpe(0.03), Mpe(0.02, 20000.0), Mpe(0.01, 1e4))
    rows = [*s.rows("bar-1", mpes), *flatness_error(cloud[seg.mask]).rows("plane-1", mpes, 300.0)]
    assert [(r.quantity, r.mpe_mm, r.passed) for r in rows] == [
        ("SD", 0.0275, True),
        ("F", 0.04, True),
    ]
    assert json.dumps(s.to_dict(), allow_nan=False).count("centre_mm") == 2
    with pytest.raises(ArtefactNotFoundError, match="plane not found: 3 finite points"):
        segment_plane(plane[:3])


# --- the acceptance file --------------------------------------------------------------------------


def test_the_example_acceptance_file_loads() -> None:
    spec = load_acceptance_file(EXAMPLE)
    assert spec.mpe.pf == Mpe(0.030) and spec.mpe.sd == Mpe(0.020, 20000.0)
    assert spec.sphere is not None and spec.sphere.diameter_mm == 50.002
    assert spec.ball_bar is not None and spec.ball_bar.diameters_mm == (25.001, 24.998)
    assert spec.plane is not None and spec.plane.flatness_mm == 0.003
    assert spec.l0_mm == pytest.approx(math.sqrt(300**2 + 200**2 + 150**2), abs=1e-12)
    assert spec.source == str(EXAMPLE) and len(spec.sha256) == 64


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (("[mpe]", "[mpe]\npff = 1"), r"'mpe.pff' is not a key .*did you mean 'pf'"),
        (("name =", "nam ="), r"'nam' is not a key .*did you mean 'name'"),
        (("width = 50.0", ""), r"'plane.width' is missing; add it"),
        (("pf = 0.030", "pf = nan"), r"'mpe.pf' must be a non-negative finite number of mm"),
        (("ps = 0.025", "ps = -0.025"), r"'mpe.ps' must be a non-negative finite number"),
        (("diameter = 50.002", 'diameter = "50"'), r"'sphere.diameter' must be a positive"),
        (("length = 200.0", "length = true"), r"'plane.length' must be a positive"),
        (("pf = 0.030", "pf = { a = 0.01, k = 100 }"), r"'mpe.pf' must be a number of mm"),
        (("k = 20000", "k = 0"), r"'mpe.sd.k' must be a positive finite number"),
        (("[25.001, 24.998]", "[25.001]"), r"'ball_bar.diameters' must be a list of two"),
        (("volume_mm = [300.0, 200.0, 150.0]", "volume_mm = 3"), r"'volume_mm' must be three"),
    ],
)
def test_acceptance_file_errors_are_one_line(
    tmp_path: Path, change: tuple[str, str], match: str
) -> None:
    text = EXAMPLE.read_text(encoding="utf-8")
    assert change[0] in text
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace(change[0], change[1], 1), encoding="utf-8")
    with pytest.raises(InputError, match=match) as err:
        load_acceptance_file(bad)
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(bad))


def test_acceptance_file_without_artefacts_or_file(tmp_path: Path) -> None:
    p = tmp_path / "a.toml"
    p.write_text("[mpe]\npf = 0.03\nps = 0.03\nsd = 0.05\nf = 0.04\n")
    with pytest.raises(InputError, match="no artefact; describe at least one of"):
        load_acceptance_file(p)
    with pytest.raises(InputError, match=r"missing\.toml: acceptance file does not exist"):
        load_acceptance_file(tmp_path / "missing.toml")
    mpe = {"pf": 0.03, "ps": 0.03, "sd": 0.05, "f": 0.04}
    with pytest.raises(InputError, match=r"^x.toml: 'plane' must be a table, got 3; write it"):
        parse_acceptance({"mpe": mpe, "plane": 3}, "x.toml")


# --- MPEs and the table ---------------------------------------------------------------------------


def test_pass_fail_against_constant_and_length_dependent_mpes() -> None:
    mpes = MpeSet(Mpe(0.030), Mpe(0.025), Mpe(0.020, 20000.0), Mpe(0.010, 10000.0))
    rows = [
        check_position("sphere-1", "PF", 0.030, mpes),  # on the MPE: passes
        check_position("sphere-1", "PS", -0.026, mpes),  # |PS| above: fails (signed value)
        check_position("bar-1", "SD", 0.0299, mpes, length_mm=200.0),  # 0.02 + 0.01 = 0.03
        check_position("bar-2", "SD", -0.0301, mpes, length_mm=200.0),
        check_position("plane-1", "F", 0.029, mpes, length_mm=200.0),  # 0.01 + 0.02 = 0.03
        check_position("plane-2", "F", float("nan"), mpes, length_mm=200.0, note="no points"),
    ]
    assert [r.passed for r in rows] == [True, False, True, False, True, False]
    assert [r.mpe_mm for r in rows[2:]] == pytest.approx([0.03] * 4, abs=1e-15)
    summary = summarize(rows)
    assert not summary.all_passed
    assert [f"{r.position}/{r.quantity}" for r in summary.failed] == [
        "sphere-1/PS",
        "bar-2/SD",
        "plane-2/F",
    ]
    data = json.loads(json.dumps(summary.to_dict(), allow_nan=False))  # no NaN anywhere
    assert data["records"][-1]["value_mm"] is None and data["records"][-1]["note"] == "no points"
    assert data["quantities"]["SD"] == {
        "positions": 2,
        "passed": 1,
        "max_abs_mm": 0.0301,
        "max_ratio": pytest.approx(0.0301 / 0.03, abs=1e-12),
    }
    # broken: the signed value compared with the MPE passes a PS of -0.026
    assert -0.026 <= mpes.ps.at()
    assert summarize(rows[:1]).all_passed and not summarize([]).all_passed


def test_mpe_checks_and_body_diagonal() -> None:
    with pytest.raises(InputError, match="the MPE of PF is a constant"):
        MpeSet(Mpe(0.03, 1000.0), Mpe(0.03), Mpe(0.05), Mpe(0.04))
    with pytest.raises(InputError, match="needs a length"):
        Mpe(0.02, 20000.0).at()
    assert body_diagonal([300, 200, 150]) == math.sqrt(152500.0)
    with pytest.raises(InputError, match="three positive edge lengths"):
        body_diagonal([300, 0, 150])
