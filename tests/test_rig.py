"""Tests of the virtual rig: geometry, radiometry (Eq. 3.3), noise, scenes and Eq. 4.1."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.ndimage import binary_erosion

from hdrfringe.core.captures import ProjectorInfo
from hdrfringe.core.frames import CenterlineFrame, UniformFrame, render_frame
from hdrfringe.core.patterns import FringeSpec, fringe_gray
from hdrfringe.errors import InputError
from hdrfringe.rig.base import Rig
from hdrfringe.rig.modify import lux_to_dn, modify_captures
from hdrfringe.rig.scenes import (
    BLACK_PLATE_REFLECTIVITY,
    SCENES,
    THESIS_CALIBRATION_DEPTHS_MM,
    black_plate,
    checkerboard,
    glossy,
    make_scene,
    mask,
    scene_from_manifest,
    white_plate,
)
from hdrfringe.rig.simulated import (
    CameraModel,
    Lighting,
    ProjectorModel,
    RigGeometry,
    SimulatedRig,
    simulate_frames,
)

FULL16 = 65535
IMIN16 = 40 * 257  # the thesis's imin = 40 of 255, in 16-bit projector units


def small_camera(**changes) -> CameraModel:
    """A coarse camera (same field of view, odd size so a pixel sits on the optical axis)."""
    args = {"width": 65, "height": 49}
    args.update(changes)
    return CameraModel(**args)


def nstep_phase(images: np.ndarray) -> np.ndarray:
    """Standard N-step phase, phi = atan2(-sum I_k sin d_k, sum I_k cos d_k) mod 2 pi."""
    n = images.shape[0]
    d = 2 * np.pi * np.arange(n) / n
    i = images.astype(np.float64)
    s = np.tensordot(np.sin(d), i, axes=1)
    c = np.tensordot(np.cos(d), i, axes=1)
    return np.mod(np.arctan2(-s, c), 2 * np.pi)


def nstep_amplitude(images: np.ndarray) -> np.ndarray:
    n = images.shape[0]
    d = 2 * np.pi * np.arange(n) / n
    i = images.astype(np.float64)
    return 2.0 / n * np.abs(np.tensordot(np.exp(-1j * d), i, axes=1))


def wrap_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * (a - b)))


# --- protocol -----------------------------------------------------------------------------------


def test_rig_implements_protocol():
    rig = SimulatedRig(white_plate(12.0), camera=small_camera(bit_depth=12))
    assert isinstance(rig, Rig)
    assert rig.camera_bit_depth == 12
    assert rig.image_shape == (49, 65)
    assert rig.projector == ProjectorInfo(1024, 768, 8, 2.812)
    images = simulate_frames(rig, FringeSpec(steps=4).frames())
    assert images.shape == (4, 49, 65) and images.dtype == np.uint16
    assert rig.capture([]).shape == (0, 49, 65)
    json.dumps(rig.to_manifest())


def test_simulate_to_folder_round_trip(tmp_path):
    from hdrfringe.io.captures import read_capture_folder, read_manifest
    from hdrfringe.tasks.simulate import simulate_to_folder

    rig = SimulatedRig(white_plate(12.0), camera=small_camera(bit_depth=12), seed=2)
    frames = [*FringeSpec(steps=4, pitch_px=8).frames(), CenterlineFrame(512.0)]
    images = simulate_to_folder(tmp_path / "caps", rig, frames)
    folder = read_capture_folder(tmp_path / "caps")
    np.testing.assert_array_equal(folder.images, images)
    assert folder.camera_bit_depth == 12
    assert folder.scene["depth_mm"] == 12.0
    assert folder.projector == rig.projector
    assert read_manifest(tmp_path / "caps")["simulator"]["seed"] == 2
    # replaying the same frames on a fresh rig reproduces the folder exactly
    np.testing.assert_array_equal(rig.replace().capture(folder.frames), images)


# --- determinism --------------------------------------------------------------------------------


def test_same_seed_identical_different_seed_differs():
    frames = FringeSpec(steps=3).frames()
    a = SimulatedRig(white_plate(10), camera=small_camera(), seed=3).capture(frames)
    b = SimulatedRig(white_plate(10), camera=small_camera(), seed=3).capture(frames)
    c = SimulatedRig(white_plate(10), camera=small_camera(), seed=4).capture(frames)
    np.testing.assert_array_equal(a, b)
    assert np.any(a != c)


def test_noise_depends_on_frame_not_capture_order():
    spec = FringeSpec(steps=3, pitch_px=8)
    f0, f1, f2 = spec.frames()
    uniform = UniformFrame(128)
    one = SimulatedRig(mask(), camera=small_camera(), seed=7)
    two = SimulatedRig(mask(), camera=small_camera(), seed=7)
    live = one.capture([f0, f1, f2, uniform])
    back = np.concatenate([two.capture([uniform, f2]), two.capture([f0]), two.capture([f1])])
    np.testing.assert_array_equal(live[0], back[2])
    np.testing.assert_array_equal(live[1], back[3])
    np.testing.assert_array_equal(live[2], back[1])
    np.testing.assert_array_equal(live[3], back[0])
    # an equal frame built anew is the same frame
    anew = SimulatedRig(mask(), camera=small_camera(), seed=7)
    np.testing.assert_array_equal(anew.capture([spec.with_migl(255).frames()[1]])[0], live[1])


def test_repeated_frame_gets_new_noise_counted_per_frame():
    frame = UniformFrame(150)
    a = SimulatedRig(white_plate(4), camera=small_camera(), seed=1)
    b = SimulatedRig(white_plate(4), camera=small_camera(), seed=1)
    pair = a.capture([frame, frame])
    assert np.any(pair[0] != pair[1])
    first = b.capture([frame])
    b.capture([UniformFrame(10)])  # other frames do not shift the count
    second = b.capture([frame])
    np.testing.assert_array_equal(pair[0], first[0])
    np.testing.assert_array_equal(pair[1], second[0])
    b.reset_noise()
    np.testing.assert_array_equal(b.capture([frame])[0], pair[0])


# --- geometry -----------------------------------------------------------------------------------


def test_plate_projector_shift_matches_pinhole_triangulation():
    """Centre pixel: u(h) = cu + fp h sin(t) / (D - h cos(t)), derived by hand for the layout."""
    geo = RigGeometry()
    t = math.radians(15.0)
    dist = 1900.0 / math.cos(t)  # projector lens at the camera's height
    fp = 1024 * dist / 400.0  # 1024 px over a 400 mm wide image at the origin
    cu, cv = 511.5, 383.5
    row, col = 24, 32  # odd camera: this pixel looks along the optical axis

    def u_closed(h: float) -> float:
        return cu + fp * h * math.sin(t) / (dist - h * math.cos(t))

    def du_dh_closed(h: float) -> float:
        return fp * math.sin(t) * dist / (dist - h * math.cos(t)) ** 2

    def truth(depth: float):
        return SimulatedRig(white_plate(depth), camera=small_camera(), geometry=geo).truth()

    step = 0.01
    for depth in (0.0, 2.0, 10.0, 24.0, 50.0):
        tr = truth(depth)
        assert tr.u[row, col] == pytest.approx(u_closed(depth), abs=1e-7)
        assert tr.v[row, col] == pytest.approx(cv, abs=1e-7)
        assert tr.x_mm[row, col] == pytest.approx(0.0, abs=1e-9)
        np.testing.assert_allclose(tr.height_mm, depth, atol=1e-9)
        slope = (truth(depth + step).u[row, col] - truth(depth - step).u[row, col]) / (2 * step)
        assert slope == pytest.approx(du_dh_closed(depth), rel=1e-6)
    # about 0.66 projector px per mm, growing toward the projector
    assert du_dh_closed(0.0) == pytest.approx(0.663, abs=0.01)


def test_surface_points_lie_on_camera_rays():
    rig = SimulatedRig(mask(), camera=small_camera())
    tr = rig.truth()
    f = 65 * 1900.0 / 320.0
    cols = np.arange(65) - 32.0
    rows = np.arange(49) - 24.0
    np.testing.assert_allclose(tr.x_mm, cols[None, :] / f * (1900.0 - tr.height_mm), atol=1e-9)
    np.testing.assert_allclose(tr.y_mm, -rows[:, None] / f * (1900.0 - tr.height_mm), atol=1e-9)
    np.testing.assert_allclose(tr.height_mm, mask().height(tr.x_mm, tr.y_mm), atol=1e-8)


def test_whole_field_is_lit_over_the_calibration_volume():
    for depth in (THESIS_CALIBRATION_DEPTHS_MM[0], THESIS_CALIBRATION_DEPTHS_MM[-1], 0.0):
        tr = SimulatedRig(white_plate(depth)).truth()
        assert tr.valid.all()
        assert tr.u.min() > 50 and tr.u.max() < 1024 - 50
    assert SimulatedRig(mask()).truth().valid.all()


def test_projector_shadow_matches_ray_sphere_intersection():
    """A tall glossy cap with the projector at 30 degrees casts a shadow on its base plane."""
    geo = RigGeometry(angle_deg=30.0)
    dome = glossy(height_mm=85.0, radius_mm=100.0)
    rig = SimulatedRig(dome, camera=CameraModel(width=161, height=121), geometry=geo)
    tr = rig.truth()
    centre = np.array([0.0, 0.0, 85.0 - 100.0])
    q = np.stack([tr.x_mm, tr.y_mm, tr.height_mm], axis=-1)
    d = geo.projector_center - q
    oc = q - centre
    a = np.sum(d * d, axis=-1)
    b = 2 * np.sum(oc * d, axis=-1)
    c = np.sum(oc * oc, axis=-1) - 100.0**2
    disc = b * b - 4 * a * c
    root = np.sqrt(np.maximum(disc, 0))
    blocked = np.zeros(tr.u.shape, dtype=bool)
    for t in ((-b - root) / (2 * a), (-b + root) / (2 * a)):
        z_hit = q[..., 2] + t * d[..., 2]
        blocked |= (disc > 0) & (t > 1e-6) & (t <= 1) & (z_hit > 0)
    lit = tr.shading > 0
    base = tr.height_mm < 1e-9
    assert (blocked & base).sum() > 100  # a real shadow on the base plane
    mismatch = lit == blocked
    assert mismatch.sum() <= 0.02 * blocked.sum()
    assert not np.any(tr.valid & ~lit)


def test_lambertian_irradiance_of_a_plate():
    """Centre pixel, full white: alpha * r * cos(i)/cos(15) * (D/d)^2 at any depth."""
    t = math.radians(15.0)
    dist = 1900.0 / math.cos(t)
    cam = small_camera(blur_px=0.0, read_noise_dn8=0.0, full_well_e=None, bit_depth=16)
    for depth in (0.0, 50.0):
        rig = SimulatedRig(white_plate(depth), camera=cam)
        signal = rig.expected_signal([UniformFrame(255)])[0, 24, 32]
        px, pz = -dist * math.sin(t), dist * math.cos(t)
        d = math.hypot(px, pz - depth)
        cos_i = (pz - depth) / d
        expected = 0.8 * FULL16 * cos_i / math.cos(t) * (dist / d) ** 2
        assert signal == pytest.approx(expected, rel=1e-9)


# --- radiometry ---------------------------------------------------------------------------------


@pytest.mark.parametrize("scene", [mask(), glossy()], ids=["mask", "glossy"])
def test_intensity_follows_eq_3_3(scene):
    """Noise off, continuous, no blur, 16-bit: I = a r (S L(u) + a1) + a a2 (+ specular)."""
    gamma, gamma_hat, black = 2.812, 2.2, 0.005
    lighting = Lighting(ambient_lux=100.0, direct_ambient_lux=20.0)
    rig = SimulatedRig.ideal(
        scene,
        camera=small_camera(bit_depth=16, read_noise_dn8=0, full_well_e=None, blur_px=0),
        lighting=lighting,
        gamma_precompensation=gamma_hat,
    )
    spec = FringeSpec("sinusoidal", 3, 7.3, "vertical", IMIN16, FULL16)
    images = rig.capture(spec.frames()).astype(np.float64)
    tr = rig.truth()
    alpha = 0.8 * FULL16
    ambient_dn = 0.17 * FULL16 / 255.0
    for k, frame in enumerate(spec.frames()):
        g = fringe_gray(tr.u, spec, frame.shift)
        sent = np.rint(FULL16 * (g / FULL16) ** (1.0 / gamma_hat))
        light = black + (1 - black) * (sent / FULL16) ** gamma
        expected = (
            alpha * tr.shading * (tr.reflectivity + tr.specular) * light
            + tr.reflectivity * 100.0 * ambient_dn
            + 20.0 * ambient_dn
        )
        expected = np.minimum(expected, FULL16)
        err = np.abs(images[k] - expected)[tr.valid]
        assert err.max() <= 0.5 + 1e-6
    assert tr.valid.mean() > 0.99


def test_pixelated_projector_samples_rendered_image():
    rig = SimulatedRig(
        mask(),
        camera=small_camera(bit_depth=16, read_noise_dn8=0, full_well_e=None, blur_px=0),
        projector_model=ProjectorModel(defocus_px=0.0, black_level=0.0),
    )
    frames = [*FringeSpec(steps=3, pitch_px=5).frames(), CenterlineFrame(512.0)]
    frames += FringeSpec(steps=3, pitch_px=9, orientation="horizontal").frames()
    tr = rig.truth()
    images = rig.capture(frames).astype(np.float64)
    for img, frame in zip(images, frames, strict=True):
        rendered = render_frame(frame, 1024, 768, 2.812, 8).astype(np.float64)
        sent = rendered[np.rint(tr.v).astype(int), np.rint(tr.u).astype(int)]
        expected = 0.8 * FULL16 * tr.shading * tr.reflectivity * (sent / 255.0) ** 2.812
        assert np.abs(img - expected)[tr.valid].max() <= 0.5 + 1e-6


@pytest.mark.parametrize("steps", [3, 4, 5])
@pytest.mark.parametrize("pitch", [6.0, 7.3, 13.0])
def test_ideal_round_trip_phase(steps, pitch):
    for scene in (white_plate(20.0), mask()):
        rig = SimulatedRig.ideal(
            scene,
            camera=CameraModel(
                width=161, height=121, bit_depth=16, read_noise_dn8=0, full_well_e=None, blur_px=0
            ),
        )
        tr = rig.truth()
        for orient, coord in (("vertical", tr.u), ("horizontal", tr.v)):
            spec = FringeSpec("sinusoidal", steps, pitch, orient, IMIN16, FULL16)
            phase = nstep_phase(rig.capture(spec.frames()))
            err = wrap_diff(phase, 2 * np.pi * coord / pitch)[tr.valid]
            assert np.abs(err).max() < 1e-3


def test_projector_defocus_attenuates_modulation_like_a_gaussian_mtf():
    cam = small_camera(bit_depth=16, read_noise_dn8=0, full_well_e=None, blur_px=0)
    pitch, sigma = 5.0, 1.0
    spec = FringeSpec("sinusoidal", 8, pitch, "vertical", IMIN16, FULL16)
    sharp = SimulatedRig.ideal(white_plate(10), camera=cam)
    blurred = sharp.replace(
        projector_model=ProjectorModel(bit_depth=16, defocus_px=sigma, model="continuous")
    )
    a0 = sharp.capture(spec.frames())
    a1 = blurred.capture(spec.frames())
    ratio = nstep_amplitude(a1) / nstep_amplitude(a0)
    mtf = math.exp(-2 * math.pi**2 * sigma**2 / pitch**2)
    np.testing.assert_allclose(ratio, mtf, rtol=0.01)
    assert np.abs(wrap_diff(nstep_phase(a1), nstep_phase(a0))).max() < 2e-3


def test_supersampling_keeps_smooth_signals_and_truth_at_pixel_centres():
    cam = small_camera(bit_depth=16, read_noise_dn8=0, full_well_e=None, blur_px=0)
    one = SimulatedRig.ideal(white_plate(10), camera=cam)
    three = one.replace(
        camera=small_camera(
            bit_depth=16, read_noise_dn8=0, full_well_e=None, blur_px=0, supersample=3
        )
    )
    np.testing.assert_array_equal(one.truth().u, three.truth().u)
    a = one.capture([UniformFrame(40000)]).astype(float)
    b = three.capture([UniformFrame(40000)]).astype(float)
    assert np.abs(a - b).max() <= 2.0
    # a fine fringe is attenuated by integrating over the pixel area (box filter)
    fine = FringeSpec("sinusoidal", 4, 3.0, "vertical", IMIN16, FULL16).frames()
    boxed = nstep_amplitude(three.capture(fine)).mean()
    assert boxed < 0.9 * nstep_amplitude(one.capture(fine)).mean()


# --- saturation ---------------------------------------------------------------------------------


def test_600_lux_saturates_white_plate_peaks_at_migl_255():
    """Default rig = thesis Ch. 4: no saturation in the dark, saturation with 600 lx."""
    spec = FringeSpec("sinusoidal", 3, 6.0, "vertical", 40, 255)
    dark = SimulatedRig(white_plate(24.0))
    lit = dark.replace(lighting=Lighting(ambient_lux=600.0))
    assert dark.capture(spec.frames()).max() < 255
    images = lit.capture(spec.frames())
    assert (images == 255).any(axis=0).mean() > 0.5  # most pixels lose a fringe peak
    assert (images == 255).mean() < 0.9  # troughs stay below
    # lowering the MIGL avoids it again (the thesis's method)
    assert lit.capture(spec.with_migl(150).frames()).max() < 255


def test_checkerboard_with_black_plate_aperture():
    camera = CameraModel().with_aperture_for(BLACK_PLATE_REFLECTIVITY)
    rig = SimulatedRig(checkerboard(), camera=camera)
    tr = rig.truth()
    white = binary_erosion(tr.reflectivity > 0.5, iterations=2)
    black = binary_erosion(tr.reflectivity < 0.5, iterations=2)
    spec = FringeSpec("sinusoidal", 4, 8.0, "vertical", 40, 255)
    images = rig.capture(spec.frames())
    peak, low = images.max(axis=0), images.min(axis=0)
    assert (peak[white] == 255).mean() > 0.99
    assert peak[black].max() < 255
    assert np.median(peak[black].astype(int) - low[black]) > 0.45 * 255  # good modulation
    # the white squares stop saturating at a low MIGL (thesis LPA reaches MIGL 70)
    assert rig.capture(spec.with_migl(70).frames()).max(axis=0)[white].max() < 255
    # the black plate with that aperture never saturates over the calibration depths
    for depth in (2.0, 50.0):
        plate = rig.replace(scene=black_plate(depth))
        assert plate.capture(spec.frames()).max() < 255


def test_glossy_highlight_saturates_on_the_projector_side():
    rig = SimulatedRig(glossy())
    spec = FringeSpec("sinusoidal", 4, 8.0, "vertical", 40, 255)
    images = rig.capture(spec.frames())
    tr = rig.truth()
    sat = (images == 255).any(axis=0)
    assert sat.sum() >= 20
    assert sat.mean() < 0.02
    assert np.all(np.hypot(tr.x_mm[sat], tr.y_mm[sat]) < glossy().base_radius_mm)
    # the normal bisects the projector (at -X) and camera directions ~7.5 deg: x ~ -R sin 7.5
    assert -25.0 < tr.x_mm[sat].mean() < -5.0
    assert abs(tr.y_mm[sat].mean()) < 5.0
    assert rig.expected_signal(spec.frames()).max() > 300  # the true intensity is lost
    matte = rig.replace(scene=glossy(specular=0.0))
    assert matte.capture(spec.frames()).max() < 255


@pytest.mark.parametrize("bits", [8, 10, 12, 16])
def test_camera_bit_depths(bits):
    full = 2**bits - 1
    spec = FringeSpec(steps=3, pitch_px=6)
    dark = SimulatedRig(white_plate(10), camera=small_camera(bit_depth=bits))
    bright = dark.replace(lighting=Lighting(ambient_lux=600.0))
    a = dark.capture(spec.frames())
    b = bright.capture(spec.frames())
    dtype = np.uint8 if bits == 8 else np.uint16
    assert a.dtype == dtype and b.dtype == dtype
    assert a.max() < full and b.max() == full
    # the same scene reads the same fraction of full scale at any bit depth
    assert a.mean() / full == pytest.approx(
        SimulatedRig(white_plate(10), camera=small_camera()).capture(spec.frames()).mean() / 255,
        rel=0.01,
    )


def test_migl_above_projector_range_is_rejected():
    rig = SimulatedRig(white_plate(0), camera=small_camera())
    with pytest.raises(InputError):
        rig.capture(FringeSpec(migl=1000.0).frames())
    cont = rig.replace(projector_model=ProjectorModel(model="continuous"))
    with pytest.raises(InputError):
        cont.capture(FringeSpec(migl=1000.0).frames())


# --- noise --------------------------------------------------------------------------------------


def test_read_noise_std_matches_sigma():
    sigma = 3.0
    rig = SimulatedRig(white_plate(10), camera=small_camera(read_noise_dn8=sigma, full_well_e=None))
    stack = rig.capture([UniformFrame(128)] * 40).astype(np.float64)
    var = stack.var(axis=0, ddof=1).mean()
    assert math.sqrt(var) == pytest.approx(math.sqrt(sigma**2 + 1 / 12), rel=0.03)
    mean_err = stack.mean(axis=0) - rig.expected_signal([UniformFrame(128)])[0]
    assert abs(mean_err.mean()) < 0.05


def test_shot_noise_grows_with_signal():
    well = 2000.0
    cam = small_camera(bit_depth=12, read_noise_dn8=0.0, full_well_e=well)
    rig = SimulatedRig(white_plate(10), camera=cam)
    for level in (60, 250):
        stack = rig.capture([UniformFrame(level)] * 30).astype(np.float64)
        signal = rig.expected_signal([UniformFrame(level)])[0]
        expected_var = (signal * 4095 / well).mean() + 1 / 12
        assert stack.var(axis=0, ddof=1).mean() == pytest.approx(expected_var, rel=0.05)


# --- scenes -------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", sorted(SCENES))
def test_scene_manifest_round_trip(name):
    scene = make_scene(name)
    entry = scene.to_manifest()
    assert entry["name"] == name
    assert scene_from_manifest(json.loads(json.dumps(entry))) == scene
    flat = name in ("white_plate", "black_plate", "plate", "checkerboard")
    assert ("depth_mm" in entry) == flat


def test_scene_errors():
    with pytest.raises(InputError):
        make_scene("teapot")
    with pytest.raises(InputError):
        make_scene("white_plate", colour="red")
    with pytest.raises(InputError):
        white_plate(float("nan"))
    with pytest.raises(InputError):
        SimulatedRig(white_plate(0), seed=-1)


def test_mask_is_a_freeform_inside_the_field():
    m = mask()
    x, y = np.meshgrid(np.linspace(-160, 160, 321), np.linspace(-122, 122, 245))
    h = m.height(x, y)
    assert 40.0 < h.max() < 70.0
    border = np.concatenate([h[0], h[-1], h[:, 0], h[:, -1]])
    assert border.max() < 0.05
    gx, gy = m.gradient(x, y)
    assert np.hypot(gx, gy).max() < 2.5


# --- Eq. 4.1 ------------------------------------------------------------------------------------


def test_modify_captures_clips_and_keeps_dtype():
    img8 = np.array([[0, 100, 153, 154, 255]], dtype=np.uint8)
    out = modify_captures(img8, 8, add_lux=600)
    assert out.dtype == np.uint8
    np.testing.assert_array_equal(out, [[102, 202, 255, 255, 255]])
    img12 = np.array([4000, 10], dtype=np.uint16)
    out12 = modify_captures(img12, 12, add_lux=100)
    assert out12.dtype == np.uint16
    assert float(lux_to_dn(100, 12)) == pytest.approx(17 * 4095 / 255)
    np.testing.assert_array_equal(out12, [4095, 10 + round(17 * 4095 / 255)])
    # D as a per-pixel distribution, broadcast over the frames
    stack = np.full((3, 2, 2), 200, dtype=np.uint8)
    d = np.array([[0.0, 10.0], [55.0, 80.0]])
    np.testing.assert_array_equal(modify_captures(stack, 8, add_dn=d)[1], [[200, 210], [255, 255]])


def test_modify_captures_noise_and_errors():
    img = np.full((200, 200), 100, dtype=np.uint8)
    noisy = modify_captures(img, 8, add_dn=20, noise_sigma=4.0, seed=5)
    assert noisy.mean() == pytest.approx(120, abs=0.1)
    assert noisy.std() == pytest.approx(math.sqrt(16 + 1 / 12), rel=0.03)
    again = modify_captures(img, 8, add_dn=20, noise_sigma=4.0, seed=5)
    np.testing.assert_array_equal(noisy, again)
    with pytest.raises(InputError):
        modify_captures(np.array([300], dtype=np.uint16), 8)
    with pytest.raises(InputError):
        modify_captures(np.array([1.0]), 8)
    with pytest.raises(InputError):
        modify_captures(np.zeros((2, 3), dtype=np.uint8), 8, add_dn=np.zeros(4))


@settings(max_examples=50, deadline=None)
@given(
    img=arrays(np.uint16, (3, 4), elements=st.integers(0, 1023)),
    add=st.integers(0, 2000),
)
def test_modify_is_eq_4_1(img, add):
    out = modify_captures(img, 10, add_dn=add)
    np.testing.assert_array_equal(out, np.minimum(1023, img.astype(np.int64) + add))
    assert out.dtype == np.uint16


@pytest.mark.parametrize(
    ("pattern", "steps", "pitch", "orientation", "defocus"),
    [
        ("sinusoidal", 3, 6, "vertical", 0.6),
        ("triangular", 2, 7, "vertical", 0.0),
        ("triangular", 3, 12, "horizontal", 0.6),
    ],
)
def test_periodic_basis_reproduces_the_expected_signal(pattern, steps, pitch, orientation, defocus):
    """The fast sweep path (one response image per projector-pixel residue) is exact: every
    step from projected light to signal is linear."""
    rig = SimulatedRig(
        checkerboard(),
        camera=CameraModel(width=160, height=120, supersample=2),
        projector_model=ProjectorModel(defocus_px=defocus),
        lighting=Lighting(ambient_lux=300.0),
    )
    spec = FringeSpec(pattern, steps, float(pitch), orientation)
    frames = [f for m in (255, 180, 105) for f in spec.with_migl(m).frames()]
    basis = rig.periodic_basis(pitch, orientation)
    light = np.stack([rig.periodic_light(f, pitch) for f in frames])
    fast = rig.ambient_signal() + np.tensordot(light, basis, axes=1)
    assert np.allclose(fast, rig.expected_signal(frames), rtol=0, atol=1e-9)
    with pytest.raises(InputError, match="does not repeat every 5"):
        rig.periodic_light(frames[0], 5)


# --- camera settings on the rig protocol --------------------------------------------------------


def test_replay_rig_takes_settings_and_refuses_exposures_it_does_not_hold():
    """The replay returns the image captured at the asked exposure, and refuses an exposure
    (or a gain) the folder does not hold instead of returning another exposure's image."""
    from hdrfringe.core.captures import CameraSettings, Captures
    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.rig.replay import ReplayRig

    rig = SimulatedRig(white_plate(5.0), camera=small_camera())
    gray = UniformFrame(100)
    images = np.concatenate(
        [
            rig.capture([gray], CameraSettings(5.0)),
            rig.capture([gray], CameraSettings(10.0)),
            rig.capture([UniformFrame(200)]),
        ]
    )
    folder = Captures([gray, gray, UniformFrame(200)], images, 8, exposure_ms=(5.0, 10.0, None))
    assert not np.array_equal(images[0], images[1])
    with ReplayRig(folder) as replay:
        assert isinstance(replay, Rig)
        np.testing.assert_array_equal(replay.capture([gray], CameraSettings(5.0))[0], images[0])
        np.testing.assert_array_equal(replay.capture([gray], CameraSettings(10))[0], images[1])
        assert replay.capture([gray]).shape == (1, 49, 65)  # no settings: as before
        with pytest.raises(CaptureFormatError, match="at 5 ms, 10 ms, not at 7 ms"):
            replay.capture([gray], CameraSettings(7.0))
        with pytest.raises(CaptureFormatError, match="no recorded exposure"):
            replay.capture([UniformFrame(200)], CameraSettings(5.0))
        with pytest.raises(CaptureFormatError, match="no camera gain"):
            replay.capture([gray], CameraSettings(gain_db=6.0))


def test_replay_rig_replays_recorded_gains():
    """With gains recorded per frame (format version 2) the replay returns the image taken at
    the asked gain, and names the held gains when asked for another."""
    from hdrfringe.core.captures import CameraSettings, Captures
    from hdrfringe.errors import CaptureFormatError
    from hdrfringe.rig.replay import ReplayRig

    rig = SimulatedRig(white_plate(5.0), camera=small_camera())
    gray = UniformFrame(100)
    low, high = CameraSettings(gain_db=0.0), CameraSettings(gain_db=6.0)
    images = np.concatenate([rig.capture([gray], low), rig.capture([gray], high)])
    assert images[1].mean() > 1.9 * images[0].mean()  # 6 dB: about twice the signal
    caps = Captures([gray, gray], images, 8, gain_db=(0.0, 6.0))
    replay = ReplayRig(caps)
    np.testing.assert_array_equal(replay.capture([gray], high)[0], images[1])
    np.testing.assert_array_equal(replay.capture([gray], low)[0], images[0])
    with pytest.raises(CaptureFormatError, match="at gain 0 dB, 6 dB, not at 3 dB"):
        replay.capture([gray], CameraSettings(gain_db=3.0))
