"""The virtual rig from plain options (rig.factory), capturing a program (rig.acquire) and the
folders written from it (io.simulation, io.modify_folder): what simulate and modify call."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.frames import CenterlineFrame, UniformFrame
from hdrfringe.core.limits import MAX_SERIES_FOLDERS
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import CaptureFormatError, InputError, OutputExistsError
from hdrfringe.io.captures import read_capture_folder, write_capture_folder
from hdrfringe.rig import Rig, SimulatedRig, virtual_rig
from hdrfringe.rig.acquire import IntensityModification, simulated_captures
from hdrfringe.rig.modify import modify_captures
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import Lighting
from hdrfringe.tasks.modify import modify_capture_folder
from hdrfringe.tasks.simulate import series_depths, series_folder_name, write_simulation

# --- virtual_rig ----------------------------------------------------------------------------------


def test_virtual_rig_defaults_are_the_plain_simulated_rig() -> None:
    rig = virtual_rig("white_plate", depth_mm=4.0, ambient_lux=600.0, seed=5)
    ref = SimulatedRig(white_plate(4.0), lighting=Lighting(ambient_lux=600.0), seed=5)
    assert isinstance(rig, Rig)
    assert rig.to_manifest() == ref.to_manifest()
    assert rig.scene.to_manifest() == ref.scene.to_manifest()


def test_virtual_rig_camera_options() -> None:
    rig = virtual_rig("plate", bit_depth=12, noise=0.5, shot_noise=False, gamma=1.0)
    assert rig.camera_bit_depth == 12 and rig.camera.read_noise_dn8 == 0.5
    assert rig.camera.full_well_e is None and rig.gamma_precompensation == 1.0
    assert virtual_rig("plate").camera.full_well_e is not None


def test_virtual_rig_ideal() -> None:
    rig = virtual_rig("mask", ideal=True, bit_depth=8, noise=3.0, seed=2)
    assert rig.to_manifest() == SimulatedRig.ideal(rig.scene, seed=2).to_manifest()
    assert rig.camera_bit_depth == 16 and rig.projector.bit_depth == 16


def test_virtual_rig_depth_is_the_base_height_of_mask_and_glossy() -> None:
    assert virtual_rig("mask", depth_mm=3.0).scene.to_manifest()["base_mm"] == 3.0
    assert virtual_rig("glossy", depth_mm=3.0).scene.to_manifest()["base_mm"] == 3.0
    assert virtual_rig("checkerboard", depth_mm=3.0).scene.to_manifest()["depth_mm"] == 3.0


@pytest.mark.parametrize(
    ("scene", "auto_is"),
    [("white_plate", "white"), ("plate", "white"), ("black_plate", "black"),
     ("checkerboard", "black"), ("mask", "white")],
)  # fmt: skip
def test_aperture_rule(scene: str, auto_is: str) -> None:
    cams = {a: virtual_rig(scene, aperture=a).camera for a in ("auto", "white", "black")}
    assert cams["auto"] == cams[auto_is]
    assert cams["black"].white_dn > cams["white"].white_dn  # opened for the black plate


def test_virtual_rig_refusals() -> None:
    with pytest.raises(InputError, match="unknown aperture 'wide'; use auto, white or black"):
        virtual_rig("white_plate", aperture="wide")
    with pytest.raises(InputError, match="unknown scene 'teapot'"):
        virtual_rig("teapot")
    with pytest.raises(InputError, match="seed must be a non-negative integer"):
        virtual_rig("white_plate", seed=-1)


# --- IntensityModification and simulated_captures -----------------------------------------------


def test_intensity_modification_is_modify_captures() -> None:
    rng = np.random.default_rng(1)
    images = rng.integers(0, 4096, (3, 5, 7)).astype(np.uint16)
    m = IntensityModification(add_lux=100.0, add_dn=7.0, noise_sigma=2.0, seed=9)
    ref = modify_captures(images, 12, add_dn=7.0, add_lux=100.0, noise_sigma=2.0, seed=9)
    assert np.array_equal(m.apply(images, 12), ref)
    assert not m.is_identity and IntensityModification().is_identity
    assert m.to_manifest() == {
        "add_lux": 100.0,
        "add_dn": 7.0,
        "noise_sigma": 2.0,
        "seed": 9,
        "equation": "thesis Eq. 4.1",
    }
    assert "seed" not in m.to_manifest(with_seed=False)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"seed": -1}, "seed must be a non-negative integer, got -1"),
        ({"seed": 1.5}, "seed must be"),
        ({"noise_sigma": -1.0}, "noise_sigma must be >= 0"),
        ({"add_lux": float("nan")}, "add_lux must be a finite number"),
        ({"add_dn": float("inf")}, "add_dn must be a finite number"),
    ],
)
def test_intensity_modification_refusals(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        IntensityModification(**kwargs)


@pytest.fixture(scope="module")
def small_program() -> list:
    return [*FringeSpec("sinusoidal", 3, 16.0).frames(), CenterlineFrame(512), UniformFrame(90)]


def test_simulated_captures_match_one_capture_of_the_program(small_program: list) -> None:
    calls: list[int] = []
    rig = virtual_rig("checkerboard", ambient_lux=300.0, seed=3)
    caps = simulated_captures(rig, small_program, progress=lambda: calls.append(1))
    ref_rig = virtual_rig("checkerboard", ambient_lux=300.0, seed=3)
    assert np.array_equal(caps.images, ref_rig.capture(small_program))  # order-free noise
    assert len(calls) == len(small_program)
    assert caps.frames == small_program and caps.camera_bit_depth == 8
    assert caps.projector == ref_rig.projector and caps.camera == ref_rig.camera_manifest()
    assert caps.scene == ref_rig.scene.to_manifest()
    assert np.array_equal(caps.maps["truth_height_mm"], ref_rig.truth().height_mm)
    m = IntensityModification(add_dn=20.0, noise_sigma=1.0, seed=4)
    modified = simulated_captures(virtual_rig("checkerboard", ambient_lux=300.0, seed=3),
                                  small_program, modification=m)  # fmt: skip
    assert np.array_equal(modified.images, m.apply(caps.images, 8))
    with pytest.raises(InputError, match="no frames"):
        simulated_captures(rig, [])


# --- write_simulation ----------------------------------------------------------------------------


def test_series_layout() -> None:
    assert series_depths([2.0, 4.0]) == [0.0, 2.0, 4.0]
    assert series_depths([4.0, 0.0]) == [4.0, 0.0]  # the reference is there already
    assert series_depths([2.0], reference=False) == [2.0]
    assert series_folder_name("white_plate", 2.0) == "white_plate_002.00mm"
    assert series_folder_name("mask", 102.5) == "mask_102.50mm"
    with pytest.raises(InputError, match=f"limit of {MAX_SERIES_FOLDERS}"):
        series_depths(list(range(1, MAX_SERIES_FOLDERS + 1)))  # + the reference: one too many
    with pytest.raises(InputError, match="at least one depth"):
        series_depths([])


def test_write_simulation_one_folder(tmp_path: Path, small_program: list) -> None:
    m = IntensityModification(add_lux=600.0, seed=0)
    done = write_simulation(tmp_path / "caps", [virtual_rig("white_plate")], small_program,
                            modification=m)  # fmt: skip
    ref = simulated_captures(virtual_rig("white_plate"), small_program, modification=m)
    back = read_capture_folder(tmp_path / "caps")
    assert np.array_equal(back.images, ref.images)
    assert done.folders == (tmp_path / "caps",) and done.images_per_folder == len(small_program)
    sat = np.mean((ref.images == 255).any(axis=0))
    assert done.saturated_fractions == (sat,) and done.max_saturated_fraction > 0.5
    manifest = json.loads((tmp_path / "caps" / "manifest.json").read_text())
    assert manifest["simulator"] == virtual_rig("white_plate").to_manifest()
    assert manifest["modification"] == m.to_manifest(with_seed=False)
    assert np.array_equal(back.map("truth_height_mm"), ref.maps["truth_height_mm"])
    # no modification, no entry
    write_simulation(tmp_path / "plain", [virtual_rig("white_plate")], small_program[-1:])
    assert "modification" not in json.loads((tmp_path / "plain" / "manifest.json").read_text())


def test_write_simulation_series(tmp_path: Path) -> None:
    depths = series_depths([3.0, 6.0])
    names = [series_folder_name("plate", d) for d in depths]
    rigs = [virtual_rig("plate", depth_mm=d) for d in depths]
    done = write_simulation(tmp_path / "series", rigs, [UniformFrame(200)], folder_names=names)
    assert sorted(p.name for p in (tmp_path / "series").iterdir()) == names
    assert done.folders == tuple(tmp_path / "series" / n for n in names)
    for d, folder in zip(depths, done.folders, strict=True):
        assert read_capture_folder(folder).scene["depth_mm"] == d


def test_write_simulation_is_all_or_nothing(tmp_path: Path) -> None:
    rigs = [virtual_rig("plate"), virtual_rig("plate", depth_mm=2.0)]
    bad = [UniformFrame(100), *FringeSpec(migl=300.0).frames()]  # above the projector's range
    with pytest.raises(InputError, match="migl 300"):
        write_simulation(tmp_path / "out", rigs, bad, folder_names=["a", "b"])
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(InputError, match="folder name"):
        write_simulation(tmp_path / "out", rigs, bad[:1])
    with pytest.raises(InputError, match="1 folder names for 2 rigs"):
        write_simulation(tmp_path / "out", rigs, bad[:1], folder_names=["a"])
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("mine")
    with pytest.raises(OutputExistsError):
        write_simulation(tmp_path / "out", rigs[:1], bad[:1])
    assert (tmp_path / "out" / "keep.txt").read_text() == "mine"


# --- modify_capture_folder -----------------------------------------------------------------------


@pytest.fixture
def source_folder(tmp_path: Path) -> Path:
    rng = np.random.default_rng(0)
    frames = [*FringeSpec("sinusoidal", 3, 8.0).frames(), UniformFrame(128)]
    caps = Captures(
        frames,
        rng.integers(0, 1024, (4, 6, 9)).astype(np.uint16),
        10,
        projector=ProjectorInfo(),
        scene={"depth_mm": 1.0},
        maps={"truth_height_mm": np.full((6, 9), 1.0)},
    )
    names = ["a", "b", "c", "d"]
    return write_capture_folder(tmp_path / "src", caps, names=names, extra={"lab": "B2"})


def test_modify_capture_folder(tmp_path: Path, source_folder: Path) -> None:
    before = {p.name: p.read_bytes() for p in source_folder.iterdir()}
    m = IntensityModification(add_lux=50.0, add_dn=3.0, noise_sigma=1.5, seed=7)
    done = modify_capture_folder(source_folder, tmp_path / "mod", m)
    src = read_capture_folder(source_folder)
    out = read_capture_folder(done.path)
    ref = modify_captures(src.images, 10, add_dn=3.0, add_lux=50.0, noise_sigma=1.5, seed=7)
    assert np.array_equal(out.images, ref) and out.frames == src.frames
    assert done.n_images == 4 and done.saturated_fraction == np.mean((ref == 1023).any(axis=0))
    manifest = json.loads((done.path / "manifest.json").read_text())
    assert [f["file"] for f in manifest["frames"]] == ["a.png", "b.png", "c.png", "d.png"]
    assert manifest["lab"] == "B2" and manifest["scene"] == {"depth_mm": 1.0}
    assert manifest["modification"] == {"source": str(source_folder), **m.to_manifest()}
    assert np.array_equal(out.map("truth_height_mm"), src.map("truth_height_mm"))
    assert {p.name: p.read_bytes() for p in source_folder.iterdir()} == before


def test_modify_capture_folder_checks_the_output_before_reading(tmp_path: Path) -> None:
    out = tmp_path / "mod"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    with pytest.raises(OutputExistsError):  # before the (missing) source is read
        modify_capture_folder(tmp_path / "missing", out, IntensityModification())
    with pytest.raises(CaptureFormatError, match="not a folder"):
        modify_capture_folder(tmp_path / "missing", tmp_path / "new", IntensityModification())
    assert not (tmp_path / "new").exists()
