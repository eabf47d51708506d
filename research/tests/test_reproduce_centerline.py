"""The thesis's pipeline in the Sec. 4.3 added-light simulation (``--unwrap centerline``).

Spatial unwrapping and a centerline captured with each set through the same virtual camera
and Eq. 4.1 give the fringe orders; ``order_error_fraction`` counts the pixels whose order is
not the known one. Quick-grid view (324 x 247), one plate position, a few cells: each test
runs in about a second.
"""

from __future__ import annotations

import numpy as np
import pytest
from tests.conftest import run_cli_in_process

from hdrfringe.core.calibration import measurement_mask
from hdrfringe.core.frames import CenterlineFrame
from hdrfringe.core.unwrap import unwrap_spatial
from hdrfringe.errors import InputError
from hdrfringe.rig.modify import lux_to_dn, modify_intensity
from hdrfringe.rig.sensor import sensor_readout
from hdrfringe_thesis.ch4 import (
    QUICK_DEPTHS_MM,
    QUICK_SETUP,
    SWEEP_DTYPE,
    TWO_PI,
    PlateSweep,
    calibrate_pattern,
    cell_rng,
    centerline_absolute,
    centerline_unwrap,
    ch4_modified_block,
    ch4_simulation_task,
    depth_normals,
    order_error_fraction,
    orders_from_expected,
    pattern_spec,
    sweep_phase,
)

SETUP = QUICK_SETUP
PATTERN, PITCH, DEPTH = "sinusoidal-3", 6.0, 18.0
MASK = measurement_mask((SETUP.height, SETUP.width), SETUP.border_px)


def _cell(
    migl: float, lux: float, pattern: str = PATTERN, depth: float = DEPTH
) -> tuple[PlateSweep, np.ndarray, np.ndarray, np.ndarray]:
    """One cell as ch4_modified_block captures it: the plate, the wrapped phase, its known-order
    phase and the centerline image, all through Eq. 4.1 with ``lux`` of added light."""
    spec = pattern_spec(pattern, PITCH, SETUP.imin)
    plate = PlateSweep(depth, SETUP, spec)
    cam = SETUP.camera_model()
    normals = depth_normals(SETUP, spec, pattern, depth, plate.rig.image_shape)
    rng = cell_rng(SETUP, "centerline", pattern, PITCH, depth)
    line_normals = rng.standard_normal((1, *plate.rig.image_shape), dtype=SWEEP_DTYPE)
    imgs = sensor_readout(plate.signal(migl), cam, normals=normals, dtype=SWEEP_DTYPE)
    line = sensor_readout(plate.centerline_signal(migl), cam, normals=line_normals)
    added = lux_to_dn(lux, cam.bit_depth)
    imgs = modify_intensity(imgs, cam.bit_depth, added, dtype=SWEEP_DTYPE)
    line = modify_intensity(line, cam.bit_depth, added, dtype=SWEEP_DTYPE)[0]
    wrapped = sweep_phase(imgs, spec)
    return plate, wrapped, orders_from_expected(wrapped, plate.expected_phase), line


@pytest.mark.parametrize("depth", [0.0, DEPTH])
def test_in_the_dark_at_255_the_pipeline_gives_the_known_heights(depth: float) -> None:
    """0 lx, MIGL 255 (the calibration's own captures at 0 and 18 mm): spatial unwrapping and
    the captured centerline give every measured pixel its known order, so the heights agree;
    keeping the calibration on known orders changes nothing."""
    plate, wrapped, known, line = _cell(255.0, 0.0, depth=depth)
    phase = centerline_unwrap(wrapped, line, plate.centerline_position, PITCH)  # no shortcut
    cal, _ = calibrate_pattern(PATTERN, PITCH, SETUP, QUICK_DEPTHS_MM)
    same = np.abs(cal.height(phase) - cal.height(known)) < 1e-9
    assert np.mean(same[MASK]) > 0.999
    assert order_error_fraction(phase, known, MASK) < 0.001


