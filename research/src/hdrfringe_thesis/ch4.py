"""The measurements of thesis Ch. 4 on the virtual rig, fast enough for the full sweep.

Sec. 4.1: a flat white plate at 25 positions (2 to 50 mm by 2), 17 pitches (4 to 20 px),
31 MIGLs (105 to 255 by 5), three patterns (sinusoidal 3-step, triangular 3- and 2-step),
with 0 and 600 lx of added ambient light; one linear calibration (Eq. 2.15, median and mean
filter of 21 px) per pattern and pitch from the same 25 positions at MIGL 255 in the dark;
RMSE against the true depth over every pixel but a 10 px border, saturated pixels included.
Sec. 4.3 modifies the 0 lx captures at a pitch of 6 px by Eq. 4.1 (added uniform light,
added Gaussian noise).

One **block** is one pattern and pitch: its calibration and every (lux, MIGL, depth)
measurement, so that the work shared by them is done once:

* per depth, the rig's response to each projector-pixel residue modulo the pitch
  (:meth:`~hdrfringe.rig.simulated.SimulatedRig.periodic_basis`) turns every frame of the MIGL
  sweep into one weighted sum (exact: the rig is linear from projected light to signal), and
  the lux levels differ only by the ambient signal;
* the noise (read and shot noise, :func:`~hdrfringe.rig.sensor.sensor_readout` as in
  :meth:`SimulatedRig.capture`) is computed in float32 (:data:`SWEEP_DTYPE`) from
  standard normal draws seeded by the pattern, pitch and depth (:func:`depth_normals`: common
  random numbers across MIGL and light), so any cell can be recomputed alone and gives the
  same numbers.

Fringe orders come from the known plate position (the micrometer reading): the phase error
that Ch. 4 studies is then measured without unwrapping failures mixed in (unwrapping is
validated on its own, docs/unwrapping.md). The added-light simulation of Sec. 4.3 (Table 4.1)
can instead, and by default does, run the thesis's own pipeline (:data:`UNWRAP_MODES`,
``"centerline"``): spatial unwrapping of the wrapped phase and a centerline captured with the
set through the same virtual camera and Eq. 4.1 (:func:`centerline_absolute`), so that
fringe-order failures under strong light are measured (``order_error_fraction``).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.calibration import Calibration, calibrate, measurement_mask
from hdrfringe.core.frames import CenterlineFrame, Frame
from hdrfringe.core.patterns import FringeSpec, PatternKind
from hdrfringe.core.phase import saturation_count, wrapped_phase
from hdrfringe.core.unwrap import (
    absolute_phase,
    centerline_phase,
    detect_centerline,
    unwrap_spatial,
)
from hdrfringe.errors import InputError
from hdrfringe.rig.modify import lux_to_dn, modify_intensity
from hdrfringe.rig.scenes import THESIS_CALIBRATION_DEPTHS_MM, Scene, white_plate
from hdrfringe.rig.sensor import sensor_readout
from hdrfringe.rig.simulated import (
    THESIS_GAMMA,
    CameraModel,
    Lighting,
    ProjectorModel,
    RigGeometry,
    SimulatedRig,
)

if TYPE_CHECKING:
    from hdrfringe_thesis.engine import SweepGrid

__all__ = [
    "ALL_PATTERNS",
    "PATTERNS",
    "QUICK_ADDED_LUX",
    "QUICK_DEPTHS_MM",
    "QUICK_MIGLS",
    "QUICK_NOISE_SIGMA",
    "QUICK_PITCHES",
    "QUICK_SETUP",
    "SATURATED_SHIFTS",
    "SIMULATION_PITCH",
    "SWEEP_DTYPE",
    "THESIS_ADDED_LUX",
    "THESIS_DEPTHS_MM",
    "THESIS_IMIN",
    "THESIS_LUX",
    "THESIS_MIGLS",
    "THESIS_NOISE_SIGMA",
    "THESIS_PITCHES",
    "TWO_PI",
    "UNWRAP_MODES",
    "WHITE_PLATE",
    "Ch4Setup",
    "PlateSweep",
    "calibrate_pattern",
    "cell_rng",
    "centerline_absolute",
    "centerline_unwrap",
    "ch4_block",
    "ch4_grid",
    "ch4_modified_block",
    "ch4_simulation_grid",
    "ch4_simulation_task",
    "ch4_task",
    "depth_normals",
    "order_error_fraction",
    "orders_from_expected",
    "pattern_spec",
    "sweep_phase",
]

TWO_PI = 2.0 * np.pi

#: The three patterns of Ch. 4: name -> (pattern, steps).
PATTERNS: dict[str, tuple[PatternKind, int]] = {
    "sinusoidal-3": ("sinusoidal", 3),
    "triangular-3": ("triangular", 3),
    "triangular-2": ("triangular", 2),
}
#: Every pattern a reproduction measures: Ch. 4's and the sinusoidal 4-step of Sec. 5.2.2 and
#: Ch. 6 (DPA needs the fourth shift to estimate a saturated one).
ALL_PATTERNS: dict[str, tuple[PatternKind, int]] = {**PATTERNS, "sinusoidal-4": ("sinusoidal", 4)}
#: Sec. 4.1 grid.
THESIS_PITCHES: tuple[int, ...] = tuple(range(4, 21))
THESIS_MIGLS: tuple[float, ...] = tuple(float(m) for m in range(255, 104, -5))
THESIS_DEPTHS_MM: tuple[float, ...] = tuple(THESIS_CALIBRATION_DEPTHS_MM)
THESIS_LUX: tuple[float, ...] = (0.0, 600.0)
#: Sec. 4.3: added light 100..900 lx (simulated by Eq. 4.1), noise sigma 1..8 at 600 lx.
THESIS_ADDED_LUX: tuple[float, ...] = tuple(float(x) for x in range(100, 1000, 100))
THESIS_NOISE_SIGMA: tuple[float, ...] = tuple(float(s) for s in range(1, 9))
THESIS_IMIN = 40.0
#: Precision of the sweeps' sensor noise, Eq. 4.1 modifications and sinusoidal phase (Eq. 2.2):
#: float32 halves the memory traffic, and its rounding (~1e-6 relative) is far below the noise.
SWEEP_DTYPE = np.float32
#: Saturated shift counts reported (Fig. 4.5: pixels saturated in one, two, three images).
SATURATED_SHIFTS: tuple[int, ...] = (1, 2, 3)
#: How a sweep gives the wrapped phase its fringe orders: ``"known"`` from the plate position
#: (:func:`orders_from_expected`), ``"centerline"`` as the thesis's pipeline (spatial
#: unwrapping and a captured centerline, :func:`centerline_absolute`). The first is the default
#: of every function; ``hdrfringe reproduce`` runs the added-light simulation (Table 4.1) with
#: the second unless told otherwise.
UNWRAP_MODES: tuple[str, ...] = ("known", "centerline")


@dataclass(frozen=True)
class Ch4Setup:
    """Rig and processing settings shared by every cell of a Ch. 4 sweep.

    Parameters
    ----------
    width, height : int
        Camera resolution (the thesis: 648 x 494).
    camera_field_mm : float
        Width of the camera's view on the reference plane. Halving it with the resolution keeps
        the sampling (camera pixels per fringe) and views the central part: the quick grid.
    seed : int
        Noise seed; each cell's noise also depends on its coordinates.
    imin : float
        Minimum input gray level (thesis Sec. 3.4.3: 40).
    window_px, border_px : int
        Calibration filter window and unfiltered border (Sec. 4.1: 21 and 10).
    camera : dict
        Further :class:`CameraModel` arguments (e.g. ``read_noise_dn8``).
    projector : dict
        :class:`ProjectorModel` arguments (e.g. its true ``gamma``, ``defocus_px``).
    gamma_precompensation : float
        The exponent the patterns are pre-compensated with (Eq. 2.17); a projector ``gamma``
        different from it leaves a residual nonlinearity.
    preset : str
        Name of the rig preset this setup was made from (``""``: the default rig; ``"thesis"``,
        ``"thesis-gamma"``, ...: :meth:`thesis_matched`). Part of a sweep's identity, shown in
        the report.

    References
    ----------
    Thesis Sec. 4.1 (the experiment), Sec. 3.4.3 (the rig).

    Examples
    --------
    >>> QUICK_SETUP.camera_model().bit_depth, (QUICK_SETUP.height, QUICK_SETUP.width)
    (8, (247, 324))
    >>> Ch4Setup(**QUICK_SETUP.to_dict()) == QUICK_SETUP
    True
    >>> thesis = Ch4Setup.thesis_matched(quick=True)
    >>> Ch4Setup(**thesis.to_dict()) == thesis, thesis.preset
    (True, 'thesis')
    """

    width: int = 648
    height: int = 494
    camera_field_mm: float = 320.0
    seed: int = 0
    imin: float = THESIS_IMIN
    window_px: int = 21
    border_px: int = 10
    camera: dict[str, Any] = field(default_factory=dict)
    projector: dict[str, Any] = field(default_factory=dict)
    gamma_precompensation: float = THESIS_GAMMA
    preset: str = ""

    @classmethod
    def thesis_matched(cls, quick: bool = False, seed: int = 0, preset: str = "thesis") -> Ch4Setup:
        """The ``thesis`` preset: noise, blur, vignetting and projector gamma mismatch fitted to
        thesis Table 4.3 (0 lx, MIGL 255, pitch 6) and the DSIE error of Sec. 6.1.2.

        Parameters
        ----------
        quick : bool
            The quick grid's quarter-size view (:data:`QUICK_SETUP`) instead of the full camera.
        seed : int
            Noise seed.
        preset : str
            The preset's name in :data:`hdrfringe_thesis.presets.PRESETS` (``"thesis-gamma"``: the
            projector's gamma matched, noise and blur fitted to Table 4.3 at 0 lx only).

        Returns
        -------
        Ch4Setup
            With the parameters of :data:`hdrfringe_thesis.presets.THESIS_PRESET` (or ``preset``).

        References
        ----------
        Thesis Table 4.3, Sec. 6.1.2; docs/virtual_rig.md ("Thesis-matched preset").

        Examples
        --------
        >>> Ch4Setup.thesis_matched().camera_model().read_noise_dn8 > 1.0
        True
        """
        from hdrfringe_thesis.presets import PRESETS, natural_vignetting

        if preset not in PRESETS:
            raise InputError(f"unknown rig preset {preset!r}; use one of {', '.join(PRESETS)}")
        chosen = PRESETS[preset]
        base = QUICK_SETUP if quick else cls()
        geometry = RigGeometry(camera_field_mm=base.camera_field_mm)
        lens = natural_vignetting(geometry, base.width, base.height)
        return cls(
            **{
                **base.to_dict(),
                "seed": int(seed),
                "camera": {**chosen.camera, "vignetting": lens},
                "projector": dict(chosen.projector),
                "gamma_precompensation": chosen.gamma_precompensation,
                "preset": chosen.name,
            }
        )

    def projector_model(self) -> ProjectorModel:
        """The virtual projector: the default with the ``projector`` arguments.

        Returns
        -------
        ProjectorModel
            The projector of every capture of the sweep.
        """
        return ProjectorModel(**self.projector)

    def camera_model(self) -> CameraModel:
        """The virtual camera: this resolution and the ``camera`` arguments.

        Returns
        -------
        CameraModel
            The camera of every capture of the sweep.
        """
        return CameraModel(width=self.width, height=self.height, **self.camera)

    def rig(self, depth_mm: float, scene: Scene | None = None) -> SimulatedRig:
        """The virtual rig looking at ``scene`` (default the white plate at ``depth_mm``), 0 lx.

        Parameters
        ----------
        depth_mm : float
            Plate position (ignored when ``scene`` is given).
        scene : Scene, optional
            Another scene (e.g. the checkerboard of Sec. 5.2.2).

        Returns
        -------
        SimulatedRig
            With this setup's camera, field of view and seed, no added light.
        """
        return SimulatedRig(
            white_plate(float(depth_mm)) if scene is None else scene,
            camera=self.camera_model(),
            projector_model=self.projector_model(),
            geometry=RigGeometry(camera_field_mm=self.camera_field_mm),
            gamma_precompensation=self.gamma_precompensation,
            seed=self.seed,
        )

    def to_dict(self) -> dict[str, Any]:
        """The settings as plain JSON values: a sweep's ``params["setup"]``.

        Returns
        -------
        dict
            The constructor arguments; ``Ch4Setup(**setup.to_dict()) == setup``. The rig
            arguments added with the presets (``projector``, ``gamma_precompensation``,
            ``preset``) appear only when they differ from the default, so that the identity of
            a sweep on the default rig (its stored ``params``) is what it was before them.
        """
        extra: dict[str, Any] = {}
        if self.projector:
            extra["projector"] = dict(self.projector)
        if self.gamma_precompensation != THESIS_GAMMA:
            extra["gamma_precompensation"] = self.gamma_precompensation
        if self.preset:
            extra["preset"] = self.preset
        return {
            "width": self.width,
            "height": self.height,
            "camera_field_mm": self.camera_field_mm,
            "seed": self.seed,
            "imin": self.imin,
            "window_px": self.window_px,
            "border_px": self.border_px,
            "camera": dict(self.camera),
            **extra,
        }


def pattern_spec(pattern: str, pitch: float, imin: float = THESIS_IMIN) -> FringeSpec:
    """The vertical fringe set of a pattern name (:data:`ALL_PATTERNS`) at MIGL 255.

    Parameters
    ----------
    pattern : str
        A key of :data:`ALL_PATTERNS`, e.g. ``"sinusoidal-3"``.
    pitch : float
        Fringe pitch in projector pixels.
    imin : float
        Minimum input gray level.

    Returns
    -------
    FringeSpec
        Vertical fringes from ``imin`` to 255.

    Raises
    ------
    InputError
        If ``pattern`` is not a key of :data:`ALL_PATTERNS`.

    Examples
    --------
    >>> spec = pattern_spec("triangular-2", 6)
    >>> spec.pattern, spec.steps, spec.pitch_px, spec.orientation, spec.migl
    ('triangular', 2, 6.0, 'vertical', 255.0)
    """
    if pattern not in ALL_PATTERNS:
        raise InputError(f"unknown pattern {pattern!r}; use one of {', '.join(ALL_PATTERNS)}")
    kind, steps = ALL_PATTERNS[pattern]
    return FringeSpec(kind, steps, float(pitch), "vertical", imin, 255.0)


def sweep_phase(images: NDArray, spec: FringeSpec) -> NDArray:
    """Wrapped phase in [0, 2 pi) of one sweep set, every pixel kept (saturated ones too).

    :func:`hdrfringe.core.phase.wrapped_phase` with the sweeps' precision: sinusoidal sets (Eq. 2.2)
    in :data:`SWEEP_DTYPE`, triangular sets (Eq. 2.8, 2.9) in float64, their only precision.

    Parameters
    ----------
    images : ndarray, shape (N, H, W)
        The set, shift k at index k.
    spec : FringeSpec
        What was projected.

    Returns
    -------
    ndarray, shape (H, W)
        The wrapped phase (float32 for sinusoidal sets, float64 for triangular ones).

    Examples
    --------
    >>> from hdrfringe.core.patterns import fringe_gray
    >>> spec = pattern_spec("sinusoidal-3", 6)
    >>> imgs = np.stack([fringe_gray(np.arange(12.0), spec, k) for k in range(3)])[:, None]
    >>> sweep_phase(imgs, spec).dtype, sweep_phase(imgs, pattern_spec("triangular-3", 6)).dtype
    (dtype('float32'), dtype('float64'))

    References
    ----------
    Thesis Eq. 2.2, 2.8, 2.9.
    """
    dtype = SWEEP_DTYPE if spec.pattern == "sinusoidal" else np.float64
    return wrapped_phase(images, spec, dtype=dtype)


def orders_from_expected(wrapped: NDArray, expected: NDArray) -> NDArray[np.float64]:
    """Absolute phase: ``wrapped`` plus the multiple of 2 pi closest to ``expected``.

    The fringe orders of the sweeps come from the known plate position (the micrometer
    reading), so the phase error is measured without unwrapping failures mixed in.

    Parameters
    ----------
    wrapped : ndarray
        Wrapped phase in [0, 2 pi).
    expected : ndarray
        The true absolute phase (same shape, or broadcastable).

    Returns
    -------
    ndarray
        ``wrapped + 2 pi k`` with the integer ``k`` that brings it closest to ``expected``.

    Examples
    --------
    >>> orders_from_expected(np.array([0.5, 6.0]), np.array([13.0, 5.9])).round(3)
    array([13.066,  6.   ])
    """
    return wrapped + TWO_PI * np.round((expected - wrapped) / TWO_PI)


def centerline_absolute(
    unwrapped: NDArray, line_image: NDArray, position: float, pitch: float
) -> NDArray[np.float64]:
    """Absolute phase of a spatially unwrapped map from a centerline capture, as ``hdrfringe
    measure`` finds it; all NaN when the image shows no line.

    The line is found in every camera row (:func:`~hdrfringe.core.unwrap.detect_centerline`, the
    library's defaults), the unwrapped phase is averaged along it (Eq. 2.12,
    :func:`~hdrfringe.core.unwrap.centerline_phase`) and the map gets the multiple of 2 pi that
    puts that average nearest to the line's projector coordinate
    (:func:`~hdrfringe.core.unwrap.absolute_phase`, Eq. 2.13 rounded to whole fringes): the chain of
    :func:`~hdrfringe.core.unwrap.absolute_phase_from_centerline`, which ``measure`` uses. A capture
    in which no row shows the line has no absolute phase: NaN everywhere (the sweep's RMSE of
    that cell is then NaN) instead of an error.

    Parameters
    ----------
    unwrapped : ndarray, shape (H, W)
        Spatially unwrapped phase (:func:`~hdrfringe.core.unwrap.unwrap_spatial`).
    line_image : ndarray, shape (H, W)
        Camera image of the vertical centerline frame.
    position : float
        Projector column of the line.
    pitch : float
        Fringe pitch in projector pixels.

    Returns
    -------
    ndarray of float64, shape (H, W)
        ``unwrapped`` plus one multiple of 2 pi (NaN where it is NaN, or everywhere when no line
        was found).

    References
    ----------
    Thesis Sec. 2.5, Eq. 2.12-2.13 (the method of Zhang and Huang).

    Examples
    --------
    A plate seen at projector columns 90..113 (pitch 8), unwrapped 3 fringes off, and a line
    at projector column 102 seen at camera column 12:

    >>> cols = np.tile(np.arange(24.0), (4, 1))
    >>> line = 10 + 200 * np.exp(-0.5 * ((cols - 12.0) / 1.2) ** 2)
    >>> relative = 2 * np.pi * (cols + 90) / 8 - 3 * 2 * np.pi
    >>> phase = centerline_absolute(relative, line, 102.0, 8)
    >>> (phase[0, :3] * 8 / (2 * np.pi)).round(6).tolist()
    [90.0, 91.0, 92.0]
    >>> bool(np.isnan(centerline_absolute(relative, np.full((4, 24), 10.0), 102.0, 8)).all())
    True
    """
    rows = detect_centerline(line_image, "vertical")
    if not np.isfinite(rows).any():
        return np.full(np.shape(unwrapped), np.nan)
    phi_c = centerline_phase(unwrapped, rows, "vertical")
    return absolute_phase(unwrapped, phi_c, position, pitch)


def centerline_unwrap(
    wrapped: NDArray,
    line_image: NDArray,
    position: float,
    pitch: float,
    *,
    candidate: NDArray | None = None,
) -> NDArray[np.float64]:
    """Absolute phase the way the thesis's pipeline (and ``hdrfringe measure``) finds it:
    spatial unwrapping of the wrapped phase, then the centerline (:func:`centerline_absolute`).

    Every pixel is unwrapped, saturated ones too (the thesis's RMSE counts them all), by
    :func:`~hdrfringe.core.unwrap.unwrap_spatial`. A ``candidate`` unwrapping is used instead when
    it proves to be the only one: ``candidate - wrapped`` a multiple of 2 pi and every
    4-neighbour step of ``candidate`` finite and below pi. Then the wrapped map has no
    residues (each step is the wrapped difference, and they sum to zero round every loop), so
    the map is a single region that every path-following unwrapper, ``unwrap_spatial``
    included, turns into ``candidate`` plus one constant multiple of 2 pi, which the centerline
    then fixes: the same absolute phase. The sweeps pass the known-order phase, which saves the
    unwrapper's cost wherever the unwrapping cannot fail (tested against ``unwrap_spatial`` in
    research/tests/test_reproduce_centerline.py); where it can, ``unwrap_spatial`` runs.

    Parameters
    ----------
    wrapped : ndarray, shape (H, W)
        Wrapped phase in [0, 2 pi) (:func:`sweep_phase`).
    line_image : ndarray, shape (H, W)
        Camera image of the vertical centerline frame.
    position : float
        Projector column of the line.
    pitch : float
        Fringe pitch in projector pixels.
    candidate : ndarray, shape (H, W), optional
        An unwrapping of ``wrapped`` to try first (see above).

    Returns
    -------
    ndarray of float64, shape (H, W)
        The absolute phase (all NaN when no line was found, :func:`centerline_absolute`).

    References
    ----------
    Thesis Sec. 2.4 (unwrapping), Sec. 2.5 and Eq. 2.12-2.13 (centerline).

    Examples
    --------
    >>> cols = np.tile(np.arange(24.0), (4, 1))
    >>> line = 10 + 200 * np.exp(-0.5 * ((cols - 12.0) / 1.2) ** 2)
    >>> truth = 2 * np.pi * (cols + 90) / 8
    >>> phase = centerline_unwrap(np.mod(truth, 2 * np.pi), line, 102.0, 8)
    >>> bool(np.allclose(phase, truth))
    True
    """
    unwrapped = None
    if candidate is not None and _only_unwrapping(candidate, wrapped):
        unwrapped = np.asarray(candidate, dtype=np.float64)
    if unwrapped is None:
        unwrapped = unwrap_spatial(wrapped)
    return centerline_absolute(unwrapped, line_image, position, pitch)


def _only_unwrapping(candidate: NDArray, wrapped: NDArray) -> bool:
    """Whether ``candidate`` unwraps ``wrapped`` with every 4-neighbour step finite and below pi
    (less a margin for rounding): then it is the map's only unwrapping up to a constant."""
    c = np.asarray(candidate, dtype=np.float64)
    if c.shape != np.shape(wrapped) or not np.isfinite(c).all():
        return False
    turns = (c - wrapped) / TWO_PI
    if not np.allclose(turns, np.rint(turns), rtol=0.0, atol=1e-6):
        return False
    limit = np.pi - 1e-6
    return bool(
        (np.abs(np.diff(c, axis=0)) < limit).all() and (np.abs(np.diff(c, axis=1)) < limit).all()
    )


