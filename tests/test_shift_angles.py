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

from hdrfringe.captures import Captures
from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.frames import FringeFrame, PixelwiseFringeFrame, frame_from_manifest
from hdrfringe.io.captures import read_capture_folder, read_manifest, write_capture_folder
from hdrfringe.patterns import FringeSpec, fringe_gray, same_fringes
from hdrfringe.phase import decode_set, sinusoidal_phase, sinusoidal_phase_ls, wrapped_phase

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
    assert not same_fringes(base, sine) and not same_fringes(base, kam)
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
