"""Static checks of the research package in the test run, as tests/test_static.py does for the
product: mypy without errors (research/pyproject.toml's configuration) and ``__all__`` in every
module."""

from __future__ import annotations

import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import hdrfringe_thesis

RESEARCH = Path(__file__).resolve().parents[1]


@pytest.mark.xdist_group("static")
def test_mypy_is_clean(monkeypatch: pytest.MonkeyPatch) -> None:
    from mypy import api  # a dev dependency of the product (pyproject): missing = broken set-up

    monkeypatch.chdir(RESEARCH)  # mypy reads `files` relative to the working folder
    # the product from its sources, as the research code sees it (editable or from a worktree)
    monkeypatch.setenv("MYPYPATH", str(Path(hdrfringe_thesis.__file__).parents[3] / "src"))
    # the product's cache (tests/test_static.py, the same xdist group: run one after the other):
    # numpy's and the product's analysis are reused, about 13 s less on a cold start
    cache = RESEARCH.parent / ".mypy_cache"
    config = str(RESEARCH / "pyproject.toml")
    stdout, stderr, _status = api.run(["--config-file", config, "--cache-dir", str(cache)])
    errors = [line for line in stdout.splitlines() if re.match(r"^[^:]+\.py:\d+: error:", line)]
    assert not stderr.strip(), stderr
    assert not errors, "mypy errors:\n" + "\n".join(errors)


def test_every_module_declares_all() -> None:
    missing = set()
    for info in pkgutil.walk_packages(hdrfringe_thesis.__path__, "hdrfringe_thesis."):
        if not hasattr(importlib.import_module(info.name), "__all__"):
            missing.add(info.name)
    assert not missing, f"modules without __all__: {sorted(missing)}"