def order_error_fraction(phase: NDArray, known: NDArray, mask: NDArray[np.bool_]) -> float:
    """Fraction of the ``mask`` pixels whose fringe order differs from the known one.

    ``phase`` and ``known`` are the same wrapped phase plus multiples of 2 pi: ``known`` with
    the orders of the true phase (:func:`orders_from_expected`), ``phase`` with those of the
    pipeline under test. A pixel whose multiple differs, or that ``phase`` leaves NaN, has a
    wrong order; a pixel without a wrapped phase (NaN in ``known``: e.g. a triangular set
    saturated in too many shifts) has no order to get wrong and is not counted as wrong.

    Parameters
    ----------
    phase : ndarray
        Absolute phase from the pipeline under test (e.g. :func:`centerline_unwrap`).
    known : ndarray
        The same wrapped phase with the known orders.
    mask : ndarray of bool
        The pixels counted.

    Returns
    -------
    float
        Wrong-order pixels / mask pixels, in [0, 1].

    Examples
    --------
    >>> wrapped = np.array([0.5, 1.0, 6.0])
    >>> known = orders_from_expected(wrapped, np.array([13.0, 7.0, 5.9]))
    >>> phase = wrapped + 2 * np.pi * np.array([2, 0, 0])   # the middle pixel is a fringe off
    >>> order_error_fraction(phase, known, np.ones(3, bool))
    0.3333333333333333
    >>> order_error_fraction(np.full(3, np.nan), known, np.ones(3, bool))
    1.0
    """
    with np.errstate(invalid="ignore"):
        wrong = np.isfinite(known) & ~(np.rint((phase - known) / TWO_PI) == 0)
    return float(np.count_nonzero(wrong[mask])) / max(int(np.count_nonzero(mask)), 1)


