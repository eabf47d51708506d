"""Frames: what the projector shows, one image each.

A frame is a projector input image. Every frame renders itself as a full projector image with
:meth:`render` (or :func:`render_frame`), evaluates its linear gray level at continuous projector
coordinates with :meth:`gray_at`, and describes itself as a capture-manifest entry (the
capture-folder contract, docs/capture_format.md).

- Line frames vary along one projector axis only: :class:`FringeFrame`, :class:`CenterlineFrame`,
  :class:`UniformFrame`, :class:`GrayCodeFrame` (one bit of a stripe code, docs/graycode.md).
  They keep a fast separable path: :meth:`gray` along their axis (:func:`frame_axis`), and
  :meth:`render` broadcasts one line.
- Image frames vary along both axes: :class:`PixelwiseFringeFrame` (a fringe whose maximum input
  gray level varies per projector pixel) and :class:`ImageFrame` (any projector image). Their 2-D
  data is stored beside a capture folder's images in a side file (docs/capture_format.md,
  "Version 2 extensions"); it is held as float32, the precision of that file, so a frame read back
  equals the frame written. They compare and hash by content (a SHA-256 digest of the data).

Gray levels are linear input gray levels, before gamma pre-compensation: rendering applies the
pre-compensation (thesis Eq. 2.17) and rounds to the projector's bit depth, for every kind.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import full_scale
from hdrfringe.core.graycode import CODES, MAX_BITS, bits_needed, code_bit
from hdrfringe.core.patterns import (
    ORIENTATIONS,
    FringeFrame,
    FringeSpec,
    Orientation,
    _LineFrameMethods,
    _num,
    fringe_gray,
    precompensate_gamma,
)
from hdrfringe.errors import CaptureFormatError, InputError

__all__ = [
    "IMAGE_FRAMES",
    "LINE_FRAMES",
    "CenterlineFrame",
    "Frame",
    "FringeFrame",
    "GrayCodeFrame",
    "ImageFrame",
    "LineFrame",
    "PixelwiseFringeFrame",
    "UniformFrame",
    "as_image_frame",
    "frame_axis",
    "frame_from_manifest",
    "opencv_graycode_frames",
    "render_frame",
    "sample_bilinear",
]


@dataclass(frozen=True)
class CenterlineFrame(_LineFrameMethods):
    """A single bright line at projector coordinate ``position`` on a dark image (Sec. 2.5).

    The line is ``width_px`` projector pixels wide at gray level ``migl``; the rest is at gray
    level ``background``.

    Parameters
    ----------
    position : float
        Projector column (vertical line) or row (horizontal line) of the line's centre.
    orientation : {"vertical", "horizontal"}
    migl : float
        Gray level of the line.
    width_px : int
        Width of the line in projector pixels.
    background : float
        Gray level elsewhere.

    References
    ----------
    Thesis Sec. 2.5 (centerline image for absolute phase).

    Examples
    --------
    >>> CenterlineFrame(3.0, migl=255.0).gray([2.0, 3.0, 4.0]).tolist()
    [0.0, 255.0, 0.0]
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

    def _axis(self) -> Orientation:
        return self.orientation

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at projector coordinates across the line (pixel-exact box).

        Parameters
        ----------
        coord : array_like
            Projector coordinate across the line.

        Returns
        -------
        ndarray of float64
        """
        x = np.asarray(coord, dtype=np.float64)
        half = self.width_px / 2.0
        inside = np.abs(x - self.position) < half
        return np.where(inside, float(self.migl), float(self.background))

    def manifest_entry(self, file: str) -> dict[str, Any]:
        """The frame's capture-manifest entry (docs/capture_format.md).

        Parameters
        ----------
        file : str
            Image file name the entry refers to.

        Returns
        -------
        dict
        """
        return {
            "file": file,
            "kind": "centerline",
            "orientation": self.orientation,
            "position": _num(self.position),
            "migl": _num(self.migl),
        }

    def default_name(self) -> str:
        """A file-name-safe stem, e.g. ``centerline_v_512_g255``.

        Returns
        -------
        str
        """
        return f"centerline_{self.orientation[0]}_{self.position:g}_g{self.migl:g}".replace(
            ".", "p"
        )


@dataclass(frozen=True)
class UniformFrame(_LineFrameMethods):
    """The whole projector at input gray ``level``.

    Parameters
    ----------
    level : float
        Linear input gray level.

    References
    ----------
    Thesis Eq. 2.1 and 3.8-3.9 (a = (migl + imin)/2, b = (migl - imin)/2, here per pixel).

    Examples
    --------
    >>> UniformFrame(128.0).render(4, 2).tolist()
    [[128, 128, 128, 128], [128, 128, 128, 128]]
    """

    level: float

    kind: str = field(default="uniform", init=False)

    def _axis(self) -> Orientation:
        return "vertical"

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:
        """The level at every projector coordinate.

        Parameters
        ----------
        coord : array_like
            Projector coordinates (any axis).

        Returns
        -------
        ndarray of float64
        """
        return np.full(np.shape(coord), float(self.level))

    def manifest_entry(self, file: str) -> dict[str, Any]:
        """The frame's capture-manifest entry (docs/capture_format.md).

        Parameters
        ----------
        file : str
            Image file name the entry refers to.

        Returns
        -------
        dict
        """
        return {"file": file, "kind": "uniform", "level": _num(self.level)}

    def default_name(self) -> str:
        """A file-name-safe stem, e.g. ``gray_128``.

        Returns
        -------
        str
        """
        return f"gray_{self.level:g}".replace(".", "p")


@dataclass(frozen=True, eq=False, repr=False)
class PixelwiseFringeFrame:
    """Shift ``shift`` of the fringe set ``spec`` with a MIGL per projector pixel.

    The gray level of projector pixel (row ``y``, column ``x``) follows the pattern convention of
    docs/capture_format.md with the pixel's own maximum input gray level ``m = migl_map[y, x]``::

        g = imin + (max(m, imin) - imin) * (1 + P((x + i*p/N) / p)) / 2

    (``y`` instead of ``x`` in ``P`` for horizontal fringes), so pixels whose ``m <= imin`` show
    ``imin``. The spec's ``migl`` is the set's nominal MIGL: recorded in the manifest, not used
    for rendering. On the continuous projector model the map is interpolated bilinearly
    (:func:`sample_bilinear`) and the fringe evaluated analytically.

    Parameters
    ----------
    spec : FringeSpec
        Pattern, steps, pitch, orientation and imin of the set.
    shift : int
        Shift index i in 0..N-1.
    migl_map : array_like, shape (projector height, projector width)
        Maximum input gray level per projector pixel, finite and >= 0; held as read-only
        float32. Checked against the projector's size and bit depth when rendered.

    Examples
    --------
    >>> spec = FringeSpec(steps=4, pitch_px=4.0, imin=0.0, migl=255.0)
    >>> m = np.full((2, 4), 200.0)
    >>> m[:, 2:] = 100.0
    >>> PixelwiseFringeFrame(spec, 0, m).render(4, 2)[0].tolist()
    [200, 100, 0, 50]
    """

    spec: FringeSpec
    shift: int
    migl_map: NDArray[np.float32]

    kind: str = field(default="pixelwise_fringe", init=False)
    content_sha256: str = field(default="", init=False)

    #: Manifest field naming the side file that holds the map.
    DATA_FIELD: ClassVar[str] = "migl_map"

    def __post_init__(self) -> None:
        if not isinstance(self.spec, FringeSpec):
            raise InputError(
                f"spec must be a hdrfringe.core.patterns.FringeSpec, got {type(self.spec).__name__}"
            )
        if isinstance(self.shift, bool) or int(self.shift) != self.shift:
            raise InputError(f"shift must be an integer, got {self.shift!r}")
        if not (0 <= self.shift < self.spec.steps):
            raise InputError(
                f"shift {self.shift} is outside 0..{self.spec.steps - 1} for a "
                f"{self.spec.steps}-step set"
            )
        if not self.spec.has_standard_phase:
            raise InputError(
                "a pixelwise fringe follows the contract's equal shifts without phase offset; "
                "leave shifts_deg and phase_offset_deg out of its spec"
            )
        data = _as_projector_array(self.migl_map, "migl_map")
        object.__setattr__(self, "shift", int(self.shift))
        object.__setattr__(self, "migl_map", data)
        object.__setattr__(self, "content_sha256", _digest(data))

    @property
    def data(self) -> NDArray[np.float32]:
        """The frame's 2-D data (the MIGL map), as stored in its side file."""
        return self.migl_map

    def key(self) -> tuple[Any, ...]:
        """Identity used for equality and hashing: kind, spec, shift and the map's digest.

        Returns
        -------
        tuple
        """
        return (self.kind, self.spec, self.shift, self.content_sha256)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, PixelwiseFringeFrame):
            return NotImplemented
        return self.key() == other.key()

    def __hash__(self) -> int:
        return hash(self.key())

    def __repr__(self) -> str:
        h, w = self.migl_map.shape
        return (
            f"PixelwiseFringeFrame(spec={self.spec!r}, shift={self.shift}, "
            f"migl_map=<{h}x{w} float32 sha256:{self.content_sha256[:12]}>)"
        )

    def _effective_migl(self, m: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.maximum(m, float(self.spec.imin))

    def _gray(self, m: NDArray[np.float64], coord: NDArray[np.float64]) -> NDArray[np.float64]:
        """The pattern convention (Eq. 2.1, ``fringe_gray``) with the MIGL map as the MIGL."""
        return fringe_gray(coord, self.spec, self.shift, migl=self._effective_migl(m))

    def check_projector(self, width: int, height: int, bit_depth: int) -> None:
        """Refuse a projector the map does not fit: size (height, width), values <= 2^Bp - 1.

        Parameters
        ----------
        width, height : int
            Projector resolution.
        bit_depth : int
            Projector input bit depth Bp.
        """
        _check_fits(self.migl_map, "migl_map", width, height, bit_depth)
        full = full_scale(bit_depth, "projector bit depth")
        if self.spec.imin > full:
            raise InputError(
                f"imin {self.spec.imin:g} exceeds the projector's maximum {full} at "
                f"{bit_depth} bits"
            )

    def gray_at(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at continuous projector coordinates (column ``u``, row ``v``).

        The map is interpolated bilinearly between pixel centres (:func:`sample_bilinear`), the
        fringe evaluated analytically along its axis.

        Parameters
        ----------
        u, v : array_like
            Projector column and row, broadcast together.

        Returns
        -------
        ndarray of float64
        """
        u, v = np.broadcast_arrays(np.asarray(u, np.float64), np.asarray(v, np.float64))
        m = sample_bilinear(self.migl_map, u, v)
        coord = u if self.spec.orientation == "vertical" else v
        return self._gray(m, coord)

    def render(
        self, width: int, height: int, gamma_hat: float = 1.0, bit_depth: int = 8
    ) -> NDArray[np.integer]:
        """Projector input image, shape (height, width); see :func:`render_frame`.

        Parameters
        ----------
        width, height : int
            Projector resolution; must equal the map's shape.
        gamma_hat : float
            Gamma pre-compensation exponent (1.0: none).
        bit_depth : int
            Projector input bit depth; the map may not exceed ``2^Bp - 1``.

        Returns
        -------
        ndarray of uint8 or uint16
        """
        self.check_projector(width, height, bit_depth)
        m = self.migl_map.astype(np.float64)
        if self.spec.orientation == "vertical":
            coord = np.arange(width, dtype=np.float64)[None, :]
        else:
            coord = np.arange(height, dtype=np.float64)[:, None]
        return precompensate_gamma(self._gray(m, coord), gamma_hat, bit_depth)

    def manifest_entry(self, file: str, data_file: str | None = None) -> dict[str, Any]:
        """The frame's capture-manifest entry (docs/capture_format.md, version 2).

        Parameters
        ----------
        file : str
            Camera image file name the entry refers to.
        data_file : str, optional
            Side file holding the MIGL map (float32 TIFF); default :meth:`default_data_file`.

        Returns
        -------
        dict
        """
        s = self.spec
        return {
            "file": file,
            "kind": "pixelwise_fringe",
            "pattern": s.pattern,
            "steps": int(s.steps),
            "shift": int(self.shift),
            "pitch": float(s.pitch_px),
            "orientation": s.orientation,
            "imin": _num(s.imin),
            "migl": _num(s.migl),
            "migl_map": data_file if data_file is not None else self.default_data_file(),
            "content_sha256": self.content_sha256,
        }

    def default_data_file(self) -> str:
        """Default side-file path for the map, named by its digest (shared by equal maps).

        Returns
        -------
        str
        """
        return f"projector/migl_{self.content_sha256[:16]}.tiff"

    def default_name(self) -> str:
        """A file-name-safe stem, e.g. ``s3_p6_v_i40_g255_map1a2b3c4d_0``.

        Returns
        -------
        str
        """
        return f"{self.spec.label()}_map{self.content_sha256[:8]}_{self.shift}"


@dataclass(frozen=True, eq=False, repr=False)
class ImageFrame:
    """Any projector image: Gray code, markers, a photo.

    Parameters
    ----------
    image : array_like, shape (projector height, projector width)
        Linear input gray levels (before gamma pre-compensation, like every frame), finite and
        >= 0; held as read-only float32. Checked against the projector's size and bit depth when
        rendered. On the continuous projector model it is interpolated bilinearly
        (:func:`sample_bilinear`).
    name : str
        A label (part of the frame's identity and of its file names).

    References
    ----------
    Thesis Eq. 2.17 (gamma pre-compensation).

    Examples
    --------
    >>> frame = ImageFrame(np.array([[0, 255], [255, 0]]), "checker")
    >>> frame.render(2, 2).tolist()
    [[0, 255], [255, 0]]
    >>> frame == ImageFrame(np.array([[0.0, 255.0], [255.0, 0.0]]), "checker")
    True
    """

    image: NDArray[np.float32]
    name: str = "image"

    kind: str = field(default="image", init=False)
    content_sha256: str = field(default="", init=False)

    #: Manifest field naming the side file that holds the image.
    DATA_FIELD: ClassVar[str] = "image"

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise InputError(f"an image frame needs a non-empty name, got {self.name!r}")
        data = _as_projector_array(self.image, "image")
        object.__setattr__(self, "image", data)
        object.__setattr__(self, "content_sha256", _digest(data))

    @property
    def data(self) -> NDArray[np.float32]:
        """The frame's 2-D data (the image), as stored in its side file."""
        return self.image

    def key(self) -> tuple[Any, ...]:
        """Identity used for equality and hashing: kind, name and the image's digest.

        Returns
        -------
        tuple
        """
        return (self.kind, self.name, self.content_sha256)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ImageFrame):
            return NotImplemented
        return self.key() == other.key()

    def __hash__(self) -> int:
        return hash(self.key())

    def __repr__(self) -> str:
        h, w = self.image.shape
        return (
            f"ImageFrame(image=<{h}x{w} float32 sha256:{self.content_sha256[:12]}>, "
            f"name={self.name!r})"
        )

    def check_projector(self, width: int, height: int, bit_depth: int) -> None:
        """Refuse a projector the image does not fit: size (height, width), values <= 2^Bp - 1.

        Parameters
        ----------
        width, height : int
            Projector resolution.
        bit_depth : int
            Projector input bit depth Bp.
        """
        _check_fits(self.image, "image", width, height, bit_depth)

    def gray_at(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at continuous projector coordinates, bilinear between pixel centres.

        Parameters
        ----------
        u, v : array_like
            Projector column and row, broadcast together.

        Returns
        -------
        ndarray of float64
        """
        return sample_bilinear(self.image, u, v)

    def render(
        self, width: int, height: int, gamma_hat: float = 1.0, bit_depth: int = 8
    ) -> NDArray[np.integer]:
        """Projector input image, shape (height, width); see :func:`render_frame`.

        Parameters
        ----------
        width, height : int
            Projector resolution; must equal the image's shape.
        gamma_hat : float
            Gamma pre-compensation exponent (1.0: none).
        bit_depth : int
            Projector input bit depth; the image may not exceed ``2^Bp - 1``.

        Returns
        -------
        ndarray of uint8 or uint16
        """
        self.check_projector(width, height, bit_depth)
        return precompensate_gamma(self.image, gamma_hat, bit_depth)

    def manifest_entry(self, file: str, data_file: str | None = None) -> dict[str, Any]:
        """The frame's capture-manifest entry (docs/capture_format.md, version 2).

        Parameters
        ----------
        file : str
            Camera image file name the entry refers to.
        data_file : str, optional
            Side file holding the projector image; default :meth:`default_data_file`.

        Returns
        -------
        dict
        """
        return {
            "file": file,
            "kind": "image",
            "name": self.name,
            "image": data_file if data_file is not None else self.default_data_file(),
            "content_sha256": self.content_sha256,
        }

    def default_data_file(self) -> str:
        """Default side-file path for the image, named by its digest.

        A PNG when every level is a whole number <= 65535, else a float32 TIFF.

        Returns
        -------
        str
        """
        whole = bool(np.all(self.image == np.round(self.image))) and self.image.max() <= 65535
        suffix = "png" if whole else "tiff"
        return f"projector/image_{self.content_sha256[:16]}.{suffix}"

    def default_name(self) -> str:
        """A file-name-safe stem from the name, e.g. ``image_gray_code_3``.

        Returns
        -------
        str
        """
        safe = "".join(c if c.isalnum() or c in "-_" else "_" for c in self.name)
        return f"image_{safe}"


def as_image_frame(frame: Frame, width: int, height: int) -> ImageFrame:
    """The projector image a frame shows, as an :class:`ImageFrame` named after the frame.

    Its image is the frame's linear gray level at every projector pixel centre
    (:meth:`gray_at`), held as float32 like every image frame; it renders to the frame's own
    projector input image (up to a rounding tie of that float32 precision). A live run's record
    stores a fringe frame that belongs to no complete set so (docs/capture_format.md,
    "Fringe frames outside a set"), and :class:`~hdrfringe.rig.replay.ReplayRig` finds it again
    by its content.

    Parameters
    ----------
    frame : Frame
        Any frame.
    width, height : int
        Projector resolution in pixels.

    Returns
    -------
    ImageFrame
        Named ``frame.default_name()`` (an image frame keeps its own).

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> frame = FringeSpec(steps=4, pitch_px=4.0, imin=0.0, migl=200.0).frames()[1]
    >>> image = as_image_frame(frame, 4, 2)
    >>> image.name, image.image.tolist()
    ('s4_p4_v_i0_g200_1', [[100.0, 0.0, 100.0, 200.0], [100.0, 0.0, 100.0, 200.0]])
    >>> bool((image.render(4, 2) == frame.render(4, 2)).all())
    True
    """
    if isinstance(frame, ImageFrame):
        return frame
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    return ImageFrame(frame.gray_at(u, v).astype(np.float32), frame.default_name())


def frame_axis(frame: Frame) -> Orientation:
    """Orientation of a line frame's varying axis ("vertical" for a uniform frame).

    Parameters
    ----------
    frame : FringeFrame, CenterlineFrame or UniformFrame
        A line frame.

    Returns
    -------
    {"vertical", "horizontal"}
        "vertical": the frame varies along projector columns.

    Raises
    ------
    InputError
        For a frame that varies along both axes (:class:`PixelwiseFringeFrame`,
        :class:`ImageFrame`).

    Examples
    --------
    >>> frame_axis(CenterlineFrame(10.0, "horizontal"))
    'horizontal'
    """
    if isinstance(frame, _LineFrameMethods):
        return frame._axis()
    raise InputError(
        f"a {type(frame).__name__} varies along both projector axes; it has no single axis "
        "(use its render or gray_at)"
    )


def render_frame(
    frame: Frame,
    width: int = 1024,
    height: int = 768,
    gamma_hat: float = 1.0,
    bit_depth: int = 8,
) -> NDArray[np.integer]:
    """Projector input image of one frame (what is written to PNG and played).

    The linear gray levels of the frame are gamma-pre-compensated and rounded to the projector's
    integer levels (:func:`hdrfringe.core.patterns.precompensate_gamma`). Line frames render one
    line
    and broadcast it.

    Parameters
    ----------
    frame : Frame
        Any frame.
    width, height : int
        Projector resolution in pixels.
    gamma_hat : float
        Gamma pre-compensation exponent (1.0: none). Every kind is pre-compensated, so that every
        frame maps linearly to projected light.
    bit_depth : int
        Projector input bit depth.

    Returns
    -------
    ndarray, shape (height, width), uint8 or uint16

    Examples
    --------
    >>> render_frame(CenterlineFrame(1.0), width=4, height=1).tolist()
    [[0, 255, 0, 0]]
    """
    if width < 1 or height < 1:
        raise InputError(f"projector resolution must be positive, got {width}x{height}")
    return frame.render(width, height, gamma_hat, bit_depth)


def sample_bilinear(image: ArrayLike, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
    """Bilinear interpolation of ``image`` at column ``u``, row ``v`` (pixel centres at integers).

    Coordinates are clamped to the pixel centres of the border (constant extension). Written as
    nested linear interpolations ``a + f (b - a)``, so a constant image gives exactly its value
    (a weighted sum ``(1 - f) a + f a`` may be off by one unit in the last place), which keeps a
    constant MIGL map bit-identical to the line frame at that MIGL.

    Parameters
    ----------
    image : array_like, shape (H, W)
        Values at the pixel centres.
    u, v : array_like
        Column and row coordinates, broadcast together.

    Returns
    -------
    ndarray of float64, the broadcast shape of ``u`` and ``v``

    Examples
    --------
    >>> sample_bilinear([[0.0, 10.0], [20.0, 30.0]], [0.5, 5.0], [0.5, 0.0]).tolist()
    [15.0, 10.0]
    """
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 2 or min(img.shape) < 1:
        raise InputError(f"sample_bilinear needs a 2-D image, got shape {img.shape}")
    h, w = img.shape
    uu, vv = np.broadcast_arrays(np.asarray(u, np.float64), np.asarray(v, np.float64))
    x = np.clip(uu, 0.0, w - 1.0)
    y = np.clip(vv, 0.0, h - 1.0)
    x0 = np.clip(np.floor(x), 0, max(w - 2, 0)).astype(np.intp)
    y0 = np.clip(np.floor(y), 0, max(h - 2, 0)).astype(np.intp)
    x1 = np.minimum(x0 + 1, w - 1)
    y1 = np.minimum(y0 + 1, h - 1)
    fx = x - x0
    fy = y - y0
    top = img[y0, x0] + fx * (img[y0, x1] - img[y0, x0])
    bottom = img[y1, x0] + fx * (img[y1, x1] - img[y1, x0])
    return top + fy * (bottom - top)


def frame_from_manifest(
    entry: dict[str, Any],
    load_array: Callable[[str], NDArray[Any]] | None = None,
    *,
    shifts_deg: tuple[float, ...] | None = None,
) -> Frame:
    """Build a frame from a (validated) manifest entry of the capture-folder contract.

    Parameters
    ----------
    entry : dict
        One element of a manifest's ``frames`` list.
    load_array : callable, optional
        ``load_array(path)`` returns the 2-D array stored in the side file ``path`` (relative to
        the folder, as written in the entry). Needed for the version-2 kinds
        ``pixelwise_fringe`` and ``image`` only; the I/O layer passes its file reader.
    shifts_deg : tuple of float, optional
        For a ``fringe`` entry with ``shift_deg`` (version 3): the shift angles of its whole
        set, by shift index (one entry gives only its own angle; the folder reader,
        :meth:`hdrfringe.core.captures.Captures.from_manifest`, collects them per set). It must
        agree with the entry's ``shift_deg``. (The version-3 kind ``graycode`` is a
        :class:`GrayCodeFrame`.)

    Returns
    -------
    Frame

    Raises
    ------
    InputError
        Unknown kind, a version-2 kind without ``load_array``, or a ``shift_deg`` entry without
        (or disagreeing with) ``shifts_deg``.
    CaptureFormatError
        The side file does not hold the data the entry's ``content_sha256`` names.

    Examples
    --------
    >>> frame_from_manifest({"file": "g.png", "kind": "uniform", "level": 128})
    UniformFrame(level=128.0, kind='uniform')
    >>> entry = {"file": "a.png", "kind": "fringe", "pattern": "sinusoidal", "steps": 3,
    ...          "shift": 0, "pitch": 8.0, "orientation": "vertical", "imin": 0, "migl": 255,
    ...          "shift_deg": -120, "phase_offset_deg": -90}
    >>> frame_from_manifest(entry, shifts_deg=(-120, 0, 120)).spec.label()
    's3_p8_v_i0_g255_o-90_d-120_0_120'
    """
    kind = entry["kind"]
    if kind == "fringe":
        shift = int(entry["shift"])
        spec = _spec_from_entry(entry)
        if "shift_deg" in entry:
            if shifts_deg is None or len(shifts_deg) != spec.steps:
                raise InputError(
                    f"the entry gives shift_deg {entry['shift_deg']} but not its set's angles; "
                    "pass shifts_deg (the folder reader collects them per set)"
                )
            if float(shifts_deg[shift]) != float(entry["shift_deg"]):
                raise InputError(
                    f"the entry gives shift_deg {entry['shift_deg']} for shift {shift} but its "
                    f"set's angles give {shifts_deg[shift]}; make them agree"
                )
            spec = replace(spec, shifts_deg=tuple(shifts_deg))
        return FringeFrame(spec, shift)
    if kind == "centerline":
        return CenterlineFrame(
            position=float(entry["position"]),
            orientation=entry["orientation"],
            migl=float(entry["migl"]),
        )
    if kind == "uniform":
        return UniformFrame(float(entry["level"]))
    if kind == "graycode":
        return GrayCodeFrame.from_manifest(entry)
    if kind in ("pixelwise_fringe", "image"):
        data_field = "migl_map" if kind == "pixelwise_fringe" else "image"
        path = entry[data_field]
        if load_array is None:
            raise InputError(
                f"a {kind} frame keeps its data in the side file {path!r}; pass load_array "
                "(the capture-folder reader does)"
            )
        data = load_array(path)
        frame: Frame
        if kind == "pixelwise_fringe":
            frame = PixelwiseFringeFrame(_spec_from_entry(entry), int(entry["shift"]), data)
        else:
            frame = ImageFrame(data, str(entry["name"]))
        expected = entry.get("content_sha256")
        if expected is not None and expected != frame.content_sha256:
            raise CaptureFormatError(
                f"{path}: content differs from the manifest's content_sha256 (the side file was "
                "changed or not stored as float32 or integer levels); rewrite the folder"
            )
        return frame
    raise InputError(
        f"unknown frame kind {kind!r}; use fringe, centerline, uniform, pixelwise_fringe, image "
        "or graycode"
    )


def _spec_from_entry(entry: dict[str, Any]) -> FringeSpec:
    # version 3 fringe entries may leave out both gray levels: the defaults imin 0 and migl
    # 255 (Captures.from_manifest sets migl to the projector's 2^Bp - 1), marked as not given
    given = "imin" in entry or "migl" in entry
    return FringeSpec(
        pattern=entry["pattern"],
        steps=int(entry["steps"]),
        pitch_px=float(entry["pitch"]),
        orientation=entry["orientation"],
        imin=float(entry.get("imin", 0.0)),
        migl=float(entry.get("migl", 255.0)),
        phase_offset_deg=float(entry.get("phase_offset_deg", 0.0)),
        gray_levels_given=given,
    )


def _as_projector_array(data: ArrayLike, what: str) -> NDArray[np.float32]:
    """A read-only float32 copy of a 2-D array of non-negative finite gray levels."""
    a = np.asarray(data)
    if a.dtype == np.bool_ or not (
        np.issubdtype(a.dtype, np.integer) or np.issubdtype(a.dtype, np.floating)
    ):
        raise InputError(
            f"{what} must hold real gray levels (integer or float), got dtype {a.dtype}; "
            "for a binary image multiply by the projector's full scale"
        )
    if a.ndim != 2 or min(a.shape) < 1:
        raise InputError(
            f"{what} must be a 2-D array (projector rows, columns), got shape {a.shape}"
        )
    out = a.astype(np.float32)  # always a copy: the caller's array may change later
    if not np.isfinite(out).all():
        raise InputError(f"{what} has non-finite values (or values beyond float32); fix them")
    if (out < 0).any():
        raise InputError(f"{what} has negative gray levels (min {out.min():g}); clip them at 0")
    out.setflags(write=False)
    return out


def _check_fits(data: NDArray[np.float32], what: str, width: int, height: int, bits: int) -> None:
    full = full_scale(bits, "projector bit depth")
    if data.shape != (height, width):
        raise InputError(
            f"{what} is {data.shape[1]}x{data.shape[0]} but the projector is {width}x{height}; "
            "give one value per projector pixel"
        )
    peak = float(data.max())
    if peak > full:
        raise InputError(
            f"{what} reaches {peak:g}, above the projector's maximum {full} at {bits} bits; "
            "lower it or raise the projector bit depth"
        )


def _digest(data: NDArray[np.float32]) -> str:
    """SHA-256 of the shape and the values as little-endian float32, row-major."""
    h = hashlib.sha256(f"{data.shape[0]}x{data.shape[1]}|".encode())
    h.update(np.ascontiguousarray(data, dtype="<f4").tobytes())
    return h.hexdigest()


@dataclass(frozen=True)
class GrayCodeFrame(_LineFrameMethods):
    """Bit ``bit`` of a ``bits``-bit stripe code (Gray or binary), or its inverse (a line frame).

    Projector pixel ``x`` (column for vertical stripes, row for horizontal) lies in stripe
    ``m = floor(x / stripe_px)``; the frame is at ``migl`` where bit ``bit`` of the code word of
    ``m`` (:func:`hdrfringe.core.graycode.binary_to_gray` of ``m`` for ``code="gray"``, ``m`` for
    ``"binary"``) is 1, and 0 elsewhere; the inverse frame the other way round. Conventions:
    docs/graycode.md.

    Parameters
    ----------
    orientation : {"vertical", "horizontal"}
        ``"vertical"``: stripes vary along projector x (OpenCV's column images).
    bit : int
        Bit significance, 0 = least significant (stripes of ``stripe_px``).
    bits : int
        Number of bits of the code (1..24).
    stripe_px : float
        The code's cell width in projector pixels (the least significant stripe width).
    inverse : bool
        The inverse pattern (lit where the bit is 0).
    code : {"gray", "binary"}
        Binary-reflected Gray code or plain binary.
    migl : float
        Gray level of the lit stripes (dark stripes are 0).
    convention : str, optional
        A label of the program that made the code (e.g. ``"opencv"``); recorded, not used.

    References
    ----------
    Thesis Sec. 2.5 (absolute phase); Sansoni et al. (1999) Appl. Opt. 38, 6565.

    Examples
    --------
    >>> GrayCodeFrame("vertical", 0, 3, 2.0).render(8, 1).tolist()
    [[0, 0, 255, 255, 255, 255, 0, 0]]
    >>> GrayCodeFrame("vertical", 0, 3, 2.0, inverse=True).gray([0.0, 2.0]).tolist()
    [255.0, 0.0]
    """

    orientation: Orientation
    bit: int
    bits: int
    stripe_px: float
    inverse: bool = False
    code: str = "gray"
    migl: float = 255.0
    convention: str | None = None

    kind: str = field(default="graycode", init=False)

    def __post_init__(self) -> None:
        if self.orientation not in ORIENTATIONS:
            raise InputError(
                f"unknown orientation {self.orientation!r}; use one of {', '.join(ORIENTATIONS)}"
            )
        for name in ("bit", "bits"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | np.integer):
                raise InputError(f"Gray-code {name} must be an integer, got {v!r}")
        if not 1 <= self.bits <= MAX_BITS:
            raise InputError(f"Gray-code bits must be 1..{MAX_BITS}, got {self.bits}")
        if not 0 <= self.bit < self.bits:
            raise InputError(f"Gray-code bit {self.bit} is outside 0..{self.bits - 1}")
        s = float(self.stripe_px)
        if not (np.isfinite(s) and s > 0):
            raise InputError(f"Gray-code stripe must be a positive width, got {self.stripe_px!r}")
        if self.code not in CODES:
            raise InputError(f"unknown code {self.code!r}; use one of {', '.join(CODES)}")
        if not (np.isfinite(self.migl) and self.migl > 0):
            raise InputError(f"Gray-code migl must be a positive gray level, got {self.migl!r}")
        if self.convention is not None and not isinstance(self.convention, str):
            raise InputError(f"convention must be a string label, got {self.convention!r}")
        object.__setattr__(self, "bit", int(self.bit))
        object.__setattr__(self, "bits", int(self.bits))
        object.__setattr__(self, "stripe_px", s)
        object.__setattr__(self, "inverse", bool(self.inverse))
        object.__setattr__(self, "migl", float(self.migl))

    def _axis(self) -> Orientation:
        return self.orientation

    def gray(self, coord: ArrayLike) -> NDArray[np.float64]:
        """Linear gray level at projector coordinates across the stripes.

        Parameters
        ----------
        coord : array_like
            Projector column (vertical stripes) or row; pixel centres at integers.

        Returns
        -------
        ndarray of float64
        """
        lit = code_bit(coord, self.bit, self.stripe_px, self.code) != self.inverse
        return np.where(lit, self.migl, 0.0)

    def _check_levels(self, bit_depth: int) -> None:
        full = full_scale(bit_depth, "projector bit depth")
        if self.migl > full:
            raise InputError(
                f"Gray-code migl {self.migl:g} exceeds the projector's maximum {full} at "
                f"{bit_depth} bits"
            )

    def set_key(self) -> tuple[Any, ...]:
        """What the frames of one code share: orientation, bits, stripe, code, migl, convention.

        Returns
        -------
        tuple
        """
        return (self.orientation, self.bits, self.stripe_px, self.code, self.migl, self.convention)

    def manifest_entry(self, file: str) -> dict[str, Any]:
        """The frame's capture-manifest entry (docs/capture_format.md, version 3).

        Parameters
        ----------
        file : str
            Image file name the entry refers to.

        Returns
        -------
        dict
        """
        entry: dict[str, Any] = {
            "file": file,
            "kind": "graycode",
            "orientation": self.orientation,
            "bit": self.bit,
            "bits": self.bits,
            "stripe": _num(self.stripe_px),
            "inverse": self.inverse,
            "code": self.code,
            "migl": _num(self.migl),
        }
        if self.convention is not None:
            entry["convention"] = self.convention
        return entry

    @classmethod
    def from_manifest(cls, entry: dict[str, Any]) -> GrayCodeFrame:
        """From a (validated) ``graycode`` manifest entry; absent optional fields take defaults.

        Parameters
        ----------
        entry : dict
            ``orientation``, ``bit``, ``bits``, ``stripe``; optional ``inverse`` (false),
            ``code`` ("gray"), ``migl`` (255), ``convention``.

        Returns
        -------
        GrayCodeFrame

        Examples
        --------
        >>> GrayCodeFrame.from_manifest({"kind": "graycode", "orientation": "horizontal",
        ...     "bit": 2, "bits": 4, "stripe": 114}).stripe_px
        114.0
        """
        return cls(
            orientation=entry["orientation"],
            bit=int(entry["bit"]),
            bits=int(entry["bits"]),
            stripe_px=float(entry["stripe"]),
            inverse=bool(entry.get("inverse", False)),
            code=str(entry.get("code", "gray")),
            migl=float(entry.get("migl", 255.0)),
            convention=entry.get("convention"),
        )

    def default_name(self) -> str:
        """A file-name-safe stem, e.g. ``gc_v_s100_b4of5_inv``.

        Returns
        -------
        str
        """
        name = f"gc_{self.orientation[0]}_s{self.stripe_px:g}_b{self.bit}of{self.bits}"
        if self.code != "gray":
            name += f"_{self.code}"
        return (name + ("_inv" if self.inverse else "")).replace(".", "p")


def opencv_graycode_frames(
    width: int, height: int, stripe_px: float = 1.0, migl: float = 255.0
) -> list[GrayCodeFrame]:
    """The frames OpenCV's ``structured_light::GrayCodePattern`` projects, in its order.

    OpenCV's pattern for ``ceil(width / stripe_px) x ceil(height / stripe_px)`` code cells,
    each cell scaled up to ``stripe_px`` projector pixels: the column (vertical-stripe) bits,
    then the row bits, most significant first, each as (pattern, inverse), the pattern lit
    where the binary-reflected Gray bit is 1. White and black images, which OpenCV makes
    separately (``getImagesForShadowMasks``), are ``UniformFrame(migl)`` and ``UniformFrame(0)``.

    Parameters
    ----------
    width, height : int
        Projector resolution.
    stripe_px : float
        Projector pixels per code cell (1: OpenCV at the projector's resolution).
    migl : float
        Gray level of the lit stripes.

    Returns
    -------
    list of GrayCodeFrame

    Examples
    --------
    kamino410/phase-shifting's object1 (1920x1080, 100 px cells): 5 column and 4 row bits.

    >>> frames = opencv_graycode_frames(1920, 1080, 100.0)
    >>> len(frames), frames[0].bit, frames[1].inverse, frames[10].orientation
    (18, 4, True, 'horizontal')
    """
    out: list[GrayCodeFrame] = []
    for orient, extent in (("vertical", width), ("horizontal", height)):
        n = bits_needed(extent, stripe_px)
        for bit in range(n - 1, -1, -1):
            for inverse in (False, True):
                out.append(
                    GrayCodeFrame(
                        orient,  # type: ignore[arg-type]
                        bit,
                        n,
                        stripe_px,
                        inverse=inverse,
                        migl=migl,
                        convention="opencv",
                    )
                )
    return out


#: A frame that varies along one projector axis (separable fast path).
LineFrame = FringeFrame | CenterlineFrame | UniformFrame | GrayCodeFrame
#: Any frame the projector can show.
Frame = (
    FringeFrame | CenterlineFrame | UniformFrame | PixelwiseFringeFrame | ImageFrame | GrayCodeFrame
)
#: The line-frame classes, for ``isinstance``.
LINE_FRAMES = (FringeFrame, CenterlineFrame, UniformFrame, GrayCodeFrame)
#: The classes of frames with 2-D data stored in a side file, for ``isinstance``.
IMAGE_FRAMES = (PixelwiseFringeFrame, ImageFrame)
