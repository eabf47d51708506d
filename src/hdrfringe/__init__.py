"""hdrfringe: phase-shifting fringe projection that keeps working when the camera saturates.

The names a user needs are importable from the package itself (``import hdrfringe as hf``):
patterns and frames, decoding, unwrapping, calibration, reconstruction, the rigs, the
saturation-avoidance strategies, the measurement pipeline and capture/calibration I/O. They are
listed in ``hdrfringe/__init__.pyi`` and loaded on first use (``lazy_loader``), so
``import hdrfringe`` stays cheap and pulls in neither dask nor matplotlib.

Examples
--------
>>> import hdrfringe as hf
>>> spec = hf.FringeSpec("sinusoidal", steps=4, pitch_px=8.0)
>>> len(spec.frames())
4
"""

from __future__ import annotations

from typing import Any

import lazy_loader as _lazy

from hdrfringe import _moved

_moved.install()

_getattr, _dir, _names = _lazy.attach_stub(__name__, __file__)
__all__ = sorted([*_names, "__version__"])


def __dir__() -> list[str]:
    """The public names (:data:`__all__`)."""
    return list(__all__)


def __getattr__(name: str) -> Any:
    """Load a public name on first use; ``__version__`` from the installed metadata."""
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("hdrfringe")
        except PackageNotFoundError:  # pragma: no cover - running from a source tree
            value = "0.0.0+unknown"
        globals()["__version__"] = value
        return value
    return _getattr(name)