def cell_rng(setup: Ch4Setup, *key: Any) -> np.random.Generator:
    """A generator that depends only on the setup's seed and the cell's coordinates.

    Parameters
    ----------
    setup : Ch4Setup
        Its ``seed`` is the sweep's seed.
    *key
        The cell's coordinates (anything with a stable ``repr``: strings, numbers, tuples).

    Returns
    -------
    numpy.random.Generator
        PCG64 seeded by the seed and a SHA-256 of ``repr(key)``: the same cell gives the same
        draws in any process, in any order.

    Examples
    --------
    >>> a = cell_rng(QUICK_SETUP, "sinusoidal-3", 6.0, 18.0).integers(1000, size=3)
    >>> b = cell_rng(QUICK_SETUP, "sinusoidal-3", 6.0, 18.0).integers(1000, size=3)
    >>> c = cell_rng(QUICK_SETUP, "sinusoidal-3", 6.0, 20.0).integers(1000, size=3)
    >>> bool((a == b).all()), bool((a == c).all())
    (True, False)
    """
    digest = hashlib.sha256(repr(key).encode()).digest()
    words = [int.from_bytes(digest[i : i + 4], "little") for i in range(0, 16, 4)]
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([setup.seed, *words])))


def depth_normals(
    setup: Ch4Setup,
    spec: FringeSpec,
    pattern: str,
    depth_mm: float,
    shape: tuple[int, int],
    *tag: str,
) -> NDArray[np.float32]:
    """Standard normal draws (float32, one per image pixel of the set) shared by every cell of
    one pattern, pitch and plate position: **common random numbers**.

    Every MIGL and lighting of a position is measured with the same draws, each scaled by
    that cell's own noise standard deviation (:func:`~hdrfringe.rig.sensor.sensor_readout`).
    A cell is still an exact sample of the camera model; only the cells of one position are
    correlated, so comparisons over MIGL and light are paired (the trade-off search compares
    exactly those) while the means over the 25 positions average independent draws. Drawing
    once per position instead of once per cell removes what was the sweep's largest cost.

    Parameters
    ----------
    setup : Ch4Setup
        The sweep's settings (its seed).
    spec : FringeSpec
        The set (its pitch and number of steps).
    pattern : str
        Pattern name (:data:`ALL_PATTERNS`).
    depth_mm : float
        Plate position.
    shape : tuple of int
        Image shape (H, W).
    *tag : str
        Distinguishes independent draws of one position (e.g. ``"eq4.1"`` for the added noise
        of Sec. 4.3).

    Returns
    -------
    ndarray, shape (N, H, W), float32
        Standard normal draws.

    Examples
    --------
    >>> z = depth_normals(QUICK_SETUP, pattern_spec("sinusoidal-3", 6), "sinusoidal-3", 6.0, (2, 3))
    >>> z.shape, z.dtype
    ((3, 2, 3), dtype('float32'))
    """
    rng = cell_rng(setup, *tag, pattern, float(spec.pitch_px), float(depth_mm))
    return rng.standard_normal((spec.steps, *shape), dtype=SWEEP_DTYPE)


