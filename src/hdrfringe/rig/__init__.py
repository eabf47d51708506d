"""Acquisition: rigs that project frames and return camera images.

* :class:`Rig` (the protocol every rig implements) and :class:`RigBase` (its housekeeping),
  :mod:`hdrfringe.rig.base`.
* :class:`SimulatedRig`, the virtual rig (:mod:`hdrfringe.rig.simulated`), and
  :func:`virtual_rig`, the one a few plain options describe (:mod:`hdrfringe.rig.factory`).
* :class:`ReplayRig`, a rig over captures read from a folder (:mod:`hdrfringe.rig.replay`).
* :class:`ProjectorInfo` and :class:`CameraSettings` (core, :mod:`hdrfringe.core.captures`).

The virtual and replay rigs are imported on first use (``hdrfringe.rig.SimulatedRig``), so that
importing the protocol does not load the simulator.

Examples
--------
>>> from hdrfringe.rig import Rig, virtual_rig
>>> isinstance(virtual_rig("white_plate"), Rig)
True
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from hdrfringe.core.captures import CameraSettings, ProjectorInfo
from hdrfringe.rig.base import Rig, RigBase

if TYPE_CHECKING:
    from hdrfringe.rig.factory import virtual_rig
    from hdrfringe.rig.replay import ReplayRig
    from hdrfringe.rig.simulated import SimulatedRig

__all__ = [
    "CameraSettings",
    "ProjectorInfo",
    "ReplayRig",
    "Rig",
    "RigBase",
    "SimulatedRig",
    "virtual_rig",
]

#: Names exported lazily, with the module defining each.
_LAZY = {
    "SimulatedRig": "hdrfringe.rig.simulated",
    "ReplayRig": "hdrfringe.rig.replay",
    "virtual_rig": "hdrfringe.rig.factory",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        value = getattr(importlib.import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
