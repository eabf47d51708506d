"""The virtual rig's manifest records its true noise model (issue 15 item 2 follow-up).

``camera.read_noise_dn`` and ``camera.gain_dn_per_e`` of a simulated folder against the
sensor's own noise: the variance over repeated captures of a flat, unchanging scene against
``read_noise_dn^2 + gain_dn_per_e * I`` at each pixel's noise-free signal ``I``.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.frames import UniformFrame
from hdrfringe.core.uncertainty import noise_from_manifest
from hdrfringe.rig.acquire import IntensityModification, simulated_captures
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, SimulatedRig

REPEATS = 120
LEVELS = (40, 255)  # projector gray levels: a dark and a bright flat field


def _variance_ratio(rig: SimulatedRig, level: int, noise: dict[str, float]) -> float:
    """Pooled variance over the repeats divided by the pooled model variance."""
    frame = UniformFrame(level)
    stack = np.stack([rig.capture([frame])[0] for _ in range(REPEATS)]).astype(np.float64)
    signal = rig.expected_signal([frame])[0]
    full = rig.camera.full_scale
    top = np.sqrt(noise["read_noise_dn"] ** 2 + noise["gain_dn_per_e"] * full)
    keep = (signal > 6 * noise["read_noise_dn"]) & (signal < full - 6 * top)  # never clipped
    assert keep.mean() > 0.9
    measured = stack.var(axis=0, ddof=1)[keep].mean()
    model = (noise["read_noise_dn"] ** 2 + noise["gain_dn_per_e"] * signal[keep]).mean()
    return float(measured / model)


@pytest.mark.parametrize(
    ("bit_depth", "gain_db"), [(8, 0.0), (12, 6.0)], ids=["8bit_0dB", "12bit_6dB"]
)
def test_manifest_noise_is_the_sensor_noise(bit_depth: int, gain_db: float) -> None:
    camera = CameraModel(width=64, height=48, bit_depth=bit_depth, blur_px=0.0, white_level=0.25)
    rig = SimulatedRig(
        white_plate(0.0), camera=camera, camera_settings=CameraSettings(gain_db=gain_db)
    )
    noise = rig.capture_folder([UniformFrame(0)]).camera
    g = 10 ** (gain_db / 20)
    assert noise["gain_dn_per_e"] == pytest.approx(g * (2**bit_depth - 1) / 20000.0)
    assert noise_from_manifest(noise) is not None
    for level in LEVELS:
        ratio = _variance_ratio(rig, level, noise)
        print(f"[noise manifest] {bit_depth} bit, {gain_db} dB, gray {level}: {ratio:.4f}")
        assert abs(ratio - 1) < 0.02  # 1440 / 3072 px x 119 dof: sampling error < 0.5 %
    if bit_depth == 8:
        # broken: the read noise without the rounding's 1/12 DN^2 (5-7 % low in the dark)
        no_round = {**noise, "read_noise_dn": camera.read_noise_dn}
        assert _variance_ratio(rig, LEVELS[0], no_round) > 1.03
    else:
        # broken: the gain at 0 dB (the analogue gain not applied to the noise)
        at_0db = {
            "read_noise_dn": camera.read_noise_dn,
            "gain_dn_per_e": noise["gain_dn_per_e"] / g,
        }
        assert _variance_ratio(rig, LEVELS[1], at_0db) > 1.5


def test_noiseless_camera_records_no_noise() -> None:
    rig = SimulatedRig.ideal(
        white_plate(0.0),
        camera=CameraModel(width=8, height=6, read_noise_dn8=0.0, full_well_e=None),
    )
    assert "read_noise_dn" not in rig.camera_manifest()
    assert set(rig.camera_manifest()) == {"focal_px", "standoff_mm"}


def test_modified_captures_record_the_modified_noise() -> None:
    """Eq. 4.1's added DN (no shot noise of its own) and added noise, rounded again."""
    camera = CameraModel(width=64, height=48, blur_px=0.0, white_level=0.6, read_noise_dn8=3.0)
    rig = SimulatedRig(white_plate(0.0), camera=camera)
    frame = UniformFrame(120)
    mods = [IntensityModification(add_dn=30.0, noise_sigma=2.0, seed=s) for s in range(REPEATS)]
    stack = np.stack(
        [simulated_captures(rig, [frame], modification=m).images[0] for m in mods]
    ).astype(np.float64)
    noise = simulated_captures(rig, [frame], modification=mods[0]).camera
    signal = rig.expected_signal([frame])[0] + 30.0
    model = noise["read_noise_dn"] ** 2 + noise["gain_dn_per_e"] * signal
    ratio = float(stack.var(axis=0, ddof=1).mean() / model.mean())
    print(f"[noise manifest] modified (add 30 DN, noise 2 DN): {ratio:.4f}")
    assert abs(ratio - 1) < 0.02
    # broken: the camera's own model (variance ~ 4 DN^2 low)
    own = rig.camera_manifest()
    assert (
        stack.var(axis=0, ddof=1).mean()
        / (own["read_noise_dn"] ** 2 + own["gain_dn_per_e"] * signal).mean()
        > 1.2
    )
    # too much light for the line: the keys are left out
    bright = simulated_captures(
        rig.replace(camera=CameraModel(width=8, height=6)),
        [frame],
        modification=IntensityModification(add_dn=100.0),
    )
    assert "read_noise_dn" not in bright.camera


