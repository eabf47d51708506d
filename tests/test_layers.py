"""One-way layers (issues 10, 29): core <- acquisition <- I/O <- tasks <- front ends; inward only.

Every module of ``src/hdrfringe`` is parsed with :mod:`ast` (nothing is imported) and every
import it makes is collected: top-level, inside functions and ``if TYPE_CHECKING:`` blocks,
``import hdrfringe.x``, ``from hdrfringe.x import y``, ``from hdrfringe import x``, relative
imports, and ``importlib.import_module("hdrfringe.x")`` with a literal name. Importing a module
also runs its parent packages' ``__init__``, so those count as imported too. A module may import
modules of its own layer or of an inner one; anything else, and any module not placed in a
layer, fails the test. ``hdrfringe/__init__.py`` (the public API, which re-exports from every
layer) is exempt, and so is importing it (``from hdrfringe import __version__``).

The same walk gives the module import graph, checked for circles (issue 29): no strongly connected
component of more than one module, lazy imports included; and src never imports the research
package (:data:`RESEARCH`, ``research/`` of the repository: it joins the product through entry
points, never through an import).
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest
from scipy.sparse import coo_array
from scipy.sparse.csgraph import connected_components

SRC = Path(__file__).resolve().parents[1] / "src" / "hdrfringe"
ROOT = "hdrfringe"

CORE, ACQUISITION, MEASUREMENT, TASKS, FRONT_END = 0, 1, 2, 3, 4
LAYER_NAMES = {
    CORE: "core",
    ACQUISITION: "acquisition",
    MEASUREMENT: "pipeline and io",
    TASKS: "tasks",
    FRONT_END: "front end",
}

#: Top-level name below ``hdrfringe`` (a folder, or a module at the root) -> layer; everything
#: under a folder is in its layer. A module may import its own layer and the inner ones.
LAYERS: dict[str, int] = {
    # 0 core: the equations on arrays and frozen dataclasses; no rig, no file, no plot
    "core": CORE,
    "errors": CORE,
    "_moved": CORE,  # old module paths of moved modules (imports by computed name only)
    "_renamed": CORE,  # old spellings of renamed keywords and fields
    # 1 acquisition: rigs, devices and the strategies that drive them
    "rig": ACQUISITION,
    "hardware": ACQUISITION,
    "strategies": ACQUISITION,
    # 2 the measurement (objects in, objects out) and the file formats; neither imports the other
    "pipeline": MEASUREMENT,
    "io": MEASUREMENT,
    # 3 one workflow per command: paths and options in, a folder and a report out
    "tasks": TASKS,
    # 4 the front end: each command declares options, calls a task, prints its report
    "cli": FRONT_END,
}

#: Imports a layer's own rank allows but the design forbids (issue 29): importer prefix ->
#: imported prefixes. I/O is file formats only: it runs no measurement and drives no rig; the
#: pipeline reads and writes no file; a command declares options, calls its task and prints the
#: report: the CLI reads, writes and drives nothing itself. (io reads and writes acquisition's
#: dataclasses, e.g. a rig configuration, as it does core's.)
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "io": ("pipeline", "rig", "tasks"),
    "pipeline": ("io",),
    "cli": ("pipeline", "io", "rig", "hardware"),
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
    """The layer of a module (by its first name below the package), or None when unplaced."""
    return layers.get(module.split(".")[0])


def _with_parents(module: str) -> list[str]:
    parts = module.split(".")
    return [".".join(parts[:n]) for n in range(len(parts), 0, -1)]


def imports_of(
    source: str, module: str, is_package: bool, known: set[str], with_parents: bool = True
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
    with_parents : bool
        Also list the parent packages of each imported module (their ``__init__`` runs too).

    Returns
    -------
    list of (str, int)
        Imported modules (parents included unless ``with_parents`` is False, the root package
        left out), with line numbers;
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
        found.extend((t, line) for t in (_with_parents(target) if with_parents else [target]))

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
            elif _forbidden(module, target):
                out.append((module, target, line, f"{module.split('.')[0]} never imports it"))
    return sorted(set(out))


def _forbidden(module: str, target: str) -> bool:
    """Whether :data:`FORBIDDEN` rules out ``module`` importing ``target``."""
    return any(
        _is_within(module, importer) and any(_is_within(target, t) for t in targets)
        for importer, targets in FORBIDDEN.items()
    )


def unplaced(modules: set[str], layers: dict[str, int] = LAYERS) -> list[str]:
    """Modules (the root excepted) that no entry of ``layers`` places."""
    return sorted(m for m in modules if m and layer_of(m, layers) is None)


def _package_sources() -> dict[str, tuple[str, bool]]:
    return {
        name: (path.read_text(encoding="utf-8"), path.name == "__init__.py")
        for name, path in package_modules().items()
    }


# --- import circles and the research package (issue 29) ---------------------------------------

#: Import circles tolerated for now (the modules of one strongly connected component -> why, and
#: the step of issue 29 that removes it). Keep it empty: a new circle fails the test, and so does
#: a circle listed here that no longer occurs, so the list cannot go stale.
KNOWN_CYCLES: dict[frozenset[str], str] = {}

#: The research package (``research/src/hdrfringe_thesis``, distribution ``hdrfringe-thesis``).
#: It joins the product through entry points (``hdrfringe.commands``: ``reproduce``;
#: ``hdrfringe.compare_references``: the thesis's numbers in ``compare``); the product never
#: imports it, so that ``pip install hdrfringe`` needs none of its dependencies.
RESEARCH = "hdrfringe_thesis"


def _is_within(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def import_graph(sources: dict[str, tuple[str, bool]]) -> dict[str, set[str]]:
    """Module -> the package modules it imports, at the top level or inside a function.

    An import names one module (``from hdrfringe.x import y`` names ``x.y`` when that is a
    module, else ``x``) and also runs that module's parent packages, which count as imported too,
    except the importer's own parents: they are already being initialised when it runs (a
    submodule needs no edge to its package for ``rig/__init__`` to import it without a circle).
    An explicit import of an own parent (``from hdrfringe.rig import Rig`` in ``rig.replay``)
    counts. The root package (``hdrfringe/__init__.py``, the lazy public API) is left out, as
    are names that are no module of the package (reported by :func:`violations`).
    """
    known = set(sources)
    graph: dict[str, set[str]] = {m: set() for m in known if m}
    for module, (source, is_package) in sources.items():
        if not module:
            continue
        for target, _ in imports_of(source, module, is_package, known, with_parents=False):
            if target.startswith("?"):
                continue
            graph[module].add(target)
            graph[module].update(p for p in _with_parents(target)[1:] if not _is_within(module, p))
        graph[module].discard(module)
    return graph


def import_cycles(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected components of ``graph`` with more than one module, sorted."""
    names = sorted(set(graph) | {t for targets in graph.values() for t in targets})
    index = {name: i for i, name in enumerate(names)}
    edges = np.array(
        [(index[m], index[t]) for m, targets in graph.items() for t in targets], dtype=np.intp
    ).reshape(-1, 2)
    adjacency = coo_array(
        (np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(len(names), len(names))
    )
    _, labels = connected_components(adjacency, directed=True, connection="strong")
    components = [
        frozenset(names[i] for i in np.flatnonzero(labels == label)) for label in set(labels)
    ]
    return sorted((c for c in components if len(c) > 1), key=sorted)


def research_importers(sources: dict[str, tuple[str, bool]]) -> dict[str, list[int]]:
    """Modules that import the research package :data:`RESEARCH` -> the lines that do: ``import
    hdrfringe_thesis.x``, ``from hdrfringe_thesis(.x) import y`` and
    ``importlib.import_module("hdrfringe_thesis.x")`` with a literal name, at any depth."""
    out: dict[str, list[int]] = {}
    for module, (source, _) in sorted(sources.items()):
        lines = set()
        for node in ast.walk(ast.parse(source)):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            elif (
                isinstance(node, ast.Call)
                and getattr(node.func, "attr", getattr(node.func, "id", None)) == "import_module"
                and node.args
                and isinstance(node.args[0], ast.Constant)
                and isinstance(node.args[0].value, str)
            ):
                names = [node.args[0].value]
            if any(_is_within(name, RESEARCH) for name in names):
                lines.add(node.lineno)
        if lines:
            out[module] = sorted(lines)
    return out


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
    assert {"core.captures", "io.captures", "rig.replay", "core.decode", "cli"} <= set(modules)
    src = modules["rig.replay"].read_text(encoding="utf-8")
    imported = {t for t, _ in imports_of(src, "rig.replay", False, set(modules))}
    assert {"core.captures", "errors", "core.frames"} <= imported


# --- the checker on synthetic modules ----------------------------------------------------------

#: A small package: core ``phase``, acquisition ``rig`` (package) with ``rig.replay`` and
#: ``pipeline``, I/O ``io`` with ``io.captures``, ``tasks`` with ``tasks.measure``, front end
#: ``cli``.
_PACKAGE = {"": ("", True), "io": ("", True), "rig": ("", True), "cli": ("", False)}
_OK = "import numpy as np\nfrom hdrfringe.errors import InputError\n"


def _check(module: str, source: str, is_package: bool = False) -> list[tuple[str, str, int, str]]:
    sources = {
        **_PACKAGE,
        "errors": (_OK, False),
        "core": ("", True),
        "core.phase": (_OK, False),
        "io.captures": (_OK, False),
        "rig.replay": (_OK, False),
        "pipeline": (_OK, False),
        "tasks": ("", True),
        "tasks.measure": (_OK, False),
    }
    sources[module] = (source, is_package)
    return violations(sources)


@pytest.mark.parametrize(
    ("module", "source", "expected"),
    [
        # the rig <-> io cycle this issue removed, top level and inside a function
        ("rig.replay", "from hdrfringe.io.captures import CaptureFolder\n", ["io.captures", "io"]),
        (
            "core.phase",
            "def f():\n    from hdrfringe.io.captures import x\n",
            ["io.captures", "io"],
        ),
        ("core.phase", "import hdrfringe.rig.replay\n", ["rig.replay", "rig"]),
        ("core.phase", "from hdrfringe import cli\n", ["cli"]),
        ("core.phase", "from hdrfringe.io import captures\n", ["io.captures", "io"]),
        ("rig.replay", "from ..io import captures\n", ["io.captures", "io"]),
        ("rig.replay", "from ..io.captures import read\n", ["io.captures", "io"]),
        ("rig", "from .. import cli\n", ["cli"]),  # relative import in a package __init__
        (
            "core.phase",
            "import typing\nif typing.TYPE_CHECKING:\n    from hdrfringe.rig import Rig\n",
            ["rig"],
        ),
        ("core.phase", "import importlib\nimportlib.import_module('hdrfringe.cli')\n", ["cli"]),
        # io is file formats only (issue 29): no rig, no pipeline, no task, though rank allows
        ("io.captures", "from hdrfringe.rig.replay import y\n", ["rig.replay", "rig"]),
        ("io.captures", "def f():\n    import hdrfringe.pipeline\n", ["pipeline"]),
        ("io.captures", "from hdrfringe.tasks import measure\n", ["tasks.measure", "tasks"]),
        ("rig.replay", "from hdrfringe.tasks.measure import run\n", ["tasks.measure", "tasks"]),
        ("tasks.measure", "from hdrfringe.cli import x\n", ["cli"]),
        # the pipeline reads and writes no file: objects in, objects out
        ("pipeline", "def f():\n    from hdrfringe.io.captures import x\n", ["io.captures", "io"]),
        # the core drives no rig and runs no measurement, even lazily
        ("core.phase", "def f():\n    import hdrfringe.pipeline\n", ["pipeline"]),
        # a command calls its task: no io, pipeline or rig of its own
        (
            "cli",
            "import hdrfringe.io.captures\nfrom hdrfringe.core import phase\n"
            "from hdrfringe import rig\n",
            ["io.captures", "io", "rig"],
        ),
        ("cli", "def f():\n    from hdrfringe.pipeline import measure\n", ["pipeline"]),
    ],
)
def test_checker_rejects_outward_imports(module: str, source: str, expected: list[str]) -> None:
    found = _check(module, source, is_package=module == "rig")
    assert sorted(t for m, t, _, _ in found if m == module) == sorted(expected)


@pytest.mark.parametrize(
    ("module", "source"),
    [
        ("io.captures", "from hdrfringe.core.phase import x\nfrom hdrfringe.errors import y\n"),
        ("tasks.measure", "from hdrfringe.rig.replay import y\nfrom hdrfringe.io import x\n"),
        ("cli", "from hdrfringe.tasks.measure import run\n"),
        ("rig.replay", "from hdrfringe.core.phase import x\nfrom . import replay\n"),
        ("cli", "import hdrfringe.tasks.measure\nfrom hdrfringe.core import phase, decode\n"),
        # the root is exempt
        ("core.phase", "from hdrfringe import __version__\nimport hdrfringe\n"),
        ("core.phase", "from hdrfringe.errors import InputError\nimport os.path\n"),
    ],
)
def test_checker_accepts_inward_imports(module: str, source: str) -> None:
    assert _check(module, source) == []


def test_checker_reports_unknown_modules_and_unplaced_ones() -> None:
    found = _check("core.phase", "from hdrfringe.nosuch import x\n")
    assert [(m, t, why) for m, t, _, why in found] == [
        ("core.phase", "nosuch", "imports no module of the package")
    ]
    assert unplaced({"", "core.phase", "rig.replay", "newthing", "tasks.x"}) == ["newthing"]
    assert layer_of("core.gamma.fits") == CORE and layer_of("strategies.lpa") == ACQUISITION
    assert layer_of("core") == CORE and layer_of("io.x") == layer_of("pipeline") == MEASUREMENT
    assert layer_of("phase") is None  # the root holds no core module any more


# --- import circles and the research package: the package -------------------------------------


def test_no_import_cycles() -> None:
    cycles = import_cycles(import_graph(_package_sources()))
    new = [c for c in cycles if c not in KNOWN_CYCLES]
    assert not new, "import circles (strongly connected components; break each):\n" + "\n".join(
        "  " + " <-> ".join(f"hdrfringe.{m}" for m in sorted(c)) for c in new
    )
    stale = [sorted(c) for c in KNOWN_CYCLES if c not in cycles]
    assert not stale, f"KNOWN_CYCLES no longer occur, remove them: {stale}"


def test_the_import_graph_is_found() -> None:
    """Guards against a vacuous pass: the graph has the edges the circles were made of, one way."""
    graph = import_graph(_package_sources())
    assert "core.patterns" in graph["core.frames"]
    assert "core.frames" not in graph["core.patterns"]
    assert {"hardware.pylon", "hardware.genicam", "hardware.opencv_camera"} <= graph[
        "hardware.backends"
    ]
    assert "hardware.camera" in graph["hardware.pylon"]
    assert not {"hardware.pylon", "hardware.backends"} & graph["hardware.camera"]
    assert "rig.replay" in graph["rig"]  # a package importing its submodules (lazily) ...
    assert "rig" not in graph["rig.replay"]  # ... which need no edge back to it
    assert sum(len(t) for t in graph.values()) > 500


def test_src_never_imports_the_research_package() -> None:
    found = research_importers(_package_sources())
    assert not found, "the product imports the research package (hdrfringe_thesis):\n" + (
        "\n".join(f"  hdrfringe.{m} (lines {lines})" for m, lines in found.items())
    )


# --- the circle check on synthetic modules ------------------------------------------------------


def _graph(modules: dict[str, str]) -> dict[str, set[str]]:
    """The import graph of a small package: names ending in ``/`` are packages."""
    sources = {"": ("", True)}
    for name, source in modules.items():
        sources[name.rstrip("/")] = (source, name.endswith("/"))
    return import_graph(sources)


@pytest.mark.parametrize(
    ("modules", "expected"),
    [
        # the patterns <-> frames circle this issue removed: a lazy import inside a method
        (
            {
                "patterns": "def frames():\n    from hdrfringe.frames import FringeFrame\n",
                "frames": "from hdrfringe.patterns import FringeSpec\n",
            },
            [{"frames", "patterns"}],
        ),
        # the camera circle: a factory importing back ends that import it (relative imports)
        (
            {
                "hw/": "",
                "hw.camera": "def open_camera():\n    from .pylon import PylonCamera\n",
                "hw.pylon": "from .camera import CameraBase\n",
                "hw.genicam": "from . import camera\n",
            },
            [{"hw.camera", "hw.pylon"}],
        ),
        # three modules, `import a.b as c`, importlib with a literal name
        (
            {
                "a/": "",
                "a.b": "import hdrfringe.c as c\n",
                "c": "import importlib\nimportlib.import_module('hdrfringe.d')\n",
                "d": "if TYPE_CHECKING:\n    from hdrfringe.a import b\n",
            },
            [{"a.b", "c", "d"}],
        ),
        # an explicit import of the own package from a submodule the package imports
        (
            {
                "rig/": "from hdrfringe.rig.replay import R\n",
                "rig.replay": "from hdrfringe.rig import B\n",
            },
            [{"rig", "rig.replay"}],
        ),
        # importing io.captures runs io/__init__, which imports the importer back
        (
            {
                "io/": "from hdrfringe.rig import x\n",
                "io.captures": "",
                "rig": "import hdrfringe.io.captures\n",
            },
            [{"io", "rig"}],
        ),
        # two separate circles are both reported
        (
            {
                "a": "import hdrfringe.b\n",
                "b": "import hdrfringe.a\n",
                "c": "from hdrfringe import d\n",
                "d": "from hdrfringe import c\n",
            },
            [{"a", "b"}, {"c", "d"}],
        ),
    ],
)
def test_cycle_check_finds_circles(modules: dict[str, str], expected: list[set[str]]) -> None:
    assert import_cycles(_graph(modules)) == [frozenset(c) for c in expected]


@pytest.mark.parametrize(
    "modules",
    [
        # a package importing its submodules, which import siblings (the own package is running)
        {
            "rig/": "from hdrfringe.rig.base import Rig\nfrom .replay import R\n",
            "rig.base": "",
            "rig.replay": "from hdrfringe.rig.base import Rig\nfrom . import base\n",
        },
        # one way, lazily or not; importing the root package is exempt
        {
            "frames": "from hdrfringe.patterns import FringeSpec\n",
            "patterns": "from hdrfringe import __version__\nimport hdrfringe\n",
        },
        # a module importing itself is no circle; unknown names are left to `violations`
        {"a": "def f():\n    import hdrfringe.a\nfrom hdrfringe.nosuch import x\n"},
    ],
)
def test_cycle_check_accepts_one_way_imports(modules: dict[str, str]) -> None:
    assert import_cycles(_graph(modules)) == []


def test_research_check_finds_importers() -> None:
    sources = {
        "": ("", True),
        "runner": ("from .reproduce import x\nimport hdrfringe_thesisx\n", True),
        "phase": ("def f():\n    from hdrfringe_thesis.runner import x\n", False),
        "cli": ("import numpy, hdrfringe_thesis\n", False),
        "io": ("import importlib\nimportlib.import_module('hdrfringe_thesis.cli')\n", True),
        "demo": ("from hdrfringe import reproduce\n", False),
    }
    assert research_importers(sources) == {"cli": [1], "io": [2], "phase": [2]}
