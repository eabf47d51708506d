"""Acquisition: rigs that project frames and return camera images."""

from hdrfringe.captures import ProjectorInfo
from hdrfringe.rig.base import Rig

__all__ = ["ProjectorInfo", "Rig"]