class PlateSweep:
    """Noise-free signals of one plate position (or any flat-lit scene) for any MIGL and
    ambient light.

    The rig is linear from projected light to signal (thesis Eq. 3.3 before noise), so the
    response to each projector-pixel residue modulo the pitch, computed once, turns every frame
    into one weighted sum.

    Parameters
    ----------
    depth_mm : float
        Plate position.
    setup : Ch4Setup
        Camera and rig settings.
    spec : FringeSpec
        The fringe set; its pitch must be a whole number of pixels.
    scene : Scene, optional
        Replaces the white plate at ``depth_mm`` (e.g. the checkerboard of Sec. 5.2.2).

    Attributes
    ----------
    expected_phase : ndarray
        The true absolute phase of each camera pixel.
    truth_height_mm : ndarray
        The scene's true height map.
    centerline_position : float
        Projector coordinate of the centerline (:meth:`centerline_signal`): the middle of the
        projector.

    Raises
    ------
    InputError
        If the pitch is not a whole number of pixels.

    Examples
    --------
    >>> setup = Ch4Setup(width=32, height=24, camera_field_mm=16.0)
    >>> plate = PlateSweep(18.0, setup, pattern_spec("sinusoidal-3", 6))
    >>> plate.signal(255.0).shape, plate.signal(255.0).dtype
    ((3, 24, 32), dtype('float32'))
    >>> bool((plate.signal(205.0) < plate.signal(255.0)).all())
    True
    """

    def __init__(
        self, depth_mm: float, setup: Ch4Setup, spec: FringeSpec, scene: Scene | None = None
    ) -> None:
        self.depth_mm = float(depth_mm)
        self.spec = spec
        self.period = round(spec.pitch_px)
        if self.period != spec.pitch_px:
            raise InputError(f"the sweep needs a whole-pixel pitch, got {spec.pitch_px:g}")
        self.rig = setup.rig(self.depth_mm, scene)
        # float32: the signal feeds float32 noise anyway; halves the memory traffic
        basis = self.rig.periodic_basis(self.period, spec.orientation).astype(np.float32)
        self._basis = basis.reshape(self.period, -1)
        self._ambient0 = self.rig.ambient_signal().astype(np.float32)
        self._ambient: dict[float, NDArray] = {0.0: self._ambient0}
        truth = self.rig.truth()
        self.expected_phase = TWO_PI * truth.u / spec.pitch_px
        self.truth_height_mm = truth.height_mm
        proj = self.rig.projector
        extent = proj.width if spec.orientation == "vertical" else proj.height
        self.centerline_position = extent / 2.0
        self._centerline: dict[float, NDArray[np.float32]] = {}

    def ambient(self, lux: float) -> NDArray:
        """Ambient signal (DN) with ``lux`` of added light (0 lx: the rig's own).

        Parameters
        ----------
        lux : float
            Added ambient light in lx.

        Returns
        -------
        ndarray, shape (H, W), float32
            The ambient part of the signal (computed once per level, then kept).
        """
        if lux not in self._ambient:
            lit = self.rig.replace(lighting=Lighting(ambient_lux=float(lux)))
            self._ambient[lux] = lit.ambient_signal().astype(np.float32)
        return self._ambient[lux]

    def signal(self, migl: float, lux: float = 0.0) -> NDArray[np.float32]:
        """Noise-free signal (float32) of the set at ``migl`` with ``lux`` of added light.

        Parameters
        ----------
        migl : float
            Maximum input gray level of the set.
        lux : float
            Added ambient light in lx.

        Returns
        -------
        ndarray, shape (N, H, W), float32
            Signal in DN before noise, rounding and clipping.
        """
        return self.frames_signal(self.spec.with_migl(float(migl)).frames(), lux)

    def frames_signal(self, frames: Sequence[Frame], lux: float = 0.0) -> NDArray[np.float32]:
        """Noise-free signal (float32) of any frames periodic with the pitch.

        Parameters
        ----------
        frames : sequence of Frame
            Fringe frames of this set at any MIGL, uniform frames.
        lux : float
            Added ambient light in lx.

        Returns
        -------
        ndarray, shape (n, H, W), float32
            Signal in DN before noise, rounding and clipping.
        """
        light = np.stack([self.rig.periodic_light(f, self.period) for f in frames])
        shape = (len(frames), *self.rig.image_shape)
        out = (light.astype(np.float32) @ self._basis).reshape(shape)
        out += self.ambient(lux)
        return out

    def centerline_signal(self, migl: float, lux: float = 0.0) -> NDArray[np.float32]:
        """Noise-free signal (float32) of the centerline frame at ``migl`` with ``lux`` of added
        light: a line one projector pixel wide at gray level ``migl`` on black, at
        :attr:`centerline_position`, oriented as the fringes (thesis Sec. 2.5).

        The line is not periodic, so the rig renders it in full (once per MIGL, then kept).

        Parameters
        ----------
        migl : float
            Gray level of the line (the set's MIGL: captured with the set).
        lux : float
            Added ambient light in lx.

        Returns
        -------
        ndarray, shape (1, H, W), float32
            Signal in DN before noise, rounding and clipping.
        """
        m = float(migl)
        if m not in self._centerline:
            frame = CenterlineFrame(self.centerline_position, self.spec.orientation, migl=m)
            self._centerline[m] = self.rig.expected_signal([frame]).astype(np.float32)
        out = self._centerline[m].copy()
        if lux:
            out += self.ambient(lux) - self.ambient(0.0)
        return out


