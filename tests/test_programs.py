"""Projector programs (hdrfringe.core.programs), resource limits (hdrfringe.core.limits), and the
examples in the docstrings of the modules the thin command line calls."""

from __future__ import annotations

import doctest
import importlib
import re

import pytest

from hdrfringe.core.captures import ProjectorInfo
from hdrfringe.core.frames import CenterlineFrame, FringeFrame, UniformFrame
from hdrfringe.core.limits import (
    MAX_PROGRAM_FRAMES,
    MAX_PROJECTOR_PIXELS,
    MAX_STEPS,
    check_count,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.programs import check_projector_size, fringe_program
from hdrfringe.errors import InputError


def _set(pattern: str, steps: int, pitch: float, o: str, imin: float, migl: float) -> list:
    spec = FringeSpec(pattern, steps, pitch, o, imin, migl)  # type: ignore[arg-type]
    return [FringeFrame(spec, k) for k in range(steps)]


def test_program_order_orientation_migl_pitch_then_centerline_then_grays() -> None:
    proj = ProjectorInfo(800, 600, 8, 2.2)
    frames = fringe_program(
        "sinusoidal",
        4,
        [8.0, 64.0],
        ["vertical", "horizontal"],
        30.0,
        [255.0, 200.0],
        projector=proj,
        grays=[0.0, 128.0],
    )
    expected: list = []
    for o, middle in (("vertical", 400), ("horizontal", 300)):
        for m in (255.0, 200.0):
            for p in (8.0, 64.0):
                expected += _set("sinusoidal", 4, p, o, 30.0, m)
        expected.append(CenterlineFrame(middle, o, 255))  # type: ignore[arg-type]
    expected += [UniformFrame(0.0), UniformFrame(128.0)]
    assert frames == expected


def test_program_centerline_options_and_no_centerline() -> None:
    proj = ProjectorInfo(64, 32, 10, 1.5)
    frames = fringe_program(
        "triangular",
        2,
        [10.0],
        ["horizontal"],
        10.0,
        [200.0],
        projector=proj,
        centerline_position=7.5,
        centerline_level=200.0,
    )
    assert frames == [
        *_set("triangular", 2, 10.0, "horizontal", 10.0, 200.0),
        CenterlineFrame(7.5, "horizontal", 200.0),
    ]
    assert fringe_program(projector=proj, centerline_position=63.0)[-1].position == 63.0
    assert fringe_program(projector=proj, centerline=False) == _set(
        "sinusoidal", 3, 8.0, "vertical", 40.0, 255.0
    )
    # the default line is at full scale of the projector (1023 at 10 bits), in the middle
    assert fringe_program(projector=proj)[-1] == CenterlineFrame(32, "vertical", 1023)


def test_level_bits_convert_8_bit_levels_for_a_16_bit_projector() -> None:
    proj = ProjectorInfo(bit_depth=16)
    frames = fringe_program(
        steps=3, imin=40.0, migls=[255.0], projector=proj, grays=[128.0], level_bits=8
    )
    spec = frames[0].spec
    assert (spec.imin, spec.migl) == (40 * 65535 / 255, 65535.0)
    assert frames[3] == CenterlineFrame(512, "vertical", 65535)
    assert frames[4] == UniformFrame(128 * 257.0)
    line = fringe_program(projector=proj, level_bits=8, centerline_level=51.0)[-1]
    assert line.migl == 51 * 257.0


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"orientations": ["diagonal"]}, "unknown orientation 'diagonal'"),
        ({"pitches": []}, "at least one pitch"),
        ({"migls": []}, "at least one pitch and one MIGL"),
        ({"steps": MAX_STEPS + 1}, f"more than the limit of {MAX_STEPS}"),
        ({"steps": 10**12}, "phase shifts"),
        ({"steps": 2}, "steps >= 3"),
        ({"pitches": [8.0] * 2500, "steps": 4}, f"limit of {MAX_PROGRAM_FRAMES}"),
        ({"grays": [1.0] * MAX_PROGRAM_FRAMES}, "frames in the program"),
        ({"migls": [300.0]}, "300"),  # above the 8-bit projector's range
        ({"grays": [-5.0]}, "gray level -5 is outside the projector's 0..255"),
        ({"grays": [256.0]}, "gray level 256 is outside"),
        ({"pitches": [8.0, 16.0, 8.0]}, "pitch 8 appears twice"),
        ({"migls": [255.0, 255.0]}, "MIGL 255 appears twice"),
        ({"orientations": ["vertical"] * 2}, "orientation vertical appears twice"),
        (
            {"centerline_position": -3.0},
            "centerline position -3 is outside the projector's 0..1023",
        ),
        ({"centerline_position": 1024.0}, "centerline position 1024 is outside"),
        ({"centerline_position": float("nan")}, "centerline position nan"),
    ],
)
def test_program_refusals(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=re.escape(match)) as err:
        fringe_program(projector=ProjectorInfo(), **kwargs)
    assert "\n" not in str(err.value)


def test_program_names_the_projector_bit_depth() -> None:
    with pytest.raises(InputError, match=r"projector bit depth must be an integer 1\.\.16, got 0"):
        fringe_program(projector=ProjectorInfo(bit_depth=0))
    with pytest.raises(InputError, match="level_bits must be"):
        fringe_program(projector=ProjectorInfo(), level_bits=40)


def test_a_program_at_the_frame_limit_is_built() -> None:
    n_grays = MAX_PROGRAM_FRAMES - 4  # 3 fringe frames and the centerline
    frames = fringe_program(projector=ProjectorInfo(), grays=[1.0] * n_grays)
    assert len(frames) == MAX_PROGRAM_FRAMES


def test_projector_size_limit() -> None:
    assert check_projector_size(ProjectorInfo(8192, 8192)).width == 8192  # 2^26 exactly
    assert 8192 * 8192 == MAX_PROJECTOR_PIXELS
    with pytest.raises(InputError, match="8193x8192"):
        check_projector_size(ProjectorInfo(8193, 8192))
    with pytest.raises(InputError, match="must be positive"):
        check_projector_size(ProjectorInfo(0, 768))


@pytest.mark.parametrize("count", [11, 11.0, float("inf"), float("nan"), 1e300])
def test_check_count_refuses_above_the_limit_and_non_finite(count: float) -> None:
    with pytest.raises(InputError, match="more than the limit of 10; use less") as err:
        check_count(count, 10, "things", fix="use less")
    assert "\n" not in str(err.value)


def test_check_count_returns_an_int_within_the_limit() -> None:
    assert check_count(10.0, 10, "things") == 10 and isinstance(check_count(3.0, 10, "x"), int)


# --- the examples in the docstrings -------------------------------------------------------------

EXAMPLE_MODULES = [
    "hdrfringe.core.limits",
    "hdrfringe.core.programs",
    "hdrfringe.rig",
    "hdrfringe.rig.factory",
    "hdrfringe.rig.acquire",
    "hdrfringe.tasks.simulate",
    "hdrfringe.tasks.modify",
    "hdrfringe.core.gamma.report",
    "hdrfringe.io.gamma_outputs",
]


@pytest.mark.parametrize("name", EXAMPLE_MODULES)
def test_docstring_examples_run(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0
