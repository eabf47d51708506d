"""The product needs none of the research package's dependencies (issue 29): dask, xarray, zarr
and markdown are requirements of ``hdrfringe-thesis`` (research/pyproject.toml) only.

The product's pyproject must not name them, and every module of ``src/hdrfringe``, ``hdrfringe
--help`` and a small ``phase`` must work in a process where importing any of them fails (a
``sys.meta_path`` finder that refuses them, as if they were not installed).
"""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESEARCH_ONLY = ("dask", "distributed", "xarray", "zarr", "markdown")

_BLOCKED = """
import importlib, pkgutil, sys

BLOCKED = {blocked!r}

class Refuse:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}} (blocked)", name=name)
        return None

sys.meta_path.insert(0, Refuse())
import hdrfringe
from hdrfringe.cli import app

native = {{"hdrfringe.core._native." + n for n in {native!r}}}
names = [i.name for i in pkgutil.walk_packages(hdrfringe.__path__, "hdrfringe.")]
for name in names:
    if name not in native:
        importlib.import_module(name)
print("imported", len(names))
for args in (["--help"], ["phase", sys.argv[1], "-o", sys.argv[2]]):
    try:
        app(args, prog_name="hdrfringe")
    except SystemExit as exc:
        assert exc.code == 0, (args, exc.code)
print("loaded", *sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED))
"""


def test_pyproject_does_not_require_them() -> None:
    with open(ROOT / "pyproject.toml", "rb") as f:
        project = tomllib.load(f)["project"]
    required = [*project["dependencies"], *project["optional-dependencies"]["dev"]]
    names = {re.match(r"[A-Za-z0-9_.-]+", r)[0].lower() for r in required}  # type: ignore[index]
    assert names and "numpy" in names  # the parse found the list
    assert not names & set(RESEARCH_ONLY), names & set(RESEARCH_ONLY)
    with open(ROOT / "research" / "pyproject.toml", "rb") as f:
        research = tomllib.load(f)["project"]["dependencies"]
    assert {"dask[distributed]", "xarray", "zarr", "markdown"} <= {
        re.match(r"[A-Za-z0-9_.\[\]-]+", r)[0].lower()  # type: ignore[index]
        for r in research
    }


def test_every_module_help_and_phase_work_without_them(
    capture_folder: Path, tmp_path: Path
) -> None:
    native = [p.stem for p in (ROOT / "src" / "hdrfringe" / "core" / "_native").glob("*.c")]
    code = _BLOCKED.format(blocked=RESEARCH_ONLY, native=native)
    res = subprocess.run(
        [sys.executable, "-c", code, str(capture_folder), str(tmp_path / "phase")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    lines = res.stdout.splitlines()
    assert int(next(ln for ln in lines if ln.startswith("imported")).split()[1]) > 100
    assert lines[-1] == "loaded", lines[-1]  # none of them was imported
    assert "Commands" in res.stdout and (tmp_path / "phase" / "wrapped_phase.tiff").is_file()
