"""Static checks in the test run: mypy on the package, numpydoc on the public API.

Both read the configuration in pyproject.toml. ``PENDING_*`` list the modules not yet brought
up to the standard while issue 10 is in progress; the tests fail when a listed module is clean
(so the list can only shrink) and when any module not listed has an error.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
from collections import defaultdict
from pathlib import Path

import pytest

import hdrfringe

ROOT = Path(__file__).resolve().parents[1]

#: Modules with mypy errors still to fix (issue 10, step "mypy clean").
PENDING_MYPY: set[str] = {
    "hdrfringe.demo",
}

#: numpydoc checks required of every public function and class: a docstring (GL08), every
#: parameter documented (PR01) and no unknown one (PR02), a Returns section (RT01), an
#: Examples section (EX01).
NUMPYDOC_CODES = ("GL08", "PR01", "PR02", "RT01", "EX01")

#: Front ends: their public functions are commands and report builders, documented by --help.
FRONT_ENDS = ("hdrfringe.cli", "hdrfringe.demo", "hdrfringe.reproduce")

#: Modules whose docstrings are still to complete (issue 10, step "numpydoc").
PENDING_DOCS: set[str] = set()


def _module_of(path: str) -> str:
    rel = Path(path).resolve().relative_to(ROOT / "src")
    parts = list(rel.with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@pytest.mark.xdist_group("static")
def test_mypy_is_clean_outside_the_pending_modules() -> None:
    api = pytest.importorskip("mypy.api")
    stdout, stderr, _status = api.run(["--config-file", str(ROOT / "pyproject.toml")])
    errors: dict[str, list[str]] = defaultdict(list)
    for line in stdout.splitlines():
        m = re.match(r"^(src/[^:]+\.py):\d+: error:", line)
        if m:
            errors[_module_of(str(ROOT / m.group(1)))].append(line)
    assert not stderr.strip(), stderr
    unexpected = {k: v for k, v in errors.items() if k not in PENDING_MYPY}
    assert not unexpected, "mypy errors:\n" + "\n".join(
        line for v in unexpected.values() for line in v
    )
    fixed = sorted(PENDING_MYPY - set(errors))
    assert not fixed, f"mypy-clean now, remove from PENDING_MYPY: {fixed}"


def _public_objects() -> dict[str, list[str]]:
    """Per library module, the qualified names of its public functions and classes."""
    out: dict[str, list[str]] = {}
    for info in pkgutil.walk_packages(hdrfringe.__path__, "hdrfringe."):
        name = info.name
        if any(p.startswith("_") for p in name.split(".")[1:]) or name.startswith(FRONT_ENDS):
            continue
        mod = importlib.import_module(name)
        names = getattr(mod, "__all__", None)
        if names is None:
            names = [k for k in vars(mod) if not k.startswith("_")]
        objs = []
        for key in names:
            obj = getattr(mod, key)
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and obj.__module__ == name:
                objs.append(f"{name}.{key}")
        out[name] = objs
    return out


def test_public_api_docstrings_follow_numpydoc() -> None:
    validate = pytest.importorskip("numpydoc.validate").validate
    problems: dict[str, list[str]] = defaultdict(list)
    for module, objs in _public_objects().items():
        for qual in objs:
            for code, msg in validate(qual)["errors"]:
                if code in NUMPYDOC_CODES:
                    problems[module].append(f"{qual}: {code} {msg}")
    unexpected = {k: v for k, v in problems.items() if k not in PENDING_DOCS}
    assert not unexpected, "docstring problems:\n" + "\n".join(
        line for v in unexpected.values() for line in v
    )
    fixed = sorted(PENDING_DOCS - set(problems))
    assert not fixed, f"docstrings complete now, remove from PENDING_DOCS: {fixed}"


#: Modules without ``__all__`` yet (issue 10, step "__all__ everywhere").
PENDING_ALL: set[str] = {
    "hdrfringe.demo",
}


def test_every_module_declares_all() -> None:
    missing = set()
    for info in pkgutil.walk_packages(hdrfringe.__path__, "hdrfringe."):
        mod = importlib.import_module(info.name)
        if not hasattr(mod, "__all__"):
            missing.add(info.name)
    assert not missing - PENDING_ALL, f"modules without __all__: {sorted(missing - PENDING_ALL)}"
    fixed = sorted(PENDING_ALL - missing)
    assert not fixed, f"__all__ declared now, remove from PENDING_ALL: {fixed}"
