"""Static checks in the test run: mypy on the package, numpydoc on the public API.

Both read the configuration in pyproject.toml. Every module must pass: mypy without errors,
numpydoc's required sections on every public function and class of the library layers, and
``__all__`` in every module.
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

#: numpydoc checks required of every public function and class: a docstring (GL08), every
#: parameter documented (PR01) and no unknown one (PR02), a Returns section (RT01), an
#: Examples section (EX01).
NUMPYDOC_CODES = ("GL08", "PR01", "PR02", "RT01", "EX01")

#: Front ends: their public functions are commands and report builders, documented by --help.
FRONT_ENDS = ("hdrfringe.cli", "hdrfringe.demo")


def _module_of(path: str) -> str:
    rel = Path(path).resolve().relative_to(ROOT / "src")
    parts = list(rel.with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@pytest.mark.xdist_group("static")
def test_mypy_is_clean() -> None:
    from mypy import api  # a dev dependency (pyproject): missing means a broken set-up

    stdout, stderr, _status = api.run(["--config-file", str(ROOT / "pyproject.toml")])
    errors: dict[str, list[str]] = defaultdict(list)
    for line in stdout.splitlines():
        m = re.match(r"^(src/[^:]+\.py):\d+: error:", line)
        if m:
            errors[_module_of(str(ROOT / m.group(1)))].append(line)
    assert not stderr.strip(), stderr
    assert not errors, "mypy errors:\n" + "\n".join(line for v in errors.values() for line in v)


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
    from numpydoc.validate import validate

    problems: dict[str, list[str]] = defaultdict(list)
    for module, objs in _public_objects().items():
        for qual in objs:
            for code, msg in validate(qual)["errors"]:
                if code in NUMPYDOC_CODES:
                    problems[module].append(f"{qual}: {code} {msg}")
    assert not problems, "docstring problems:\n" + "\n".join(
        line for v in problems.values() for line in v
    )


#: The compiled kernels ``hdrfringe/core/_native/<name>.<EXT_SUFFIX>`` (one per C file) look like
#: extension modules to pkgutil, but are plain C libraries opened with ctypes: not imported.
NATIVE_LIBRARIES = {
    f"hdrfringe.core._native.{p.stem}"
    for p in (ROOT / "src" / "hdrfringe" / "core" / "_native").glob("*.c")
}


def test_every_module_declares_all() -> None:
    missing = set()
    for info in pkgutil.walk_packages(hdrfringe.__path__, "hdrfringe."):
        if info.name in NATIVE_LIBRARIES:
            continue
        mod = importlib.import_module(info.name)
        if not hasattr(mod, "__all__"):
            missing.add(info.name)
    assert not missing, f"modules without __all__: {sorted(missing)}"