_CALIBRATIONS: dict[str, tuple[Calibration, NDArray[np.float64]]] = {}
#: Reflectivity of the white calibration plate.
WHITE_PLATE = 1.0
_CALIBRATIONS_KEPT = 4


def calibrate_pattern(
    pattern: str,
    pitch: float,
    setup: Ch4Setup,
    depths_mm: Sequence[float] = THESIS_DEPTHS_MM,
    plate_reflectivity: float = WHITE_PLATE,
) -> tuple[Calibration, NDArray[np.float64]]:
    """The Sec. 4.1 calibration of one pattern and pitch: reference plane and the plate
    positions at MIGL 255, 0 lx, linear model (Eq. 2.15), filtered.

    Deterministic, so a worker keeps its last few calibrations: blocks that share a pattern
    and pitch (the Sec. 4.3 blocks, one per depth) calibrate once per worker process.

    Parameters
    ----------
    pattern : str
        Pattern name (:data:`ALL_PATTERNS`).
    pitch : float
        Fringe pitch in projector pixels (whole).
    setup : Ch4Setup
        Camera, filter window and border (Sec. 4.1: 21 and 10 px).
    depths_mm : sequence of float
        Plate positions of the calibration.
    plate_reflectivity : float
        The calibration plate: white, or the black plate of Sec. 5.2.2 with the camera opened
        for it through ``setup.camera``.

    Returns
    -------
    Calibration
        The linear phase-to-height calibration.
    ndarray
        The reference plane's absolute phase.

    References
    ----------
    Thesis Sec. 4.1 (procedure), Eq. 2.15 (least-squares K), Sec. 2.5.
    """
    key = json.dumps(
        [pattern, float(pitch), setup.to_dict(), [float(d) for d in depths_mm], plate_reflectivity]
    )
    if key not in _CALIBRATIONS:
        if len(_CALIBRATIONS) >= _CALIBRATIONS_KEPT:
            del _CALIBRATIONS[next(iter(_CALIBRATIONS))]
        _CALIBRATIONS[key] = _calibrate_pattern(
            pattern, pitch, setup, depths_mm, plate_reflectivity
        )
    return _CALIBRATIONS[key]


