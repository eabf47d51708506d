"""One implementation per thesis equation: the index (in docs/architecture.md) cannot rot, and the
shared implementations (camera readout, Eq. 4.1) give each caller's numbers in its precision.

References here are written out from the formulas, not produced by the code under test.
"""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.frames import FringeFrame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.rig.modify import lux_to_dn, modify_captures, modify_intensity
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.sensor import sensor_readout
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig

ROOT = Path(__file__).resolve().parents[1]
INDEX = ROOT / "docs" / "architecture.md"
#: The equations the code must index (issue 10), besides any the source cites.
REQUIRED = (
    [f"2.{k}" for k in range(1, 18)]
    + [f"3.{k}" for k in range(3, 10)]
    + ["4.1", "5.1", "6.2", "6.3", "6.4"]
)
_EQ = re.compile(r"Eqs?\.\s*\d+\.\d+(?:\s*(?:-|–|to|and|,|/)\s*\d+\.\d+)*")


def _rows(index: Path = INDEX) -> dict[str, tuple[str, str]]:
    """Index rows by equation label: (function cell, notes cell)."""
    rows: dict[str, tuple[str, str]] = {}
    for line in index.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 4 and (cells[0].startswith("Eq. ") or cells[0].startswith("Sec. ")):
            assert cells[0] not in rows, f"{cells[0]} listed twice in {index.name}"
            rows[cells[0]] = (cells[2], cells[3])
    return rows


