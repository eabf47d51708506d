"""Strategies as plug-ins: the registry, typed parameters, the CLI's options, new strategies.

A toy strategy defined here ("every-other-set": LPA that skips every other step) is registered
and runs through the same entry points as the built-in ones: the registry, measurement's
composite path and ``hdrfringe measure`` (in a subprocess that imports it before the CLI).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import types
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hdrfringe.cli._strategy_options import cli_options, params_from_options
from hdrfringe.core._validation import unsaturated_mask
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError
from hdrfringe.pipeline import composite_captures
from hdrfringe.rig.base import Rig
from hdrfringe.rig.scenes import white_plate
from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
from hdrfringe.strategies import (
    BUILTIN,
    CapturedSet,
    StrategyResult,
    available_strategies,
    get_strategy,
    make_params,
    register,
    unregister,
)
from hdrfringe.strategies.base import (
    capture_set,
    check_fringe_spec,
    default_min_migl,
    merge_into_composite,
)
from hdrfringe.strategies.lpa import lpa

ROOT = Path(__file__).resolve().parents[1]
SPEC = FringeSpec("sinusoidal", 4, 8.0)


# ---------------------------------------------------------------------------------------------
# the toy strategy: sets at migl, migl - 2s, migl - 4s, ... (every other set of LPA with step s)
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class EveryOtherSetParams:
    stride: float = field(
        default=10.0, metadata={"help": "half the MIGL step between sets.", "cli": "--stride"}
    )


class EveryOtherSet:
    name = "every-other-set"
    title = "Every-other-set"
    help = "LPA's sets, every other one"
    Params = EveryOtherSetParams

    def run(self, rig: Rig, spec: FringeSpec, params: EveryOtherSetParams) -> StrategyResult:
        check_fringe_spec(spec, rig)
        bits, floor, step = rig.camera_bit_depth, default_min_migl(spec), 2 * params.stride
        composite = capture_set(rig, spec, spec.migl)
        remaining = ~unsaturated_mask(composite, bits)
        index = np.full(composite.shape[1:], spec.migl, dtype=np.float32)
        sets, newly = [CapturedSet(migl=float(spec.migl))], [int((~remaining).sum())]
        m = float(spec.migl)
        while remaining.any() and m - step >= floor:
            m -= step
            imgs = capture_set(rig, spec, m)
            unsat = unsaturated_mask(imgs, bits)
            newly.append(merge_into_composite(composite, index, remaining, imgs, unsat, m))
            sets.append(CapturedSet(migl=m))
        return StrategyResult(composite, spec, sets, index, newly, remaining, self.name)

    def describe(self, params: EveryOtherSetParams) -> str:
        return f"every other set, stride {params.stride:g}"


@pytest.fixture
def toy() -> Iterator[str]:
    register(EveryOtherSet)
    try:
        yield EveryOtherSet.name
    finally:
        unregister(EveryOtherSet.name)


def lit_rig() -> SimulatedRig:
    """White plate under 600 lx on a small camera: saturated at MIGL 255, fast to capture."""
    return SimulatedRig(
        white_plate(), camera=CameraModel(width=162, height=124), lighting=Lighting(600)
    )


def test_builtin_strategies_are_registered_in_the_thesis_order() -> None:
    assert available_strategies()[: len(BUILTIN)] == BUILTIN  # the thesis's first, then ours
    assert BUILTIN[:4] == ("conventional", "uniform", "lpa", "dpa")
    assert [get_strategy(n).title for n in BUILTIN[:4]] == ["Conventional", "Uniform", "LPA", "DPA"]
    with pytest.raises(InputError, match=r"unknown strategy 'magic'; use one of conventional, "):
        get_strategy("magic")


def test_a_registered_strategy_is_listed_and_runs_like_a_builtin(toy: str) -> None:
    assert toy in available_strategies()
    assert make_params(toy) == EveryOtherSetParams(stride=10.0)
    assert get_strategy(toy).describe(make_params(toy, stride=20.0)) == "every other set, stride 20"
    # measurement's composite path, as measure and the demo use it
    folder, results = composite_captures(lit_rig(), [SPEC], toy, {"stride": 20.0})
    (res,) = results
    ref = lpa(lit_rig(), SPEC, step=40.0)  # the same sets: LPA with twice the stride
    assert res.strategy == toy and res.migls == ref.migls and len(res.migls) >= 3
    assert np.array_equal(res.images, ref.images)
    assert np.array_equal(res.migl_index, ref.migl_index)
    assert res.newly_unsaturated == ref.newly_unsaturated
    assert np.array_equal(folder.images, ref.images)  # no centerline: the composite alone
    # the unregistered strategy is gone again
    unregister(toy)
    try:
        with pytest.raises(InputError, match="unknown strategy 'every-other-set'"):
            composite_captures(lit_rig(), [SPEC], toy)
    finally:
        register(EveryOtherSet)


def test_the_toy_strategy_through_the_command_line(tmp_path: Path) -> None:
    """A plug-in imported before the CLI gets --strategy and its own option in measure."""
    script = (
        "import sys; from tests.test_strategy_registry import EveryOtherSet; "
        "from hdrfringe.strategies import register; register(EveryOtherSet); "
        "from hdrfringe.cli import app; sys.argv[0] = 'hdrfringe'; app()"
    )

    def cli(*args: str) -> subprocess.CompletedProcess:
        env = {**os.environ, "COLUMNS": "200"}  # the help on one line per option
        return subprocess.run(
            [sys.executable, "-c", script, *args],
            capture_output=True,
            text=True,
            cwd=ROOT,
            env=env,
            timeout=300,
        )

    help_text = cli("measure", "--help")
    assert help_text.returncode == 0, help_text.stderr
    listed = r"conventional, uniform, lpa, dpa(, [a-z0-9_-]+)* or every-other-set"
    assert re.search(listed, help_text.stdout), help_text.stdout
    assert "--stride" in help_text.stdout and "Every-other-set: half the MIGL" in help_text.stdout
    out = tmp_path / "out"
    args = ["--rig", "sim", "--ambient-lux", "600", "--pitch", "8", "--no-previews", "--no-report"]
    args += ["-o", str(out)]  # no previews nor report: nothing here reads them
    res = cli("measure", *args, "--strategy", "every-other-set", "--stride", "20")
    assert res.returncode == 0, res.stderr
    m = json.loads((out / "metrics.json").read_text())
    assert m["method"] == "every-other-set" and m["sets_captured"] == len(m["migls"]) >= 3
    assert (out / "migl_index.tiff").is_file()
    # --stride belongs to the toy: with another strategy it is refused (as --step is with the
    # toy); LPA with twice the stride captures the same sets
    args[-1] = str(tmp_path / "lpa")
    res = cli("measure", *args, "--strategy", "lpa", "--step", "40", "--stride", "5")
    assert res.returncode == 2 and "--stride is an Every-other-set option" in res.stderr
    assert not (tmp_path / "lpa").exists()
    res = cli("measure", *args, "--strategy", "lpa", "--step", "40")
    assert res.returncode == 0, res.stderr
    ref = json.loads((tmp_path / "lpa" / "metrics.json").read_text())
    assert ref["method"] == "lpa" and ref["migls"] == m["migls"]
    assert ref["phase_valid_fraction"] == m["phase_valid_fraction"]


def test_the_cli_method_list_and_options_are_the_registry() -> None:
    """measure's --strategy help and its per-method options are read from the registry: the
    two cannot drift apart."""
    import typer.main

    from hdrfringe.cli import app

    command = typer.main.get_command(app).commands["measure"]  # type: ignore[attr-defined]
    params = {p.name: p for p in command.params}
    listed = re.match(r"Saturation avoidance: (.*?) \(", params["strategy"].help or "")
    assert listed is not None, params["strategy"].help
    assert re.split(r", | or ", listed.group(1)) == list(available_strategies())
    strategy_opts = {o.option for o in cli_options()}
    assert strategy_opts == {"--step", "--threshold", "--correction", "--bound-pending",
                             "--uniform-migl", "--tolerance", "--inverted", "--min-shifts",
                             "--tolerant-migl", "--exposures", "--exposure-ratio",
                             "--max-exposure-ms", "--target-modulation", "--max-sets",
                             "--adaptive-margin", "--adaptive-iterations", "--mapping-migl",
                             "--adaptive-exposure-ms", "--adaptive-auto-exposure",
                             "--adaptive-boost", "--adaptive-topup", "--adaptive-epipolar",
                             "--adaptive-full-mapping", "--adaptive-bias-correction",
                             "--max-images"}  # fmt: skip
    for o in cli_options():
        p = params[o.dest]
        assert o.option in p.opts and p.default == o.default and p.help.startswith(o.help)
    assert params["bound_pending"].secondary_opts == ["--no-bound-pending"]


def test_the_docs_worked_example_is_a_working_strategy() -> None:
    """docs/saturation.md's "Writing a strategy" example registers and runs as documented."""
    text = (ROOT / "docs" / "saturation.md").read_text(encoding="utf-8")
    section = text.split("## Writing a strategy", 1)[1]
    code = section.split("```python\n", 1)[1].split("```", 1)[0]
    module = types.ModuleType("two_set_doc_example")
    sys.modules[module.__name__] = module
    try:
        exec(compile(code, "docs/saturation.md", "exec"), module.__dict__)
        assert "two-set" in available_strategies()
        assert [o.option for o in cli_options() if "two-set" in o.fields] == ["--low-migl"]
        _, (res,) = composite_captures(lit_rig(), [SPEC], "two-set", {"low_migl": 180.0})
        top, low = capture_set(lit_rig(), SPEC, 255), capture_set(lit_rig(), SPEC, 180)
        keep = unsaturated_mask(top, 8)
        assert not keep.all()  # saturated at 255: the second set is captured
        assert np.array_equal(res.images, np.where(keep, top, low))
        assert np.array_equal(res.migl_index, np.where(keep, 255.0, 180.0))
        assert res.migls == [255.0, 180.0]
    finally:
        sys.modules.pop(module.__name__)
        if "two-set" in available_strategies():
            unregister("two-set")


