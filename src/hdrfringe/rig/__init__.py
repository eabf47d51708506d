"""Acquisition: rigs that project frames and return camera images."""

from hdrfringe.rig.base import ProjectorInfo, Rig

__all__ = ["ProjectorInfo", "Rig"]
