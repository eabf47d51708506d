"""One-way layers (issue 10): core <- acquisition <- I/O <- front ends; imports point inward only.

Every module of ``src/hdrfringe`` is parsed with :mod:`ast` (nothing is imported) and every
import it makes is collected: top-level, inside functions and ``if TYPE_CHECKING:`` blocks,
``import hdrfringe.x``, ``from hdrfringe.x import y``, ``from hdrfringe import x``, relative
imports, and ``importlib.import_module("hdrfringe.x")`` with a literal name. Importing a module
also runs its parent packages' ``__init__``, so those count as imported too. A module may import
modules of its own layer or of an inner one; anything else, and any module not placed in a
layer, fails the test. ``hdrfringe/__init__.py`` (the public API, which re-exports from every
layer) is exempt, and so is importing it (``from hdrfringe import __version__``).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "hdrfringe"
ROOT = "hdrfringe"

CORE, ACQUISITION, IO, FRONT_END = 0, 1, 2, 3
LAYER_NAMES = {CORE: "core", ACQUISITION: "acquisition", IO: "io", FRONT_END: "front end"}

#: Module (dotted, without ``hdrfringe.``) -> layer. ``pkg.*`` covers everything under ``pkg``;
#: an exact entry wins over a pattern.
LAYERS: dict[str, int] = {
    # 0 core: pure numpy, no I/O, no rigs
    "errors": CORE,
    "_validation": CORE,
    "patterns": CORE,
    "frames": CORE,
    "limits": CORE,
    "programs": CORE,
    "captures": CORE,
    "phase": CORE,
    "_blockdecode": CORE,
    "_native": CORE,
    "unwrap": CORE,
    "graycode": CORE,
    "harmonics": CORE,
    "calibration": CORE,
    "reconstruct": CORE,
    "stereo": CORE,
    "stereo_calibration": CORE,
    "geometric_order": CORE,
    "gamma": CORE,
    "gamma.*": CORE,
    "process": CORE,
    # the package __init__ runs whenever a core module imports saturation.estimate: keep it core
    "saturation": CORE,
    "saturation.estimate": CORE,
    "saturation.dpa_rules": CORE,
    "saturation_tolerant": CORE,
    "uncertainty": CORE,
    "saturation.adaptive_map": CORE,
    # 1 acquisition: rigs and the strategies that drive them
    "rig": ACQUISITION,
    "rig.*": ACQUISITION,
    "strategies": ACQUISITION,
    "strategies.*": ACQUISITION,
    "pipeline": ACQUISITION,
    "hardware": ACQUISITION,
    "hardware.*": ACQUISITION,
    # 2 I/O: files in and out
    "io": IO,
    "io.*": IO,
    # 3 front ends
    "cli": FRONT_END,
    "cli.*": FRONT_END,
    "demo": FRONT_END,
    "reproduce": FRONT_END,
    "reproduce.*": FRONT_END,
}

#: (importer, imported) pairs tolerated for now, each with the reason and the step removing it.
#: Keep it empty: a pair listed here that no longer occurs fails the test, so it cannot go stale.
ALLOWED_EXCEPTIONS: dict[tuple[str, str], str] = {}


def module_name(path: Path, src: Path = SRC) -> str:
    """Dotted name below the package (``io/captures.py`` -> ``io.captures``; root: ``""``)."""
    parts = list(path.relative_to(src).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def package_modules(src: Path = SRC) -> dict[str, Path]:
    """Every module of the package by dotted name."""
    return {module_name(p, src): p for p in sorted(src.rglob("*.py"))}


def layer_of(module: str, layers: dict[str, int] = LAYERS) -> int | None:
    """The layer of a module, or None when no entry places it."""
    if module in layers:
        return layers[module]
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        pattern = ".".join(parts[:n]) + ".*"
        if pattern in layers and n < len(parts):
            return layers[pattern]
    return None


def _with_parents(module: str) -> list[str]:
    parts = module.split(".")
    return [".".join(parts[:n]) for n in range(len(parts), 0, -1)]


def imports_of(
    source: str, module: str, is_package: bool, known: set[str]
) -> list[tuple[str, int]]:
    """(imported module, line) for every import of a package module that ``source`` makes.

    Parameters
    ----------
    source : str
        Python source of the importing module.
    module : str
        Its dotted name below the package (for relative imports).
    is_package : bool
        True for a package's ``__init__``.
    known : set of str
        Dotted names of the package's modules (to tell ``from x import submodule`` from
        ``from x import attribute``).

    Returns
    -------
    list of (str, int)
        Imported modules (parents included, the root package left out), with line numbers;
        a name that is no module of the package is returned as ``?<name>``.
    """
    here = module.split(".") if module else []
    package = here if is_package else here[:-1]
    found: list[tuple[str, int]] = []

    def add(target: str, line: int) -> None:
        if not target:
            return  # the root package: exempt
        if target not in known:
            found.append((f"?{target}", line))
            return
        found.extend((t, line) for t in _with_parents(target))

    def absolute(dotted: str) -> str | None:
        """``hdrfringe.x.y`` -> ``x.y``; ``hdrfringe`` -> ``""``; other packages -> None."""
        if dotted == ROOT:
            return ""
        if dotted.startswith(ROOT + "."):
            return dotted[len(ROOT) + 1 :]
        return None

    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                target = absolute(alias.name)
                if target is not None:
                    add(target, node.lineno)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                keep = len(package) - (node.level - 1)
                if keep < 0:
                    found.append((f"?{'.' * node.level}{node.module or ''}", node.lineno))
                    continue
                base = ".".join(package[:keep] + ([node.module] if node.module else []))
            else:
                resolved = absolute(node.module or "")
                if resolved is None:
                    continue
                base = resolved
            for alias in node.names:
                sub = f"{base}.{alias.name}" if base else alias.name
                add(sub if sub in known else base, node.lineno)
        elif (
            isinstance(node, ast.Call)
            and (
                (isinstance(node.func, ast.Attribute) and node.func.attr == "import_module")
                or (isinstance(node.func, ast.Name) and node.func.id == "import_module")
            )
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            target = absolute(node.args[0].value)
            if target is not None:
                add(target, node.lineno)
    return found


def violations(
    sources: dict[str, tuple[str, bool]], layers: dict[str, int] = LAYERS
) -> list[tuple[str, str, int, str]]:
    """(importer, imported, line, why) for every import that points outward.

    ``sources`` maps a module's dotted name to (source, is_package); the root (``""``) is
    exempt. Unplaced modules are reported by :func:`unplaced`, not here.
    """
    known = set(sources)
    out: list[tuple[str, str, int, str]] = []
    for module, (source, is_package) in sorted(sources.items()):
        if not module:
            continue
        own = layer_of(module, layers)
        if own is None:
            continue
        for target, line in imports_of(source, module, is_package, known):
            if target.startswith("?"):
                out.append((module, target[1:], line, "imports no module of the package"))
                continue
            theirs = layer_of(target, layers)
            if theirs is not None and theirs > own:
                why = f"{LAYER_NAMES[own]} imports {LAYER_NAMES[theirs]}"
                out.append((module, target, line, why))
    return sorted(set(out))


def unplaced(modules: set[str], layers: dict[str, int] = LAYERS) -> list[str]:
    """Modules (the root excepted) that no entry of ``layers`` places."""
    return sorted(m for m in modules if m and layer_of(m, layers) is None)


def _package_sources() -> dict[str, tuple[str, bool]]:
    return {
        name: (path.read_text(encoding="utf-8"), path.name == "__init__.py")
        for name, path in package_modules().items()
    }


# --- the package ------------------------------------------------------------------------------


def test_every_module_is_placed_in_a_layer() -> None:
    missing = unplaced(set(package_modules()))
    assert not missing, (
        f"modules in no layer: {', '.join(missing)}; add them to LAYERS in tests/test_layers.py"
    )


def test_imports_point_inward_only() -> None:
    found = violations(_package_sources())
    left = [v for v in found if (v[0], v[1]) not in ALLOWED_EXCEPTIONS]
    assert not left, "imports pointing outward:\n" + "\n".join(
        f"  hdrfringe.{m} (line {line}) imports hdrfringe.{t}: {why}" for m, t, line, why in left
    )


def test_allowed_exceptions_are_still_needed() -> None:
    found = {(m, t) for m, t, _, _ in violations(_package_sources())}
    stale = sorted(set(ALLOWED_EXCEPTIONS) - found)
    assert not stale, f"ALLOWED_EXCEPTIONS no longer needed, remove them: {stale}"


def test_the_package_is_found() -> None:
    """Guards against a vacuous pass: the walk sees the modules and their imports."""
    modules = package_modules()
    assert {"captures", "io.captures", "rig.replay", "process", "cli"} <= set(modules)
    src = modules["rig.replay"].read_text(encoding="utf-8")
    imported = {t for t, _ in imports_of(src, "rig.replay", False, set(modules))}
    assert {"captures", "errors", "frames"} <= imported


# --- the checker on synthetic modules ----------------------------------------------------------

#: A small package: core ``phase``, acquisition ``rig`` (package) with ``rig.replay``, I/O ``io``
#: with ``io.captures``, front end ``cli``.
_PACKAGE = {"": ("", True), "io": ("", True), "rig": ("", True), "cli": ("", False)}
_OK = "import numpy as np\nfrom hdrfringe.errors import InputError\n"


def _check(module: str, source: str, is_package: bool = False) -> list[tuple[str, str, int, str]]:
    sources = {
        **_PACKAGE,
        "errors": (_OK, False),
        "phase": (_OK, False),
        "io.captures": (_OK, False),
        "rig.replay": (_OK, False),
    }
    sources[module] = (source, is_package)
    return violations(sources)


@pytest.mark.parametrize(
    ("module", "source", "expected"),
    [
        # the rig <-> io cycle this issue removed, top level and inside a function
        ("rig.replay", "from hdrfringe.io.captures import CaptureFolder\n", ["io.captures", "io"]),
        ("phase", "def f():\n    from hdrfringe.io.captures import x\n", ["io.captures", "io"]),
        ("phase", "import hdrfringe.rig.replay\n", ["rig.replay", "rig"]),
        ("phase", "from hdrfringe import cli\n", ["cli"]),
        ("phase", "from hdrfringe.io import captures\n", ["io.captures", "io"]),
        ("rig.replay", "from ..io import captures\n", ["io.captures", "io"]),
        ("rig.replay", "from ..io.captures import read\n", ["io.captures", "io"]),
        ("rig", "from .. import cli\n", ["cli"]),  # relative import in a package __init__
        (
            "phase",
            "import typing\nif typing.TYPE_CHECKING:\n    from hdrfringe.rig import Rig\n",
            ["rig"],
        ),
        ("phase", "import importlib\nimportlib.import_module('hdrfringe.cli')\n", ["cli"]),
    ],
)
def test_checker_rejects_outward_imports(module: str, source: str, expected: list[str]) -> None:
    found = _check(module, source, is_package=module == "rig")
    assert sorted(t for m, t, _, _ in found if m == module) == sorted(expected)


@pytest.mark.parametrize(
    ("module", "source"),
    [
        ("io.captures", "from hdrfringe.phase import x\nfrom hdrfringe.rig.replay import y\n"),
        ("rig.replay", "from hdrfringe.phase import x\nfrom . import replay\n"),
        ("cli", "import hdrfringe.io.captures\nfrom hdrfringe import phase, rig\n"),
        ("phase", "from hdrfringe import __version__\nimport hdrfringe\n"),  # the root is exempt
        ("phase", "from hdrfringe.errors import InputError\nimport os.path\n"),
    ],
)
def test_checker_accepts_inward_imports(module: str, source: str) -> None:
    assert _check(module, source) == []


def test_checker_reports_unknown_modules_and_unplaced_ones() -> None:
    found = _check("phase", "from hdrfringe.nosuch import x\n")
    assert [(m, t, why) for m, t, _, why in found] == [
        ("phase", "nosuch", "imports no module of the package")
    ]
    assert unplaced({"", "phase", "rig.replay", "newthing", "reproduce.x"}) == ["newthing"]
    assert layer_of("gamma.fits") == CORE and layer_of("strategies.lpa") == ACQUISITION
    assert layer_of("saturation") == CORE