def _resolve(dotted: str) -> object:
    """The object a dotted name ``hdrfringe.module[.Class].attr`` refers to."""
    parts = dotted.split(".")
    for split in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:split]))
        except ModuleNotFoundError:
            continue
        for attr in parts[split:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(dotted)


#: A dotted name in the index: the product's (``hdrfringe.``) or the research package's
#: (``hdrfringe_thesis.``, installed with the product by ``make test``).
_NAME = r"`(hdrfringe(?:_thesis)?\.[\w.]+)`"


def _index_problems(index: Path = INDEX) -> list[str]:
    """What is wrong with the index: malformed rows, names that do not resolve."""
    problems = []
    for label, (function, notes) in _rows(index).items():
        names = re.findall(_NAME, function)
        if function != "—" and len(names) != 1:
            problems.append(f"{label}: give one function or '—', got {function!r}")
        if function == "—" and not notes:
            problems.append(f"{label}: say why the code does not compute it")
        for name in names + re.findall(_NAME, notes):
            try:
                obj = _resolve(name)
            except (ImportError, AttributeError) as err:
                problems.append(f"{label}: {name} does not exist ({err})")
                continue
            if not (callable(obj) or isinstance(obj, property)):
                problems.append(f"{label}: {name} is not a function, class or property")
    return problems


def test_every_name_in_the_equation_index_exists() -> None:
    assert len(_rows()) >= 30
    problems = _index_problems()
    assert not problems, "docs/architecture.md equation index:\n" + "\n".join(problems)


def test_every_cited_equation_is_indexed() -> None:
    """The required equations and every ``Eq. X.Y`` the source cites have a row."""
    cited = set(REQUIRED)
    for path in (ROOT / "src" / "hdrfringe").rglob("*.py"):
        for match in _EQ.finditer(path.read_text(encoding="utf-8")):
            cited.update(re.findall(r"\d+\.\d+", match.group()))
    indexed = {label.removeprefix("Eq. ") for label in _rows()}
    missing = sorted(cited - indexed, key=lambda s: tuple(map(int, s.split("."))))
    assert not missing, f"equations cited but not in docs/architecture.md's index: {missing}"


def test_the_index_check_rejects_a_bad_index(tmp_path: Path) -> None:
    """What keeps the index honest: a removed function or a second function is reported."""
    bad = tmp_path / "equations.md"
    bad.write_text(
        "| Eq. 2.2 | phase | `hdrfringe.core.phase.sinusoidal_phase_only` | |\n"
        "| Eq. 2.8 | ratio | `hdrfringe.core.phase.triangular_2step`, "
        "`hdrfringe.core.phase.wrap_phase` | |\n"
        "| Eq. 3.7 | approx | — | |\n"
        "| Eq. 3.6 | psi | `hdrfringe.core.phase.TWO_PI` | |\n"
        "| Eq. 3.9 | b | `hdrfringe.core.patterns.fringe_gray` | "
        "`hdrfringe_thesis.ch4.no_such` |\n",
        encoding="utf-8",
    )
    problems = _index_problems(bad)
    assert len(problems) == 5, problems
    assert "sinusoidal_phase_only does not exist" in problems[0]
    assert "give one function" in problems[1]
    assert "say why" in problems[2]
    assert "TWO_PI is not a function" in problems[3]
    assert "hdrfringe_thesis.ch4.no_such does not exist" in problems[4]


# ---------------------------------------------------------------------------------------------
# the camera readout: one function, float64 for the rig and float32 for the sweeps
# ---------------------------------------------------------------------------------------------
def _readout_reference(signal, read, shot, z, full):
    """The readout written out: ``clip(rint(s + sqrt(read^2 + shot*max(s, 0)) * z), 0, full)``."""
    std = np.sqrt(read * read + shot * np.maximum(signal, 0.0))
    return np.clip(np.rint(signal + std * z), 0, full)


def test_rig_capture_is_the_float64_readout_of_its_signal() -> None:
    cam = CameraModel(width=40, height=30, bit_depth=10, read_noise_dn8=1.5)
    rig = SimulatedRig(white_plate(8.0), camera=cam, lighting=Lighting(ambient_lux=300))
    frames = FringeSpec("sinusoidal", 4, 9.0, "vertical", 40, 255).frames()
    captured = rig.capture(frames)
    signal = rig.expected_signal(frames)
    twin = rig.replace()  # same seed and scene: the same per-frame generators
    shot = cam.full_scale / cam.full_well_e
    for k, frame in enumerate(frames):
        settings = twin.resolve_settings(None)
        z = twin._frame_rng(frame, settings).standard_normal(signal[k].shape)  # float64 draws
        ref = _readout_reference(signal[k], cam.read_noise_dn, shot, z, cam.full_scale)
        assert np.array_equal(captured[k], ref.astype(np.uint16))
    assert captured.dtype == np.uint16 and captured.max() > 0


def test_float32_readout_with_common_draws() -> None:
    """The sweeps' readout: float32 arithmetic on float32 draws, given or drawn."""
    cam = CameraModel(width=8, height=6)
    rng = np.random.default_rng(3)
    signal = rng.uniform(-5, 300, (3, 6, 8)).astype(np.float32)
    z = rng.standard_normal(signal.shape, dtype=np.float32)
    got = sensor_readout(signal, cam, normals=z, dtype=np.float32)
    f32 = np.float32
    read, shot = f32(cam.read_noise_dn), f32(cam.full_scale / cam.full_well_e)
    ref = _readout_reference(signal, read, shot, z, cam.full_scale)
    assert ref.dtype == np.float32 and np.array_equal(got, ref.astype(np.uint8))
    drawn = sensor_readout(signal, cam, np.random.default_rng(9), dtype=np.float32)
    z9 = np.random.default_rng(9).standard_normal(signal.shape, dtype=np.float32)
    assert np.array_equal(drawn, sensor_readout(signal, cam, normals=z9, dtype=np.float32))
    # float64 from the same generator draws other numbers (a float64 stream)
    assert not np.array_equal(drawn, sensor_readout(signal, cam, np.random.default_rng(9)))


def test_noise_free_readout_draws_nothing_and_checks_its_input() -> None:
    quiet = CameraModel(width=4, height=2, read_noise_dn8=0.0, full_well_e=None)
    rng = np.random.default_rng(1)
    before = rng.bit_generator.state
    signal = np.array([[-1.0, 0.4, 0.5, 1.5], [254.4, 254.6, 255.0, 1e4]])
    out = sensor_readout(signal, quiet, rng)
    assert rng.bit_generator.state == before
    assert out.tolist() == [[0, 0, 0, 2], [254, 255, 255, 255]]  # rint: half to even
    assert signal[0, 0] == -1.0  # the caller's signal is not modified
    with pytest.raises(InputError, match="give a generator"):
        sensor_readout(signal, CameraModel())
    with pytest.raises(InputError, match="one draw per signal value"):
        sensor_readout(signal, CameraModel(), normals=np.zeros(3))
    with pytest.raises(InputError, match="float32 or float64"):
        sensor_readout(signal, quiet, dtype=np.int32)


# ---------------------------------------------------------------------------------------------
# Eq. 4.1: one function, float64 for the modify command and float32 for the Sec. 4.3 sweep
# ---------------------------------------------------------------------------------------------
def test_modify_captures_is_eq_4_1_with_its_own_draws() -> None:
    imgs = np.random.default_rng(2).integers(0, 4096, (2, 9, 11)).astype(np.uint16)
    d = 37.25 + lux_to_dn(250.0, 12)
    got = modify_captures(imgs, 12, add_dn=37.25, add_lux=250.0, noise_sigma=3.0, seed=7)
    n = 3.0 * np.random.default_rng(7).standard_normal(imgs.shape)
    ref = np.clip(np.rint(imgs.astype(np.float64) + d + n), 0, 4095).astype(np.uint16)
    assert np.array_equal(got, ref)
    assert np.array_equal(modify_intensity(imgs, 12, d, n), ref)


def test_float32_eq_4_1_adds_the_light_in_float32() -> None:
    """D is rounded to float32 before the sum (what the sweep's numbers were made with)."""
    imgs = np.arange(0, 250, 7, dtype=np.uint8).reshape(1, 1, -1)
    d = lux_to_dn(430.0, 8)  # 73.1 DN: not a whole number
    got = modify_intensity(imgs, 8, d, dtype=np.float32)
    ref = np.clip(np.rint(imgs.astype(np.float32) + np.float32(d)), 0, 255).astype(np.uint8)
    assert got.dtype == np.uint8 and np.array_equal(got, ref)
    with pytest.raises(InputError, match="float32 or float64"):
        modify_intensity(imgs, 8, d, dtype=np.float16)


def test_sweep_readout_frame_matches_the_rig_statistics() -> None:
    """Same camera, same signal: the float32 and float64 readouts differ by their draws only."""
    cam = CameraModel(width=64, height=48)
    rig = SimulatedRig(white_plate(8.0), camera=cam)
    frame = FringeFrame(FringeSpec(steps=3), 0)
    signal = rig.expected_signal([frame])
    a = sensor_readout(signal, cam, np.random.default_rng(1)).astype(float)
    b = sensor_readout(signal, cam, np.random.default_rng(1), dtype=np.float32).astype(float)
    assert abs((a - signal).std() - (b - signal).std()) < 0.05
