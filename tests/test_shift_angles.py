"""Shift angles and phase offset (issue 12 point 2; capture format version 3).

Every reference here is computed independently of the code under test: the fringes from
``cos(2*pi*x/p + offset + delta)`` written out in the test, the equal-shift phase from the
N = 3 and N = 4 closed forms, the rig's truth from its projector coordinates.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures
from hdrfringe.core.frames import FringeFrame, PixelwiseFringeFrame, frame_from_manifest
from hdrfringe.core.patterns import FringeSpec, fringe_gray, same_fringes
from hdrfringe.core.phase import decode_set, sinusoidal_phase, sinusoidal_phase_ls, wrapped_phase
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.io.captures import read_capture_folder, read_manifest, write_capture_folder

TWO_PI = 2 * np.pi
DATA = Path(__file__).parent / "data"


def wrap_err(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(np.angle(np.exp(1j * (np.asarray(a) - np.asarray(b)))))


def cosine_set(x: np.ndarray, pitch: float, shifts_deg, offset_deg: float = 0.0, a=90.0, b=60.0):
    """The model written out: I_k = a + b*cos(2*pi*x/p + offset + delta_k)."""
    return np.stack(
        [a + b * np.cos(TWO_PI * x / pitch + np.radians(offset_deg + d)) for d in shifts_deg]
    )


# --- FringeSpec ------------------------------------------------------------------------------


def test_default_spec_is_unchanged_and_the_new_fields_change_the_label() -> None:
    base = FringeSpec("sinusoidal", 3, 8.0)
    assert base.shifts_deg is None and base.phase_offset_deg == 0.0 and base.has_standard_phase
    assert base.label() == "s3_p8_v_i40_g255"
    sine = FringeSpec("sinusoidal", 3, 8.0, phase_offset_deg=-90)
    kam = FringeSpec("sinusoidal", 3, 8.0, shifts_deg=(-120, 0, 120))
    labels = {base.label(), sine.label(), kam.label()}
    assert len(labels) == 3
    assert sine.label() == "s3_p8_v_i40_g255_o-90"
    assert kam.label() == "s3_p8_v_i40_g255_d-120_0_120"
    # the same fringes for calibration and MIGL sweeps: every set decodes to 2*pi*x/p
    assert same_fringes(base, sine) and same_fringes(base, kam) and base != sine != kam
    assert same_fringes(kam, kam.with_migl(200)) and kam.with_migl(200).shifts_deg == (-120, 0, 120)
    assert sine.with_migl(200).phase_offset_deg == -90
    # the contract's equal shifts, however written, are the standard set
    assert FringeSpec("sinusoidal", 3, 8.0, shifts_deg=(0, 120, 240)) == base
    assert FringeSpec("sinusoidal", 4, 8.0, shifts_deg=(360, 90, -180, 270)).shifts_deg is None
    many = FringeSpec("sinusoidal", 9, 8.0, shifts_deg=tuple(range(0, 360, 40))[::-1])
    assert many.label().startswith("s9_p8_v_i40_g255_d") and len(many.label()) < 40


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"pattern": "triangular", "phase_offset_deg": -90}, "apply to sinusoidal sets"),
        ({"pattern": "triangular", "shifts_deg": (0, 100, 200)}, "apply to sinusoidal sets"),
        ({"shifts_deg": (0, 100)}, "2 angles for a 3-step set"),
        ({"shifts_deg": (0, 100, 360)}, "repeats an angle"),
        ({"shifts_deg": (0, 100, float("nan"))}, "finite"),
        ({"shifts_deg": (0, 100, "x")}, "numbers of degrees"),
        ({"phase_offset_deg": float("inf")}, "finite"),
    ],
)
def test_spec_refuses_bad_angles(kwargs, needle) -> None:
    args = {"pattern": "sinusoidal", "steps": 3, "pitch_px": 8.0, **kwargs}
    with pytest.raises(InputError, match=needle):
        FringeSpec(**args)


def test_fringe_gray_follows_the_written_out_model() -> None:
    x = np.linspace(-7.0, 31.0, 97)
    shifts = (-120.0, 0.0, 120.0)
    spec = FringeSpec("sinusoidal", 3, 9.5, imin=10, migl=210, shifts_deg=shifts)
    sine = FringeSpec("sinusoidal", 4, 9.5, imin=10, migl=210, phase_offset_deg=-90)
    for k, d in enumerate(shifts):
        ref = 10 + 200 * (1 + np.cos(TWO_PI * x / 9.5 + np.radians(d))) / 2
        assert np.allclose(fringe_gray(x, spec, k), ref, rtol=0, atol=1e-9)
    for k in range(4):  # a sine profile: sin(2*pi*x/p + 2*pi*k/4)
        ref = 10 + 200 * (1 + np.sin(TWO_PI * x / 9.5 + TWO_PI * k / 4)) / 2
        assert np.allclose(fringe_gray(x, sine, k), ref, rtol=0, atol=1e-9)
    # the frame (what the rig renders) is the same function
    assert np.array_equal(FringeFrame(spec, 2).gray(x), fringe_gray(x, spec, 2))


def test_pixelwise_frames_refuse_shift_angles() -> None:
    spec = FringeSpec("sinusoidal", 3, 8.0, phase_offset_deg=-90)
    with pytest.raises(InputError, match="pixelwise fringe follows the contract"):
        PixelwiseFringeFrame(spec, 0, np.full((2, 4), 200.0))


# --- decoding --------------------------------------------------------------------------------


def test_an_offset_alone_keeps_the_standard_modulation_bit_for_bit() -> None:
    """A sine profile with the contract's angles: the phase is the standard one minus the
    offset, and modulation and mean (hence validity at the threshold) are those of the standard
    decode exactly; the least-squares route differs from them by rounding (~1e-13), which
    flipped pixels sitting on the modulation threshold."""
    rng = np.random.default_rng(5)
    x = np.linspace(0, 40, 333)[None, :]
    imgs = np.rint(
        cosine_set(x, 9.0, [0, 90, 180, 270], offset_deg=-90) + rng.normal(0, 1, (4, 1, 333))
    )
    spec = FringeSpec("sinusoidal", 4, 9.0, imin=0, migl=255, phase_offset_deg=-90)
    res = decode_set(imgs.astype(np.uint8), spec, 8, min_modulation=0)
    std = decode_set(
        imgs.astype(np.uint8),
        FringeSpec("sinusoidal", 4, 9.0, imin=0, migl=255),
        8,
        min_modulation=0,
    )
    assert np.array_equal(res.modulation, std.modulation)
    assert np.array_equal(res.mean_intensity, std.mean_intensity)
    assert wrap_err(res.wrapped_phase, std.wrapped_phase + np.pi / 2).max() < 1e-12
    assert res.wrapped_phase.min() >= 0 and res.wrapped_phase.max() < TWO_PI


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_least_squares_equals_the_closed_forms_for_equal_shifts(dtype) -> None:
    """For equal shifts the LS fit is Eq. 2.2: checked against the N = 3 and N = 4 closed forms
    (written here, not produced by hdrfringe) and against the standard decoder."""
    rng = np.random.default_rng(3)
    x = np.linspace(0, 50, 401)[None, :]
    tol = 1e-12 if dtype == np.float64 else 2e-5
    for n, closed in (
        (3, lambda i: np.arctan2(np.sqrt(3) * (i[2] - i[1]), 2 * i[0] - i[1] - i[2])),
        (4, lambda i: np.arctan2(i[3] - i[1], i[0] - i[2])),
    ):
        imgs = cosine_set(x, 7.3, [360 * k / n for k in range(n)])
        imgs = imgs + rng.normal(0, 2.0, imgs.shape)  # noise: the forms agree beyond the model
        ref = np.mod(closed(imgs), TWO_PI)
        phi, b, a = sinusoidal_phase_ls(imgs, [360 * k / n for k in range(n)], dtype=dtype)
        assert phi.dtype == dtype
        assert wrap_err(phi, ref).max() < tol
        std, b_std, a_std = sinusoidal_phase(imgs, dtype=dtype)
        assert wrap_err(phi, std).max() < tol
        assert np.allclose(b, b_std, rtol=10 * tol, atol=0) and np.allclose(a, a_std, rtol=10 * tol)


def test_unequal_shifts_decode_the_truth_and_wrong_shifts_do_not() -> None:
    x = np.linspace(-10, 60, 701)[None, :]
    truth = np.mod(TWO_PI * x / 11.0, TWO_PI)
    shifts = [0.0, 90.0, 200.0, 300.0]
    imgs = cosine_set(x, 11.0, shifts, offset_deg=-37.0)
    phi, b, a = sinusoidal_phase_ls(imgs, shifts, phase_offset_deg=-37.0)
    assert wrap_err(phi, truth).max() < 1e-9
    assert np.allclose(b, 60.0, atol=1e-9) and np.allclose(a, 90.0, atol=1e-9)
    assert np.all((phi >= 0) & (phi < TWO_PI))
    # the broken variants: the contract's equal shifts, or the offset forgotten
    wrong, _, _ = sinusoidal_phase_ls(imgs, [0.0, 90.0, 180.0, 270.0], phase_offset_deg=-37.0)
    assert wrap_err(wrong, truth).max() > 0.05
    no_offset, _, _ = sinusoidal_phase_ls(imgs, shifts)
    assert np.allclose(wrap_err(no_offset, truth), np.radians(37.0), atol=1e-9)
    # through decode_set and wrapped_phase with the spec
    spec = FringeSpec(
        "sinusoidal", 4, 11.0, shifts_deg=tuple(shifts), phase_offset_deg=-37.0, imin=0, migl=255
    )
    res = decode_set(imgs, spec, 8)  # 30..150 DN: nothing saturates
    assert res.valid.all() and wrap_err(res.wrapped_phase, truth).max() < 1e-9
    fast = wrapped_phase(imgs, spec, dtype=np.float32)
    assert fast.dtype == np.float32 and wrap_err(fast, truth).max() < 2e-5


def test_declared_shifts_equal_the_standard_decoder_on_reordered_frames() -> None:
    """-120/0/+120 is 240/0/120: the standard decoder on frames (1, 2, 0) gives the same phase."""
    rng = np.random.default_rng(7)
    x = np.linspace(0, 200, 501)[None, :]
    imgs = cosine_set(x, 66.67, [-120, 0, 120]) + rng.normal(0, 1.5, (3, 1, 501))
    spec = FringeSpec("sinusoidal", 3, 66.67, shifts_deg=(-120, 0, 120), imin=0, migl=255)
    declared = wrapped_phase(imgs, spec)
    standard = wrapped_phase(imgs[[1, 2, 0]], FringeSpec("sinusoidal", 3, 66.67, imin=0, migl=255))
    assert wrap_err(declared, standard).max() < 1e-9
    assert wrap_err(declared, wrapped_phase(imgs, FringeSpec("sinusoidal", 3, 66.67))).max() > 1


@pytest.mark.parametrize(
    ("shifts", "needle"),
    [
        ([0, 360, 720], r"\(0, 360, 720\) degrees are degenerate.*rank 1"),
        ([0, 180, 0, 180], r"\(0, 180, 0, 180\) degrees are degenerate.*rank 2"),
        ([0, 90], "needs at least 3 images"),
        ([0, 90, 180, 200, 300], "5 shift angles"),
        ([0, 90, np.nan, 180], "must be finite"),
    ],
)
def test_degenerate_or_wrong_shifts_are_refused(shifts, needle) -> None:
    imgs = cosine_set(np.arange(8.0)[None, :], 8.0, [0, 90, 180, 270])
    if len(shifts) < 4:
        imgs = imgs[: len(shifts)]
    with pytest.raises(InputError, match=needle):
        sinusoidal_phase_ls(imgs, shifts)


def test_the_virtual_rig_renders_and_decoding_recovers_its_truth() -> None:
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.rig.simulated import SimulatedRig

    rig = SimulatedRig.ideal(white_plate(5.0))
    truth = rig.truth()
    for spec in (
        FringeSpec("sinusoidal", 3, 13.7, imin=40 * 257, migl=60000, shifts_deg=(-120, 0, 120)),
        FringeSpec("sinusoidal", 4, 13.7, imin=40 * 257, migl=60000, phase_offset_deg=-90),
        FringeSpec(
            "sinusoidal",
            5,
            13.7,
            imin=40 * 257,
            migl=60000,
            shifts_deg=(10, 95, 170, 250, 330),
            phase_offset_deg=33,
        ),
    ):
        res = decode_set(rig.capture(spec.frames()), spec, 16)
        ok = truth.valid & res.valid
        assert ok.mean() > 0.99
        err = wrap_err(res.wrapped_phase, TWO_PI * truth.u / 13.7)[ok]
        assert err.max() < 1e-3, spec.label()
        # decoding as if the contract's set had been projected misses the truth
        plain = FringeSpec("sinusoidal", spec.steps, 13.7, imin=40 * 257, migl=60000)
        bad = decode_set(rig.capture(spec.frames()), plain, 16)
        assert np.median(wrap_err(bad.wrapped_phase, TWO_PI * truth.u / 13.7)[ok]) > 0.1


# --- capture folders (version 3) ---------------------------------------------------------------


def _caps(spec: FringeSpec) -> Captures:
    x = np.arange(5.0)[None, :].repeat(4, 0)
    imgs = np.stack([np.rint(fringe_gray(x, spec, k)) for k in range(spec.steps)]).astype(np.uint8)
    return Captures(spec.frames(), imgs, 8)


def test_folder_round_trip_writes_version_3_only_when_needed(tmp_path: Path) -> None:
    spec = FringeSpec("sinusoidal", 3, 8.0, shifts_deg=(-120, 0, 120), phase_offset_deg=-90)
    out = write_capture_folder(tmp_path / "v3", _caps(spec))
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["version"] == 3
    assert [f["shift_deg"] for f in manifest["frames"]] == [-120, 0, 120]
    assert {f["phase_offset_deg"] for f in manifest["frames"]} == {-90}
    back = read_capture_folder(out)
    assert back.sets[0].spec == spec and back.frames == spec.frames()
    # only the offset: no shift_deg written
    sine = FringeSpec("sinusoidal", 3, 8.0, phase_offset_deg=-90)
    m2 = json.loads(
        (write_capture_folder(tmp_path / "o", _caps(sine)) / "manifest.json").read_text()
    )
    assert m2["version"] == 3 and all("shift_deg" not in f for f in m2["frames"])
    # the standard set: version 1, no new field
    m1 = json.loads(
        (write_capture_folder(tmp_path / "v1", _caps(FringeSpec())) / "manifest.json").read_text()
    )
    assert m1["version"] == 1 and all(
        "shift_deg" not in f and "phase_offset_deg" not in f for f in m1["frames"]
    )


def _v3_folder(tmp_path: Path, edit) -> Path:
    spec = FringeSpec("sinusoidal", 3, 8.0, shifts_deg=(-120, 0, 120), phase_offset_deg=-90)
    folder = write_capture_folder(tmp_path / "caps", _caps(spec))
    path = folder / "manifest.json"
    manifest = json.loads(path.read_text())
    edit(manifest)
    path.write_text(json.dumps(manifest))
    return folder


def _one_line(folder: Path, *needles: str) -> str:
    with pytest.raises(CaptureFormatError) as info:
        read_capture_folder(folder)
    msg = str(info.value)
    assert "\n" not in msg
    for needle in needles:
        assert needle in msg, msg
    return msg


@pytest.mark.parametrize("version", [1, 2])
def test_older_versions_refuse_the_new_fields(tmp_path: Path, version: int) -> None:
    folder = _v3_folder(tmp_path, lambda m: m.update(version=version))
    _one_line(folder, "field 'shift_deg' needs capture format version 3", '"version": 3')
    # reading version 1 and 2 folders is otherwise unchanged
    v1 = tmp_path / "v1"
    shutil.copytree(DATA / "capture_v1", v1)
    assert read_manifest(v1)["version"] == 1 and read_capture_folder(v1).sets


def test_phase_offset_alone_needs_version_3(tmp_path: Path) -> None:
    def edit(m):
        m["version"] = 2
        for f in m["frames"]:
            del f["shift_deg"]

    _one_line(_v3_folder(tmp_path, edit), "field 'phase_offset_deg' needs capture format version 3")


@pytest.mark.parametrize(
    ("edit", "needles"),
    [
        (
            lambda m: (
                m["frames"][1].update(phase_offset_deg=-80, set="a")
                or [f.update(set="a") for f in m["frames"]]
            ),
            ("phase_offset_deg -80", "must agree on the offset"),
        ),
        (
            lambda m: m["frames"][2].pop("shift_deg"),
            ("gives shift_deg but", "does not; give every frame of the set its shift_deg"),
        ),
        (lambda m: m["frames"][2].update(shift_deg=240), ("repeats an angle", "distinct")),
        (lambda m: m["frames"][2].update(shift_deg="120"), ("'shift_deg' must be a finite",)),
        (
            lambda m: [f.update(pattern="triangular") for f in m["frames"]],
            ("applies to sinusoidal fringe frames only",),
        ),
    ],
)
def test_bad_version_3_fields_are_one_line_errors(tmp_path: Path, edit, needles) -> None:
    _one_line(_v3_folder(tmp_path, edit), *needles)


def test_frame_from_manifest_needs_the_sets_angles() -> None:
    entry = {
        "file": "a.png",
        "kind": "fringe",
        "pattern": "sinusoidal",
        "steps": 3,
        "shift": 1,
        "pitch": 8.0,
        "orientation": "vertical",
        "imin": 0,
        "migl": 255,
        "shift_deg": 0,
    }
    with pytest.raises(InputError, match="pass shifts_deg"):
        frame_from_manifest(entry)
    with pytest.raises(InputError, match="make them agree"):
        frame_from_manifest(entry, shifts_deg=(0, 120, 240))
    frame = frame_from_manifest(entry, shifts_deg=(-120, 0, 120))
    assert frame.spec.shifts_deg == (-120, 0, 120) and frame.shift == 1


# --- real data (../shared/realdata; skipped when absent) ---------------------------------------


def _realdata_folder(tmp_path: Path, sources: list[Path], entries: list[dict], **top) -> Path:
    """A version-3 capture folder under ``tmp_path`` holding copies of real images.

    Copies, not symlinks: the folder reader refuses symlinks that resolve outside the folder
    (docs/capture_format.md, "Limits"); nothing is written into the repository.
    """
    folder = tmp_path / "caps"
    folder.mkdir()
    for src, entry in zip(sources, entries, strict=True):
        shutil.copyfile(src, folder / entry["file"])
    manifest = {"format": "hdrfringe-captures", "version": 3, **top, "frames": entries}
    (folder / "manifest.json").write_text(json.dumps(manifest, indent=1))
    return folder


def _fringe_entry(file: str, steps: int, shift: int, pitch: float, orientation: str, **extra):
    return {
        "file": file,
        "kind": "fringe",
        "pattern": "sinusoidal",
        "steps": steps,
        "shift": shift,
        "pitch": pitch,
        "orientation": orientation,
        "imin": 0,
        "migl": 255,
        **extra,
    }


@pytest.mark.realdata
def test_kamino410_object1_declared_shifts(tmp_path: Path) -> None:
    """kamino410 object1 pat00-05: cos(2*pi*x/p + (phs-2)*2*pi/3), shifts -120/0/+120 degrees.

    Read through a version-3 manifest with ``shift_deg`` and decoded by the least-squares path:
    (a) equals the standard equal-shift decoder on the frames reordered to 0/120/240 (pat01,
    pat02, pat00) to 1e-9 rad; (b) equals their own closed form (phase_shifting.py,
    ``atan2(sqrt(3)*(I1 - I3), 2*I2 - I1 - I3)``, written out here) to 1e-9 rad; (c) the two
    pitches agree: for phi_p = 2*pi*x/p, ``2*phi_66.67 - 3*phi_100 = 0`` (mod 2*pi).
    """
    from tests.conftest import realdata_path

    root = realdata_path("kamino410", "object1")
    pitches = (200.0 / 3.0, 100.0)
    entries, sources = [], []
    for s, pitch in enumerate(pitches):
        for k, deg in enumerate((-120, 0, 120)):
            name = f"pat{3 * s + k:02d}.png"
            sources.append(root / name)
            entries.append(_fringe_entry(name, 3, k, pitch, "vertical", shift_deg=deg))
    folder = _realdata_folder(
        tmp_path,
        sources,
        entries,
        camera={"bit_depth": 8},
        projector={"width": 1920, "height": 1080, "bit_depth": 8},
    )
    caps = read_capture_folder(folder)
    assert [s.spec.shifts_deg for s in caps.sets] == [(-120.0, 0.0, 120.0)] * 2
    phis = []
    for fs in caps.sets:
        imgs = caps.set_images(fs)
        res = decode_set(imgs, fs.spec, 8)
        ok = res.valid
        assert ok.mean() > 0.3, ok.mean()
        standard = FringeSpec("sinusoidal", 3, fs.spec.pitch_px, "vertical", 0, 255)
        reordered = decode_set(imgs[[1, 2, 0]], standard, 8)
        # validity agrees but where the modulation is the 2 DN threshold itself (8-bit counts
        # give exactly 2.0 DN often, e.g. 0.4 % of pixels here) and rounding decides the side
        differ = reordered.valid != ok
        _, m_std, _ = sinusoidal_phase(imgs[[1, 2, 0]])
        assert np.abs(m_std[differ] - 2.0).max(initial=0.0) < 1e-12
        both = ok & reordered.valid
        err = wrap_err(res.wrapped_phase[both], reordered.wrapped_phase[both])
        assert err.max() < 1e-9, err.max()
        assert np.allclose(res.modulation[both], reordered.modulation[both], rtol=1e-12, atol=0)
        i1, i2, i3 = imgs.astype(np.float64)
        theirs = np.arctan2(np.sqrt(3) * (i1 - i3), 2 * i2 - i1 - i3)
        assert wrap_err(res.wrapped_phase[ok], theirs[ok]).max() < 1e-9
        # the broken variant: the same frames read as the contract's 0/120/240
        plain = wrapped_phase(imgs, standard)  # off by 120 degrees everywhere
        assert np.median(wrap_err(plain[ok], theirs[ok])) > 1.0
        phis.append(res)
    a, b = phis
    both = a.valid & b.valid
    c = np.median(np.angle(np.exp(1j * (2 * a.wrapped_phase[both] - 3 * b.wrapped_phase[both]))))
    print(f"[realdata] kamino410 object1: median(2*phi_66.67 - 3*phi_100) = {c:.4f} rad")
    assert abs(c) < 0.1, c


CHECKER_ROOT = ("thomriiii", "dec2025_checkerboard_saturated_4step")


@pytest.mark.realdata
def test_thomriiii_checkerboard_sine_offset_from_the_manifest(tmp_path: Path) -> None:
    """thomriiii checkerboard: ``sin(2*pi*F*x + 2*pi*K/4)`` declared as phase_offset_deg = -90.

    For phi_F = 2*pi*F*x + c at every frequency, ``2*phi_F - phi_2F = c``: docs/realdata.md
    measured c = -pi/2 without the offset; with it declared in the manifest, c is ~0 for every
    F pair and both orientations. The broken variant (offset left out) keeps -pi/2.
    """
    from tests.conftest import realdata_path

    root = realdata_path(*CHECKER_ROOT, "images")
    prefix = {"vertical": "scan", "horizontal": "scanh"}
    freqs = (4, 8, 16, 32)
    entries, sources = [], []
    for o, pre in prefix.items():
        for f in freqs:
            for k in range(4):
                name = f"{pre}_f{f:03d}_n{k:02d}.png"
                sources.append(root / name)
                entries.append(_fringe_entry(name, 4, k, 1024.0 / f, o, phase_offset_deg=-90))
    folder = _realdata_folder(tmp_path, sources, entries, camera={"bit_depth": 8})
    caps = read_capture_folder(folder)
    assert len(caps.sets) == 8 and all(s.spec.phase_offset_deg == -90 for s in caps.sets)
    by_key = {(s.spec.orientation, round(1024.0 / s.spec.pitch_px)): s for s in caps.sets}
    for o in prefix:
        res = {}
        for f in freqs:
            fs = by_key[o, f]
            imgs = caps.set_images(fs)
            res[f] = (
                decode_set(imgs, fs.spec, 8, reject_saturated=False),
                decode_set(imgs, replace_offset(fs.spec, 0.0), 8, reject_saturated=False),
            )
        for lo in (4, 8, 16):
            for which, expect in ((0, 0.0), (1, -np.pi / 2)):
                a, b = res[lo][which], res[2 * lo][which]
                ok = a.valid & b.valid & (a.saturation_count == 0) & (b.saturation_count == 0)
                d = 2 * a.wrapped_phase[ok] - b.wrapped_phase[ok]
                c = float(np.median(np.angle(np.exp(1j * d))))
                if which == 0:
                    print(f"[realdata] checkerboard {o}: median(2*phi_{lo} - phi_{2 * lo}) {c:.4f}")
                assert abs(c - expect) < 0.05, (o, lo, which, c)


def replace_offset(spec: FringeSpec, offset: float) -> FringeSpec:
    import dataclasses

    return dataclasses.replace(spec, phase_offset_deg=offset)


def test_pattern_folders_of_such_sets_are_version_3(tmp_path: Path) -> None:
    """`hdrfringe patterns` output: the rendered images follow the declared phases, and its
    manifest is version 3 (a version-1 manifest with shift_deg would be refused on reading)."""
    import imageio.v3 as iio

    from hdrfringe.core.captures import ProjectorInfo
    from hdrfringe.io.pattern_folder import write_pattern_folder

    spec = FringeSpec("sinusoidal", 3, 16.0, imin=0, migl=255, shifts_deg=(-120, 0, 120))
    m = write_pattern_folder(tmp_path / "pat", spec.frames(), ProjectorInfo(64, 4, 8))
    assert m["version"] == 3 and [f["shift_deg"] for f in m["frames"]] == [-120, 0, 120]
    first = iio.imread(tmp_path / "pat" / m["frames"][0]["file"])[0].astype(float)
    ref = np.rint(255 * (1 + np.cos(TWO_PI * np.arange(64) / 16 - TWO_PI / 3)) / 2)
    assert np.array_equal(first, ref)
    plain = write_pattern_folder(tmp_path / "std", FringeSpec().frames(), ProjectorInfo(8, 2, 8))
    assert plain["version"] == 1


def test_gamma_from_fringes_with_declared_phases() -> None:
    """The fringe gamma fit models each frame's pattern phase (shift plus offset): a -120/0/120
    set and a sine set, pre-distorted with 1/0.75 and 1/1.25, recover the rig's gamma."""
    from hdrfringe.core.gamma.fringes import fit_gamma_fringes
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.rig.simulated import SimulatedRig

    specs = (
        FringeSpec("sinusoidal", 3, 96.0, "vertical", 0, 255, shifts_deg=(-120, 0, 120)),
        FringeSpec("sinusoidal", 3, 96.0, "vertical", 0, 255, phase_offset_deg=-90),
    )
    sets = []
    for spec, gh in zip(specs, (0.75, 1.25), strict=True):
        rig = SimulatedRig(white_plate(5.0), gamma_precompensation=gh, seed=7)
        sets.append((spec, gh, rig.capture(spec.frames())))
    truth = SimulatedRig(white_plate(5.0)).projector_model.gamma
    fit = fit_gamma_fringes(sets, camera_bit_depth=8, max_pixels=5000)
    assert fit.gamma == pytest.approx(truth, rel=0.01)


