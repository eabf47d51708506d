"""Projector images (2-D frames) and camera settings on the virtual rig.

The projector-to-camera mapping is checked against the rig geometry computed here from first
principles (pinhole camera, look-at projector, plate plane), not through the rig's tracing.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from scipy.ndimage import binary_erosion

from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.frames import (
    FringeFrame,
    ImageFrame,
    PixelwiseFringeFrame,
    UniformFrame,
    frame_from_manifest,
    render_frame,
    sample_bilinear,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.rig.base import Rig, RigBase
from hdrfringe.rig.scenes import mask, white_plate
from hdrfringe.rig.simulated import (
    REFERENCE_EXPOSURE_MS,
    CameraModel,
    Lighting,
    ProjectorModel,
    RigGeometry,
    SimulatedRig,
)

FULL16 = 65535
IMIN16 = 40 * 257
PROJ_W, PROJ_H = 1024, 768


def ideal_camera(**changes) -> CameraModel:
    """A noise-free, blur-free 16-bit camera, coarse (odd size: a pixel on the optical axis)."""
    args: dict[str, Any] = {
        "width": 129,
        "height": 97,
        "bit_depth": 16,
        "read_noise_dn8": 0.0,
        "full_well_e": None,
        "blur_px": 0.0,
    }
    args.update(changes)
    return CameraModel(**args)


def plate_projector_coords(
    geometry: RigGeometry, camera: CameraModel, depth_mm: float
) -> tuple[np.ndarray, np.ndarray]:
    """Projector (column, row) seen by each camera pixel centre on a plate at ``depth_mm``.

    From the documented layout (docs/virtual_rig.md, "Geometry"): a pinhole camera at
    ``(0, 0, standoff)`` looking down -Z, image columns along +X and rows along -Y, focal length
    ``W * standoff / camera_field``; a pinhole projector at ``D (-sin a, 0, cos a)`` with
    ``D = standoff / cos a``, looking at the origin with its rows along -Y, focal length
    ``Wp * D / projector_field``, principal points at the image centres. Each camera ray is
    intersected with the plane ``z = depth`` and the point projected with ``K [R | -R C]``.
    """
    h, w = camera.height, camera.width
    f = w * geometry.standoff_mm / geometry.camera_field_mm
    jj, ii = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    direction = np.stack(
        [(jj - (w - 1) / 2) / f, -(ii - (h - 1) / 2) / f, -np.ones_like(jj)], axis=-1
    )
    cam_centre = np.array([0.0, 0.0, geometry.standoff_mm])
    t = (geometry.standoff_mm - depth_mm) / 1.0  # the ray's z falls by 1 per unit t
    points = cam_centre + t * direction  # (h, w, 3) on the plate

    a = math.radians(geometry.angle_deg)
    dist = geometry.standoff_mm / math.cos(a)
    proj_centre = dist * np.array([-math.sin(a), 0.0, math.cos(a)])
    z_axis = -proj_centre / np.linalg.norm(proj_centre)  # looks at the origin
    y_axis = np.array([0.0, -1.0, 0.0])  # image rows run along -Y
    x_axis = np.cross(y_axis, z_axis)
    rot = np.stack([x_axis, y_axis, z_axis])
    fp = PROJ_W * dist / geometry.projector_field_mm
    k = np.array([[fp, 0.0, (PROJ_W - 1) / 2], [0.0, fp, (PROJ_H - 1) / 2], [0.0, 0.0, 1.0]])
    p = (points - proj_centre) @ rot.T @ k.T
    return p[..., 0] / p[..., 2], p[..., 1] / p[..., 2]


def decode_level(rig: SimulatedRig, frame, full: float = FULL16) -> np.ndarray:
    """The linear input gray level each camera pixel sees, from captures of the frame and of
    black and white frames: the ideal rig pre-compensates the true gamma, so the camera signal
    is affine in the gray level per pixel (shading, reflectivity, black level, ambient)."""
    black, white, img = rig.capture([UniformFrame(0), UniformFrame(full), frame]).astype(float)
    return full * (img - black) / (white - black)


# --- projector-to-camera mapping -----------------------------------------------------------------


@pytest.mark.parametrize("depth", [0.0, 35.0])
def test_image_frame_mapping_is_exact_on_a_plate_pixelated(depth):
    """Each camera pixel sees the projector pixel containing its first-principles (u, v).

    Pixelated 16-bit projector without defocus: the level of an image encoding the column
    (64 * c) or row (85 * r) comes back within about 2 of 65535 (projector rounding after
    pre-compensation, at most 0.5 * gamma = 1.4 levels, plus the camera's rounding), far below
    half the 64/85 spacing, so the decoded pixel index is exact. It must equal
    floor(u + 0.5) of the geometry except where u lies within 1e-6 px of a pixel border.
    Rejects: a half-pixel principal-point error, swapped u/v, mirrored axes, a wrong focal
    length, nearest-pixel rounding done as floor(u).
    """
    geometry = RigGeometry()
    camera = ideal_camera()
    rig = SimulatedRig.ideal(
        white_plate(depth),
        camera=camera,
        projector_model=ProjectorModel(bit_depth=16, defocus_px=0.0, model="pixelated"),
    )
    u, v = plate_projector_coords(geometry, camera, depth)
    cols = np.broadcast_to(np.arange(PROJ_W) * 64.0, (PROJ_H, PROJ_W))
    rows = np.broadcast_to(np.arange(PROJ_H)[:, None] * 85.0, (PROJ_H, PROJ_W))
    for image, scale, coord in ((cols, 64.0, u), (rows, 85.0, v)):
        level = decode_level(rig, ImageFrame(image, "ramp"))
        decoded = np.rint(level / scale)
        assert np.abs(level - decoded * scale).max() < 3.0  # within rounding of a level
        expected = np.floor(coord + 0.5)
        on_border = np.abs(coord - np.floor(coord) - 0.5) < 1e-6
        assert np.all((decoded == expected) | on_border)
        # only the camera row on the optical axis (Y = 0: v = 383.5 exactly) sits on a border
        assert on_border.sum() <= camera.width


def test_image_frame_mapping_is_exact_on_a_plate_continuous():
    """Continuous projector (bilinear image): the decoded column/row equals the geometry's u/v.

    A linear ramp interpolated bilinearly is exactly linear, so the decoded level / 64 is u up
    to rounding: projector 0.5 level after pre-compensation (<= 1.4 input levels), camera
    0.5 DN on three captures of a >= 40000 DN span (<= 1.5 levels): < 3 levels, 0.05 px at 64
    levels per column. Rejects the same geometry bugs, and the image sampled with its
    pixel centres taken at half-integers (0.5 px).
    """
    geometry = RigGeometry()
    camera = ideal_camera()
    depth = 20.0
    rig = SimulatedRig.ideal(white_plate(depth), camera=camera)
    u, v = plate_projector_coords(geometry, camera, depth)
    cols = np.broadcast_to(np.arange(PROJ_W) * 64.0, (PROJ_H, PROJ_W))
    rows = np.broadcast_to(np.arange(PROJ_H)[:, None] * 85.0, (PROJ_H, PROJ_W))
    err_u = decode_level(rig, ImageFrame(cols, "columns")) / 64.0 - u
    err_v = decode_level(rig, ImageFrame(rows, "rows")) / 85.0 - v
    assert np.abs(err_u).max() < 0.05
    assert np.abs(err_v).max() < 0.05
    # the field spans hundreds of projector pixels, so a 0.05 px agreement is not trivial
    assert np.ptp(u) > 300 and np.ptp(v) > 200


# --- the 2-D path against the 1-D path ------------------------------------------------------------


def _line_frames() -> list:
    return [
        FringeSpec("sinusoidal", 3, 6.0, "vertical", 40, 255).frames()[1],
        FringeSpec("triangular", 3, 9.0, "horizontal", 40, 200).frames()[2],
        UniformFrame(180),
    ]


@pytest.mark.parametrize("defocus", [0.0, 0.6, 1.3])
def test_line_frame_through_the_image_path_matches_the_line_path(defocus):
    """A line frame shown as an ImageFrame of its rendered image gives the line path's signal.

    Without defocus both sample the projector pixel containing (u, v): bit-identical. With
    defocus the line path blurs a line sampled 16 times per pixel and interpolates linearly
    (error <= h^2/8 max|L''| with h = 1/16 px, max|L''| <= 0.24/sigma^2 per unit step for a
    blurred edge: 3.3e-4 of the full light at sigma 0.6, plus the Gaussian's 4-sigma
    truncation, 6e-5), while the image path is exact: they agree to 1e-3 of full white.
    Rejects an off-by-one tap, sigma scaled by sqrt(2), a kernel missing the pixel box, and
    taps that let light in from outside the projector.
    """
    rig = SimulatedRig(
        mask(),
        camera=CameraModel(width=160, height=120, read_noise_dn8=0.0, full_well_e=None),
        projector_model=ProjectorModel(defocus_px=defocus),
        gamma_precompensation=1.0,  # so the rendered integers re-render to themselves
    )
    white = (rig.expected_signal([UniformFrame(255)])[0] - rig.ambient_signal()).max()
    for frame in _line_frames():
        as_image = ImageFrame(render_frame(frame, PROJ_W, PROJ_H, 1.0, 8), "rendered")
        line, image = rig.expected_signal([frame, as_image])
        if defocus == 0:
            np.testing.assert_array_equal(image, line)
        else:
            assert np.abs(image - line).max() < 1e-3 * white
            assert np.abs(image - line).max() > 0  # really two computations


@pytest.mark.parametrize("defocus", [0.0, 0.6])
def test_image_path_darkens_outside_the_projector(defocus):
    """A projector field narrower than the camera's: the camera pixels beyond the projector
    image stay dark in the image path, as in the line path (agreement as above: exact when
    sharp, 1e-3 of white with defocus). Rejects sampling the clamped border pixel there."""
    geometry = RigGeometry(projector_field_mm=250.0)  # narrower than the camera field
    rig = SimulatedRig(
        white_plate(0.0),
        geometry=geometry,
        camera=CameraModel(width=160, height=120, read_noise_dn8=0.0, full_well_e=None),
        projector_model=ProjectorModel(defocus_px=defocus),
    )
    frame = UniformFrame(255)
    as_image = ImageFrame(np.full((PROJ_H, PROJ_W), 255.0), "white")
    line, image = rig.expected_signal([frame, as_image])
    outside = binary_erosion(~rig.truth().valid, iterations=3, border_value=1)  # off the edge
    assert outside.mean() > 0.05
    assert image[outside].max() < 0.01 * image.max()
    assert np.abs(image - line).max() <= 1e-3 * image.max() * (defocus > 0)


# --- per-pixel MIGL -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "projector",
    [
        ProjectorModel(bit_depth=16, defocus_px=0.0, model="continuous"),
        ProjectorModel(bit_depth=16, defocus_px=0.0, model="pixelated"),
        ProjectorModel(bit_depth=16, defocus_px=0.6, model="pixelated"),
    ],
    ids=["continuous", "pixelated", "pixelated-defocus"],
)
def test_constant_migl_map_equals_the_fringe_frame(projector):
    """A constant map gives the FringeFrame at that MIGL: bit-identical without defocus (same
    gray-level arithmetic; the bilinear map of a constant is exactly the constant), within the
    line path's discretisation (1e-3 of full white, see above) with defocus. Rejects a map
    read as MIGL minus imin, or ignored in favour of spec.migl."""
    rig = SimulatedRig.ideal(mask(), camera=ideal_camera(), projector_model=projector)
    migl = 50000.0
    spec = FringeSpec("sinusoidal", 4, 7.0, "vertical", IMIN16, FULL16)  # nominal migl 65535
    fringe = FringeFrame(spec.with_migl(migl), 1)
    pixelwise = PixelwiseFringeFrame(spec, 1, np.full((PROJ_H, PROJ_W), migl))
    a, b = rig.expected_signal([fringe, pixelwise])
    if projector.defocus_px == 0:
        np.testing.assert_array_equal(a, b)
    else:
        white = (rig.expected_signal([UniformFrame(FULL16)])[0] - rig.ambient_signal()).max()
        assert np.abs(a - b).max() < 1e-3 * white


def _amplitude(images: np.ndarray) -> np.ndarray:
    n = images.shape[0]
    d = 2 * np.pi * np.arange(n) / n
    return 2.0 / n * np.abs(np.tensordot(np.exp(-1j * d), images.astype(float), axes=1))


@pytest.mark.parametrize(
    ("projector", "margin"),
    [
        (ProjectorModel(bit_depth=16, defocus_px=0.0, model="continuous"), 1.0),
        (ProjectorModel(bit_depth=16, defocus_px=0.6, model="pixelated"), 4.0),
    ],
    ids=["continuous", "pixelated-defocus"],
)
def test_half_migl_map_lowers_the_amplitude_where_the_geometry_says(projector, margin):
    """MIGL lowered over the projector's left half (columns < 512): the camera pixels whose
    first-principles u is left of it get the amplitude ratio (m_low - imin)/(m_high - imin),
    the others keep the full amplitude; pixels where the map is 0 (<= imin) show imin.

    The ideal rig pre-compensates the true gamma, so the amplitude is proportional to
    migl - imin up to 16-bit rounding (1e-4 relative). Rejects a transposed or mirrored map,
    a MIGL applied without the imin offset (ratio 0.5 instead of 0.41), and maps below imin
    going darker than imin.
    """
    geometry = RigGeometry()
    camera = ideal_camera()
    depth = 10.0
    rig = SimulatedRig.ideal(white_plate(depth), camera=camera, projector_model=projector)
    u, v = plate_projector_coords(geometry, camera, depth)
    m_low = 32768.0
    spec = FringeSpec("sinusoidal", 4, 8.0, "vertical", IMIN16, FULL16)
    migl = np.full((PROJ_H, PROJ_W), float(FULL16))
    migl[:, :512] = m_low
    migl[:384, 700:] = 0.0  # top right quarter: below imin
    full = _amplitude(rig.capture(spec.frames()))
    half = rig.capture([PixelwiseFringeFrame(spec, i, migl) for i in range(4)])
    ratio = _amplitude(half) / full
    left = u < 511.5 - margin
    right = (u > 511.5 + margin) & ~((u > 699.5 - margin) & (v < 383.5 + margin))
    dark = (u > 699.5 + margin) & (v < 383.5 - margin)
    assert left.sum() > 1000 and right.sum() > 1000 and dark.sum() > 500
    expected = (m_low - IMIN16) / (FULL16 - IMIN16)
    np.testing.assert_allclose(ratio[left], expected, rtol=2e-3)
    np.testing.assert_allclose(ratio[right], 1.0, rtol=2e-3)
    assert ratio[dark].max() < 2e-3
    # in the dark quarter every shift shows imin: the same level as a uniform imin frame
    flat = rig.capture([UniformFrame(IMIN16)])[0].astype(float)
    assert np.abs(half[:, dark].astype(float) - flat[dark]).max() <= 1.0


# --- the frames themselves ------------------------------------------------------------------------


def test_pixelwise_frame_renders_the_pattern_convention_per_pixel():
    """Render against the docs' formula written out here: g = imin + (max(m, imin) - imin) *
    (1 + cos(2 pi (x + i p/N) / p)) / 2, then rounding (gamma 1)."""
    spec = FringeSpec("sinusoidal", 3, 5.0, "horizontal", 30, 255)
    rng = np.random.default_rng(1)
    m = rng.uniform(0, 255, (12, 17))
    img = PixelwiseFringeFrame(spec, 2, m).render(17, 12, 1.0, 8)
    y = np.arange(12)[:, None]
    m32 = m.astype(np.float32).astype(float)
    g = 30 + (np.maximum(m32, 30) - 30) * (1 + np.cos(2 * np.pi * (y + 2 * 5.0 / 3) / 5.0)) / 2
    np.testing.assert_array_equal(img, np.rint(g))


def test_image_frames_validate_and_compare_by_content():
    spec = FringeSpec()
    m = np.full((4, 6), 200.0)
    a = PixelwiseFringeFrame(spec, 0, m)
    m[0, 0] = 0.0  # the frame holds its own copy
    assert a == PixelwiseFringeFrame(spec, 0, np.full((4, 6), 200))
    assert a != PixelwiseFringeFrame(spec, 0, m)
    assert a != PixelwiseFringeFrame(spec, 1, np.full((4, 6), 200))
    assert len({a, PixelwiseFringeFrame(spec, 0, np.full((4, 6), 200.0))}) == 1
    assert not a.migl_map.flags.writeable
    assert ImageFrame(np.eye(3), "x") == ImageFrame(np.eye(3), "x") != ImageFrame(np.eye(3), "y")
    with pytest.raises(InputError):
        PixelwiseFringeFrame(spec, 0, np.ones(5))  # not 2-D
    with pytest.raises(InputError):
        PixelwiseFringeFrame(spec, 0, np.array([[1.0, np.nan]]))
    with pytest.raises(InputError):
        PixelwiseFringeFrame(spec, 3, np.ones((2, 2)))  # shift outside 0..N-1
    with pytest.raises(InputError):
        ImageFrame(-np.ones((2, 2)), "negative")
    with pytest.raises(InputError):
        ImageFrame(np.ones((2, 2), dtype=bool), "binary")
    with pytest.raises(InputError, match="projector is 8x4"):
        a.render(8, 4)  # wrong projector size
    with pytest.raises(InputError, match="above the projector's maximum"):
        ImageFrame(np.full((4, 6), 300.0), "bright").render(6, 4, 1.0, 8)
    rig = SimulatedRig(white_plate(0), camera=CameraModel(width=32, height=24))
    with pytest.raises(InputError, match="projector is 1024x768"):
        rig.capture([a])
    cont = rig.replace(projector_model=ProjectorModel(model="continuous"))
    with pytest.raises(InputError, match="continuous projector model with defocus"):
        cont.capture([ImageFrame(np.zeros((PROJ_H, PROJ_W)), "black")])


def test_image_frames_seed_noise_by_content():
    """Equal content, equal noise on fresh rigs; a changed pixel or a repeat, fresh noise."""
    rig = SimulatedRig(white_plate(5), camera=CameraModel(width=48, height=36))
    spec = FringeSpec()
    m = np.full((PROJ_H, PROJ_W), 200.0)
    frame = PixelwiseFringeFrame(spec, 0, m)
    first = rig.replace().capture([frame, frame])
    again = rig.replace().capture([PixelwiseFringeFrame(spec, 0, m.copy())])
    np.testing.assert_array_equal(first[0], again[0])
    assert np.any(first[0] != first[1])
    m[0, 0] = 199.0  # a projector pixel no camera pixel sees: same signal, other noise
    other = rig.replace().capture([PixelwiseFringeFrame(spec, 0, m)])
    assert np.any(other[0] != first[0])


def test_manifest_round_trip_through_a_loader():
    """Entries name a side file and the content digest; frame_from_manifest rebuilds the frame
    with the I/O layer's loader and refuses a side file whose content changed."""
    spec = FringeSpec("triangular", 3, 12.5, "vertical", 40, 230)
    frames = [
        PixelwiseFringeFrame(spec, 1, np.linspace(50, 230, 24).reshape(4, 6)),
        ImageFrame(np.arange(24).reshape(4, 6) * 10, "ramp"),
    ]
    store: dict[str, np.ndarray] = {}
    entries = []
    for k, f in enumerate(frames):
        entry = f.manifest_entry(f"{k}.png", data_file=f"projector/{k}.tiff")
        store[entry[f.DATA_FIELD]] = f.data.copy()
        entries.append(entry)
    assert entries[0]["kind"] == "pixelwise_fringe" and entries[0]["migl_map"] == "projector/0.tiff"
    assert entries[1]["kind"] == "image" and entries[1]["image"] == "projector/1.tiff"
    for f, entry in zip(frames, entries, strict=True):
        assert frame_from_manifest(entry, store.__getitem__) == f
    with pytest.raises(InputError, match="load_array"):
        frame_from_manifest(entries[0])
    store["projector/1.tiff"][0, 0] += 1
    with pytest.raises(CaptureFormatError, match="content_sha256"):
        frame_from_manifest(entries[1], store.__getitem__)
    # default side-file names follow the content (equal data, one file)
    assert frames[1].default_data_file().endswith(".png")
    assert frames[0].manifest_entry("a.png")["migl_map"] == frames[0].default_data_file()


def test_sample_bilinear_against_hand_values():
    """Hand-computed values on a non-linear image (a linear ramp cannot tell neighbours apart:
    any two of its pixels extrapolate it exactly), clamping at the border, and exactness on a
    constant (a (1 - f) a + f a weighted sum misses 1/3 by an ulp at 4 % of the f). Rejects the
    neighbour pair chosen by rounding instead of flooring, and swapped axes."""
    img = np.array([[0.0, 10.0, 40.0], [30.0, 40.0, 90.0]])
    got = sample_bilinear(img, [0.75, 1.5, -3.0, 2.0, 1.25], [0.0, 1.0, 0.0, 9.0, 0.5])
    np.testing.assert_allclose(got, [7.5, 65.0, 0.0, 90.0, 35.0])
    rng = np.random.default_rng(3)
    u, v = rng.uniform(0, 3, 1000), rng.uniform(0, 2, 1000)
    assert np.all(sample_bilinear(np.full((3, 4), 1 / 3), u, v) == 1 / 3)


# --- exposure and gain ----------------------------------------------------------------------------


def _lit_ideal_rig(**changes) -> SimulatedRig:
    args = {
        "camera": ideal_camera(),
        "lighting": Lighting(ambient_lux=300.0, direct_ambient_lux=50.0),
    }
    args.update(changes)
    return SimulatedRig.ideal(mask(), **args)


def test_counts_scale_linearly_with_exposure_ambient_included():
    """Fit I = a t + b per pixel over three exposures: b = 0 (the ambient terms scale too) and
    a t_ref = the reference signal; each doubling doubles the counts to rounding (|rint(2x) -
    2 rint(x)| <= 1). The fit's tolerances are its rounding bounds: the least-squares intercept
    and slope are fixed combinations of the three counts, each off by <= 0.5 DN, which bounds
    |b| by 1.01 DN and |a t_ref - signal| by 1.45 DN. Rejects scaling only the projector term
    (b = ambient, about 11000 DN here), an offset left unscaled, an inverted exposure factor."""
    rig = _lit_ideal_rig()
    frames = [FringeSpec("sinusoidal", 3, 8.0, "vertical", IMIN16, 30000).frames()[0]]
    times = np.array([2.5, 5.0, 10.0])
    caps = np.stack([rig.capture(frames, CameraSettings(t))[0] for t in times]).astype(float)
    assert caps.max() < FULL16  # no clipping in this range
    assert rig.ambient_signal().mean() > 10000  # the ambient really is large
    for lo, hi in ((0, 1), (1, 2)):
        assert np.abs(caps[hi] - 2 * caps[lo]).max() <= 1.0
    design = np.stack([times, np.ones_like(times)], axis=1)
    (slope, offset), *_ = np.linalg.lstsq(design, caps.reshape(3, -1), rcond=None)
    assert np.abs(offset).max() < 1.02
    reference = rig.expected_signal(frames)[0].reshape(-1)
    assert np.abs(slope * REFERENCE_EXPOSURE_MS - reference).max() < 1.46
    # the expected signal scales exactly
    e1 = rig.expected_signal(frames, CameraSettings(5.0))
    e2 = rig.expected_signal(frames, CameraSettings(10.0))
    np.testing.assert_allclose(e2, 2 * e1, rtol=1e-14)


def test_long_exposure_clips_every_bright_pixel_at_full_scale():
    """Eight times the reference: every lit pixel's true signal exceeds 2^B - 1 and reads
    exactly 2^B - 1 (never wraps around in uint16, never exceeds it); at the reference
    exposure none does. Rejects clipping before the exposure scaling and a uint16 cast without
    clipping."""
    rig = _lit_ideal_rig(lighting=Lighting())
    frame = [UniformFrame(40000)]
    long = CameraSettings(exposure_ms=8 * REFERENCE_EXPOSURE_MS)
    bright = rig.truth().valid & (rig.expected_signal(frame, long)[0] > FULL16)
    assert bright.mean() > 0.9
    img = rig.capture(frame, long)[0]
    assert np.all(img[bright] == FULL16)
    assert img.max() == FULL16
    assert rig.capture(frame)[0].max() < FULL16


def test_gain_scales_signal_and_read_noise():
    """+20 log10(2) dB doubles the signal; the read noise doubles with it (variance x4)."""
    gain = CameraSettings(gain_db=20 * math.log10(2.0))
    rig = _lit_ideal_rig()
    frame = [UniformFrame(20000)]
    np.testing.assert_allclose(
        rig.expected_signal(frame, gain), 2 * rig.expected_signal(frame), rtol=1e-12
    )
    noisy = SimulatedRig(
        white_plate(10),
        camera=CameraModel(width=64, height=48, read_noise_dn8=2.0, full_well_e=None),
    )
    base = noisy.capture([UniformFrame(60)] * 30).astype(float).var(axis=0, ddof=1).mean()
    boosted = noisy.capture([UniformFrame(60)] * 30, gain).astype(float).var(axis=0, ddof=1).mean()
    # variances: read^2 + 1/12 (rounding): 4.08 and 16.08; pooled over 3072 pixels x 29 dof
    assert base == pytest.approx(4 + 1 / 12, rel=0.05)
    assert boosted == pytest.approx(16 + 1 / 12, rel=0.05)


def test_noise_regimes_follow_the_model_across_exposures():
    """Read-noise only: the variance of repeated captures does not change with exposure. Shot
    noise only: it is (2^B - 1)/full_well times the (scaled) signal, so it doubles with the
    exposure. Rejects read noise scaled by the exposure and shot noise computed from the
    unscaled signal."""
    frame = UniformFrame(100)
    settings = [CameraSettings(5.0), CameraSettings(20.0)]
    read_only = SimulatedRig(
        white_plate(10),
        camera=CameraModel(width=64, height=48, read_noise_dn8=3.0, full_well_e=None),
    )
    var_read = [
        read_only.capture([frame] * 30, s).astype(float).var(axis=0, ddof=1).mean()
        for s in settings
    ]
    for var in var_read:
        assert var == pytest.approx(9 + 1 / 12, rel=0.05)

    shot_only = SimulatedRig(
        white_plate(10),
        camera=CameraModel(width=64, height=48, bit_depth=16, read_noise_dn8=0.0),
    )
    per_electron = shot_only.camera.full_scale / shot_only.camera.full_well_e
    var_shot = []
    for s in settings:
        stack = shot_only.capture([frame] * 30, s).astype(float)
        expected = shot_only.expected_signal([frame], s)[0]
        var = stack.var(axis=0, ddof=1)
        assert (var / (per_electron * expected + 1 / 12)).mean() == pytest.approx(1.0, rel=0.05)
        var_shot.append(var.mean())
    assert var_shot[1] / var_shot[0] == pytest.approx(4.0, rel=0.05)  # 4x the exposure


def test_two_exposures_of_a_frame_get_independent_noise():
    """The settings are part of the noise seed: residuals at two exposures are uncorrelated
    (with the seed ignoring them both would draw the same normals: correlation near 1), while
    reference settings given explicitly seed exactly like no settings."""
    rig = SimulatedRig(
        white_plate(10),
        camera=CameraModel(width=64, height=48, read_noise_dn8=3.0, full_well_e=None),
    )
    frame = [UniformFrame(100)]

    def fresh() -> SimulatedRig:  # no capture counted yet: the count cannot separate them
        return rig.replace()

    residuals = [
        fresh().capture(frame, CameraSettings(t))[0]
        - rig.expected_signal(frame, CameraSettings(t))[0]
        for t in (8.0, 12.0)
    ]
    assert abs(np.corrcoef(residuals[0].ravel(), residuals[1].ravel())[0, 1]) < 0.1

    assert CameraModel().exposure_ms == REFERENCE_EXPOSURE_MS == 10.0  # as documented
    reference = CameraSettings(REFERENCE_EXPOSURE_MS, 0.0)
    np.testing.assert_array_equal(fresh().capture(frame), fresh().capture(frame, reference))
    np.testing.assert_array_equal(
        fresh().capture(frame), fresh().capture(frame, CameraSettings(exposure_ms=10))
    )


def test_camera_settings_attribute_sets_the_defaults():
    rig = SimulatedRig(white_plate(5), camera=ideal_camera(exposure_ms=4.0))
    assert rig.camera_settings == CameraSettings(4.0, 0.0)
    frame = [UniformFrame(20000)]
    base = rig.expected_signal(frame)
    rig.camera_settings = CameraSettings(exposure_ms=8.0)
    assert rig.camera_settings == CameraSettings(8.0, 0.0)
    np.testing.assert_allclose(rig.expected_signal(frame), 2 * base, rtol=1e-14)
    # a capture's own settings win; its None fields take the rig's
    np.testing.assert_allclose(
        rig.expected_signal(frame, CameraSettings(gain_db=20 * math.log10(3))), 6 * base, rtol=1e-12
    )
    assert rig.replace().camera_settings == rig.camera_settings
    with pytest.raises(InputError):
        rig.camera_settings = 8.0  # type: ignore[assignment]
    with pytest.raises(InputError):
        rig.capture(frame, {"exposure_ms": 8.0})  # type: ignore[arg-type]


# --- the protocol ---------------------------------------------------------------------------------


def test_rigs_open_close_and_work_as_context_managers():
    events: list[str] = []

    class Logged(SimulatedRig):
        def open(self) -> None:
            events.append("open")

        def close(self) -> None:
            events.append("close")

    rig = Logged(white_plate(5), camera=CameraModel(width=32, height=24))
    assert isinstance(rig, Rig) and isinstance(rig, RigBase)
    with rig as r:
        assert r is rig
        r.capture([UniformFrame(100)])
    assert events == ["open", "close"]
    with pytest.raises(RuntimeError), rig:
        raise RuntimeError("the exception is not swallowed")
    assert events == ["open", "close", "open", "close"]
    with SimulatedRig(white_plate(5), camera=CameraModel(width=32, height=24)) as plain:
        assert plain.capture([UniformFrame(100)]).shape == (1, 24, 32)