def _calibrate_pattern(
    pattern: str,
    pitch: float,
    setup: Ch4Setup,
    depths_mm: Sequence[float],
    reflectivity: float,
) -> tuple[Calibration, NDArray[np.float64]]:
    spec = pattern_spec(pattern, pitch, setup.imin)
    cam = setup.camera_model()
    phases = []
    # the white plate keeps its historical noise key (stores made before stay valid)
    key = ("cal",) if reflectivity == WHITE_PLATE else ("cal", reflectivity)
    for d in (0.0, *depths_mm):
        plate = PlateSweep(d, setup, spec, scene=white_plate(d, reflectivity))
        rng = cell_rng(setup, *key, pattern, pitch, d)
        imgs = sensor_readout(plate.signal(255.0), cam, rng, dtype=SWEEP_DTYPE)
        phases.append(orders_from_expected(sweep_phase(imgs, spec), plate.expected_phase))
    cal = calibrate(
        phases[0],
        np.stack(phases[1:]),
        np.asarray(depths_mm, dtype=np.float64),
        model="linear",
        compare=["linear"],
        window_px=setup.window_px,
        border_px=setup.border_px,
        spec=spec,
        camera_bit_depth=cam.bit_depth,
    )
    return cal, phases[0]


def _metrics(
    imgs: NDArray,
    spec: FringeSpec,
    plate: PlateSweep,
    cal: Calibration,
    mask: NDArray[np.bool_],
    bit_depth: int,
    phase: NDArray | None = None,
) -> tuple[float, float, float, list[float]]:
    """RMSE, bias (mean error) and std over the pixels of the height error, and the saturated
    fractions; RMSE^2 = bias^2 + std^2 (population std). ``phase``: the caller's absolute phase
    of ``imgs`` (None: known fringe orders)."""
    if phase is None:
        phase = orders_from_expected(sweep_phase(imgs, spec), plate.expected_phase)
    err = cal.height(phase)[mask] - plate.depth_mm
    nsat = saturation_count(imgs, bit_depth)[mask]
    fractions = [float(np.count_nonzero(nsat == k)) / nsat.size for k in SATURATED_SHIFTS]
    return float(np.sqrt(np.mean(err * err))), float(np.mean(err)), float(np.std(err)), fractions


def ch4_block(
    pattern: str,
    pitch: float,
    luxes: Sequence[float],
    migls: Sequence[float],
    depths_mm: Sequence[float],
    setup: Ch4Setup,
) -> dict[str, NDArray[np.float64]]:
    """Every Sec. 4.2 measurement of one pattern and pitch.

    Parameters
    ----------
    pattern : str
        Pattern name (:data:`PATTERNS`).
    pitch : float
        Fringe pitch in projector pixels (whole).
    luxes, migls, depths_mm : sequence of float
        Added ambient light (lx), MIGLs and plate positions measured.
    setup : Ch4Setup
        Camera and processing settings.

    Returns
    -------
    dict
        ``rmse_mm``, ``mean_error_mm`` (bias) and ``std_mm`` (standard deviation over the
        measurement pixels of the height error) of shape (lux, MIGL, depth), and
        ``saturated_fraction`` of shape (lux, MIGL, depth, 3): the fraction of measurement
        pixels saturated in exactly 1, 2 and 3 of the shifts (Fig. 4.5).

    References
    ----------
    Thesis Sec. 4.1-4.2.
    """
    spec = pattern_spec(pattern, pitch, setup.imin)
    cam = setup.camera_model()
    cal, _ = calibrate_pattern(pattern, pitch, setup, depths_mm)
    mask = measurement_mask((setup.height, setup.width), setup.border_px)
    shape = (len(luxes), len(migls), len(depths_mm))
    rmse, bias, std = np.full(shape, np.nan), np.full(shape, np.nan), np.full(shape, np.nan)
    sat = np.full((*shape, len(SATURATED_SHIFTS)), np.nan)
    for k, d in enumerate(depths_mm):
        plate = PlateSweep(d, setup, spec)
        normals = depth_normals(setup, spec, pattern, d, plate.rig.image_shape)
        for j, m in enumerate(migls):
            base = plate.signal(m)
            for i, lux in enumerate(luxes):
                signal = base + (plate.ambient(lux) - plate.ambient(0.0)) if lux else base
                imgs = sensor_readout(signal, cam, normals=normals, dtype=SWEEP_DTYPE)
                rmse[i, j, k], bias[i, j, k], std[i, j, k], sat[i, j, k] = _metrics(
                    imgs, spec, plate, cal, mask, cam.bit_depth
                )
    return {"rmse_mm": rmse, "mean_error_mm": bias, "std_mm": std, "saturated_fraction": sat}


