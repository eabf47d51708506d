"""Multi-exposure fusion (Zhang & Yau 2009) and the exposure choice (thesis 7.3).

Each test names the broken variant it rejects. The synthetic rig below is noise-free and
linear, so the exposures the automatic rule must pick and the exposure each pixel must come
from are closed forms of its gains.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdrfringe.core.captures import CameraSettings, ProjectorInfo
from hdrfringe.core.frames import Frame
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set, sinusoidal_phase
from hdrfringe.errors import InputError
from hdrfringe.rig.base import RigBase
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.rig.scenes import checkerboard, plate
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
from hdrfringe.strategies import get_strategy, make_params
from hdrfringe.strategies.conventional import conventional
from hdrfringe.strategies.exposure import (
    choose_exposure,
    default_target_modulation,
    run_at_exposure,
)
from hdrfringe.strategies.multiexposure import fuse_exposures, multiexposure
from tests.conftest import run_cli

TWO_PI = 2 * np.pi
SPEC = FringeSpec("sinusoidal", 4, 8.0)  # imin 40, MIGL 255: amplitude 107.5 gray levels
#: Row gains of the synthetic rig (DN per gray level at 10 ms): dark .. specular. The two 0.12
#: rows outnumber the darkest one, so a rule on the median would stop the walk up at 80 ms.
GAINS = (0.06, 0.12, 0.12, 0.3, 0.9, 4.5, 30.0)


class LinearRig(RigBase):
    """Noise-free, linear: ``I = min(255, rint(t / 10 ms * k_row * g(x)))`` with ``g`` the gray
    level sent at projector column ``x`` = camera column, three rows per gain. Records every
    exposure captured."""

    camera_bit_depth = 8
    projector = ProjectorInfo()

    def __init__(self, gains: Sequence[float] = GAINS, width: int = 64) -> None:
        # three rows per gain: bands, as surfaces are (the darkest rule averages 3 x 3)
        self.gains = np.repeat(np.asarray(gains, dtype=float), 3)
        self.image_shape = (len(self.gains), width)
        self.camera_settings = CameraSettings(10.0, 0.0)
        self.log: list[float] = []

    def capture(
        self, frames: Sequence[Frame], settings: CameraSettings | None = None
    ) -> np.ndarray:
        t = self.resolve_settings(settings).exposure_ms
        assert t is not None
        self.log.append(t)
        x = np.arange(self.image_shape[1], dtype=float)
        return np.stack([self.expected(t, f.gray(x)) for f in frames])  # fringe frames only

    def expected(self, t: float, gray: np.ndarray) -> np.ndarray:
        return np.minimum(255, np.rint(t / 10.0 * self.gains[:, None] * gray[None, :])).astype(
            np.uint8
        )


#: Highest gray level sent at each column over the four shifts (255 at even columns, 223.5 at
#: odd ones: the shifts are 2 px apart), from the pattern itself.
PEAK = np.max([f.gray(np.arange(64.0)) for f in SPEC.frames()], axis=0)


def _longest_unsaturated(times: Sequence[float], k: float) -> np.ndarray:
    """Closed form per column: unsaturated at t iff rint(t / 10 * k * peak) < 255; NaN where
    no exposure is."""
    out = np.full(PEAK.shape, np.nan)
    for t in sorted(times):
        out[t / 10.0 * k * PEAK < 254.5] = t
    return out


def test_auto_exposures_follow_the_closed_form_and_each_pixel_takes_its_longest() -> None:
    """Down until the brightest row (k = 30) unclips, up until the darkest row (k = 0.06)
    reaches 53 DN, then per row the longest unsaturated exposure. Rejects: fusing the
    shortest (or first captured) unsaturated set, choosing per shift instead of per pixel,
    stopping the walk up on the median instead of the darkest pixels, or skipping the walk up
    when the first set saturates."""
    rig = LinearRig()
    res = multiexposure(rig, SPEC)
    target = default_target_modulation(4, 8)
    down = math.ceil(math.log2(10.0 * 30.0 * 255.0 / 10.0 / 254.5))  # 2^j > 30.06: j = 5
    up = math.ceil(math.log2(target / (0.06 * 107.5)))  # 2^j >= 8.22: j = 4 (160 ms = 16x)
    want = (
        [10.0] + [10.0 / 2**j for j in range(1, down + 1)] + [10.0 * 2**j for j in range(1, up + 1)]
    )
    assert rig.log == want == res.details["exposures_ms"]
    assert res.details["stop"] == "target reached" and res.details["darkest_modulation_dn"] > target
    assert [c.exposure_ms for c in res.captured] == want and res.index_quantity == "exposure_ms"
    x = np.arange(64.0)
    frames = SPEC.frames()
    for row, k in enumerate(rig.gains):
        t = _longest_unsaturated(want, k)
        assert not np.isnan(t).any()
        assert np.array_equal(res.index_map[row], t), (k, res.index_map[row])
        expect = np.stack([np.rint(t / 10.0 * k * f.gray(x)) for f in frames])
        assert np.array_equal(res.images[:, row], expect), k
    assert len(np.unique(res.index_map[3 * GAINS.index(4.5)])) == 2  # per pixel, not per row
    assert not res.never_unsaturated.any()
    assert sum(res.newly_unsaturated) == res.images[0].size


def test_an_exposure_list_is_captured_as_given_and_fused() -> None:
    """Exactly the listed exposures, in the order given; a row saturated at all of them takes
    the shortest and is reported. Rejects sorting or extending the list, and a fusion that
    gives never-unsaturated pixels the last set instead of the shortest."""
    rig = LinearRig()
    res = multiexposure(rig, SPEC, exposures="8,0.5,2")
    assert rig.log == [8.0, 0.5, 2.0]
    for row, k in enumerate(rig.gains):
        t = _longest_unsaturated([8.0, 0.5, 2.0], k)
        assert np.array_equal(res.index_map[row], np.where(np.isnan(t), 0.5, t))
        assert np.array_equal(res.never_unsaturated[row], np.isnan(t))
    assert res.never_unsaturated[rig.gains == 30.0].all()
    comp, idx, _never, chosen = fuse_exposures(
        [rig.capture(SPEC.frames(), CameraSettings(t)) for t in (8.0, 0.5, 2.0)], [8, 0.5, 2], 8
    )
    assert np.array_equal(comp, res.images) and np.array_equal(idx, res.index_map)
    assert (chosen[rig.gains == 30.0] == 1).all()  # the shortest, not the last


@given(
    reflectivity=st.floats(0.2, 1.0),
    depth=st.floats(0.0, 50.0),
    lux=st.floats(0.0, 60.0),
    pitch=st.floats(12.0, 64.0),
    steps=st.integers(3, 6),
    seed=st.integers(0, 1000),
)
@settings(max_examples=10, deadline=None)
def test_requirement_4_unsaturated_scenes_give_the_conventional_result(
    reflectivity: float, depth: float, lux: float, pitch: float, steps: int, seed: int
) -> None:
    """Nothing saturated at the rig's exposure: the conventional set, bit for bit, after one
    set. Rejects a variant that also walks up for dark pixels, or starts at another exposure."""

    def rig() -> SimulatedRig:
        return SimulatedRig(
            plate(depth, reflectivity),
            camera=CameraModel(width=48, height=36),
            lighting=Lighting(ambient_lux=lux),
            seed=seed,
        )

    spec = FringeSpec("sinusoidal", steps, pitch)
    ref = conventional(rig(), spec)
    assert ref.images.max() < 255
    res = multiexposure(rig(), spec)
    assert res.sets_captured == 1 and res.images_captured == steps
    assert np.array_equal(res.images, ref.images)
    assert np.all(res.index_map == 10.0) and not res.never_unsaturated.any()


def test_auto_exposure_brings_the_darkest_reflectivity_to_the_target() -> None:
    """A checkerboard with black squares of reflectivity 0.1 (white 0.95, white-plate
    aperture): the choice is the exposure the noise-free signal predicts for the darkest 1 %
    of the black squares, and a fresh capture there has them at the target. Rejects the median
    (or brightest) pixel as the reference, and a non-linear update."""
    spec = FringeSpec("sinusoidal", 4, 32.0)
    rig = SimulatedRig(
        checkerboard(black_reflectivity=0.1), camera=CameraModel(width=160, height=120)
    )
    target = default_target_modulation(4, 8)
    choice = choose_exposure(rig, spec)
    truth = rig.truth()
    black = truth.reflectivity == 0.1
    inner = (
        black
        & np.roll(black, 2, 0)
        & np.roll(black, -2, 0)
        & np.roll(black, 2, 1)
        & np.roll(black, -2, 1)
    )
    _, b0, _ = sinusoidal_phase(rig.expected_signal(spec.frames()))
    predicted = 10.0 * target / np.percentile(b0[inner], 1)
    assert abs(choice.exposure_ms / predicted - 1) < 0.15, (choice.exposure_ms, predicted)
    assert 1 <= choice.sets_captured <= 3 and choice.limited is None
    fresh = decode_set(rig.capture(spec.frames(), CameraSettings(choice.exposure_ms)), spec, 8)
    assert np.percentile(fresh.modulation[inner], 1) > 0.85 * target
    assert np.median(fresh.modulation[inner]) < 1.5 * target


def test_a_migl_strategy_runs_at_the_chosen_exposure_without_recapturing() -> None:
    """LPA after the exposure choice: every set at the chosen exposure, the choice's last set
    reused as LPA's first. Rejects capturing that set twice or running at the rig's own
    exposure."""
    spec = FringeSpec("sinusoidal", 4, 32.0)
    rig = virtual_rig("checkerboard", resolution=(160, 120))
    choice, res, images = run_at_exposure(rig, spec, "lpa", {"step": 15.0})
    assert choice.last_at_choice is not None and choice.exposure_ms != 10.0
    assert {c.exposure_ms for c in res.captured} == {choice.exposure_ms}
    assert images == choice.images_captured + (res.sets_captured - 1) * 4
    assert np.array_equal(
        res.images[:, res.index_map == 255.0], choice.last_at_choice[:, res.index_map == 255.0]
    )
    blind = LinearRig()
    blind.camera_settings = CameraSettings()  # a rig that does not know its exposure
    with pytest.raises(InputError, match="reports none"):
        choose_exposure(blind, spec)
    with pytest.raises(InputError, match="reports none"):
        multiexposure(blind, SPEC)


@pytest.fixture(scope="module")
def specular() -> dict:
    spec = FringeSpec("sinusoidal", 4, 32.0)
    rig = lambda: virtual_rig("specular_part", resolution=(160, 120))  # noqa: E731
    return {
        "spec": spec,
        "truth": rig().truth(),
        "expected": rig().expected_signal(spec.frames()),
        "conv": conventional(rig(), spec),
        "multi": multiexposure(rig(), spec),
    }


def test_multiexposure_measures_the_specular_highlight(specular: dict) -> None:
    """On the specular part the conventional set clips the highlight; the fusion covers every
    pixel, takes the highlight from short exposures and the dark metal from long ones, its
    phase on the clipped pixels is the noise-free phase of the rig (whose camera blur across
    the steep lobe biases it by about 0.1 rad from 2 pi u / p at this small size, for any
    method), and elsewhere it beats the conventional set's noise. Rejects a fusion that keeps
    clipped pixels or takes the brightest set regardless of clipping."""
    spec, truth, conv, res = (specular[k] for k in ("spec", "truth", "conv", "multi"))
    clipped = conv.never_unsaturated
    assert clipped.mean() > 0.01
    assert not res.never_unsaturated.any() and res.details["stop"] == "target reached"
    assert res.index_map[clipped].max() < 10.0 and res.index_map.max() > 10.0
    dec = decode_set(res.images, spec, 8)
    assert dec.valid[truth.valid].all()

    def err(phase: np.ndarray, ref: np.ndarray) -> np.ndarray:  # no phase: pi
        return np.nan_to_num(np.abs(np.angle(np.exp(1j * (phase - ref)))), nan=np.pi)

    noise_free, _, _ = sinusoidal_phase(specular["expected"])
    kept = decode_set(conv.images, spec, 8, reject_saturated=False).wrapped_phase
    assert np.median(err(dec.wrapped_phase, noise_free)[clipped]) < 0.03
    assert np.median(err(kept, noise_free)[clipped]) > 0.1
    known = TWO_PI * truth.u / spec.pitch_px
    rest = truth.valid & ~clipped
    conv_ok = decode_set(conv.images, spec, 8).wrapped_phase
    assert np.median(err(dec.wrapped_phase, known)[rest]) < 0.7 * np.median(
        err(conv_ok, known)[rest]
    )
    assert np.percentile(dec.modulation[truth.valid], 1) > 0.8 * res.details["target_modulation_dn"]


def test_parameters_are_checked_and_registered() -> None:
    strategy = get_strategy("multiexposure")
    assert strategy.describe(make_params("multiexposure")) == "multi-exposure auto x2"
    with pytest.raises(InputError, match="comma-separated milliseconds"):
        make_params("multiexposure", exposures="5,fast")
    with pytest.raises(InputError, match="repeat"):
        multiexposure(LinearRig(), SPEC, exposures=[5.0, 5.0])
    with pytest.raises(InputError, match="ratio must be a number > 1"):
        multiexposure(LinearRig(), SPEC, ratio=1.0)


def test_measure_on_the_live_rig_through_the_cli(tmp_path: Path) -> None:
    """measure --rig sim --scene specular_part --strategy multiexposure end to end: nothing
    saturated in the composite, exposures recorded per pitch, the exposure index map written."""
    out = tmp_path / "out"
    res = run_cli(
        "measure", "--rig", "sim", "--scene", "specular_part", "--strategy", "multiexposure",
        "--pitch", "1024,32", "--steps", "3", "--max-sets", "6", "-o", str(out),
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert "multiexposure: 12 sets, 36 images captured" in res.stdout
    m = json.loads((out / "metrics.json").read_text())
    assert m["method"] == "multiexposure" and m["index_quantity"] == "exposure_ms"
    assert m["exposures_ms"] == [[10.0, 5.0, 2.5, 1.25, 0.625, 20.0]] * 2
    assert m["saturated_fraction"] == 0.0 and m["never_unsaturated_fraction"] == 0.0
    assert (out / "exposure_ms_index.tiff").is_file() and (out / "exposure_ms_pie.png").is_file()


def test_auto_exposures_on_a_replayed_folder_are_refused_in_one_line() -> None:
    """A replayed folder cannot change the exposure: automatic exposures are refused before
    any capture with that reason, also when the folder records an exposure time (before, the
    message blamed a missing exposure time). A list of held exposures still replays."""
    from hdrfringe.core.captures import Captures
    from hdrfringe.rig.replay import ReplayRig

    spec = FringeSpec("sinusoidal", 4, 16.0)
    live = virtual_rig(scene="checkerboard", resolution=(64, 48), seed=0)
    frames = spec.frames()
    caps = Captures(frames, live.capture(frames), 8, exposure_ms=[10.0] * 4, name="folder")
    rig = ReplayRig(caps)
    with pytest.raises(InputError, match=r"replayed folder cannot; .*--exposures") as err:
        multiexposure(rig, spec)
    assert "\n" not in str(err.value) and rig.captured == 0
    assert multiexposure(rig, spec, exposures="10").sets_captured == 1