NOISE_KEYS = ("read_noise_dn", "gain_dn_per_e")


@pytest.mark.parametrize(
    ("steps", "scene", "lux"),
    [(4, "white_plate", 0.0), (8, "white_plate", 0.0), (4, "checkerboard", 300.0)],
    ids=["4step_plate", "8step_plate", "4step_checker_300lx"],
)
def test_manifest_and_estimated_noise_agree_at_the_median_intensity(
    steps: int, scene: str, lux: float
) -> None:
    """A simulated folder (160 x 120, sets at 1024, 64 and 8 px): the noise model its manifest
    records and the one estimated from its N >= 4 residuals (the manifest's keys left out)
    give the same sigma_I at the median intensity of the finest set, within 10 %."""
    from hdrfringe.core.decode import decode_captures
    from hdrfringe.core.patterns import FringeSpec
    from hdrfringe.core.uncertainty import predict_uncertainty
    from hdrfringe.rig.factory import virtual_rig

    rig = virtual_rig(scene, ambient_lux=lux, resolution=(160, 120))
    frames = [f for p in (1024.0, 64.0, 8.0) for f in FringeSpec("sinusoidal", steps, p).frames()]
    caps = rig.capture_folder(frames)
    decoded = decode_captures(caps)
    recorded = predict_uncertainty(caps, decoded).summary()
    bare = dataclasses.replace(
        caps, camera={k: v for k, v in caps.camera.items() if k not in NOISE_KEYS}
    )
    estimated = predict_uncertainty(bare, decoded).summary()
    assert recorded["noise"]["source"].startswith("manifest camera.read_noise_dn")
    assert estimated["noise"]["source"].startswith("estimated")
    level = recorded["median_intensity_dn"]
    ratio = estimated["sigma_i_dn"] / recorded["sigma_i_dn"]
    print(
        f"[noise manifest] {scene} {steps}-step {lux:g} lx: at the median {level:.1f} DN "
        f"manifest {recorded['sigma_i_dn']:.4f}, estimated {estimated['sigma_i_dn']:.4f} DN "
        f"(ratio {ratio:.4f}; estimated read {estimated['noise']['read_noise_dn']:.3f}, "
        f"gain {estimated['noise']['gain_dn_per_e']:.5f}); phase std median manifest "
        f"{recorded['phase_std_median_rad']:.5f}, estimated {estimated['phase_std_median_rad']:.5f}"
    )
    assert abs(ratio - 1) < 0.10
    # broken: the read noise alone (no shot noise) is far outside at that level
    read_only = recorded["noise"]["read_noise_dn"] / recorded["sigma_i_dn"]
    assert abs(read_only - 1) > 0.10