# ---------------------------------------------------------------------------------------------
# typed parameters and command-line options
# ---------------------------------------------------------------------------------------------


def test_make_params_checks_names_and_types() -> None:
    assert make_params("dpa", threshold=0.2, bound_pending=True).bound_pending is True
    assert make_params("uniform", candidates=[150.0, 160.0]).candidates == [150.0, 160.0]
    with pytest.raises(InputError, match="lpa has no parameter 'threshold'; its parameters: step"):
        make_params("lpa", threshold=0.2)
    with pytest.raises(InputError, match="lpa parameter step must be float, got 'five'"):
        make_params("lpa", step="five")
    with pytest.raises(InputError, match="dpa parameter bound_pending must be bool"):
        make_params("dpa", bound_pending=1)
    with pytest.raises(InputError, match="dpa parameter correction must be"):
        make_params("dpa", correction="poly.json")  # a path is read by the front end


def test_params_from_options_keeps_todays_cli_rules() -> None:
    opts = {"--step": 15.0, "--threshold": 0.2, "--uniform-migl": 180.0}
    assert params_from_options("lpa", opts) == make_params("lpa", step=15.0)
    assert params_from_options("uniform", opts) == make_params("uniform", migl=180.0)
    assert params_from_options("conventional", opts) == make_params("conventional")
    # the exclusive option, set, with another strategy or none: today's one-line error
    for method in ("lpa", None):
        with pytest.raises(
            InputError,
            match=rf"--bound-pending is a DPA option; use it with --strategy dpa \(got {method}\)",
        ):
            params_from_options(method, {"--bound-pending": True})
    assert params_from_options("lpa", {"--bound-pending": False}) == make_params("lpa")
    assert params_from_options(None, {"--step": 3.0}) is None
    with pytest.raises(InputError, match="unknown strategy option --speed"):
        params_from_options("lpa", {"--speed": 3.0})
    with pytest.raises(InputError, match="unknown strategy 'magic'"):
        params_from_options("magic", {})