def ch4_modified_block(
    pattern: str,
    pitch: float,
    added_lux: Sequence[float],
    noise_sigma: Sequence[float],
    migls: Sequence[float],
    depths_mm: Sequence[float],
    setup: Ch4Setup,
    *,
    noise_lux: float = 600.0,
    calibration_depths_mm: Sequence[float] | None = None,
    unwrap: str = "known",
) -> dict[str, NDArray[np.float64]]:
    """The Sec. 4.3 simulations for one pattern (pitch 6 in the thesis).

    The 0 lx captures of :func:`ch4_block` (same noise) are modified by Eq. 4.1: uniform added
    light ``added_lux`` (0.17 gray level per lux, Fig. 4.14c), and separately ``noise_lux`` of
    added light plus zero-mean Gaussian noise of each ``noise_sigma``. The Gaussian noise is
    one standard normal draw per plate position scaled to each sigma (common random numbers,
    :func:`depth_normals`: the levels differ by sigma alone, so the RMSE-against-sigma curves
    of Table 4.2 are not blurred by independent draws).

    With ``unwrap="centerline"`` the added-light measurements take their fringe orders as the
    thesis's pipeline does: the wrapped phase of every pixel (saturated ones too) is unwrapped
    spatially (:func:`~hdrfringe.core.unwrap.unwrap_spatial`) and made absolute with a centerline
    (:func:`centerline_absolute`) captured at the set's MIGL through the same camera: its own
    noise draw per position (common across MIGL and light, as the set's) and the same Eq. 4.1
    added light, so saturation can hide the line or break the unwrapping as on the real rig.
    Where the known-order phase is itself a valid spatial unwrapping (every 4-neighbour step
    below pi), it stands in for :func:`~hdrfringe.core.unwrap.unwrap_spatial`, which would return it
    plus a constant multiple of 2 pi (:func:`centerline_unwrap`): the orders then rest on the
    centerline alone, exactly as with the unwrapper. The calibration keeps known orders (made
    in the dark at MIGL 255, where the centerline gives the same orders:
    research/tests/test_reproduce_centerline.py) and so do the noise measurements.

    Parameters
    ----------
    pattern : str
        Pattern name (:data:`PATTERNS`).
    pitch : float
        Fringe pitch in projector pixels (whole).
    added_lux : sequence of float
        Simulated added light levels (lx).
    noise_sigma : sequence of float
        Standard deviations of the simulated Gaussian noise (DN).
    migls, depths_mm : sequence of float
        MIGLs and plate positions measured.
    setup : Ch4Setup
        Camera and processing settings.
    noise_lux : float
        Added light of the noise simulation.
    calibration_depths_mm : sequence of float, optional
        The plate positions of the calibration (default ``depths_mm``), when the block
        measures only some of them.
    unwrap : {"known", "centerline"}
        Fringe orders of the added-light measurements (:data:`UNWRAP_MODES`).

    Returns
    -------
    dict
        ``rmse_light_mm`` (added lux, MIGL, depth) and ``rmse_noise_mm`` (sigma, MIGL, depth),
        and likewise the bias (``mean_error_light_mm``, ``mean_error_noise_mm``) and the
        standard deviation over pixels (``std_light_mm``, ``std_noise_mm``);
        ``saturated_fraction_light`` (added lux, MIGL, depth): the fraction of measurement
        pixels saturated in at least one shift (where saturation starts under added light);
        ``order_error_fraction`` (added lux, MIGL, depth): the fraction of the measured pixels
        whose fringe order is wrong (:func:`order_error_fraction`; 0 with known orders; NaN,
        as the RMSE, where no centerline was detected).

    Raises
    ------
    InputError
        If ``unwrap`` is not one of :data:`UNWRAP_MODES`.

    References
    ----------
    Thesis Sec. 4.3, Eq. 4.1; Sec. 2.4-2.5 (unwrapping, centerline).
    """
    if unwrap not in UNWRAP_MODES:
        raise InputError(f"unknown unwrapping {unwrap!r}; use one of {', '.join(UNWRAP_MODES)}")
    spec = pattern_spec(pattern, pitch, setup.imin)
    cam = setup.camera_model()
    cal_depths = depths_mm if calibration_depths_mm is None else calibration_depths_mm
    cal, _ = calibrate_pattern(pattern, pitch, setup, cal_depths)
    mask = measurement_mask((setup.height, setup.width), setup.border_px)
    out = {
        f"{stat}_{kind}_mm": np.full((len(levels), len(migls), len(depths_mm)), np.nan)
        for kind, levels in (("light", added_lux), ("noise", noise_sigma))
        for stat in ("rmse", "mean_error", "std")
    }
    out["saturated_fraction_light"] = np.full((len(added_lux), len(migls), len(depths_mm)), np.nan)
    out["order_error_fraction"] = np.zeros((len(added_lux), len(migls), len(depths_mm)))
    for k, d in enumerate(depths_mm):
        plate = PlateSweep(d, setup, spec)
        normals = depth_normals(setup, spec, pattern, d, plate.rig.image_shape)
        # Eq. 4.1 noise: one draw per depth, scaled to each sigma (common random numbers)
        z = depth_normals(setup, spec, pattern, d, plate.rig.image_shape, "eq4.1")
        if unwrap == "centerline":
            rng = cell_rng(setup, "centerline", pattern, float(spec.pitch_px), float(d))
            line_normals = rng.standard_normal((1, *plate.rig.image_shape), dtype=SWEEP_DTYPE)
        for j, m in enumerate(migls):
            imgs = sensor_readout(plate.signal(m), cam, normals=normals, dtype=SWEEP_DTYPE)
            if unwrap == "centerline":
                line = sensor_readout(
                    plate.centerline_signal(m), cam, normals=line_normals, dtype=SWEEP_DTYPE
                )
            for i, lux in enumerate(added_lux):
                added = lux_to_dn(lux, cam.bit_depth)
                mod = modify_intensity(imgs, cam.bit_depth, added, dtype=SWEEP_DTYPE)
                phase = None
                if unwrap == "centerline":
                    wrapped = sweep_phase(mod, spec)
                    known = orders_from_expected(wrapped, plate.expected_phase)
                    seen = modify_intensity(line, cam.bit_depth, added, dtype=SWEEP_DTYPE)[0]
                    phase = centerline_unwrap(
                        wrapped, seen, plate.centerline_position, spec.pitch_px, candidate=known
                    )
                    frac = order_error_fraction(phase, known, mask)
                    out["order_error_fraction"][i, j, k] = (
                        frac if np.isfinite(phase).any() else np.nan
                    )
                stats = _metrics(mod, spec, plate, cal, mask, cam.bit_depth, phase)
                for stat, v in zip(("rmse", "mean_error", "std"), stats[:3], strict=True):
                    out[f"{stat}_light_mm"][i, j, k] = v
                out["saturated_fraction_light"][i, j, k] = sum(stats[3])
            for i, sigma in enumerate(noise_sigma):
                added, n = lux_to_dn(noise_lux, cam.bit_depth), SWEEP_DTYPE(sigma) * z
                mod = modify_intensity(imgs, cam.bit_depth, added, n, dtype=SWEEP_DTYPE)
                stats = _metrics(mod, spec, plate, cal, mask, cam.bit_depth)
                for stat, v in zip(("rmse", "mean_error", "std"), stats[:3], strict=True):
                    out[f"{stat}_noise_mm"][i, j, k] = v
    return out


# --------------------------------------------------------------------------------------------
# sweep grids and tasks (run by hdrfringe_thesis.engine)
# --------------------------------------------------------------------------------------------
#: Quick grid: a quarter-size view at the thesis's sampling, fewer pitches, MIGLs and depths.
QUICK_SETUP = Ch4Setup(width=324, height=247, camera_field_mm=160.0)
QUICK_PITCHES: tuple[int, ...] = (4, 6, 12, 20)
QUICK_MIGLS: tuple[float, ...] = tuple(float(m) for m in range(255, 104, -15))
QUICK_DEPTHS_MM: tuple[float, ...] = (6.0, 18.0, 30.0, 42.0)
QUICK_ADDED_LUX: tuple[float, ...] = (300.0, 600.0, 900.0)
QUICK_NOISE_SIGMA: tuple[float, ...] = (1.0, 4.0, 8.0)
#: The Sec. 4.3 simulations use one pitch.
SIMULATION_PITCH = 6