def test_a_version_3_folder_through_hdrfringe_phase(tmp_path: Path) -> None:
    """Simulated sine and unequal-shift sets of one family, written as a version-3 folder: the
    CLI's wrapped and absolute phase are the rig's 2*pi*u/p (the offset must be removed per set,
    or temporal unwrapping from the coarse set would pick wrong fringe orders)."""
    import tifffile

    from hdrfringe.core.frames import CenterlineFrame
    from hdrfringe.rig.scenes import white_plate
    from hdrfringe.rig.simulated import SimulatedRig
    from hdrfringe.tasks.simulate import simulate_to_folder
    from tests.conftest import run_cli

    rig = SimulatedRig.ideal(white_plate(12.0))
    levels = {"imin": 40 * 257, "migl": 65535}
    fine = FringeSpec("sinusoidal", 4, 9.37, phase_offset_deg=-90, **levels)
    coarse = FringeSpec("sinusoidal", 4, 61.0, shifts_deg=(0, 80, 190, 270), **levels)
    frames = [*coarse.frames(), *fine.frames(), CenterlineFrame(512, "vertical", 65535)]
    simulate_to_folder(tmp_path / "caps", rig, frames)
    assert read_manifest(tmp_path / "caps")["version"] == 3
    res = run_cli("phase", str(tmp_path / "caps"), "-o", str(tmp_path / "out"))
    assert res.returncode == 0, res.stderr
    truth = rig.truth()
    wrapped = tifffile.imread(tmp_path / "out" / "wrapped_phase.tiff")  # the finest set's
    ok = truth.valid & np.isfinite(wrapped)
    assert ok.mean() > 0.99
    assert wrap_err(wrapped, TWO_PI * truth.u / 9.37)[ok].max() < 1e-3
    absolute = tifffile.imread(tmp_path / "out" / "absolute_phase_vertical.tiff")
    ok = truth.valid & np.isfinite(absolute)
    assert ok.mean() > 0.99
    assert np.abs(absolute - TWO_PI * truth.u / 9.37)[ok].max() < 1e-3