def test_params_from_options_reads_files_only_for_the_chosen_strategy() -> None:
    from hdrfringe.core.saturation.estimate import CorrectionPolynomial

    read: list[str] = []

    def reader(path: str) -> CorrectionPolynomial:
        read.append(path)
        return CorrectionPolynomial.identity()

    readers: dict[type, Callable[[Any], Any]] = {CorrectionPolynomial: reader}
    lpa_params = params_from_options("lpa", {"--correction": "c.json"}, readers=readers)
    assert lpa_params == make_params("lpa") and read == []
    dpa_params = params_from_options("dpa", {"--correction": "c.json"}, readers=readers)
    assert read == ["c.json"] and isinstance(dpa_params.correction, CorrectionPolynomial)


# ---------------------------------------------------------------------------------------------
# what register refuses
# ---------------------------------------------------------------------------------------------


def _strategy(name: str, params: type, title: str = "S") -> object:
    return type(
        "S",
        (),
        {
            "name": name,
            "title": title,
            "help": "test",
            "Params": params,
            "run": lambda self, rig, spec, p: None,
            "describe": lambda self, p: name,
        },
    )()


@dataclass
class NotFrozen:
    x: float = field(default=1.0, metadata={"help": "x"})


@dataclass(frozen=True)
class NoHelp:
    x: float = 1.0


