"""Projector gamma (hdrfringe.core.gamma): uniform-gray and fringe fits, residual nonlinearity,
plot.

Synthetic captures are generated here with the contract's pattern and pre-compensation formulas
(hdrfringe.core.patterns), a known gamma, an offset, a reflectivity map, noise and 8-bit rounding;
the virtual rig and the command line are exercised once each; the kamino410 real-data test
skips when ../shared/realdata is absent.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.frames import UniformFrame
from hdrfringe.core.gamma import (
    MIN_FRINGE_PITCH_PX,
    MIN_UNIFORM_LEVELS,
    GammaFit,
    fit_gamma_fringes,
    fit_gamma_uniform,
    gamma_report,
    measure_nonlinearity,
    predicted_nonlinearity,
    residual_nonlinearity,
    select_gamma_sets,
    uniform_gray_means,
)
from hdrfringe.core.patterns import FringeSpec, fringe_gray, precompensate_gamma
from hdrfringe.errors import CaptureFormatError, InputError, OutputExistsError
from hdrfringe.io.gamma_outputs import write_gamma_outputs
from hdrfringe.io.plots import plot_gamma_mapping
from tests.conftest import realdata_path, run_cli

THESIS_GAMMA = 2.812
LEVELS = np.arange(0.0, 256.0, 15.0)  # 0, 15, ..., 255


# ---------------------------------------------------------------------------------------------
# synthetic captures
# ---------------------------------------------------------------------------------------------


def uniform_images(
    levels: np.ndarray,
    gamma: float = THESIS_GAMMA,
    *,
    precomp: float = 1.0,
    scale: float = 300.0,
    offset: float = 14.0,
    noise: float = 1.5,
    shape: tuple[int, int] = (40, 50),
    seed: int = 0,
) -> np.ndarray:
    """8-bit captures of uniform grays: offset + scale * reflectivity * (sent/255)^gamma + noise.

    With scale 300 the brightest levels clip at 255.
    """
    rng = np.random.default_rng(seed)
    h, w = shape
    rows, cols = np.mgrid[0:h, 0:w]
    refl = 0.9 + 0.1 * np.cos(cols / w * np.pi) * np.cos(rows / h * np.pi)
    sent = precompensate_gamma(levels, precomp).astype(float) / 255.0
    imgs = offset + scale * refl[None] * sent[:, None, None] ** gamma
    imgs = imgs + rng.normal(0.0, noise, imgs.shape)
    return np.clip(np.rint(imgs), 0, 255).astype(np.uint8)


def fringe_sets(
    gamma: float,
    exponents: tuple[float, ...] = (0.75, 1.25),
    *,
    steps: int = 3,
    scatter: float = 0.05,
    noise: float = 1.0,
    shape: tuple[int, int] = (80, 110),
    pitch: float = 48.0,
    seed: int = 0,
) -> tuple[list[tuple[FringeSpec, float, np.ndarray]], np.ndarray, np.ndarray]:
    """Sinusoidal sets pre-distorted with ``exponents`` (kamino410's design), and black/white.

    The camera sees a smooth, slightly nonlinear map of projector columns, a reflectivity map
    (0.55..0.95), an ambient offset (10..15 DN), light scattered from the rest of the scene
    (``scatter`` times the pattern's mean light: it differs between pre-distortions), Gaussian
    noise and 8-bit rounding. Returns the sets, the black and the white capture.
    """
    rng = np.random.default_rng(seed)
    h, w = shape
    rows, cols = np.mgrid[0:h, 0:w].astype(float)
    x = 3.1 * cols + 0.4 * rows + 0.002 * cols**2
    refl = 0.55 + 0.4 * np.exp(-((rows - h / 2) ** 2 + (cols - w / 3) ** 2) / (2 * (w / 2) ** 2))
    ambient = 10.0 + 5.0 * cols / w
    spec = FringeSpec("sinusoidal", steps, pitch, "vertical", 0, 255)

    def capture(light: np.ndarray, mean_light: float) -> np.ndarray:
        img = ambient + 200.0 * (scatter * mean_light + refl * light)
        return np.clip(np.rint(img + rng.normal(0.0, noise, img.shape)), 0, 255).astype(np.uint8)

    sets = []
    for gh in exponents:
        light = [
            (precompensate_gamma(fringe_gray(x, spec, k), gh) / 255.0) ** gamma
            for k in range(steps)
        ]
        mean_light = float(np.mean(light))
        sets.append((spec, gh, np.stack([capture(li, mean_light) for li in light])))
    black = capture(np.zeros(shape), 0.0)
    white = capture(np.ones(shape), 1.0)
    return sets, black, white


# ---------------------------------------------------------------------------------------------
# uniform grays
# ---------------------------------------------------------------------------------------------


def test_uniform_fit_recovers_thesis_gamma_from_clipped_noisy_images() -> None:
    imgs = uniform_images(LEVELS)
    assert (imgs[-1] == 255).mean() > 0.5  # the top levels are clipped
    fit = fit_gamma_uniform(LEVELS, imgs, camera_bit_depth=8, roi=(5, 35, 5, 45))
    assert fit.gamma == pytest.approx(THESIS_GAMMA, rel=0.01)
    assert fit.ci95[0] < fit.gamma < fit.ci95[1] and fit.stderr < 0.03
    assert fit.offset == pytest.approx(14.0, abs=1.0)
    assert fit.rms_residual < 1.0
    # clipped levels are reported but not fitted
    assert not fit.used[-1] and fit.used[:10].all() and fit.n_samples == fit.used.sum()
    assert fit.n_pixels == 30 * 40
    # the fit predicts a linear mapping once pre-compensated with its gamma, not without
    g = np.arange(256.0)
    assert residual_nonlinearity(g, fit, fit.gamma) < 1.0
    assert residual_nonlinearity(g, fit, 1.0) > 10.0
    mx, rms = predicted_nonlinearity(fit, fit.gamma)
    assert mx < 1.0 and rms < mx


def test_uniform_fit_from_means_with_precompensation_and_measured_nonlinearity() -> None:
    # captures sent WITH a pre-compensation of 2.0: the fit still returns the projector's gamma
    imgs = uniform_images(LEVELS, precomp=2.0, scale=220.0, seed=1)
    means = imgs.reshape(len(LEVELS), -1).mean(axis=1)
    fit = fit_gamma_uniform(LEVELS, means, camera_bit_depth=8, gamma_precompensation=2.0)
    assert fit.gamma == pytest.approx(THESIS_GAMMA, rel=0.01)
    np.testing.assert_array_equal(fit.sent, precompensate_gamma(LEVELS, 2.0))

    # measured: captures made with the fitted pre-compensation are linear within 1 % ...
    dn_fit = uniform_images(LEVELS, precomp=fit.gamma, scale=220.0, seed=2)
    dn_fit = dn_fit.reshape(len(LEVELS), -1).mean(axis=1)
    assert residual_nonlinearity(LEVELS, dn_fit, fit.gamma) < 1.0
    # ... captures without correction are not ...
    dn_raw = uniform_images(LEVELS, scale=220.0, seed=3).reshape(len(LEVELS), -1).mean(axis=1)
    assert residual_nonlinearity(LEVELS, dn_raw, 1.0) > 10.0
    # ... and re-indexing those raw captures by the level that pre-compensation would map to
    # their gray shows, without any model, what pre-compensation leaves
    nl = measure_nonlinearity(LEVELS, dn_raw, fit.gamma, captured_with=1.0)
    assert nl.max_percent < 1.0 and nl.rms_percent <= nl.max_percent and nl.slope > 0


def test_uniform_fit_is_robust_to_one_bad_capture() -> None:
    imgs = uniform_images(LEVELS, scale=220.0, seed=4)
    means = imgs.reshape(len(LEVELS), -1).mean(axis=1)
    means[8] += 25.0  # e.g. a light switched on during one capture
    fit = fit_gamma_uniform(LEVELS, means, camera_bit_depth=8)
    assert fit.gamma == pytest.approx(THESIS_GAMMA, rel=0.02)


def test_uniform_fit_on_the_virtual_rig() -> None:
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.rig.simulated import Lighting, SimulatedRig

    rig = SimulatedRig(
        white_plate(10.0), gamma_precompensation=1.0, lighting=Lighting(ambient_lux=100.0), seed=2
    )
    imgs = rig.capture([UniformFrame(g) for g in LEVELS])
    h, w = rig.image_shape
    fit = fit_gamma_uniform(
        LEVELS,
        imgs,
        camera_bit_depth=rig.camera_bit_depth,
        roi=(slice(h // 4, 3 * h // 4), slice(w // 4, 3 * w // 4)),
    )
    assert fit.gamma == pytest.approx(THESIS_GAMMA, rel=0.01)


@pytest.mark.parametrize(
    ("levels", "data", "kwargs", "match"),
    [
        (LEVELS[:3], np.array([10.0, 20.0, 30.0]), {}, "usable levels"),
        (LEVELS, np.ones(3), {}, "one mean per level"),
        (LEVELS, np.full(len(LEVELS), 255.0), {}, "usable levels"),
        (LEVELS, np.zeros((len(LEVELS), 4, 4)), {"roi": (0, 0, 0, 0)}, "selects no pixel"),
        (LEVELS, np.zeros((len(LEVELS), 4, 4)), {"mask": np.ones((3, 3), bool)}, "mask"),
        (LEVELS + 300, np.arange(len(LEVELS)) + 20.0, {}, "levels must lie"),
        (LEVELS, np.full((len(LEVELS), 2, 2), 300.0), {}, "bit depth"),
    ],
)
def test_uniform_fit_input_errors(levels, data, kwargs, match) -> None:
    with pytest.raises(InputError, match=match):
        fit_gamma_uniform(levels, data, camera_bit_depth=8, **kwargs)


# ---------------------------------------------------------------------------------------------
# fringes
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("gamma", [1.6, THESIS_GAMMA])
@pytest.mark.parametrize("weighting", ["levels", "samples"])
def test_fringe_fit_recovers_gamma_from_two_predistortions(gamma: float, weighting: str) -> None:
    """kamino410's design: 3-step sets pre-distorted with 1/0.75 and 1/1.25, no Gray code."""
    sets, _, _ = fringe_sets(gamma)
    fit = fit_gamma_fringes(sets, camera_bit_depth=8, weighting=weighting, max_pixels=5000)
    assert fit.gamma == pytest.approx(gamma, rel=0.01)
    assert fit.ci95[0] < fit.gamma < fit.ci95[1] and fit.stderr < 0.01 * gamma
    assert fit.rms_residual < 1.0  # noise 1 DN, with 4 of 6 samples' degrees of freedom fitted
    assert fit.method == "fringes" and fit.n_pixels > 4900
    # samples re-indexed by the level that pre-compensation with the fit would send: linear
    nl = measure_nonlinearity(fit.sent, fit.dn, fit.gamma, captured_with=1.0, bins=24)
    assert nl.max_percent < 1.0
    assert measure_nonlinearity(fit.sent, fit.dn, 1.0, captured_with=1.0, bins=24).max_percent > 8


def test_fringe_fit_needs_per_set_offsets_under_scattered_light() -> None:
    """Scattered light follows each pattern's mean light; one offset for both sets biases gamma."""
    sets, _, _ = fringe_sets(THESIS_GAMMA, scatter=0.05)
    shared = fit_gamma_fringes(sets, camera_bit_depth=8, offset_per_set=False, max_pixels=4000)
    per_set = fit_gamma_fringes(sets, camera_bit_depth=8, max_pixels=4000)
    assert abs(shared.gamma / THESIS_GAMMA - 1) > 0.01
    assert abs(per_set.gamma / THESIS_GAMMA - 1) < 0.005
    assert per_set.rms_residual < shared.rms_residual


def test_fringe_fit_on_the_virtual_rig() -> None:
    """Pixelated projector, defocus, camera blur and noise: within 1 % at a 96 px pitch."""
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.rig.simulated import SimulatedRig

    spec = FringeSpec("sinusoidal", 3, 96.0, "vertical", 0, 255)
    sets = []
    for gh in (0.75, 1.25):
        rig = SimulatedRig(white_plate(5.0), gamma_precompensation=gh, seed=7)
        sets.append((spec, gh, rig.capture(spec.frames())))
    fit = fit_gamma_fringes(sets, camera_bit_depth=8, max_pixels=5000)
    assert fit.gamma == pytest.approx(THESIS_GAMMA, rel=0.01)


def test_fringe_fit_warns_on_narrow_fringes() -> None:
    sets, _, _ = fringe_sets(2.2, pitch=8.0, shape=(30, 40))
    with pytest.warns(RuntimeWarning, match="pitch of 8 projector px"):
        fit_gamma_fringes(sets, camera_bit_depth=8)


def test_fringe_fit_single_four_step_set() -> None:
    sets, _, _ = fringe_sets(2.2, (1.6,), steps=4, scatter=0.0)
    fit = fit_gamma_fringes(sets, camera_bit_depth=8, max_pixels=4000)
    assert fit.gamma == pytest.approx(2.2, rel=0.01)


def test_fringe_fit_black_white_normalisation() -> None:
    # one 3-step set suffices when black and white fix offset and scale ...
    sets, black, white = fringe_sets(2.2, (1.25,), scatter=0.0, seed=3)
    fit = fit_gamma_fringes(
        sets, camera_bit_depth=8, normalization="black_white", black=black, white=white
    )
    assert fit.gamma == pytest.approx(2.2, rel=0.01)
    assert fit.normalization == "black_white"
    # ... but scattered light (white gets more of it than a fringe) biases that normalisation
    sets, black, white = fringe_sets(2.2, (1.25,), scatter=0.05, seed=3)
    biased = fit_gamma_fringes(
        sets, camera_bit_depth=8, normalization="black_white", black=black, white=white
    )
    assert abs(biased.gamma / 2.2 - 1) > 0.02


def test_fringe_fit_ignores_saturated_pixels() -> None:
    sets, _, _ = fringe_sets(2.2, seed=5)
    bright = [(s, g, np.clip(im * 1.25, 0, 255).astype(np.uint8)) for s, g, im in sets]
    assert any((im == 255).any() for _, _, im in bright)
    fit = fit_gamma_fringes(bright, camera_bit_depth=8, max_pixels=4000)
    assert fit.gamma == pytest.approx(2.2, rel=0.01)


def test_fringe_fit_input_errors() -> None:
    sets, black, _ = fringe_sets(2.2, (1.0,), noise=0.5)
    with pytest.raises(InputError, match="two pre-distortions"):
        fit_gamma_fringes(sets, camera_bit_depth=8)  # 3 samples for 4 unknowns per pixel
    with pytest.raises(InputError, match="black and white"):
        fit_gamma_fringes(sets, camera_bit_depth=8, normalization="black_white", black=black)
    spec, gh, imgs = sets[0]
    with pytest.raises(InputError, match="one image per shift"):
        fit_gamma_fringes([(spec, gh, imgs[:2])], camera_bit_depth=8)
    with pytest.raises(InputError, match="gamma_hat"):
        fit_gamma_fringes([(spec, 0.0, imgs)], camera_bit_depth=8)
    with pytest.raises(InputError, match="at least one"):
        fit_gamma_fringes([], camera_bit_depth=8)


# ---------------------------------------------------------------------------------------------
# which fringe sets a shape fit uses
# ---------------------------------------------------------------------------------------------


def test_select_gamma_sets_rule() -> None:
    """Wide sinusoidal sets only (the boundary pitch included); fittable with two exponents
    or N >= 4 steps among the USED sets (narrow and triangular sets do not count)."""

    def sin(steps: int, pitch: float) -> FringeSpec:
        return FringeSpec("sinusoidal", steps, pitch)

    tri = FringeSpec("triangular", 3, 48.0)
    items = [(sin(4, 8.0), 0.75), (sin(3, 48.0), 0.75), (tri, 1.25), (sin(3, 32.0), 1.25)]
    sel = select_gamma_sets(items)
    assert MIN_FRINGE_PITCH_PX == 32.0 and sel.min_pitch_px == 32.0
    assert sel.used == (1, 3) and sel.too_narrow == (0,) and sel.fittable
    assert sel.sets == (items[1], items[3])
    # one exponent among the used sets: the triangular set's other exponent does not count ...
    assert not select_gamma_sets([(sin(3, 48.0), 0.75), (tri, 1.25)]).fittable
    # ... nor do narrow sets, whatever their steps and exponents
    only_narrow = select_gamma_sets([(sin(4, 8.0), 0.75), (sin(4, 16.0), 1.25)])
    assert only_narrow.used == () and only_narrow.too_narrow == (0, 1)
    assert not only_narrow.fittable
    # one exponent: fittable with four steps, not with three
    assert select_gamma_sets([(sin(4, 64.0), 1.0)]).fittable
    assert not select_gamma_sets([(sin(3, 64.0), 1.0), (sin(3, 96.0), 1.0)]).fittable
    # another minimum pitch
    wide = select_gamma_sets(items, min_pitch_px=40.0)
    assert wide.used == (1,) and wide.too_narrow == (0, 3) and not wide.fittable
    assert select_gamma_sets([]).used == () and not select_gamma_sets([]).fittable
    with pytest.raises(InputError, match="FringeSpec"):
        select_gamma_sets([("sinusoidal", 1.0)])


def test_select_gamma_sets_agrees_with_the_fringe_fit() -> None:
    """``fittable`` says whether fit_gamma_fringes can fit the selected sets by shape; the items
    (with their images) pass through untouched."""
    sets, _, _ = fringe_sets(2.2, (0.75, 1.25), shape=(40, 60))
    narrow, _, _ = fringe_sets(2.2, (1.0,), shape=(40, 60), pitch=8.0, steps=4)
    sel = select_gamma_sets(narrow + sets)
    assert sel.too_narrow == (0,) and sel.used == (1, 2) and sel.fittable
    assert all(a is b for a, b in zip(sel.sets, sets, strict=True))
    fit = fit_gamma_fringes(sel.sets, camera_bit_depth=8)
    assert fit.gamma == pytest.approx(2.2, rel=0.01)
    one, _, _ = fringe_sets(2.2, (1.0,), shape=(40, 60))
    sel = select_gamma_sets(one)
    assert sel.used == (0,) and not sel.fittable
    with pytest.raises(InputError, match="two pre-distortions"):
        fit_gamma_fringes(sel.sets, camera_bit_depth=8)


# ---------------------------------------------------------------------------------------------
# plot
# ---------------------------------------------------------------------------------------------


def test_plot_gamma_mapping(tmp_path: Path) -> None:
    imgs = uniform_images(LEVELS)
    fit = fit_gamma_uniform(LEVELS, imgs, camera_bit_depth=8)
    measured = uniform_images(LEVELS, precomp=fit.gamma, scale=220.0, seed=2)
    out = plot_gamma_mapping(
        fit,
        tmp_path / "uniform.png",
        measured_levels=LEVELS,
        measured_dn=measured.reshape(len(LEVELS), -1).mean(axis=1),
        title="synthetic",
    )
    assert out.stat().st_size > 10_000 and out.read_bytes()[:4] == b"\x89PNG"
    sets, _, _ = fringe_sets(2.2, shape=(40, 60))
    ffit = fit_gamma_fringes(sets, camera_bit_depth=8)
    assert isinstance(ffit, GammaFit) and ffit.sent.size == ffit.dn.size > 0
    assert plot_gamma_mapping(ffit, tmp_path / "fringes.png", gamma_hat=2.0).stat().st_size > 10_000


def test_gamma_package_is_core_math() -> None:
    """No module of hdrfringe.core.gamma (nor reconstruct) imports matplotlib, plyfile or the I/O
    layer, not even inside a function: plots and file formats live in hdrfringe.io."""
    import ast

    import hdrfringe.core.gamma
    import hdrfringe.core.reconstruct

    files = [
        *Path(hdrfringe.core.gamma.__file__).parent.glob("*.py"),
        Path(hdrfringe.core.reconstruct.__file__),
    ]
    assert len(files) >= 8
    forbidden = ("matplotlib", "plyfile", "hdrfringe.io", "hdrfringe.cli")
    for file in files:
        for node in ast.walk(ast.parse(file.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            else:
                continue
            bad = [n for n in names if n.startswith(forbidden)]
            assert not bad, f"{file.name} imports {bad}"


# ---------------------------------------------------------------------------------------------
# the report of a set of captures (what the command computes) and its output folder
# ---------------------------------------------------------------------------------------------


def report_captures(n_levels: int = len(LEVELS)) -> tuple[Captures, list, list]:
    """Uniform grays (gamma 2.2), a narrow 4-step set and two wide sets pre-distorted with 0.75
    and 1.25, 40 x 60 pixels; also returns the wide sets and the uniform images."""
    shape = (40, 60)
    wide, _, _ = fringe_sets(2.2, (0.75, 1.25), shape=shape)
    narrow, _, _ = fringe_sets(2.2, (1.0,), shape=shape, pitch=8.0, steps=4)
    levels = LEVELS[:n_levels]
    grays = uniform_images(levels, 2.2, scale=220.0, shape=shape)
    frames, images, gp = [UniformFrame(g) for g in levels], [grays], [None] * len(levels)
    for spec, gh, imgs in narrow + wide:
        frames += spec.frames()
        images.append(imgs)
        gp += [gh] * spec.steps
    caps = Captures(
        frames,
        np.concatenate(images),
        8,
        projector=ProjectorInfo(gamma_precompensation=1.0),
        gamma_precompensation=gp,
    )
    return caps, wide, list(grays)


def test_uniform_gray_means_rule() -> None:
    """At least 4 distinct levels; the mean over the centre half of the image only."""
    images = np.zeros((5, 8, 12), np.uint8)
    images[:, 2:6, 3:9] = np.arange(10, 60, 10)[:, None, None]  # the centre half
    images[:, 0, :] = 250  # outside it
    caps = Captures([UniformFrame(g) for g in (0, 10, 20, 30, 30)], images, 8)
    levels, means = uniform_gray_means(caps)
    assert levels.tolist() == [0, 10, 20, 30, 30] and means.tolist() == [10, 20, 30, 40, 50]
    three = Captures([UniformFrame(g) for g in (0, 10, 20, 20)], images[:4], 8)
    assert MIN_UNIFORM_LEVELS == 4 and uniform_gray_means(three) is None


def test_gamma_report_fits_uniform_grays_and_wide_sets_only() -> None:
    caps, wide, grays = report_captures()
    rep = gamma_report(caps, source="bench")
    means = np.array([g[10:30, 15:45].mean() for g in grays])
    ref_u = fit_gamma_uniform(LEVELS, means, camera_bit_depth=8, projector_bit_depth=8)
    ref_f = fit_gamma_fringes(wide, camera_bit_depth=8, projector_bit_depth=8)
    assert rep.uniform_fit is not None and rep.fringe_fit is not None and rep.fitted
    assert rep.report["uniform"]["gamma"] == ref_u.gamma == pytest.approx(2.2, rel=0.01)
    assert rep.report["fringes"]["gamma"] == ref_f.gamma == pytest.approx(2.2, rel=0.01)
    assert rep.report["source"] == "bench"
    assert rep.report["fringes"]["sets"] == [s.label for s in caps.sets[1:]]
    nl = rep.report["uniform"]["residual_nonlinearity_percent"]
    assert nl["precompensated_with_fit"] == predicted_nonlinearity(ref_u, ref_u.gamma)[0]
    assert nl["precompensated_with_1"] == nl["no_precompensation"] > 10.0
    assert [line.split(":")[0] for line in rep.lines] == [
        "uniform grays",
        "residual nonlinearity (max, % of range)",
        "note",
        "fringe shape",
        "residual nonlinearity (max, % of range)",
    ]
    fnl = rep.report["fringes"]["residual_nonlinearity_percent"]
    assert fnl["precompensated_with_fit"] == predicted_nonlinearity(ref_f, ref_f.gamma)[0] < 1.0
    assert fnl["no_precompensation"] > 10.0
    measured = measure_nonlinearity(ref_f.sent, ref_f.dn, ref_f.gamma, captured_with=1.0, bins=32)
    assert fnl["measured_precompensated_with_fit"] == pytest.approx(measured.max_percent)
    assert rep.report["warnings"] == [] and not rep.report["fringes"]["residual_large"]
    assert caps.sets[0].label in rep.lines[2] and "narrower than 32 px" in rep.lines[2]
    rep.check_fitted()
    json.dumps(rep.report, allow_nan=False)  # standard JSON


def test_gamma_report_with_nothing_to_fit() -> None:
    caps, _, _ = report_captures(n_levels=3)
    only_narrow = Captures(caps.frames[:7], caps.images[:7], 8, gamma_precompensation=[None] * 7)
    rep = gamma_report(only_narrow, source="folder x")
    assert not rep.fitted and rep.report == {"source": "folder x"} and len(rep.lines) == 1
    with pytest.raises(CaptureFormatError, match="folder x: nothing to fit"):
        rep.check_fitted()


def test_write_gamma_outputs(tmp_path: Path) -> None:
    caps, _, _ = report_captures()
    rep = gamma_report(caps, source="bench")
    out = write_gamma_outputs(tmp_path / "g", rep)
    assert json.loads((out / "gamma.json").read_text()) == rep.report
    assert sorted(p.name for p in out.iterdir()) == [
        "gamma.json",
        "gamma_mapping.png",
        "gamma_mapping_fringes.png",
        "gamma_nonlinearity.png",
        "gamma_nonlinearity_fringes.png",
    ]
    assert (out / "gamma_mapping.png").stat().st_size > 10_000
    (out / "keep.txt").write_text("mine")
    with pytest.raises(OutputExistsError):
        write_gamma_outputs(out, rep)
    assert (out / "keep.txt").read_text() == "mine"
    n = len(LEVELS)
    fringes = caps.frames[n:], caps.images[n:]
    fringes_only = gamma_report(
        Captures(*fringes, 8, gamma_precompensation=caps.gamma_precompensation[n:]), source="f"
    )
    assert fringes_only.uniform_fit is None
    out = write_gamma_outputs(out, fringes_only, force=True)  # wrote no plot before
    names = ["gamma.json", "gamma_mapping_fringes.png", "gamma_nonlinearity_fringes.png"]
    assert sorted(p.name for p in out.iterdir()) == names
    assert all((out / n).stat().st_size > 10_000 for n in names[1:])


def test_large_fit_residual_is_reported_with_a_warning() -> None:
    """A light switched on for one of the grays (+40 DN): gamma moves to 2.14 and the rms
    residual, 9.1 DN or 4.6 % of the 197 DN signal range, says the power law does not describe
    the captures. The same captures without the disturbance: 0.06 DN (0.03 %), no warning."""
    from hdrfringe.core.gamma.report import LARGE_RESIDUAL_FRACTION

    *_, grays = report_captures()
    n = len(LEVELS)
    clean = Captures([UniformFrame(g) for g in LEVELS], np.stack(grays), 8)
    lit = np.stack(grays).astype(np.int64)
    lit[n // 2] += 40  # 40 DN of extra light on one capture
    disturbed = Captures([UniformFrame(g) for g in LEVELS], lit.clip(0, 255).astype(np.uint8), 8)
    ok, bad = gamma_report(clean, source="clean"), gamma_report(disturbed, source="lit")
    assert ok.report["uniform"]["residual_large"] is False and ok.report["warnings"] == []
    assert not any(line.startswith("warning:") for line in ok.lines)
    u = bad.report["uniform"]
    assert u["rms_residual_dn"] > LARGE_RESIDUAL_FRACTION * u["scale_dn"]
    assert u["residual_large"] is True and u["degenerate"] is False
    warnings = [line for line in bad.lines if line.startswith("warning:")]
    assert len(warnings) == 1 and "rms residual" in warnings[0]
    assert bad.report["warnings"] == warnings
    json.dumps(bad.report, allow_nan=False)


# ---------------------------------------------------------------------------------------------
# command line (reads the capture folder, calls the functions above)
# ---------------------------------------------------------------------------------------------


def test_gamma_cli_on_uniform_folder_skips_narrow_fringes(tmp_path: Path) -> None:
    """Uniform grays fit through the command; the folder's 4-step set at 8 px is distorted by
    projector pixels and blur (the shape fit would read that as gamma 3.18 on the rig), so the
    command leaves it out and says so."""
    caps = tmp_path / "caps"
    res = run_cli(
        "simulate",
        "white_plate",
        "-o",
        str(caps),
        "--gamma",
        "1",
        "--gray",
        ",".join(str(int(g)) for g in LEVELS),
        "--no-centerline",
    )
    assert res.returncode == 0, res.stderr
    out = tmp_path / "g"
    res = run_cli("gamma", str(caps), "-o", str(out))
    assert res.returncode == 0, res.stderr
    assert "not used for gamma" in res.stdout and "fringe shape" not in res.stdout
    report = json.loads((out / "gamma.json").read_text())
    assert "fringes" not in report
    assert report["uniform"]["gamma"] == pytest.approx(THESIS_GAMMA, rel=0.01)
    assert (out / "gamma_mapping.png").is_file()


def test_gamma_cli_on_fringe_captures_writes_the_plots(tmp_path: Path) -> None:
    """Fringe captures alone (the two wide pre-distorted sets): the help and the README
    promise the plot; before, only gamma.json was written."""
    from hdrfringe.io.captures import write_capture_folder

    caps, _, _ = report_captures()
    n = len(LEVELS) + 4  # the grays and the narrow set left out
    folder = tmp_path / "fringes"
    fringes = Captures(
        caps.frames[n:],
        caps.images[n:],
        8,
        projector=ProjectorInfo(gamma_precompensation=1.0),
        gamma_precompensation=caps.gamma_precompensation[n:],
    )
    write_capture_folder(folder, fringes)
    out = tmp_path / "g"
    res = run_cli("gamma", str(folder), "-o", str(out))
    assert res.returncode == 0, res.stderr
    assert "fringe shape: gamma = 2.2" in res.stdout and "warning" not in res.stdout
    names = ["gamma.json", "gamma_mapping_fringes.png", "gamma_nonlinearity_fringes.png"]
    assert sorted(p.name for p in out.iterdir()) == names
    report = json.loads((out / "gamma.json").read_text())
    assert report["warnings"] == [] and report["fringes"]["residual_large"] is False


# ---------------------------------------------------------------------------------------------
# real data: kamino410 gamma_correction_subset
# ---------------------------------------------------------------------------------------------

KAMINO_AUTHOR_GAMMA = 1.6448  # gamma_result.txt (Gray-code based; the subset has no Gray code)


def kamino_sets(src: Path, orientation: str) -> list[tuple[FringeSpec, float, np.ndarray]]:
    """pat00-05 vertical, pat06-11 horizontal; in each, exponent 1/0.75 then 1/1.25.

    The files show shifts -120, 0, +120 degrees of ``0.5 * (1 + cos)``: in the contract's
    convention imin 0, migl 255, pre-compensation gamma-hat 0.75 and 1.25, shifts 2, 0, 1.
    """
    import imageio.v3 as iio

    base = 0 if orientation == "vertical" else 6
    sets = []
    for j, gh in enumerate((0.75, 1.25)):
        files = [src / f"pat{base + 3 * j + k:02d}.png" for k in range(3)]
        imgs = [iio.imread(f) for f in files]
        spec = FringeSpec("sinusoidal", 3, 240.0, orientation, 0, 255)
        sets.append((spec, gh, np.stack([imgs[1], imgs[2], imgs[0]])))  # shifts 0, 1, 2
    return sets


@pytest.mark.realdata
def test_kamino410_gamma_subset(tmp_path: Path) -> None:
    """Measured: 1.585 (vertical), 1.574 (horizontal), 1.583 both; the author's 1.6448.

    Tolerance 6 % of the author's value: this projector is not a pure power law (its local
    exponent runs from about 1.40 in the dark to 1.63 at mid gray, docs/gamma.md), so estimators
    that weight the range differently legitimately land between about 1.51 and 1.68 on these
    captures; ours weights the requested levels evenly. The two orientations see the same
    projector and must agree within 1.5 %; the fit must describe the captures to about the
    camera's noise, and pre-compensation with it must leave < 1 % nonlinearity (vs > 8 %
    without).
    """
    src = realdata_path("kamino410", "gamma_correction_subset")
    fits = {
        o: fit_gamma_fringes(kamino_sets(src, o), camera_bit_depth=8)
        for o in ("vertical", "horizontal")
    }
    g_v, g_h = fits["vertical"].gamma, fits["horizontal"].gamma
    print(
        f"\nkamino410 gamma: vertical {g_v:.4f}, horizontal {g_h:.4f} "
        f"(author {KAMINO_AUTHOR_GAMMA})"
    )
    assert g_v == pytest.approx(g_h, rel=0.015)
    for fit in fits.values():
        assert fit.gamma == pytest.approx(KAMINO_AUTHOR_GAMMA, rel=0.06)
        assert fit.rms_residual < 1.5
        after = measure_nonlinearity(fit.sent, fit.dn, fit.gamma, captured_with=1.0, bins=32)
        before = measure_nonlinearity(fit.sent, fit.dn, 1.0, captured_with=1.0, bins=32)
        assert after.max_percent < 1.0 and before.max_percent > 8.0

    # the command line on a capture folder of the same files (per-set exponents in the manifest)
    caps = tmp_path / "kamino"
    caps.mkdir()
    frames = []
    for base, orient in ((0, "vertical"), (6, "horizontal")):
        for j, gh in enumerate((0.75, 1.25)):
            for k, shift in enumerate((2, 0, 1)):
                name = f"pat{base + 3 * j + k:02d}.png"
                # a copy: the reader refuses symlinks that leave the capture folder
                shutil.copyfile(src / name, caps / name)
                frames.append(
                    {
                        "file": name,
                        "kind": "fringe",
                        "pattern": "sinusoidal",
                        "steps": 3,
                        "shift": shift,
                        "pitch": 240.0,
                        "orientation": orient,
                        "imin": 0,
                        "migl": 255,
                        "gamma_precompensation": gh,
                    }
                )
    manifest = {
        "format": "hdrfringe-captures",
        "version": 1,
        "camera": {"bit_depth": 8},
        "projector": {"width": 1920, "height": 1080, "bit_depth": 8},
        "frames": frames,
    }
    (caps / "manifest.json").write_text(json.dumps(manifest))
    res = run_cli("gamma", str(caps))
    assert res.returncode == 0, res.stderr
    m = re.search(r"fringe shape: gamma = ([0-9.]+)", res.stdout)
    assert m is not None, res.stdout
    assert float(m.group(1)) == pytest.approx((g_v + g_h) / 2, rel=0.01)
