"""Frames: what the projector shows, one image each.

A frame is a projector input image. The 1-D frames (:class:`FringeFrame`,
:class:`CenterlineFrame`, :class:`UniformFrame`) vary along one projector axis only, so they
render from one line (the separable fast path the virtual rig and the pattern writer use); each
renders to a full image with :func:`render_frame` and describes itself as a capture-manifest
entry (the capture-folder contract, docs/capture_format.md).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe._validation import full_scale
from hdrfringe.errors import InputError
from hdrfringe.patterns import (
    ORIENTATIONS,
    FringeSpec,
    Orientation,
    fringe_gray,
    precompensate_gamma,
)


@dataclass(frozen=True)
class FringeFrame:
    """Shift ``shift`` of the fringe set ``spec``."""

    spec: FringeSpec
    shift: int

    kind: str = field(default="fringe", init=False)

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at projector coordinates along the fringe axis."""
        return fringe_gray(coord, self.spec, self.shift)

    def manifest_entry(self, file: str) -> dict[str, Any]:
        s = self.spec
        return {
            "file": file,
            "kind": "fringe",
            "pattern": s.pattern,
            "steps": int(s.steps),
            "shift": int(self.shift),
            "pitch": float(s.pitch_px),
            "orientation": s.orientation,
            "imin": _num(s.imin),
            "migl": _num(s.migl),
        }

    def default_name(self) -> str:
        return f"{self.spec.label()}_{self.shift}"


@dataclass(frozen=True)
class CenterlineFrame:
    """A single bright line at projector coordinate ``position`` on a dark image (Sec. 2.5).

    The line is one projector pixel wide (``width_px``) at gray level ``migl``; the rest is at
    gray level ``background``.
    """

    position: float
    orientation: Orientation = "vertical"
    migl: float = 255.0
    width_px: int = 1
    background: float = 0.0

    kind: str = field(default="centerline", init=False)

    def __post_init__(self) -> None:
        if self.orientation not in ORIENTATIONS:
            raise InputError(
                f"unknown orientation {self.orientation!r}; use one of {', '.join(ORIENTATIONS)}"
            )
        if self.width_px < 1:
            raise InputError(f"centerline width must be >= 1 projector pixel, got {self.width_px}")

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at projector coordinates across the line (pixel-exact box)."""
        x = np.asarray(coord, dtype=np.float64)
        half = self.width_px / 2.0
        inside = np.abs(x - self.position) < half
        return np.where(inside, float(self.migl), float(self.background))

    def manifest_entry(self, file: str) -> dict[str, Any]:
        return {
            "file": file,
            "kind": "centerline",
            "orientation": self.orientation,
            "position": _num(self.position),
            "migl": _num(self.migl),
        }

    def default_name(self) -> str:
        return f"centerline_{self.orientation[0]}_{self.position:g}_g{self.migl:g}".replace(
            ".", "p"
        )


@dataclass(frozen=True)
class UniformFrame:
    """The whole projector at input gray ``level``."""

    level: float

    kind: str = field(default="uniform", init=False)

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:
        return np.full(np.shape(coord), float(self.level))

    def manifest_entry(self, file: str) -> dict[str, Any]:
        return {"file": file, "kind": "uniform", "level": _num(self.level)}

    def default_name(self) -> str:
        return f"gray_{self.level:g}".replace(".", "p")


Frame = FringeFrame | CenterlineFrame | UniformFrame


def frame_axis(frame: Frame) -> Orientation:
    """Orientation of the frame's varying axis ("vertical" for a uniform frame)."""
    if isinstance(frame, UniformFrame):
        return "vertical"
    if isinstance(frame, FringeFrame):
        return frame.spec.orientation
    return frame.orientation


def render_frame(
    frame: Frame,
    width: int = 1024,
    height: int = 768,
    gamma_hat: float = 1.0,
    bit_depth: int = 8,
) -> NDArray[np.integer]:
    """Projector input image of one frame (what is written to PNG and played).

    Parameters
    ----------
    frame : FringeFrame, CenterlineFrame or UniformFrame
    width, height : int
        Projector resolution in pixels.
    gamma_hat : float
        Gamma pre-compensation exponent (1.0: none). Centerline and uniform frames are
        pre-compensated too, so that every frame maps linearly to projected light.
    bit_depth : int
        Projector input bit depth.

    Returns
    -------
    ndarray, shape (height, width), uint8 or uint16
    """
    if width < 1 or height < 1:
        raise InputError(f"projector resolution must be positive, got {width}x{height}")
    full = full_scale(bit_depth)
    if isinstance(frame, FringeFrame) and frame.spec.migl > full:
        raise InputError(
            f"migl {frame.spec.migl:g} exceeds the projector's maximum {full} at {bit_depth} bits"
        )
    axis = frame_axis(frame)
    n = width if axis == "vertical" else height
    line = precompensate_gamma(frame.gray(np.arange(n)), gamma_hat, bit_depth)
    if axis == "vertical":
        return np.ascontiguousarray(np.broadcast_to(line[None, :], (height, width)))
    return np.ascontiguousarray(np.broadcast_to(line[:, None], (height, width)))


def frame_from_manifest(entry: dict[str, Any]) -> Frame:
    """Build a frame from a (validated) manifest entry of the capture-folder contract."""
    kind = entry["kind"]
    if kind == "fringe":
        spec = FringeSpec(
            pattern=entry["pattern"],
            steps=int(entry["steps"]),
            pitch_px=float(entry["pitch"]),
            orientation=entry["orientation"],
            imin=float(entry["imin"]),
            migl=float(entry["migl"]),
        )
        return FringeFrame(spec, int(entry["shift"]))
    if kind == "centerline":
        return CenterlineFrame(
            position=float(entry["position"]),
            orientation=entry["orientation"],
            migl=float(entry["migl"]),
        )
    if kind == "uniform":
        return UniformFrame(float(entry["level"]))
    raise InputError(f"unknown frame kind {kind!r}; use fringe, centerline or uniform")


def _num(v: float) -> float | int:
    """JSON-friendly number: an int when integral."""
    f = float(v)
    return int(f) if f.is_integer() else f