@dataclass(frozen=True)
class NoDefault:
    x: float = field(metadata={"help": "x"})


@dataclass(frozen=True)
class StepAsInt:
    step: int = field(default=5, metadata={"help": "S", "cli": "--step"})


@dataclass(frozen=True)
class Empty:
    pass


@pytest.mark.parametrize(
    ("strategy", "needle"),
    [
        (_strategy("x", NotFrozen), "Params must be frozen"),
        (_strategy("x", NoHelp), "parameter x needs help text"),
        (_strategy("x", NoDefault), "parameter x needs a default"),
        (_strategy("x", StepAsInt), "option --step is already LPA's with type float"),
        (_strategy("lpa", Empty), "strategy 'lpa' is already registered"),
        (_strategy("Bad Name", Empty), "name must be lower case"),
        (_strategy("x", Empty, title=""), "title must be a non-empty string"),
        (object(), "is not a Strategy"),
    ],
)
def test_register_refuses_what_the_registry_could_not_use(strategy: object, needle: str) -> None:
    before = available_strategies()
    with pytest.raises(InputError, match=re.escape(needle)):
        register(strategy)
    assert available_strategies() == before


# ---------------------------------------------------------------------------------------------
# results say what varied
# ---------------------------------------------------------------------------------------------


def _result(captured: list[CapturedSet], quantity: str = "migl", n: int | None = None):
    shape = (2, 3)
    return StrategyResult(
        images=np.zeros((4, *shape), np.uint8),
        spec=SPEC,
        captured=captured,
        index_map=np.zeros(shape, np.float32),
        newly_unsaturated=[0] * (len(captured) if n is None else n),
        never_unsaturated=np.zeros(shape, bool),
        strategy="toy",
        index_quantity=quantity,
    )


def test_result_views_exist_only_when_the_sets_vary_the_migl() -> None:
    res = _result([CapturedSet(migl=255.0), CapturedSet(migl=200.0)])
    assert res.migls == [255.0, 200.0] and res.sets_captured == 2 and res.images_captured == 8
    assert res.migl_index is res.index_map
    exposure = _result([CapturedSet(migl=255.0, exposure_ms=e) for e in (10, 5)], "exposure_ms")
    assert exposure.migls == [255.0, 255.0]
    with pytest.raises(AttributeError, match="holds exposure_ms, not the MIGL"):
        _ = exposure.migl_index
    per_pixel = _result([CapturedSet(migl_map=np.full((4, 4), 200.0))])
    with pytest.raises(AttributeError, match="no single MIGL"):
        _ = per_pixel.migls
    assert per_pixel.sets_captured == 1


def test_result_refuses_inconsistent_records() -> None:
    with pytest.raises(InputError, match="1 newly-unsaturated counts for 2 captured sets"):
        _result([CapturedSet(migl=255.0), CapturedSet(migl=200.0)], n=1)
    with pytest.raises(InputError, match="index_quantity 'gain'"):
        _result([CapturedSet(migl=255.0)], "gain")