def test_both_modes_agree_where_orders_hold_and_differ_where_they_fail() -> None:
    """A block of both modes: the same RMSE and no wrong order at 0 lx and in the thesis's
    strongest light (900 lx) on this rig; at 1100 lx the fringe minimum plus the added light
    saturates every shift of most pixels, spatial unwrapping loses whole fringes and the
    centerline pipeline's RMSE explodes (known orders cannot fail: a version that took them,
    or ignored the unwrapping, fails here)."""
    lux, migls = (0.0, 900.0, 1100.0), (255.0, 165.0)
    args = ("sinusoidal-3", PITCH, lux, (), migls, (DEPTH,), SETUP)
    kw = {"calibration_depths_mm": QUICK_DEPTHS_MM}
    known = ch4_modified_block(*args, **kw, unwrap="known")
    line = ch4_modified_block(*args, **kw, unwrap="centerline")
    assert np.array_equal(known["order_error_fraction"], np.zeros((3, 2, 1)))
    np.testing.assert_allclose(line["rmse_light_mm"][:2], known["rmse_light_mm"][:2], rtol=1e-9)
    assert np.all(line["order_error_fraction"][:2] == 0.0)
    assert line["order_error_fraction"][2, 0, 0] > 0.5
    assert line["rmse_light_mm"][2, 0, 0] > 20 * known["rmse_light_mm"][2, 0, 0]
    np.testing.assert_array_equal(line["rmse_noise_mm"], known["rmse_noise_mm"])


def test_the_line_is_read_from_the_captured_image() -> None:
    """The centerline's position comes from its image, not from the known geometry: a line
    captured one pitch further than announced shifts every order by one, and a line that
    Eq. 4.1 saturates away (1500 lx: 255 DN everywhere) leaves no absolute phase (NaN)."""
    plate, wrapped, known, _ = _cell(255.0, 0.0)
    frame = CenterlineFrame(plate.centerline_position + PITCH, migl=255.0)
    moved = plate.rig.capture([frame])[0]
    phase = centerline_unwrap(wrapped, moved, plate.centerline_position, PITCH, candidate=known)
    assert order_error_fraction(phase, known, MASK) == 1.0
    np.testing.assert_allclose((phase - known)[MASK], -TWO_PI, atol=1e-9)  # line seen 1 fringe on

    gone = ch4_modified_block(
        PATTERN, PITCH, (1500.0,), (), (255.0,), (DEPTH,), SETUP, unwrap="centerline",
        calibration_depths_mm=QUICK_DEPTHS_MM,
    )  # fmt: skip
    assert np.isnan(gone["rmse_light_mm"]).all() and np.isnan(gone["order_error_fraction"]).all()
    assert np.isnan(centerline_absolute(known, np.full(known.shape, 255.0), 512.0, PITCH)).all()


@pytest.mark.parametrize(
    ("pattern", "lux"),
    [("sinusoidal-3", 600.0), ("sinusoidal-3", 900.0), ("triangular-2", 900.0)],
)
def test_the_known_candidate_gives_what_the_unwrapper_gives(pattern: str, lux: float) -> None:
    """The sweep's shortcut (the known-order phase stands in for ``unwrap_spatial`` when every
    neighbour step is below pi) gives the unwrapper's absolute phase on saturated cells; a
    candidate a fringe off in one column band is refused, so the unwrapper decides."""
    plate, wrapped, known, line = _cell(255.0, lux, pattern)
    pos = plate.centerline_position
    full = centerline_unwrap(wrapped, line, pos, PITCH)
    fast = centerline_unwrap(wrapped, line, pos, PITCH, candidate=known)
    assert np.array_equal(np.rint((fast - full) / TWO_PI), np.zeros(known.shape))
    broken = known.copy()
    broken[:, 100:140] += TWO_PI
    refused = centerline_unwrap(wrapped, line, pos, PITCH, candidate=broken)
    assert np.array_equal(refused, full)
    # the unwrapper's orders are the known ones here (the shortcut is not assumed)
    direct = unwrap_spatial(wrapped)
    assert np.ptp(np.rint((direct - known) / TWO_PI)) == 0


def test_the_task_reads_the_mode_and_refuses_an_unknown_one(tmp_path) -> None:
    params = {
        "setup": SETUP.to_dict(),
        "added_lux": [1100.0],
        "noise_sigma": [],
        "calibration_depths_mm": list(QUICK_DEPTHS_MM),
    }
    coords = {"pattern": PATTERN, "migl": [255.0], "depth_mm": DEPTH}
    assert ch4_simulation_task(coords, params)["order_error_fraction"].tolist() == [[0.0]]
    out = ch4_simulation_task(coords, {**params, "unwrap": "centerline"})
    assert out["order_error_fraction"][0, 0] > 0.5
    with pytest.raises(InputError, match="unknown unwrapping 'gray'"):
        ch4_simulation_task(coords, {**params, "unwrap": "gray"})
    res = run_cli_in_process(
        "reproduce", "ch4", "--quick", "-o", str(tmp_path / "r"), "--unwrap", "gray"
    )
    assert res.returncode != 0 and "unknown --unwrap 'gray'" in res.stderr
    assert not (tmp_path / "r").exists()
