"""Old module paths of modules that moved (issue 29), kept importable with a warning.

The core modules moved from the package root into :mod:`hdrfringe.core`
(``hdrfringe.phase`` is now ``hdrfringe.core.phase``), ``hdrfringe.process`` became
``hdrfringe.core.decode``, ``hdrfringe.saturation_tolerant`` became
``hdrfringe.core.saturation.tolerant`` and the virtual camera's sensor model
``hdrfringe.rig.camera`` became ``hdrfringe.rig.sensor``. Importing an old path (or a submodule
below it) returns the module object of the new path itself, never a second copy, and emits a
:class:`DeprecationWarning` that names the new path. :func:`install` puts the finder first on
:data:`sys.meta_path`; the package's ``__init__`` calls it.

Examples
--------
>>> import warnings
>>> import hdrfringe.core.phase
>>> with warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     import hdrfringe.phase
>>> hdrfringe.phase is hdrfringe.core.phase
True
>>> str(caught[0].message)
'hdrfringe.phase moved to hdrfringe.core.phase; import it from there'
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import importlib.util
import sys
import warnings
from types import ModuleType

__all__ = ["MOVED", "install", "new_name"]

#: Old path -> new path (full dotted names). A submodule of an old path maps below the new one.
MOVED: dict[str, str] = {
    **{
        f"hdrfringe.{name}": f"hdrfringe.core.{name}"
        for name in (
            "_blockdecode", "_native", "_validation", "calibration", "captures", "frames",
            "gamma", "geometric_order", "graycode", "harmonics", "limits", "patterns", "phase",
            "programs", "reconstruct", "saturation", "stereo", "stereo_calibration",
            "uncertainty", "unwrap",
        )
    },
    "hdrfringe.process": "hdrfringe.core.decode",
    "hdrfringe.saturation_tolerant": "hdrfringe.core.saturation.tolerant",
    "hdrfringe.rig.camera": "hdrfringe.rig.sensor",
}  # fmt: skip


def new_name(fullname: str) -> str | None:
    """The new dotted path of a moved module (or of a submodule below one), else None.

    Parameters
    ----------
    fullname : str
        A full dotted module name, e.g. ``"hdrfringe.gamma.model"``.

    Returns
    -------
    str or None
        ``"hdrfringe.core.gamma.model"`` for that example; None for a module that did not move.

    Examples
    --------
    >>> new_name("hdrfringe.gamma.model"), new_name("hdrfringe.io.captures")
    ('hdrfringe.core.gamma.model', None)
    """
    parts = fullname.split(".")
    for n in range(len(parts), 1, -1):
        target = MOVED.get(".".join(parts[:n]))
        if target is not None:
            return ".".join([target, *parts[n:]])
    return None


class _AliasLoader(importlib.abc.Loader):
    """Loads an old path as the module of its new path (the same object)."""

    def __init__(self, new: str) -> None:
        self.new = new
        self.spec: importlib.machinery.ModuleSpec | None = None

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(
            f"{spec.name} moved to {self.new}; import it from there",
            DeprecationWarning,
            stacklevel=2,
        )
        module = importlib.import_module(self.new)
        self.spec = module.__spec__
        return module

    def exec_module(self, module: ModuleType) -> None:
        # the import system set __spec__ to the alias's spec: give the module its own back
        module.__spec__ = self.spec


class _MovedFinder(importlib.abc.MetaPathFinder):
    """Finds old paths of moved modules (see :data:`MOVED`)."""

    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        new = new_name(fullname)
        if new is None:
            return None
        return importlib.util.spec_from_loader(fullname, _AliasLoader(new))


def install() -> None:
    """Put the finder of old paths first on :data:`sys.meta_path` (once)."""
    if not any(isinstance(f, _MovedFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, _MovedFinder())