def ch4_grid(quick: bool = False) -> SweepGrid:
    """The Sec. 4.2 sweep: dims pattern, pitch (one task each) x lux, MIGL, depth.

    Parameters
    ----------
    quick : bool
        The reduced grid (:data:`QUICK_PITCHES`, :data:`QUICK_MIGLS`, :data:`QUICK_DEPTHS_MM`)
        instead of the thesis's (Sec. 4.1).

    Returns
    -------
    SweepGrid
        Variables ``rmse_mm``, ``mean_error_mm``, ``std_mm`` and ``saturated_fraction``;
        computed by :func:`ch4_task`.

    Examples
    --------
    >>> ch4_grid().n_blocks, ch4_grid(quick=True).n_blocks
    (51, 12)
    """
    from hdrfringe_thesis.engine import SweepGrid, Variable

    return SweepGrid(
        dims={
            "pattern": list(PATTERNS),
            "pitch": list(QUICK_PITCHES if quick else THESIS_PITCHES),
            "lux": list(THESIS_LUX),
            "migl": list(QUICK_MIGLS if quick else THESIS_MIGLS),
            "depth_mm": list(QUICK_DEPTHS_MM if quick else THESIS_DEPTHS_MM),
        },
        variables=[
            Variable("rmse_mm", attrs={"units": "mm", "long_name": "height RMSE"}),
            Variable("mean_error_mm", attrs={"units": "mm", "long_name": "mean height error"}),
            Variable(
                "std_mm",
                attrs={"units": "mm", "long_name": "standard deviation of the height error"},
            ),
            Variable(
                "saturated_fraction",
                extra_dims={"saturated_shifts": list(SATURATED_SHIFTS)},
                attrs={"long_name": "fraction of pixels saturated in exactly k shifts"},
            ),
        ],
        block_dims=["lux", "migl", "depth_mm"],
        attrs={"experiment": "thesis Sec. 4.1-4.2", "quick": int(quick)},
    )


def ch4_task(coords: dict[str, Any], params: dict[str, Any]) -> dict[str, NDArray]:
    """Engine task: one pattern and pitch (see :func:`ch4_block`).

    Parameters
    ----------
    coords : dict
        The block's coordinates (:meth:`SweepGrid.block_coords
        <hdrfringe_thesis.engine.SweepGrid.block_coords>` of :func:`ch4_grid`).
    params : dict
        ``{"setup": Ch4Setup.to_dict()}``.

    Returns
    -------
    dict
        The block's variables, as :func:`ch4_block`.
    """
    return ch4_block(
        coords["pattern"],
        coords["pitch"],
        coords["lux"],
        coords["migl"],
        coords["depth_mm"],
        Ch4Setup(**params["setup"]),
    )


def ch4_simulation_grid(quick: bool = False) -> SweepGrid:
    """The Sec. 4.3 sweep at pitch 6: dims pattern and depth (one task each: enough tasks to
    keep every worker busy) x MIGL, and the added light / noise levels as trailing dims of
    their variables.

    Parameters
    ----------
    quick : bool
        The reduced grid instead of the thesis's.

    Returns
    -------
    SweepGrid
        Variables ``rmse_light_mm``, ``mean_error_light_mm``, ``std_light_mm``, the same
        three with ``noise``, ``saturated_fraction_light`` and ``order_error_fraction`` (of
        the added-light measurements); computed by :func:`ch4_simulation_task`.

    Examples
    --------
    >>> grid = ch4_simulation_grid(quick=True)
    >>> grid.n_blocks, {grid.block_shape(v) for v in grid.variables}
    (12, {(11, 3)})
    >>> [v.name for v in grid.variables][:3]
    ['rmse_light_mm', 'mean_error_light_mm', 'std_light_mm']
    """
    from hdrfringe_thesis.engine import SweepGrid, Variable

    added_lux = {"added_lux": list(QUICK_ADDED_LUX if quick else THESIS_ADDED_LUX)}
    return SweepGrid(
        dims={
            "pattern": list(PATTERNS),
            "migl": list(QUICK_MIGLS if quick else THESIS_MIGLS),
            "depth_mm": list(QUICK_DEPTHS_MM if quick else THESIS_DEPTHS_MM),
        },
        variables=[
            Variable(
                f"{stat}_{kind}_mm",
                extra_dims=levels,
                attrs={"units": "mm", "long_name": f"{name} with {what}"},
            )
            for kind, levels, what in (
                (
                    "light",
                    {"added_lux": list(QUICK_ADDED_LUX if quick else THESIS_ADDED_LUX)},
                    "added uniform light (Eq. 4.1)",
                ),
                (
                    "noise",
                    {"noise_sigma": list(QUICK_NOISE_SIGMA if quick else THESIS_NOISE_SIGMA)},
                    "600 lx and Gaussian noise",
                ),
            )
            for stat, name in (
                ("rmse", "RMSE"),
                ("mean_error", "mean height error"),
                ("std", "height error std"),
            )
        ]
        + [
            Variable(
                "saturated_fraction_light",
                extra_dims=added_lux,
                attrs={"long_name": "fraction of pixels saturated in any shift (Eq. 4.1 light)"},
            ),
            Variable(
                "order_error_fraction",
                extra_dims=added_lux,
                attrs={"long_name": "fraction of pixels with a wrong fringe order (added light)"},
            ),
        ],
        block_dims=["migl"],
        attrs={
            "experiment": "thesis Sec. 4.3",
            "pitch": SIMULATION_PITCH,
            "quick": int(quick),
        },
    )


def ch4_simulation_task(coords: dict[str, Any], params: dict[str, Any]) -> dict[str, NDArray]:
    """Engine task: the Sec. 4.3 simulations of one pattern and depth
    (:func:`ch4_modified_block`).

    Parameters
    ----------
    coords : dict
        The block's coordinates (of :func:`ch4_simulation_grid`).
    params : dict
        ``setup`` (:meth:`Ch4Setup.to_dict`), ``added_lux``, ``noise_sigma``,
        ``calibration_depths_mm`` and optionally ``unwrap`` (:data:`UNWRAP_MODES`; default
        ``"known"``).

    Returns
    -------
    dict
        ``rmse_light_mm``, ``order_error_fraction`` (MIGL, added lux), ``rmse_noise_mm``
        (MIGL, sigma) and their ``mean_error_*`` and ``std_*`` (as :func:`ch4_modified_block`).
    """
    setup = Ch4Setup(**params["setup"])
    out = ch4_modified_block(
        coords["pattern"],
        SIMULATION_PITCH,
        params["added_lux"],
        params["noise_sigma"],
        coords["migl"],
        (coords["depth_mm"],),
        setup,
        calibration_depths_mm=params["calibration_depths_mm"],
        unwrap=params.get("unwrap", "known"),
    )
    # (level, MIGL, one depth) -> (MIGL, level): the engine's block dims come first
    return {k: np.moveaxis(v[..., 0], 0, -1) for k, v in out.items()}
