"""Per-pixel adaptive projection, ``--strategy adaptive`` (beyond the thesis: its Sec. 7.2).

The steps (docs/adaptive.md); with ``auto_exposure`` the exposure is chosen first (thesis
Sec. 7.3, :func:`~hdrfringe.strategies.exposure.choose_exposure`):

1. **Mapping** in both orientations: a ladder of fringe sets from one period across the
   projector down to within 16x of the finest pitch (it includes the measurement's coarser
   pitches). The first one-period set is captured at a low MIGL (``imin + 20``); its response
   ``I = a g + c`` (:func:`~hdrfringe.core.saturation.adaptive_map.response_from_fringes`) sets the
   MIGL of the others: the highest that keeps every pixel 10 % below clipping. Where a
   highlight holds that so low that more than 2 % of the field carries no fringe, the ladder
   is captured again at the full MIGL and merged per pixel (the bright capture where it does
   not clip). The phases are median-smoothed level by level while they are unwrapped
   temporally into each camera pixel's projector column ``u`` and row ``v``.
2. **Map**: per camera pixel the highest MIGL that keeps every shift a ``margin`` below
   clipping, carried to the projector (minimum per projector pixel, holes filled, eroded by the
   camera pixel's footprint plus ``blur_px``, smoothed from below;
   :func:`~hdrfringe.core.saturation.adaptive_map.projector_migl_map`).
3. **Adapted set** at the finest pitch of each orientation
   (:class:`~hdrfringe.core.frames.PixelwiseFringeFrame`); a **refit** from its own offset and
   modulation (a fine fringe loses modulation to blur, so its peak stays below what the
   response predicts: :func:`~hdrfringe.core.saturation.adaptive_map.refined_migl`) and one more
   set where that gains a gray level or more, kept where it does not clip; **check** passes
   where a shift still clipped, lowered from the peak bound and merged there (Eq. 5.1), at most
   ``iterations``; a **boost** set where the erosion left pixels far below their own level
   (a dim pixel next to a bright one: :func:`~hdrfringe.core.saturation.adaptive_map.boosted_map`),
   kept for those pixels where its unclipped modulation is larger.
4. **Phase**: the adapted set's fringe orders come from the mapping (no adapted set at the
   coarser pitches: the measurement's coarser sets are the mapping's own captures), and the
   bias of the map's steps under the blur is subtracted
   (:func:`~hdrfringe.core.saturation.adaptive_map.map_phase_bias`, the blur fitted against the
   mapping). The result's ``absolute_phase`` is what :func:`hdrfringe.pipeline.measure` uses
   for the family's absolute phase.

With ``epipolar`` the mapping is the vertical ladder only, each pixel's projector row from the
projector-camera calibration (:func:`~hdrfringe.core.saturation.adaptive_map.epipolar_rows`); with
``full_mapping`` the first mapping set is tried at the full MIGL and, where only a highlight
clips in it, the whole mapping stays there, the highlight is left to the top-up and the refit,
check and boost sets are not captured (docs/adaptive.md, "One direction + the epipolar
constraint, and the full-MIGL mapping").
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core._validation import full_scale, json_safe, saturation_count
from hdrfringe.core.captures import CameraSettings
from hdrfringe.core.frames import ImageFrame, PixelwiseFringeFrame, as_image_frame
from hdrfringe.core.geometric_order import (
    GeometricOrder,
    check_depth_range,
    geometric_order,
    ray_projector_points,
)
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.phase import decode_set, default_min_modulation
from hdrfringe.core.saturation.adaptive_map import (
    boosted_map,
    epipolar_rows,
    erode_map,
    fill_holes,
    fit_blur_sigma,
    footprint_px,
    lowered_floor,
    lowered_where_clipped,
    map_phase_bias,
    median_smooth,
    projector_coordinates,
    projector_migl_map,
    refined_migl,
    response_from_fringes,
    safe_migl,
    sample_map,
)
from hdrfringe.core.saturation.tolerant import tolerant_phase
from hdrfringe.core.stereo import StereoCalibration
from hdrfringe.core.uncertainty import (
    NoiseModel,
    NoiseUnknownError,
    estimate_noise,
    noise_from_manifest,
)
from hdrfringe.core.unwrap import unwrap_spatial, unwrap_temporal
from hdrfringe.errors import HdrFringeError, InputError
from hdrfringe.rig.base import Rig
from hdrfringe.strategies.base import (
    CapturedSet,
    DecoderSettings,
    FunctionStrategy,
    MetricsContext,
    RunContext,
    StrategyMetrics,
    StrategyResult,
    check_fringe_spec,
    default_min_migl,
    register,
)
from hdrfringe.strategies.exposure import (
    choose_exposure,
    default_target_modulation,
    detection_modulation,
)

__all__ = [
    "ADAPTIVE_METRICS",
    "Adaptive",
    "AdaptiveParams",
    "adaptive",
    "adaptive_sets",
    "adaptive_summary",
    "mapping_pitches",
]

#: Largest pitch ratio between consecutive mapping sets.
MAPPING_RATIO = 16.0
#: Headroom (fraction of full scale) of the automatic mapping MIGL.
AUTO_MAPPING_MARGIN = 0.1
#: Pixels the map-bias blur is fitted on (evenly spread over the valid ones).
FIT_PIXELS = 20000
#: A pixel whose received modulation (MIGL - imin) is below this fraction of its own level's
#: is short of light (the boost set raises it).
BOOST_RATIO = 0.7
#: The boost set raises the projector pixels within this fraction of the erosion radius of
#: each starved pixel: its own footprint, not the bright neighbour's, whose spill through the
#: blur would bias its phase (checkerboard std in mrad at 648 x 494, bench_adaptive.py
#: --study: fraction 0.25 47.2, 0.5 39.6, 0.75 39.5, 1.0 40.3, no boost 44.1; at 160 x 120,
#: tests/test_adaptive.py: 0.5 64, 1.0 122, no boost 82; docs/adaptive.md).
BOOST_RADIUS_FRACTION = 0.5
#: Fraction of the mapped pixels short of light above which the boost set is captured.
BOOST_MIN_FRACTION = 0.002
#: Predicted map biases (rad) below this are not subtracted: the model (one Gaussian blur for
#: the field, the map read at the mapped coordinates) is not that exact. On the 600 lx plate,
#: whose map is smooth, subtracting biases of a few mrad raised the phase std by 2.7 %
#: (docs/adaptive.md); the steps next to dark squares give tenths of a radian.
BIAS_MIN_RAD = 0.05
#: Fraction of the camera pixels that neither clip nor decode in the low mapping ladder above
#: which the ladder is captured again at the full MIGL and merged per pixel.
BRIGHT_MIN_FRACTION = 0.02
#: Window (camera pixels) of the median that denoises each mapping level before unwrapping.
MEDIAN_WINDOW = 5
#: Coverage top-up: the first exposure is the reference's divided by this. The pixels it is for
#: clip at the lowest usable MIGL (often under the projector's ``imin`` alone); on the specular
#: part at 160 x 120 and 10 ms, 1/16 (0.625 ms) leaves none clipped while 1/8 leaves 28 of
#: 149 (tests/test_adaptive.py), and the multi-exposure baseline's shortest is 1/16 too.
TOPUP_FIRST_DIVISOR = 16.0
#: Top-up sets at most: each next one 4x shorter, only while top-up pixels still clip. None is
#: captured longer for modulation: on the specular part at 160 x 120 a second set at the
#: exposure the brightest top-up pixel allowed (1.2 ms against 0.625) left the new pixels'
#: error at 0.297 rad against 0.298 (the highlight's own bias, not noise, dominates there).
TOPUP_MAX_SETS = 3
#: Fraction of the mapped pixels that must clip at the lowest usable MIGL for the top-up to
#: be captured (as the boost's :data:`BOOST_MIN_FRACTION`): a few stray pixels are not worth
#: 4 images (glossy dome at 160 x 120 with the automatic exposure: 2 pixels).
TOPUP_MIN_FRACTION = 0.002
#: Ring (camera pixels) of pixels with known fringe orders that anchors a patch unwrapped
#: spatially (the top-up's pixels, whose mapping clipped, have no orders of their own).
ORDER_RING_PX = 2
#: Fraction of a patch's ring that must agree with its shift (within a quarter period).
ORDER_RING_AGREE = 0.5

#: Full-MIGL mapping (``full_mapping``): the largest fraction of the camera pixels that may
#: clip in the first mapping set at the full MIGL for the whole mapping to stay there (those
#: pixels are left to the top-up). A highlight clips a few percent (the specular part: 1.48 %
#: at 648 x 494, ``bench_adaptive.py --epipolar``; 1.4 % at 160 x 120, tests/test_adaptive.py);
#: a scene bright all over clips far more (the checkerboard's white squares 53 % at 648 x 494,
#: 62 % at 160 x 120; the plate under 600 lx all of it) and falls back to the low-MIGL mapping.
FULL_MAPPING_MAX_CLIPPED = 0.05

#: Budget (``max_images``): the exposure chosen from the mapping may clip at most this
#: fraction of the mapped pixels at the lowest usable MIGL (their shifts then go to the
#: saturation-tolerant decoder, or stay unreached).
BUDGET_CLIP_FRACTION = 0.0005
#: Budget: the longest exposure chosen from the mapping, as a multiple of the rig's
#: (:func:`~hdrfringe.strategies.exposure.choose_exposure`'s default limit), and the shortest
#: as a fraction of it.
BUDGET_MAX_EXPOSURE_RATIO = 16.0
#: Erosion beyond the camera pixel's footprint and smoothing of the map from below
#: (projector pixels), the defaults of ``blur_px`` and ``smooth_px``.
BLUR_PX = 2.0
SMOOTH_PX = 3.0
#: Budget: their defaults with ``max_images``, where no boost set follows the one adapted
#: set: the map's step next to the footprint and softened further, which lights the dim side
#: of a reflectivity edge and evens the radiance across it (checkerboard at 648 x 494, seed
#: 0, ``bench_budget_regions.py --strategies adaptive-12``: 35.0 mrad, with ``--set
#: blur_px=2.0 --set smooth_px=3.0`` 59.7).
BUDGET_BLUR_PX = 0.0
BUDGET_SMOOTH_PX = 4.0
#: Budget: candidate exposures per octave (the choice's resolution, 2^(1/16) = 4.4 %).
BUDGET_EXPOSURE_STEPS = 16
#: Budget: the rig's exposure is kept where its predicted phase variance is within this
#: fraction of the least.
BUDGET_EXPOSURE_TOLERANCE = 0.02
#: Budget: mapped pixels the exposure choice evaluates at most (evenly spread).
BUDGET_EXPOSURE_PIXELS = 20000

#: Budget: window (camera pixels) over which the coarsest phase of a set completed from
#: three low shifts is averaged (on the circle) before it orders the next set: with the 5 px
#: median of the other mapping levels three shifts at the lowest MIGL slipped a 64 px order
#: at some pixels of the 600 lx plate at 648 x 494.
BUDGET_FIRST_WINDOW = 15

#: Budget: where a pixel's safe MIGL falls below the lowest usable one (``imin + 20``), the
#: fringe's floor falls with it (:func:`~hdrfringe.core.saturation.adaptive_map.lowered_floor`
#: with this span), so that a highlight too bright for the lowest usable MIGL at the chosen
#: exposure still carries a fringe under its peak (docs/adaptive.md, "Budget").
BUDGET_FLOOR_SPAN = 20.0
#: Budget: the MIGL (floor lowered to the projector's black) at which the mapping sets after
#: the full-MIGL probe show the pixels that clipped in it, so that their response is known
#: (the same span as the lowest usable fringe); everywhere else those sets keep the full MIGL.
BUDGET_SAFE_MIGL = 20.0
#: Budget: how far (projector pixels) beyond the camera pixel's footprint that dimmed region
#: reaches: the probe's clipped pixels take their projector coordinates from their
#: neighbours' coarse phase.
BUDGET_SAFE_MARGIN_PX = 4.0
#: Budget: camera pixels around those the probe clipped over which the map-bias blur is
#: fitted to the phase's smoothness when the mapping was dimmed there (the dimmed sets'
#: phase, the usual reference, carries their own map's step; the adapted map's largest step
#: is there).
BUDGET_DIM_NEAR_PX = 8
#: Budget: the map-bias blur where the mapping was dimmed is the one (in steps of this many
#: projector pixels) that leaves the phase smoothest around the highlight, from at least
#: this many pixels there. The fit against the mapping's phase (its pixels near the
#: highlight left out) came out 0.70-1.01 px over seeds 0-3 on the specular part at 648 x
#: 494 (20.54-25.55 mrad against the rig's truth), the smoothness 0.56-0.61 px on all four
#: (20.63-21.07 mrad; docs/adaptive.md, "Budget").
BUDGET_BLUR_STEP_PX = 0.05
#: Budget with a depth range: spacing (projector pixels) of the points along each epipolar
#: segment that the probe's dimmed shifts cover (half a pixel: the rounded points join).
BUDGET_SEGMENT_STEP_PX = 0.5
#: Budget with a depth range: clipped pixels whose segments are drawn at once (memory).
BUDGET_SEGMENT_CHUNK = 20000
#: Budget with a depth range: a camera pixel whose projector coordinate lies within this many
#: projector pixels of the dimmed probe's map step straddles it (the camera pixel's footprint
#: and the coordinate's error): its shifts are not one fringe, it gives no phase or response.
BUDGET_STRADDLE_PX = 2
#: Budget with a depth range: the least modulation (8-bit DN, scaled to the camera's bit
#: depth) at which a pixel of the dimmed probe gives the mapping a phase that orders the
#: finer set (below it the pixel still places itself in the projector). The dimmed region
#: (the clipped pixels' epipolar segments) also covers dark surface beside the highlight,
#: whose dimmed fringe (a few DN from the camera's black, its troughs clipped at 0) has a
#: phase error of a period's tenths, too much to order an 8x finer set, and a pixel at its
#: edge whose coordinate put it on the wrong side of the step mixes two levels: those pixels
#: take their fringe orders from their neighbours (docs/adaptive.md, "Budget").
BUDGET_DIM_MIN_MODULATION = 10.0
BUDGET_SMOOTH_MIN_PIXELS = 200

ORIENTATIONS = ("vertical", "horizontal")


def mapping_pitches(extent: int, finest_px: float, ratio: float = MAPPING_RATIO) -> list[float]:
    """Pitches of a mapping ladder: one period over ``extent``, then down by ``ratio``.

    The ladder stops at the first pitch within ``ratio`` of ``finest_px`` (the set it will
    unwrap), so the last step to the measurement's finest pitch is at most ``ratio`` too.

    Parameters
    ----------
    extent : int
        Projector width (vertical fringes) or height (horizontal), pixels.
    finest_px : float
        The finest pitch to be unwrapped from the ladder.
    ratio : float
        Largest pitch ratio between consecutive sets (> 1).

    Returns
    -------
    list of float
        Coarsest first; the first spans the projector with one period.

    Examples
    --------
    >>> mapping_pitches(1024, 8.0), mapping_pitches(768, 8.0), mapping_pitches(64, 8.0)
    ([1024.0, 64.0], [768.0, 48.0], [64.0])
    """
    if not ratio > 1:
        raise InputError(f"mapping ratio must be > 1, got {ratio!r}")
    out = [float(extent)]
    while out[-1] > ratio * float(finest_px):
        out.append(out[-1] / ratio)
    return out


@dataclass
class _Mapping:
    """What the mapping step measured, per orientation (internal)."""

    pitches: dict[str, list[float]]
    images: dict[str, list[NDArray]]
    migls: dict[str, list[float]]
    absolute: dict[str, NDArray[np.float64]]
    coords: dict[str, NDArray[np.float64]]
    gain: NDArray[np.float64]
    ambient: NDArray[np.float64]
    saturated: NDArray[np.bool_]
    #: MIGL of the bright ladder (None: not captured) and, per set, the MIGL of each pixel
    bright_migl: float | None = None
    index: dict[str, list[NDArray[np.float32]]] = field(default_factory=dict)
    #: the budget's dimmed map of the sets after the probe (None: none) and the probe's
    #: clipped pixels whose response those sets measured
    dim_map: NDArray[np.float64] | None = None
    safe: NDArray[np.bool_] | None = None
    #: pixels decoded in at least one mapping set
    decoded: NDArray[np.bool_] | None = None
    #: whether ``dim_map`` dimmed the first set's shifts 1.. too (the budget's dimmed probe)
    dim_first: bool = False
    #: the absolute phase that orders the finer sets where it is not ``absolute`` (the dimmed
    #: probe's: without its weak pixels, which still place themselves in the projector)
    ordering: dict[str, NDArray[np.float64]] | None = None


def _capture(rig: Rig, frames: list[Any], settings: CameraSettings | None) -> NDArray:
    return rig.capture(frames) if settings is None else rig.capture(frames, settings)


def _measure_mapping(
    rig: Rig,
    template: FringeSpec,
    pitches: dict[str, list[float]],
    migl: float,
    settings: CameraSettings | None,
    auto: bool,
    first_images: NDArray | None = None,
    trial: tuple[NDArray, float] | None = None,
    allow_bright: bool = True,
    first_window: int | None = None,
    dim: StereoCalibration | None = None,
    first_dim: _DimmedProbe | None = None,
    geometric: tuple[StereoCalibration, tuple[float, float]] | None = None,
) -> _Mapping:
    """Capture and decode the mapping sets; absolute phase, coordinates and response.

    The first set (one period, of the first orientation in ``pitches``) is captured at
    ``migl``. With ``auto`` the others are captured at the highest MIGL its response says
    keeps every pixel :data:`AUTO_MAPPING_MARGIN` below clipping (never below ``migl``): a
    brighter mapping is a less noisy one. The caller puts first the orientation whose fringe
    orders matter least (one the measurement does not use). With ``auto``, where more than
    :data:`BRIGHT_MIN_FRACTION` of the pixels neither clipped nor decoded in every set (a
    scene whose highlight holds the mapping MIGL so low that its dim surface carries no fringe), the
    ladder is captured once more at the full MIGL and merged per pixel: the bright capture
    where it did not clip (Eq. 5.1). ``first_images``: the first set, already captured at
    ``migl`` (the full-MIGL mapping's trial set). ``trial``: the first set captured at a
    higher MIGL (the full-MIGL mapping's trial set where too much clipped in it), merged into
    the first set where it did not clip (Eq. 5.1) and added to the response there.
    ``first_window``: the first orientation's coarsest phase averaged over that window
    (:func:`_unwrap_ladder`). ``dim``: the calibration of a one-ladder (epipolar) budget
    mapping whose first set is ``first_images`` at the full MIGL: the later sets show the
    pixels that clipped in it at :data:`BUDGET_SAFE_MIGL` (:func:`_dimmed_map`), and their
    response is measured there. ``first_dim``: ``first_images`` is the budget's dimmed probe
    (:func:`_dimmed_probe`): its per-pixel levels give the response, its dimmed pixels that
    clipped in the full-MIGL shot are measured. ``geometric``: the calibration and depth range
    that order the coarsest set (:func:`_unwrap_ladder`).
    """
    bits = rig.camera_bit_depth
    imin = template.imin
    images: dict[str, list[NDArray]] = {}
    migls: dict[str, list[float]] = {}
    index: dict[str, list[NDArray[np.float32]]] = {}
    response = _Response(imin)
    saturated = np.zeros(rig.image_shape, bool)
    decodes = np.ones(rig.image_shape, bool)  # valid in every set
    decoded = np.zeros(rig.image_shape, bool)  # valid in one
    m_next = migl
    dim_map: NDArray[np.float64] | None = None
    dim_levels: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
    safe: NDArray[np.bool_] | None = None

    # pass 1: the ladder at the low MIGL(s)
    for orient, ps in pitches.items():
        imgs: list[NDArray] = []
        ms: list[float] = []
        for k_, p in enumerate(ps):
            m = migl if not response.gains and not imgs else m_next
            spec = _spec_at(template, orient, p, m)
            if first_images is not None and not response.gains and not imgs:
                imgs.append(first_images)
            elif dim_map is not None:
                frames = _floored_frames(spec, dim_map)
                imgs.append(_capture(rig, frames, settings))
            else:
                imgs.append(_capture(rig, spec.frames(), settings))
            dec = decode_set(imgs[-1], spec, bits)
            if k_ == 0 and first_dim is not None:  # straddling the dimmed probe's step: none
                dec = dataclasses.replace(dec, valid=dec.valid & first_dim.usable)
            ms.append(m)
            clipped_here = saturation_count(imgs[-1], bits) > 0
            if k_ == 0 and dim is not None and len(pitches) == 1 and clipped_here.any():
                dim_map, dim_levels = _dimmed_map(rig, dim, dec, spec, clipped_here)
                safe = clipped_here.copy()
            saturated |= clipped_here
            decodes &= dec.valid
            decoded |= dec.valid
            if len(pitches) == 1 and k_ == 1:
                # one orientation (epipolar): its second set, at the automatic MIGL, stands in
                # for the other orientation's one-period set in the response (its pitch, 16x
                # the finest, loses little modulation to the blur); dimmed where the probe
                # clipped: there the only response
                if dim_levels is None:
                    response.add(dec, m, np.ones(dec.valid.shape, bool))
                else:
                    response.add(dec, dim_levels[0], np.ones(dec.valid.shape, bool), dim_levels[1])
                    assert safe is not None
                    safe &= dec.valid
            if k_ == 0 and first_dim is not None:  # the dimmed probe: its levels per pixel
                response.add(dec, first_dim.levels, dec.valid, first_dim.floor)
                saturated |= first_dim.clipped
                dim_map = first_dim.pmap
                safe = first_dim.clipped & first_dim.dimmed & dec.valid
            elif p == ps[0]:  # a one-period set: the response
                g, c = response_from_fringes(dec.mean_intensity, dec.modulation, m, imin)
                response.add(dec, m, np.ones(g.shape, bool))
                if auto and len(response.gains) == 1:
                    m_next = _auto_mapping_migl(dec, g, c, bits, template, migl, m_next)
        images[orient] = imgs
        migls[orient] = ms
        index[orient] = [np.full(rig.image_shape, m, np.float32) for m in ms]
        if first_dim is not None and orient == next(iter(pitches)):
            index[orient][0] = first_dim.levels.astype(np.float32)
        if dim_levels is not None:
            index[orient][1:] = [dim_levels[0].astype(np.float32)] * (len(ms) - 1)

    if trial is not None:  # a brighter capture of the first set: merged where it did not clip
        t_imgs, t_migl = trial
        o0 = next(iter(pitches))
        take = saturation_count(t_imgs, bits) == 0
        images[o0][0] = np.where(take, t_imgs, images[o0][0])
        index[o0][0] = np.where(take, np.float32(t_migl), index[o0][0])
        t_spec = _spec_at(template, o0, pitches[o0][0], t_migl)
        response.add(decode_set(t_imgs, t_spec, bits), t_migl, take)

    # pass 2, only where the low ladder left much of the field dark: the full MIGL, merged
    bright: float | None = None
    dark = ~decodes & ~saturated
    wanted = auto and m_next < float(template.migl) and dark.mean() > BRIGHT_MIN_FRACTION
    if wanted and allow_bright:
        bright = float(template.migl)
        _merge_full_migl_ladder(rig, template, pitches, images, index, response, settings)

    absolute, ordering = _ladder_phases(
        template, pitches, images, migls, bits, first_window, dim_map is not None, first_dim,
        geometric,
    )  # fmt: skip
    coords = {o: projector_coordinates(absolute[o], pitches[o][-1]) for o in pitches}
    gain, ambient = response.combined()
    return _Mapping(
        pitches,
        images,
        migls,
        absolute,
        coords,
        gain,
        ambient,
        saturated,
        bright,
        index,
        dim_map,
        safe,
        decoded,
        first_dim is not None,
        ordering,
    )


def _ladder_phases(
    template: FringeSpec,
    pitches: dict[str, list[float]],
    images: dict[str, list[NDArray]],
    migls: dict[str, list[float]],
    bits: int,
    first_window: int | None,
    dimmed_later: bool,
    first_dim: _DimmedProbe | None,
    geometric: tuple[StereoCalibration, tuple[float, float]] | None,
) -> tuple[dict[str, NDArray[np.float64]], dict[str, NDArray[np.float64]] | None]:
    """Each orientation's mapping ladder unwrapped (:func:`_unwrap_ladder`; the first
    orientation's coarsest level over ``first_window``, its holes filled where the later sets
    were dimmed, ``dimmed_later``); and, after the dimmed probe, the first orientation's phase
    without its weak pixels, which orders the finer sets (None otherwise)."""
    o0 = next(iter(pitches))
    absolute: dict[str, NDArray[np.float64]] = {}
    for orient, ps in pitches.items():
        sets = [_spec_at(template, orient, p, m) for p, m in zip(ps, migls[orient], strict=True)]
        absolute[orient] = _unwrap_ladder(
            images[orient],
            sets,
            bits,
            first_window if orient == o0 else None,
            fill_first=dimmed_later and first_dim is None,
            geometric=geometric,
            first_mask=None if first_dim is None else first_dim.usable,
        )
    if first_dim is None:
        return absolute, None
    sets = [_spec_at(template, o0, p, m) for p, m in zip(pitches[o0], migls[o0], strict=True)]
    ordering = _unwrap_ladder(
        images[o0],
        sets,
        bits,
        first_window,
        geometric=geometric,
        first_mask=first_dim.usable,
        order_mask=first_dim.ordered,
    )
    return absolute, {o0: ordering}


def _floored_frames(spec: FringeSpec, pmap: NDArray[np.float64]) -> list[ImageFrame]:
    """``spec``'s shifts with the per-pixel MIGL map ``pmap`` and the floor lowered under the
    lowest usable MIGL (:func:`~hdrfringe.core.saturation.adaptive_map.lowered_floor`), as
    the projector images they are (a :class:`PixelwiseFringeFrame` has one floor, ``imin``)."""
    h, w = pmap.shape
    floor = lowered_floor(pmap, spec.imin, BUDGET_FLOOR_SPAN)
    span = np.maximum(pmap, floor) - floor
    unit = FringeSpec(spec.pattern, spec.steps, spec.pitch_px, spec.orientation, 0.0, 1.0)
    out = []
    for frame, named in zip(unit.frames(), spec.frames(), strict=True):
        profile = as_image_frame(frame, w, h).image.astype(np.float64)  # (1 + P) / 2
        image = (floor + span * profile).astype(np.float32)
        out.append(ImageFrame(image, f"{named.default_name()}_floored"))
    return out


def _dimmed_map(
    rig: Rig,
    calib: StereoCalibration,
    first: Any,
    first_spec: FringeSpec,
    clipped: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The budget's map for the mapping sets after the full-MIGL probe (decoded as ``first``):
    the full MIGL, but :data:`BUDGET_SAFE_MIGL` (floor at black) where the probe ``clipped``,
    so that those pixels' response is measured. Their projector columns come from their
    neighbours' one-period phase, their rows from the epipolar constraint; the region reaches
    the footprint plus :data:`BUDGET_SAFE_MARGIN_PX` beyond them. Returns the projector map
    and, per camera pixel, the MIGL and floor it received."""
    full = float(first_spec.migl)
    phase = np.where(first.valid, first.wrapped_phase, np.nan)
    u = projector_coordinates(phase, first_spec.pitch_px)
    u = fill_holes(u)
    v = epipolar_rows(calib, u)
    levels = np.where(clipped, BUDGET_SAFE_MIGL, full)
    shape = (rig.projector.height, rig.projector.width)
    radius = footprint_px(u, v) + BUDGET_SAFE_MARGIN_PX
    pmap = projector_migl_map(
        levels, u, v, shape, radius=radius, sigma=0.0, imin=0.0, projector_full=full
    )
    received = sample_map(pmap, u, v)
    return pmap, (received, lowered_floor(received, first_spec.imin, BUDGET_FLOOR_SPAN))


@dataclass
class _DimmedProbe:
    """The budget's probe with its shifts after the first dimmed (internal, :func:`_dimmed_probe`).

    ``images``: the set (the full-MIGL shifts where the map did not dim the pixel, else the
    first shift completed from the dimmed ones); ``pmap``: the dimmed shifts' projector map;
    per camera pixel the ``levels`` (MIGL) and ``floor`` its set was captured at; ``clipped``:
    the pixels that clipped in the full-MIGL first shift or that, dimmed, show a response that
    clips at the full MIGL; ``dimmed``: those the map dimmed; ``usable``: not those that
    straddle the map's step (their shifts saw both levels: no phase, no response);
    ``ordered``: usable, with a modulation of at least :data:`BUDGET_DIM_MIN_MODULATION` (a
    phase that orders the finer set).
    """

    images: NDArray
    pmap: NDArray[np.float64]
    levels: NDArray[np.float64]
    floor: NDArray[np.float64]
    clipped: NDArray[np.bool_]
    dimmed: NDArray[np.bool_]
    usable: NDArray[np.bool_]
    ordered: NDArray[np.bool_]


def _segment_map(run: _Run, clipped: NDArray[np.bool_]) -> NDArray[np.float64]:
    """The projector map of the dimmed probe: the full MIGL, but :data:`BUDGET_SAFE_MIGL`
    along the epipolar segment (over the depth range) of every camera pixel in ``clipped``,
    eroded by the camera pixel's footprint plus :data:`BUDGET_SAFE_MARGIN_PX`. Without a
    coarser phase the segment is all that is known of where such a pixel looks."""
    calib, zrange = run.geometric_inputs
    proj = run.rig.projector
    full = float(run.first.migl)
    h, w = clipped.shape
    # the camera pixel's footprint from a grid of every k-th pixel (its steps over k), in the
    # middle of the range (the mean of the segments' two ends)
    k = max(1, min(h, w) // 64)
    rows, cols = np.mgrid[0:h:k, 0:w:k].astype(np.float64)
    eu, ev = ray_projector_points(calib, zrange, cols, rows, step_px=np.finfo(float).max)
    grid = rows.shape
    footprint = footprint_px(eu.mean(axis=0).reshape(grid), ev.mean(axis=0).reshape(grid)) / k
    pmap = np.full((proj.height, proj.width), full)
    rr, cc = np.nonzero(clipped)
    for start in range(0, rr.size, BUDGET_SEGMENT_CHUNK):  # bounded memory on large cameras
        part = slice(start, start + BUDGET_SEGMENT_CHUNK)
        pu, pv = ray_projector_points(
            calib,
            zrange,
            cc[part].astype(np.float64),
            rr[part].astype(np.float64),
            step_px=BUDGET_SEGMENT_STEP_PX,
        )
        ok = np.isfinite(pu) & np.isfinite(pv)
        ci, ri = np.rint(pu[ok]).astype(np.intp), np.rint(pv[ok]).astype(np.intp)
        inside = (ci >= 0) & (ci < proj.width) & (ri >= 0) & (ri < proj.height)
        pmap[ri[inside], ci[inside]] = BUDGET_SAFE_MIGL
    return erode_map(pmap, footprint + BUDGET_SAFE_MARGIN_PX)


def _dimmed_probe(run: _Run, spec: FringeSpec, shot: NDArray) -> _DimmedProbe:
    """The budget's probe with a depth range, after its full-MIGL first shift ``shot`` clipped
    somewhere: its other shifts dimmed along the clipped pixels' epipolar segments
    (:func:`_segment_map`, floor at black), their first shift completed from them
    (:func:`_with_first_shift`). Where each pixel looks, to know what it received: the three
    shifts' own phase ordered from the geometry, the row from the calibration."""
    bits, full = run.bits, float(spec.migl)
    calib, zrange = run.geometric_inputs
    clipped = saturation_count(shot, bits) > 0
    pmap = _segment_map(run, clipped)
    rest = _capture(run.rig, _floored_frames(spec, pmap)[1:], run.settings)
    completed = _with_first_shift(rest, bits)
    dec = decode_set(completed, spec, bits)
    phase = np.where(dec.valid, dec.wrapped_phase, np.nan)
    ordered = _geometric_orders(phase, spec.pitch_px, spec.orientation, calib, zrange)
    absolute = _plane_mean(ordered.absolute_phase, MEDIAN_WINDOW)
    u = fill_holes(projector_coordinates(absolute, spec.pitch_px))
    v = epipolar_rows(calib, u)
    # the map around where each pixel looks (its footprint and the coordinate's error): all
    # dimmed, all full, or both (the pixel straddles the step)
    from scipy import ndimage  # here: measure imports this module (cold start, issue 16)

    size = 2 * BUDGET_STRADDLE_PX + 1
    lo = sample_map(ndimage.minimum_filter(pmap, size, mode="nearest"), u, v)
    hi = sample_map(ndimage.maximum_filter(pmap, size, mode="nearest"), u, v)
    got = sample_map(pmap, u, v)
    dimmed = (hi < full) | (~np.isfinite(got) & clipped)
    usable = dimmed | ~(lo < full)
    levels = np.where(dimmed, np.where(np.isfinite(got), got, BUDGET_SAFE_MIGL), full)
    levels = np.where(usable, levels, np.where(np.isfinite(got), got, full))
    images = np.where(dimmed[None], completed, np.concatenate([shot, rest]))
    floor = lowered_floor(levels, spec.imin, BUDGET_FLOOR_SPAN)
    # the dimmed pixels whose response says the full-MIGL probe would have clipped them are
    # the highlight as much as those its first shift clipped (the full probe's own set)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = 2.0 * dec.modulation / (levels - floor)
        peak = dec.mean_intensity + g * (full - (levels + floor) / 2.0)
    clipped = clipped | (dimmed & dec.valid & (peak >= full_scale(bits)))
    # weak: a fringe too faint to order the finer set, dimmed or not (beside the dimmed
    # region a coordinate off by a few pixels puts a pixel on the wrong side of the step)
    limit = BUDGET_DIM_MIN_MODULATION * full_scale(bits) / 255.0
    weak = ~(decode_set(images, spec, bits).modulation >= limit)
    return _DimmedProbe(images, pmap, levels, floor, clipped, dimmed, usable, usable & ~weak)


def _spec_at(template: FringeSpec, orient: str, pitch: float, migl: float) -> FringeSpec:
    """``template``'s set at another pitch, orientation and MIGL."""
    return FringeSpec(template.pattern, template.steps, pitch, orient, template.imin, migl)  # type: ignore[arg-type]


@dataclass
class _Response:
    """The response ``I = a g + c`` estimated from each set that gives one (internal)."""

    imin: float
    gains: list[NDArray[np.float64]] = field(default_factory=list)
    ambients: list[NDArray[np.float64]] = field(default_factory=list)
    weights: list[NDArray[np.float64]] = field(default_factory=list)

    def add(
        self,
        dec: Any,
        m: float | NDArray,
        where: NDArray[np.bool_],
        floor: NDArray[np.float64] | None = None,
    ) -> None:
        """The response of a set decoded as ``dec``, projected at ``m`` (with ``floor``, per
        pixel, where not ``imin``), at ``where``."""
        imin: float | NDArray[np.float64] = self.imin if floor is None else floor
        mm = np.broadcast_to(np.asarray(m, np.float64), where.shape)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = 2.0 * dec.modulation / (mm - imin)
            c = dec.mean_intensity - g * (mm + imin) / 2.0
        ok = where & dec.valid
        self.gains.append(np.where(ok, g, np.nan))
        self.ambients.append(np.where(ok, c, np.nan))
        self.weights.append(np.where(ok, (mm - imin) ** 2, 0.0))  # the estimate's SNR squared

    def combined(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Gain and ambient averaged per pixel with the weights (the estimates' SNR squared),
        then median-smoothed (a low-MIGL set is a noisy response: the median keeps its
        edges)."""
        w = np.stack(self.weights)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # pixels valid in no set stay NaN
            g_stack, c_stack = np.stack(self.gains), np.stack(self.ambients)
            wsum = np.sum(np.where(np.isfinite(g_stack), w, 0.0), axis=0)
            gain = np.nansum(g_stack * w, axis=0) / wsum
            ambient = np.nansum(c_stack * w, axis=0) / wsum
        return median_smooth(gain, MEDIAN_WINDOW), median_smooth(ambient, MEDIAN_WINDOW)


def _auto_mapping_migl(
    dec: Any,
    g: NDArray[np.float64],
    c: NDArray[np.float64],
    bits: int,
    template: FringeSpec,
    migl: float,
    current: float,
) -> float:
    """The MIGL of the next mapping sets: the highest the first set's response (``g``, ``c``)
    says keeps every pixel :data:`AUTO_MAPPING_MARGIN` below clipping, never below ``migl``
    (``current`` where no pixel gives one)."""
    level = safe_migl(
        median_smooth(np.where(dec.valid, g, np.nan), MEDIAN_WINDOW),
        median_smooth(np.where(dec.valid, c, np.nan), MEDIAN_WINDOW),
        bits,
        margin=AUTO_MAPPING_MARGIN,
        imin=template.imin,
        projector_full=template.migl,
    )
    if np.isfinite(level).any():
        return float(max(migl, np.floor(np.nanmin(level))))
    return current


def _merge_full_migl_ladder(
    rig: Rig,
    template: FringeSpec,
    pitches: dict[str, list[float]],
    images: dict[str, list[NDArray]],
    index: dict[str, list[NDArray[np.float32]]],
    response: _Response,
    settings: CameraSettings | None,
) -> None:
    """The ladder captured again at the full MIGL and merged per pixel where it does not
    clip (Eq. 5.1), in place; each one-period set's bright capture added to the response."""
    bits = rig.camera_bit_depth
    bright = float(template.migl)
    for orient, ps in pitches.items():
        for k, p in enumerate(ps):
            spec = _spec_at(template, orient, p, bright)
            imgs_b = _capture(rig, spec.frames(), settings)
            take = saturation_count(imgs_b, bits) == 0
            images[orient][k] = np.where(take, imgs_b, images[orient][k])
            index[orient][k] = np.where(take, np.float32(bright), index[orient][k])
            if k == 0:
                response.add(decode_set(imgs_b, spec, bits), bright, take)


#: Budget with a depth range: the least fraction of the coarsest set's decoded pixels the
#: geometry must order; below it the depth range, not the scene, is what failed.
GEOMETRIC_MIN_ORDERED = 0.5


def _geometric_orders(
    phase: NDArray[np.float64],
    pitch: float,
    orientation: str,
    calib: StereoCalibration,
    zrange: tuple[float, float],
) -> GeometricOrder:
    """:func:`~hdrfringe.core.geometric_order.geometric_order` of the coarsest set; InputError
    naming the depth range where it orders fewer than :data:`GEOMETRIC_MIN_ORDERED` of the
    decoded pixels (a range too deep for the pitch, or one the scene lies outside)."""
    ordered = geometric_order(phase, pitch, orientation, calib, zrange)
    info = ordered.summary()
    if info["decoded_pixels"] and info["valid_fraction"] < GEOMETRIC_MIN_ORDERED:
        raise InputError(
            f"adaptive: the depth range {zrange[0]:g}..{zrange[1]:g} mm gives "
            f"{100 * info['valid_fraction']:.0f} % of the {pitch:g} px set's decoded pixels a "
            f"fringe order ({100 * info['ambiguous_fraction']:.0f} % ambiguous: deeper than "
            f"one order of {pitch:g} px allows; {100 * info['no_candidate_fraction']:.0f} % "
            "without one: the scene outside it); give the measuring volume's depths along the "
            "camera axis (--depth-range ZMIN:ZMAX, docs/stereo.md) or a coarser pitch"
        )
    return ordered


def _unwrap_ladder(
    images: list[NDArray],
    sets: list[FringeSpec],
    bits: int,
    first_window: int | None = None,
    fill_first: bool = False,
    geometric: tuple[StereoCalibration, tuple[float, float]] | None = None,
    first_mask: NDArray[np.bool_] | None = None,
    order_mask: NDArray[np.bool_] | None = None,
) -> NDArray[np.float64]:
    """One orientation's mapping ladder unwrapped temporally, coarsest set first; each level
    median-smoothed: the low-MIGL phases are noisy, smoothing each level before it predicts
    the next one's fringe order keeps the orders where a plain unwrap would slip.
    ``first_window``: the coarsest level averaged on the circle over that window instead
    (the budget's set completed from three low shifts: noisier than four). ``fill_first``:
    the coarsest level's holes filled from their neighbours (the budget's probe clipped where
    the dimmed later sets decode: a one-period phase is smooth enough to order them).
    ``geometric``: a calibration and depth range: the coarsest set spans no projector, it is
    ordered pixel by pixel from the geometry
    (:func:`~hdrfringe.core.geometric_order.geometric_order`; NaN where no single
    order fits), then averaged with a plane over that window (:func:`_plane_mean`).
    ``first_mask``: the coarsest set's pixels that may be used. ``order_mask`` (with
    ``geometric``): the coarsest level averaged over these pixels alone (NaN elsewhere):
    pixels whose phase places them but is too poor to order a finer set neither order nor
    bias their neighbours."""
    phases = []
    for imgs, spec in zip(images, sets, strict=True):
        # a merged set decodes as one: the phase does not depend on the MIGL
        d = decode_set(imgs, spec, bits)
        phases.append(np.where(d.valid, d.wrapped_phase, np.nan))
    if first_mask is not None:
        phases[0] = np.where(first_mask, phases[0], np.nan)
    ps = [s.pitch_px for s in sets]
    if geometric is not None:
        calib, zrange = geometric
        window = MEDIAN_WINDOW if first_window is None else first_window
        ordered = _geometric_orders(phases[0], ps[0], sets[0].orientation, calib, zrange)
        mask = np.ones(phases[0].shape, bool) if order_mask is None else order_mask
        current = _plane_mean(np.where(mask, ordered.absolute_phase, np.nan), window)
    elif first_window is None:
        current = median_smooth(phases[0], MEDIAN_WINDOW)
    else:
        current = _circular_mean(phases[0], first_window)
    if fill_first:
        current = fill_holes(current)
    for k in range(1, len(ps)):
        current = unwrap_temporal([current, phases[k]], ps[k - 1 : k + 1], coarse_unwrapped=True)
        current = median_smooth(current, MEDIAN_WINDOW)
    return current


def _circular_mean(phase: NDArray[np.float64], size: int) -> NDArray[np.float64]:
    """The wrapped ``phase`` averaged as unit vectors over a ``size`` x ``size`` window (NaN
    ignored, stays NaN), in [0, 2 pi) as the decoder gives it: unbiased on a ramp, a
    one-period phase's wrap kept."""
    from scipy.ndimage import uniform_filter

    ok = np.isfinite(phase)
    z = np.where(ok, np.exp(1j * np.where(ok, phase, 0.0)), 0.0)
    re = uniform_filter(z.real, size, mode="nearest")
    im = uniform_filter(z.imag, size, mode="nearest")
    return np.where(ok, np.mod(np.arctan2(im, re), 2 * np.pi), np.nan)


def _plane_mean(values: NDArray[np.float64], size: int) -> NDArray[np.float64]:
    """A continuous map (an absolute phase) averaged over a ``size`` x ``size`` window with
    a plane: the window's mean less its local gradient times the offset of the window's
    valid pixels' centroid from the pixel (NaN ignored, stays NaN). Unbiased on a ramp beside
    holes and edges, where a plain mean gives the value at the centroid (a 64 px fringe turns
    some 0.16 rad per camera pixel at 648 x 494: a centroid 3 px off is 0.5 rad, more than
    an 8 px set's order tolerates). The gradient is the window's mean difference between
    neighbouring valid pixels. Outside the image counts as no data (a border pixel's window
    holds only real pixels; repeating the edge would weigh a corner pixel 64 times in 225)."""
    from scipy.ndimage import uniform_filter

    ok = np.isfinite(values)
    weight = uniform_filter(ok.astype(np.float64), size, mode="constant")
    with np.errstate(invalid="ignore", divide="ignore"):
        out = uniform_filter(np.where(ok, values, 0.0), size, mode="constant") / weight
        for axis in (0, 1):
            index = np.indices(values.shape, dtype=np.float64)[axis]
            offset = uniform_filter(np.where(ok, index, 0.0), size, mode="constant") / weight
            step = np.diff(values, axis=axis, append=np.nan)  # forward difference
            pair = np.isfinite(step)
            gradient = uniform_filter(np.where(pair, step, 0.0), size, mode="constant") / (
                uniform_filter(pair.astype(np.float64), size, mode="constant")
            )
            out = out - np.where(np.isfinite(gradient), gradient, 0.0) * (offset - index)
    return np.where(ok, out, np.nan)


def _correct_map_bias(
    absolute: NDArray[np.float64],
    reference: NDArray[np.float64],
    maps: list[NDArray[np.float64]],
    source: NDArray[np.intp],
    u: NDArray[np.float64],
    v: NDArray[np.float64],
    spec: FringeSpec,
    imin: float,
    radius: float,
    floor_span: float | None = None,
    smooth_region: NDArray[np.bool_] | None = None,
    footprint: float = 0.0,
) -> tuple[NDArray[np.float64], float]:
    """Subtract the phase bias of the projected maps, with the blur fitted to the mapping
    (``floor_span``: the maps' floor falls below ``imin + floor_span``, the budget's).

    The mapping sets were projected at one MIGL: their phase carries the surface's own bias
    but not the map's, so the residual of the adapted phase against it is the map's bias plus
    noise (:func:`~hdrfringe.core.saturation.adaptive_map.fit_blur_sigma`). With
    ``smooth_region`` (the budget's, where the mapping was dimmed around a highlight: no
    reference there, and the map's largest step) the blur is instead the one that leaves the
    corrected phase smoothest there (:func:`_blur_from_smoothness`; ``footprint``: the
    camera pixel's, in projector pixels).
    """

    residual = (absolute - reference).ravel()
    # one blur for the field: fit it on an evenly spread subset of the pixels (fast at any
    # camera size), then correct every pixel
    usable = np.flatnonzero(np.isfinite(residual))
    fit_on = usable[:: max(1, usable.size // FIT_PIXELS)]

    def bias_of(sigma: float, where: NDArray[np.intp]) -> NDArray[np.float64]:
        out = np.full(where.size, np.nan)
        src = source.ravel()[where]
        for j, pm in enumerate(maps):
            sel = src == j
            if sel.any():
                out[sel] = map_phase_bias(
                    pm,
                    u.ravel()[where][sel][None, :],
                    v.ravel()[where][sel][None, :],
                    pitch_px=spec.pitch_px,
                    orientation=spec.orientation,
                    sigma_px=sigma,
                    imin=imin,
                    floor_span=floor_span,
                )[0]
        return out

    if smooth_region is not None and smooth_region.sum() >= BUDGET_SMOOTH_MIN_PIXELS:
        sigma = _blur_from_smoothness(
            absolute, smooth_region, bias_of, footprint / np.sqrt(12.0), max(1.0, radius)
        )
    else:
        sigma = fit_blur_sigma(residual[fit_on], lambda s: bias_of(s, fit_on), max(1.0, radius))
    bias = bias_of(sigma, np.arange(residual.size)).reshape(absolute.shape)
    # a predicted bias below BIAS_MIN_RAD is within the model's own error: left alone
    apply = np.isfinite(bias) & (np.abs(bias) >= BIAS_MIN_RAD)
    return absolute - np.where(apply, bias, 0.0), sigma


def _blur_from_smoothness(
    absolute: NDArray[np.float64],
    region: NDArray[np.bool_],
    bias_of: Any,
    min_sigma: float,
    max_sigma: float,
) -> float:
    """The blur (``min_sigma`` to ``max_sigma`` in steps of :data:`BUDGET_BLUR_STEP_PX`) whose
    map bias, subtracted, leaves ``absolute`` smoothest over ``region``: the least mean
    squared Laplacian, over the pixels whose 3 x 3 neighbourhood has a phase. The surface's
    phase is smooth; a bias under- or over-corrected at a map step is not. ``bias_of(sigma,
    flat indices)`` is the bias model. ``min_sigma``: the camera pixel's footprint as a box
    (``footprint / sqrt(12)``), the least blur there is; the model sampled at a finer blur
    than the pixels' own is rougher than the phase left uncorrected, which is not smoother
    for it (specular part, 648 x 494: uncorrected the smoothest, while a 0.7 px correction
    halves the error against the rig's truth)."""
    from scipy import ndimage

    rows = np.flatnonzero(region.any(axis=1))
    cols = np.flatnonzero(region.any(axis=0))
    h, w = absolute.shape
    r0, r1 = max(rows[0] - 2, 0), min(rows[-1] + 3, h)
    c0, c1 = max(cols[0] - 2, 0), min(cols[-1] + 3, w)
    box = absolute[r0:r1, c0:c1]
    finite = np.isfinite(box)
    inner = region[r0:r1, c0:c1] & ndimage.minimum_filter(finite, 3, mode="constant")
    rr, cc = np.nonzero(finite)
    where = (rr + r0) * w + (cc + c0)
    best, best_score = float(min_sigma), np.inf
    for sigma in np.arange(float(min_sigma), float(max_sigma) + 1e-9, BUDGET_BLUR_STEP_PX):
        corrected = np.zeros(box.shape)
        b = bias_of(float(sigma), where)
        corrected[rr, cc] = box[rr, cc] - np.where(np.isfinite(b), b, 0.0)
        score = float(np.mean(ndimage.laplace(corrected)[inner] ** 2))
        if score < best_score:
            best, best_score = float(sigma), score
    return best


def _capture_topup(
    rig: Rig,
    spec: FringeSpec,
    need: NDArray[np.bool_],
    reference_ms: float | None,
    max_sets: int = TOPUP_MAX_SETS,
) -> tuple[list[tuple[float, NDArray]], str | None]:
    """The top-up sets: ``spec`` at its full MIGL at exposures short enough for ``need``.

    The first at ``reference_ms / TOPUP_FIRST_DIVISOR``, each next one 4x shorter while
    pixels of ``need`` still clip, at most :data:`TOPUP_MAX_SETS`. Returns the
    ``(exposure_ms, images)`` captured and, when none could be, why.
    """
    if reference_ms is None or not (np.isfinite(reference_ms) and reference_ms > 0):
        return [], "the rig reports no exposure time to shorten"
    bits = rig.camera_bit_depth
    t = float(f"{reference_ms / TOPUP_FIRST_DIVISOR:.4g}")
    out: list[tuple[float, NDArray]] = []
    for _ in range(max_sets):
        try:
            imgs = rig.capture(spec.frames(), CameraSettings(exposure_ms=t))
        except HdrFringeError as exc:  # e.g. a replayed folder: its exposures are fixed
            return out, f"the rig cannot capture at {t:g} ms ({exc})"
        out.append((t, imgs))
        if not (need & (saturation_count(imgs, bits) > 0)).any():
            break
        t = float(f"{t / 4.0:.4g}")
    return out, None


def _orders_from_neighbours(
    absolute: NDArray[np.float64],
    wrapped: NDArray[np.float64],
    valid: NDArray[np.bool_],
    seeds: NDArray[np.bool_],
) -> tuple[NDArray[np.float64], int]:
    """Fringe orders for the top-up's pixels, which the mapping could not give (it clipped).

    Each patch of decoded pixels without an order that holds a pixel of ``seeds`` (the
    top-up's), with a ring of :data:`ORDER_RING_PX` pixels of known absolute phase, is
    unwrapped spatially (:func:`~hdrfringe.core.unwrap.unwrap_spatial`) and shifted by the whole
    number of periods that puts the ring on its known phase (the median over the ring). The
    patch keeps no phase where the ring disagrees: fewer than :data:`ORDER_RING_AGREE` of its
    pixels within a quarter period of the shift (a fringe sampled too coarsely for spatial
    unwrapping, more than half a period per camera pixel). Returns the phase and the pixels
    given an order.
    """
    missing = valid & np.isfinite(wrapped) & ~np.isfinite(absolute)
    if not (missing & seeds).any():
        return absolute, 0
    from scipy import ndimage  # here: measure imports this module (cold start, issue 16)

    patches, n = ndimage.label(missing)
    keep = np.zeros(n + 1, bool)
    keep[np.unique(patches[missing & seeds])] = True
    keep[0] = False
    missing &= keep[patches]
    known = np.isfinite(absolute)
    ring = ndimage.binary_dilation(missing, iterations=ORDER_RING_PX) & known
    region = missing | ring
    unwrapped = unwrap_spatial(np.where(region, wrapped, np.nan), region)
    labels, n = ndimage.label(region)
    out = absolute.copy()
    given = 0
    for j in range(1, n + 1):
        patch = labels == j
        anchor = patch & ring & np.isfinite(unwrapped)
        fill = patch & missing & np.isfinite(unwrapped)
        if not anchor.any() or not fill.any():
            continue
        shift = (absolute[anchor] - unwrapped[anchor]) / (2 * np.pi)
        k = np.rint(np.median(shift))
        if np.mean(np.abs(shift - k) < 0.25) < ORDER_RING_AGREE:
            continue
        out[fill] = unwrapped[fill] + 2 * np.pi * k
        given += int(fill.sum())
    return out, given


def _check_specs(rig: Rig, specs: Sequence[FringeSpec]) -> list[FringeSpec]:
    specs = list(specs)
    if not specs:
        raise InputError("adaptive needs at least one fringe set to measure")
    for s in specs:
        check_fringe_spec(s, rig)
        if s.pattern != "sinusoidal" or s.steps < 3 or not s.has_standard_phase:
            raise InputError(
                f"adaptive needs sinusoidal sets of at least 3 equal shifts (the response is "
                f"read from the fringe modulation); got {s.pattern} {s.steps}-step"
            )
    first = specs[0]
    for s in specs[1:]:
        if (s.steps, s.imin, s.migl) != (first.steps, first.imin, first.migl):
            raise InputError(
                "adaptive needs every set with the same steps, imin and MIGL; got "
                f"{first.steps}/{first.imin:g}/{first.migl:g} and {s.steps}/{s.imin:g}/{s.migl:g}"
            )
    return specs


def _epipolar_calibration(
    rig: Rig,
    specs: Sequence[FringeSpec],
    epipolar: bool,
    calibration: StereoCalibration | None,
) -> StereoCalibration | None:
    """The calibration the epipolar mapping uses (None: both orientations are mapped)."""
    if not epipolar:
        if calibration is not None:
            raise InputError(
                "adaptive: stereo_calibration is used by the epipolar mapping only; give "
                "epipolar=True (--adaptive-epipolar) or drop it"
            )
        return None
    if any(s.orientation != "vertical" for s in specs):
        raise InputError(
            "adaptive --adaptive-epipolar maps vertical fringes only (the row comes from the "
            "calibration); measure vertical sets only, or drop --adaptive-epipolar"
        )
    if calibration is None:
        own = getattr(rig, "stereo_calibration", None)
        if not callable(own):
            raise InputError(
                f"adaptive --adaptive-epipolar needs a projector-camera calibration and the "
                f"{type(rig).__name__} rig has none; give one (measure --calibration "
                "STEREO.h5, or stereo_calibration= in Python) or drop --adaptive-epipolar"
            )
        calibration = own()
    if not isinstance(calibration, StereoCalibration):
        raise InputError(
            "adaptive: stereo_calibration must be a hdrfringe.core.stereo.StereoCalibration, got "
            f"{type(calibration).__name__}"
        )
    cam = (rig.image_shape[1], rig.image_shape[0])
    proj = (rig.projector.width, rig.projector.height)
    if tuple(calibration.camera.size) != cam or tuple(calibration.projector.size) != proj:
        raise InputError(
            f"adaptive: the stereo calibration is for a {calibration.camera.size} camera and a "
            f"{calibration.projector.size} projector, the rig has {cam} and {proj}; give this "
            "rig's calibration"
        )
    return calibration


def _checked_inputs(
    rig: Rig, specs: Sequence[FringeSpec], params: AdaptiveParams
) -> tuple[list[FringeSpec], StereoCalibration | None, float]:
    """The sets, the epipolar calibration and the mapping MIGL; InputError for what the
    strategy cannot do."""
    specs = _check_specs(rig, specs)
    margin, exposure_ms = params.margin, params.exposure_ms
    if not 0.0 <= float(margin) < 1.0:
        raise InputError(f"adaptive margin must be a fraction in [0, 1), got {margin!r}")
    iterations = params.iterations
    if isinstance(iterations, bool) or int(iterations) != iterations or iterations < 0:
        raise InputError(f"adaptive iterations must be a whole number >= 0, got {iterations!r}")
    for name, value in (("blur_px", params.blur_px), ("smooth_px", params.smooth_px)):
        if value is not None and not float(value) >= 0:
            raise InputError(f"adaptive {name} must be >= 0 projector pixels, got {value!r}")
    if exposure_ms is not None and not float(exposure_ms) > 0:
        raise InputError(f"adaptive exposure_ms must be > 0, got {exposure_ms!r}")
    if params.auto_exposure and exposure_ms is not None:
        raise InputError(
            "adaptive: give a fixed exposure (--adaptive-exposure-ms) or the automatic one "
            "(--adaptive-auto-exposure), not both"
        )
    calib = _epipolar_calibration(rig, specs, params.epipolar, params.stereo_calibration)
    if params.depth_range_mm is not None:
        if params.max_images is None:
            raise InputError(
                "adaptive depth_range_mm orders the image budget's coarsest set; give "
                "max_images (--max-images) or drop the depth range"
            )
        check_depth_range(params.depth_range_mm)
    if params.full_mapping and params.mapping_migl is not None:
        raise InputError(
            "adaptive: --adaptive-full-mapping chooses the mapping MIGL itself; drop "
            "--mapping-migl or --adaptive-full-mapping"
        )
    if params.full_mapping and not params.topup:
        raise InputError(
            "adaptive: --adaptive-full-mapping leaves the pixels that clip at the full MIGL to "
            "the top-up; drop --no-adaptive-topup or --adaptive-full-mapping"
        )
    first = specs[0]
    m0 = default_min_migl(first) if params.mapping_migl is None else float(params.mapping_migl)
    if not first.imin < m0 <= first.migl:
        raise InputError(
            f"adaptive mapping_migl must be above imin {first.imin:g} and at most the MIGL "
            f"{first.migl:g}, got {m0:g}"
        )
    return specs, calib, m0


def _plan_ladders(
    rig: Rig, specs: list[FringeSpec], calib: StereoCalibration | None, geometric: bool = False
) -> tuple[dict[str, int], dict[str, list[float]]]:
    """Per orientation the index of the finest set (the adapted one) and the mapping ladder,
    which includes the measurement's coarser pitches (those sets are the mapping's own
    captures); the orientation the measurement does not unwrap first. ``geometric`` (a
    calibration and a depth range order the coarsest set): the ladder is the measurement's
    coarser sets alone, where it has any."""
    proj = rig.projector
    finest_any = min(s.pitch_px for s in specs)
    finest: dict[str, int] = {}
    pitches: dict[str, list[float]] = {}
    for orient in ORIENTATIONS:
        if calib is not None and not any(s.orientation == orient for s in specs):
            continue  # the epipolar constraint gives this coordinate
        extent = proj.width if orient == "vertical" else proj.height
        own = sorted(
            (i for i, s in enumerate(specs) if s.orientation == orient),
            key=lambda i: -specs[i].pitch_px,
        )
        target = specs[own[-1]].pitch_px if own else finest_any
        coarser = {specs[i].pitch_px for i in own[:-1]}
        if geometric and coarser:
            ladder = coarser
        else:
            ladder = set(mapping_pitches(extent, target)) | coarser
        pitches[orient] = sorted(ladder, reverse=True)
        if own:
            finest[orient] = own[-1]
            if any(specs[i].pitch_px == target for i in own[:-1]):
                raise InputError(f"adaptive: two {orient} sets of pitch {target:g} px")
    # the first (darkest, noisiest) set in the orientation the measurement does not unwrap
    pitches = {o: pitches[o] for o in sorted(pitches, key=lambda o: o in finest)}
    return finest, pitches


@dataclass
class _Budget:
    """The images a run may still capture (``max_images``) and the steps it had to skip."""

    limit: int
    left: int
    skipped: list[str] = field(default_factory=list)

    def afford(self, step: str, images: int) -> bool:
        """Charge ``images`` for one set of ``step`` if they fit; else record the skip."""
        if images <= self.left:
            self.left -= images
            return True
        if step not in self.skipped:
            self.skipped.append(step)
        return False


@dataclass
class _Run:
    """One adaptive run's settled inputs: sets, parameters, exposure and ladders (internal)."""

    rig: Rig
    specs: list[FringeSpec]
    params: AdaptiveParams
    calib: StereoCalibration | None
    #: the exposure of every capture (None: the rig's) and (exposure, MIGL) of each set the
    #: automatic exposure captured
    exposure_ms: float | None
    chosen: list[tuple[float, float]]
    finest: dict[str, int]
    pitches: dict[str, list[float]]
    seconds: dict[str, float]
    #: the image budget (``max_images``); None: none
    budget: _Budget | None = None
    #: the exposure the top-up shortens (None: the adapted sets'); the budget's raised
    #: exposure is not what its highlight clipped at, the mapping's is
    topup_reference_ms: float | None = None

    def afford(self, step: str) -> bool:
        """Whether one more set of ``step`` fits the budget (and charge it); always without."""
        return self.budget is None or self.budget.afford(step, self.first.steps)

    @property
    def geometric(self) -> tuple[StereoCalibration, tuple[float, float]] | None:
        """The calibration and depth range that order the coarsest set (None: a one-period
        set does)."""
        zrange = self.params.depth_range_mm
        if self.calib is None or zrange is None or self.budget is None:
            return None
        return self.calib, check_depth_range(zrange)

    @property
    def geometric_inputs(self) -> tuple[StereoCalibration, tuple[float, float]]:
        """:attr:`geometric`, which the caller knows is set."""
        geo = self.geometric
        assert geo is not None
        return geo

    @property
    def first(self) -> FringeSpec:
        return self.specs[0]

    @property
    def bits(self) -> int:
        return self.rig.camera_bit_depth

    @property
    def settings(self) -> CameraSettings | None:
        return (
            None
            if self.exposure_ms is None
            else CameraSettings(exposure_ms=float(self.exposure_ms))
        )


def _choose_exposure_first(
    rig: Rig, specs: list[FringeSpec], params: AdaptiveParams
) -> tuple[float | None, list[tuple[float, float]], float]:
    """Step 0: with ``auto_exposure`` the exposure chosen on the finest set at its highest
    MIGL (thesis Sec. 7.3); the exposure, the sets the choice captured and its seconds."""
    t0 = time.perf_counter()
    exposure_ms = params.exposure_ms
    chosen: list[tuple[float, float]] = []  # (exposure, MIGL) of each set the choice captured
    if params.auto_exposure:
        fine = min(specs, key=lambda s: s.pitch_px)
        choice = choose_exposure(rig, fine, keep_if_unsaturated=True)
        chosen = [(t, float(fine.migl)) for t, _ in choice.captures]
        exposure_ms = choice.exposure_ms
    return exposure_ms, chosen, time.perf_counter() - t0


@dataclass
class _MappingOutcome:
    """Step 1's result: the mapping, the camera pixels' projector coordinates (internal)."""

    mp: _Mapping
    #: the MIGL of the first mapping set (the full MIGL when the full-MIGL mapping was kept)
    m0: float
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    #: the full-MIGL first set that was not kept (counted), whether it was kept, what clipped
    trial: list[float]
    full_mapped: bool
    full_clipped: float | None


def _map_camera_to_projector(
    run: _Run,
    m0: float,
    probe: NDArray | None = None,
    allow_bright: bool = True,
    low_first: tuple[NDArray, float] | None = None,
) -> _MappingOutcome:
    """Step 1: the mapping (at a low MIGL, or at the full one where only a highlight clips in
    its first set): response, coordinates, fringe orders. ``probe``: the first set already
    captured at the full MIGL (the budget's; the full-MIGL mapping then). ``low_first``: the
    first set already captured at ``m0`` and what clipped of its first shift at the full MIGL
    (the budget's one-shift probe; the low-MIGL mapping then)."""
    t0 = time.perf_counter()
    first, pitches, settings = run.first, run.pitches, run.settings
    trial: list[float] = []  # a full-MIGL first set that was not kept (counted)
    trial_images: tuple[NDArray, float] | None = None
    full_mapped = False
    full_clipped: float | None = None
    mp: _Mapping | None = None
    if low_first is not None:
        full_clipped = low_first[1]
        mp = _measure_mapping(
            run.rig,
            first,
            pitches,
            m0,
            settings,
            auto=run.params.mapping_migl is None,
            first_images=low_first[0],
            allow_bright=allow_bright,
            first_window=BUDGET_FIRST_WINDOW,
            geometric=run.geometric,
        )
    elif run.params.full_mapping or probe is not None:
        o0 = next(iter(pitches))
        spec0 = FringeSpec(first.pattern, first.steps, pitches[o0][0], o0, first.imin, first.migl)  # type: ignore[arg-type]
        imgs0 = _capture(run.rig, spec0.frames(), settings) if probe is None else probe
        full_clipped = float(np.mean(saturation_count(imgs0, run.bits) > 0))
        if full_clipped <= FULL_MAPPING_MAX_CLIPPED:
            m0, full_mapped = float(first.migl), True
            # the budget's one ladder: the pixels the probe clipped measured, dimmed, after it
            # (with a depth range the probe was dimmed itself: _dimmed_probe)
            budget_probe = run.budget is not None and probe is not None
            dim = run.calib if budget_probe and run.geometric is None else None
            mp = _measure_mapping(
                run.rig,
                first,
                pitches,
                m0,
                settings,
                auto=False,
                first_images=imgs0,
                dim=dim,
                geometric=run.geometric,
            )
        else:
            trial, trial_images = [float(first.migl)], (imgs0, float(first.migl))
    if mp is None:
        mp = _measure_mapping(
            run.rig,
            first,
            pitches,
            m0,
            settings,
            auto=run.params.mapping_migl is None,
            trial=trial_images,
            allow_bright=allow_bright,
            geometric=run.geometric,
        )
    u = mp.coords["vertical"]
    v = mp.coords["horizontal"] if run.calib is None else epipolar_rows(run.calib, u)
    run.seconds["mapping"] = time.perf_counter() - t0
    return _MappingOutcome(mp, m0, u, v, trial, full_mapped, full_clipped)


def _resolved(width: float | None) -> float:
    """A map width (``blur_px``, ``smooth_px``) after :func:`_run_adaptive` resolved None."""
    assert width is not None
    return float(width)


@dataclass
class _Projection:
    """Step 2's result: the camera-side levels carried to the projector (internal).

    What every adapted pass needs: the camera pixels' projector coordinates (``uf``, ``vf``:
    the clipped pixels' borrowed from their neighbours), the erosion radius, and how a MIGL
    map is built from camera-side levels and projected.
    """

    run: _Run
    uf: NDArray[np.float64]
    vf: NDArray[np.float64]
    shape: tuple[int, int]
    radius: float
    ambient: NDArray[np.float64]
    mapped: NDArray[np.bool_]
    base_levels: NDArray[np.float64]
    first_map: NDArray[np.float64] | None = None
    #: the budget's maps: below the lowest usable MIGL the floor falls with the map
    #: (:func:`_floored_frames`), else every level below it shows ``imin``
    low_floor: bool = False

    @property
    def imin(self) -> float:
        return self.run.first.imin

    @property
    def full(self) -> float:
        return float(self.run.first.migl)

    def build(self, cam_levels: NDArray[np.float64]) -> NDArray[np.float64]:
        """The projector MIGL map of camera-side levels (eroded, smoothed from below); the
        budget's may fall below ``imin`` (:func:`_floored_frames` projects them)."""
        pm = projector_migl_map(
            cam_levels,
            self.uf,
            self.vf,
            self.shape,
            radius=self.radius,
            sigma=_resolved(self.run.params.smooth_px),
            imin=0.0 if self.low_floor else self.imin,
            projector_full=self.full,
        )
        return pm

    def shoot(self, spec: FringeSpec, pmap: NDArray[np.float64]) -> NDArray:
        """Capture ``spec`` projected with the per-pixel MIGL map ``pmap``."""
        frames: list[Any]
        if self.low_floor and bool((pmap < self.imin + BUDGET_FLOOR_SPAN).any()):
            frames = _floored_frames(spec, pmap)
        else:
            steps = self.run.first.steps
            frames = [PixelwiseFringeFrame(spec, k, pmap.astype(np.float32)) for k in range(steps)]
        return _capture(self.run.rig, frames, self.run.settings)

    def sample(self, pmap: NDArray[np.float64]) -> NDArray[np.float64]:
        """What each camera pixel receives of the map ``pmap``."""
        return sample_map(pmap, self.uf, self.vf)


def _plan_projector_map(run: _Run, mapping: _MappingOutcome, scale: float = 1.0) -> _Projection:
    """Step 2: per camera pixel the highest safe MIGL, carried to the projector. ``scale``:
    the adapted sets' exposure over the mapping's (the response scales with it)."""
    t0 = time.perf_counter()
    first, mp, u, v = run.first, mapping.mp, mapping.u, mapping.v
    full_p = float(first.migl)
    low_floor = run.budget is not None  # the budget's maps may fall below imin
    base_levels = safe_migl(
        mp.gain * scale,
        mp.ambient * scale,
        run.bits,
        margin=run.params.margin,
        imin=0.0 if low_floor else first.imin,
        projector_full=full_p,
    )
    # pixels clipped in the mapping: their response is unknown (but where the budget's dimmed
    # sets measured it), start them half way down
    unknown = mp.saturated if mp.safe is None else mp.saturated & ~mp.safe
    base_levels[unknown] = first.imin + (mapping.m0 - first.imin) / 2.0
    if scale > 1.0:  # a longer exposure than the mapping's: those clip at any higher level
        base_levels[unknown] = default_min_migl(first)
    if mp.dim_map is not None:
        # clipped in the dimmed sets too: brighter than BUDGET_SAFE_MIGL clips at the
        # mapping's exposure, so below it scaled to the chosen one (less the margin)
        base_levels[unknown] = BUDGET_SAFE_MIGL / scale * (1.0 - run.params.margin)
    mapped = np.isfinite(u) & np.isfinite(v)
    if not mapped.any():
        raise InputError(
            "adaptive: no camera pixel decoded in the mapping sets; raise mapping_migl or the "
            "exposure (the mapping needs a fringe above the minimum modulation)"
        )
    # clipped pixels sit where their neighbours map: borrow the neighbours' coordinates
    uf = np.where(mp.saturated & ~mapped, fill_holes(np.where(mapped, u, np.nan)), u)
    vf = np.where(mp.saturated & ~mapped, fill_holes(np.where(mapped, v, np.nan)), v)
    proj = _Projection(
        run,
        uf,
        vf,
        (run.rig.projector.height, run.rig.projector.width),
        footprint_px(u, v) + _resolved(run.params.blur_px),
        np.where(np.isfinite(mp.ambient), mp.ambient * scale, 0.0),
        mapped,
        base_levels,
        low_floor=low_floor,
    )
    proj.first_map = proj.build(base_levels)
    run.seconds["map"] = time.perf_counter() - t0
    return proj


def _mapping_set_results(run: _Run, mp: _Mapping) -> list[StrategyResult | None]:
    """The results of the coarser sets, the mapping's own captures (None: an adapted set)."""
    results: list[StrategyResult | None] = [None] * len(run.specs)
    for i, spec in enumerate(run.specs):
        if i in run.finest.values():
            continue
        k = run.pitches[spec.orientation].index(spec.pitch_px)
        imgs, m_set = mp.images[spec.orientation][k], mp.migls[spec.orientation][k]
        sat = saturation_count(imgs, run.bits) > 0
        # the budget's: dimmed where the probe clipped (its own shifts too with a depth range)
        dimmed = mp.dim_map if k > 0 or mp.dim_first else None
        sets = [CapturedSet(migl=m_set, exposure_ms=run.exposure_ms, migl_map=dimmed)]
        if mp.bright_migl is not None:
            sets.append(CapturedSet(migl=mp.bright_migl, exposure_ms=run.exposure_ms))
        results[i] = StrategyResult(
            images=imgs,
            spec=spec,
            captured=sets,
            index_map=mp.index[spec.orientation][k],
            newly_unsaturated=[int((~sat).sum())] + [0] * (len(sets) - 1),
            never_unsaturated=sat,
            strategy="adaptive",
            details={"mapping_set": True, "mapping_migl": m_set},
        )
    return results


def _spare_mapping_migls(run: _Run, mp: _Mapping) -> list[float]:
    """The MIGLs of the mapping sets no spec stands for (counted with the first adapted set)."""
    return [
        m
        for o in ORIENTATIONS
        if o in run.pitches
        for k, p in enumerate(run.pitches[o])
        if not any(s.orientation == o and s.pitch_px == p for s in run.specs)
        for m in [mp.migls[o][k]] + ([] if mp.bright_migl is None else [mp.bright_migl])
    ]


@dataclass
class _AdaptedSet:
    """One orientation's adapted set while its passes run (internal).

    ``composite``: the merged images; ``levels``: the camera-side levels; ``pmap``: the map of
    the last refit or check pass; ``received``: what each pixel received of it; ``index``: the
    MIGL each pixel's images were captured at; ``remaining``: pixels with a clipped shift;
    ``used``: the maps projected and ``source``, per pixel, which one its images come from;
    ``captured``, ``newly``, ``clipped``: per capture; ``passes`` and ``seconds`` per step.
    """

    spec: FringeSpec
    composite: NDArray
    levels: NDArray[np.float64]
    pmap: NDArray[np.float64]
    received: NDArray[np.float64]
    index: NDArray[np.float32]
    remaining: NDArray[np.bool_]
    captured: list[CapturedSet]
    newly: list[int]
    clipped: list[int]
    used: list[NDArray[np.float64]]
    source: NDArray[np.intp]
    passes: dict[str, int] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)


def _capture_adapted_set(proj: _Projection, spec: FringeSpec) -> _AdaptedSet:
    """Step 3: the adapted set, projected with the first map."""
    t0 = time.perf_counter()
    assert proj.first_map is not None
    pmap = proj.first_map
    composite = proj.shoot(spec, pmap)
    received = proj.sample(pmap)
    remaining = saturation_count(composite, proj.run.bits) > 0
    st = _AdaptedSet(
        spec=spec,
        composite=composite,
        levels=proj.base_levels.copy(),
        pmap=pmap,
        received=received,
        index=received.astype(np.float32),
        remaining=remaining,
        captured=[CapturedSet(migl=None, exposure_ms=proj.run.exposure_ms, migl_map=pmap)],
        newly=[int((~remaining).sum())],
        clipped=[int(remaining.sum())],  # pixels with a clipped shift, per capture
        used=[pmap],
        source=np.zeros(remaining.shape, np.intp),
    )
    st.seconds["adapted"] = time.perf_counter() - t0
    return st


def _refit_pass(proj: _Projection, st: _AdaptedSet, full_mapped: bool) -> None:
    """The refit: the set's own offset and modulation give each pixel's level at this pitch;
    one more set where that gains a gray level or more, kept where it does not clip."""
    t0 = time.perf_counter()
    run, spec, bits = proj.run, st.spec, proj.run.bits
    margin, imin, full_p = run.params.margin, proj.imin, proj.full
    st.passes["refit"] = 0
    if run.params.refit and not full_mapped:
        dec = decode_set(st.composite, spec, bits, reject_saturated=False)
        got = np.where(np.isfinite(st.received), st.received, full_p)
        up = refined_migl(
            np.where(st.remaining, np.nan, dec.mean_intensity),
            dec.modulation,
            got,
            proj.ambient,
            bits,
            margin=margin,
            imin=imin,
            projector_full=full_p,
        )
        up = median_smooth(up, MEDIAN_WINDOW)  # per-pixel noise would bias the erosion low
        new_levels = np.where(np.isfinite(up), np.maximum(up, st.levels), st.levels)
        new_levels, _ = lowered_where_clipped(
            new_levels, st.composite, got, proj.ambient, bits, margin=margin, imin=imin
        )
        if np.nanmax(np.abs(new_levels - st.levels)) >= 1.0 and run.afford("refit"):
            new_map = proj.build(new_levels)
            imgs = proj.shoot(spec, new_map)
            clip = saturation_count(imgs, bits) > 0
            st.clipped.append(int(clip.sum()))
            take = ~clip | st.remaining  # unclipped now, or clipped both times (the newer)
            st.composite[:, take] = imgs[:, take]
            st.used.append(new_map)
            st.source[take] = len(st.used) - 1
            got2 = proj.sample(new_map).astype(np.float32)
            st.index[take] = got2[take]
            st.newly.append(int((st.remaining & ~clip).sum()))
            st.remaining &= clip
            # where the refit clipped a pixel the first set kept, keep its first level
            levels = np.where(clip & ~st.remaining, st.levels, new_levels)
            st.levels = np.where(st.remaining, new_levels, levels)
            st.pmap, st.received = new_map, got2.astype(np.float64)
            st.captured.append(
                CapturedSet(migl=None, exposure_ms=run.exposure_ms, migl_map=st.pmap)
            )
            st.passes["refit"] = 1
    st.seconds["refit"] = time.perf_counter() - t0


def _check_passes(proj: _Projection, st: _AdaptedSet, full_mapped: bool) -> None:
    """The check passes: lower the level only where a shift still clipped, merge there
    (Eq. 5.1), at most ``iterations``."""
    t0 = time.perf_counter()
    run, bits, full_p = proj.run, proj.run.bits, proj.full
    passes = 0
    while (
        st.remaining.any()
        and passes < (0 if full_mapped else run.params.iterations)
        and run.afford("check")
    ):
        got = np.where(np.isfinite(st.received), st.received, full_p)
        lowered, _ = lowered_where_clipped(
            st.levels,
            st.composite,
            got,
            proj.ambient,
            bits,
            margin=run.params.margin,
            imin=proj.imin,
        )
        st.levels = np.where(st.remaining, lowered, st.levels)
        st.pmap = proj.build(st.levels)
        imgs = proj.shoot(st.spec, st.pmap)
        got2 = proj.sample(st.pmap).astype(np.float32)
        unsat = saturation_count(imgs, bits) == 0
        st.clipped.append(int((~unsat).sum()))
        new = st.remaining & unsat
        st.composite[:, st.remaining] = imgs[:, st.remaining]
        st.index[st.remaining] = got2[st.remaining]
        st.used.append(st.pmap)
        st.source[st.remaining] = len(st.used) - 1
        st.remaining &= ~new
        st.received = np.where(new | st.remaining, got2, st.received)
        st.captured.append(CapturedSet(migl=None, exposure_ms=run.exposure_ms, migl_map=st.pmap))
        st.newly.append(int(new.sum()))
        passes += 1
    st.passes["check"] = passes
    st.seconds["check"] = time.perf_counter() - t0


def _boost_pass(proj: _Projection, st: _AdaptedSet, full_mapped: bool) -> None:
    """The boost: the erosion lowers a dim pixel next to a bright one (a black square's edge)
    far below its own level; one more set with those pixels' levels, merged where it gives a
    larger unclipped modulation (LPA's rule: the best unsaturated set)."""
    t0 = time.perf_counter()
    run, spec, bits, imin = proj.run, st.spec, proj.run.bits, proj.imin
    st.passes["boost"] = 0
    if run.params.boost and not full_mapped:
        short = (st.received - imin) < BOOST_RATIO * (st.levels - imin)
        wanted = np.isfinite(st.received) & np.isfinite(st.levels) & short & ~st.remaining
        enough = wanted.sum() >= BOOST_MIN_FRACTION * np.isfinite(st.received).sum()
        if enough and run.afford("boost"):
            bmap = boosted_map(
                st.pmap,
                np.where(wanted, st.levels, np.nan),
                proj.uf,
                proj.vf,
                radius=BOOST_RADIUS_FRACTION * proj.radius,
                projector_full=proj.full,
            )
            imgs = proj.shoot(spec, bmap)
            clip = saturation_count(imgs, bits) > 0
            st.clipped.append(int(clip.sum()))
            had = decode_set(st.composite, spec, bits)
            new_dec = decode_set(imgs, spec, bits)
            # only the pixels it was built for (or a pixel still clipped): a neighbour
            # whose footprint straddles the raised area reads a larger but biased fringe
            gain = (
                new_dec.valid
                & (wanted | st.remaining)
                & (~had.valid | (new_dec.modulation > had.modulation))
            )
            st.composite[:, gain] = imgs[:, gain]
            st.used.append(bmap)
            st.source[gain] = len(st.used) - 1
            got_b = proj.sample(bmap).astype(np.float32)
            st.index[gain] = got_b[gain]
            st.newly.append(int((st.remaining & gain).sum()))
            st.remaining &= ~gain
            st.captured.append(CapturedSet(migl=None, exposure_ms=run.exposure_ms, migl_map=bmap))
            st.passes["boost"] = 1
    st.seconds["boost"] = time.perf_counter() - t0


def _topup_pass(
    proj: _Projection, st: _AdaptedSet, mp: _Mapping
) -> tuple[NDArray[np.bool_] | None, dict[str, Any]]:
    """The top-up: pixels that clip even at the lowest usable MIGL (or in the mapping, where
    their response is unknown) only come under at a shorter exposure (docs/adaptive.md).
    Returns the pixels it decoded (None: no top-up set) and what ``details["topup"]`` says."""
    t0 = time.perf_counter()
    run, spec, bits, full_p = proj.run, st.spec, proj.run.bits, proj.full
    floor = float(default_min_migl(run.first))  # the lowest MIGL that carries a fringe
    stuck = st.remaining & ((st.index <= floor + 0.5) | mp.saturated)
    info: dict[str, Any] = {
        "pixels": int(stuck.sum()),
        "exposures_ms": [],
        "taken": 0,
        "ordered_from_neighbours": 0,
        "skipped": None,
    }
    took = None
    st.passes["topup"] = 0
    worth = stuck.sum() >= max(1.0, TOPUP_MIN_FRACTION * float(proj.mapped.sum()))
    if run.params.topup and worth:
        exposure_ms = run.exposure_ms
        reference = exposure_ms if exposure_ms is not None else run.rig.camera_settings.exposure_ms
        if run.topup_reference_ms is not None:
            reference = run.topup_reference_ms
        max_sets = TOPUP_MAX_SETS
        if run.budget is not None:
            max_sets = min(max_sets, run.budget.left // run.first.steps)
            if max_sets == 0:
                run.budget.skipped.append("topup")
        sets_t, why = _capture_topup(run.rig, spec, st.remaining, reference, max_sets)
        if run.budget is not None:
            run.budget.left -= len(sets_t) * run.first.steps
        info["skipped"] = why
        full_map = np.full(proj.shape, full_p)
        for t_set, imgs in sets_t:
            st.clipped.append(int((saturation_count(imgs, bits) > 0).sum()))
            had = decode_set(st.composite, spec, bits)
            new_dec = decode_set(imgs, spec, bits)
            gain = (
                new_dec.valid & st.remaining & (~had.valid | (new_dec.modulation > had.modulation))
            )
            st.composite[:, gain] = imgs[:, gain]
            if not any(m is full_map for m in st.used):
                st.used.append(full_map)
            st.source[gain] = len(st.used) - 1
            st.index[gain] = np.float32(full_p)
            st.newly.append(int(gain.sum()))
            st.captured.append(CapturedSet(migl=full_p, exposure_ms=t_set))
            info["exposures_ms"].append(t_set)
        st.passes["topup"] = len(sets_t)
        took = st.remaining & decode_set(st.composite, spec, bits).valid
        info["taken"] = int(took.sum())
        st.remaining &= ~took
    elif stuck.any():
        info["skipped"] = (
            "turned off (topup=False)"
            if not run.params.topup
            else f"{int(stuck.sum())} pixels, below {100 * TOPUP_MIN_FRACTION:g} % of the "
            "mapped ones"
        )
    st.seconds["topup"] = time.perf_counter() - t0
    return took, info


def _adapted_phase(
    proj: _Projection,
    st: _AdaptedSet,
    mapping: _MappingOutcome,
    took: NDArray[np.bool_] | None,
    topup_info: dict[str, Any],
) -> tuple[NDArray[np.float64], float | None]:
    """Step 4: the adapted set's absolute phase, unwrapped with the mapping's fringe orders
    (the top-up's pixels with their neighbours'), less the map's bias; and the blur fitted."""
    run, spec, bits, mp = proj.run, st.spec, proj.run.bits, mapping.mp
    # the mapping's fringe orders unwrap the adapted set: the order is the rounded
    # difference between the mapping's phase scaled to this pitch and the wrapped phase
    wrapped = decode_set(st.composite, spec, bits).wrapped_phase
    if run.budget is not None and st.remaining.any():
        # no budget left to capture them again: a clipped pixel's phase from its
        # unsaturated shifts (at least 3 of them; the saturation-tolerant decoder)
        shifts = 360.0 * np.arange(spec.steps) / spec.steps
        phi, mod, _, _ = tolerant_phase(st.composite, shifts, bits, min_shifts=3)
        fill = st.remaining & np.isfinite(phi) & (mod >= default_min_modulation(bits))
        wrapped = np.where(fill, phi, wrapped)
    orient = spec.orientation
    ordering = mp.absolute if mp.ordering is None else mp.ordering
    predicted = ordering[orient] * (run.pitches[orient][-1] / spec.pitch_px)
    absolute = wrapped + 2 * np.pi * np.rint((predicted - wrapped) / (2 * np.pi))
    # pixels clipped in the mapping have no orders: the top-up's, and with the full-MIGL
    # mapping any that the adapted set decoded (a glint under the half-way level)
    seeds = took if took is not None and st.passes["topup"] else np.zeros(mapping.u.shape, bool)
    if mapping.full_mapped:
        seeds = seeds | mp.saturated
    if mp.dim_map is not None or run.geometric is not None:
        # the budget's dimmed sets, or the geometry, left some without a mapping phase
        seeds = seeds | ~np.isfinite(predicted)
    if seeds.any():
        t1 = time.perf_counter()
        final = decode_set(st.composite, spec, bits)
        absolute, filled = _orders_from_neighbours(absolute, wrapped, final.valid, seeds)
        topup_info["ordered_from_neighbours"] = filled
        st.seconds["topup"] += time.perf_counter() - t1
    t0 = time.perf_counter()
    blur = None
    # with a budget, only after the full-MIGL mapping: the low-MIGL mapping's phase (low
    # shifts, noisy, the reflectivity edges' own bias) is no reference to fit the blur on
    # (on the checkerboard it made the std depend on the draw and raised it)
    if run.params.bias_correction and (run.budget is None or mapping.full_mapped):
        reference, smooth_region = predicted, None
        if mp.dim_map is not None:
            # not where the dimmed mapping sets' own map step biased the reference; there the
            # blur is fitted to the phase's smoothness
            from scipy import ndimage

            near = ndimage.binary_dilation(mp.saturated, iterations=BUDGET_DIM_NEAR_PX)
            reference = np.where(near, np.nan, reference)
            smooth_region = near & np.isfinite(absolute)
        absolute, blur = _correct_map_bias(
            absolute,
            reference,
            st.used,
            st.source,
            proj.uf,
            proj.vf,
            spec,
            proj.imin,
            proj.radius,
            BUDGET_FLOOR_SPAN if proj.low_floor else None,
            smooth_region,
            proj.radius - _resolved(run.params.blur_px),
        )
    st.seconds["bias"] = time.perf_counter() - t0
    return absolute, blur


def _adapted_details(
    proj: _Projection,
    st: _AdaptedSet,
    mapping: _MappingOutcome,
    topup_info: dict[str, Any],
    blur: float | None,
) -> dict[str, Any]:
    """The adapted set's ``details``: the maps, the counts and seconds per step, the blur."""
    run, mp, steps = proj.run, mapping.mp, proj.run.first.steps
    n_map = sum(len(p) for p in run.pitches.values()) * (1 if mp.bright_migl is None else 2)
    n_map += len(mapping.trial)
    sets = {"exposure": len(run.chosen), "mapping": n_map, "adapted": 1}
    sets |= {k: st.passes[k] for k in ("refit", "check", "boost", "topup")}
    seconds = {k: run.seconds[k] for k in ("exposure", "mapping", "map")}
    seconds |= {k: st.seconds[k] for k in ("adapted", "refit", "check", "boost", "topup", "bias")}
    return {
        "margin": float(run.params.margin),
        "mapping_migls": {o: list(m) for o, m in mp.migls.items()},
        "mapping_bright_migl": mp.bright_migl,
        "mapping_pitches": {o: list(p) for o, p in run.pitches.items()},
        "erosion_radius_px": float(proj.radius),
        "mapping_saturated": int(mp.saturated.sum()),
        "refit_passes": st.passes["refit"],
        "check_passes": st.passes["check"],
        "boost_passes": st.passes["boost"],
        "topup": topup_info,
        "clipped_per_capture": st.clipped,
        "images_per_step": {k: n * steps for k, n in sets.items()},
        "sets_per_step": sets,
        "seconds_per_step": {k: round(t, 4) for k, t in seconds.items()},
        "blur_sigma_px": blur,
        "exposure_ms": run.exposure_ms,
        "epipolar": run.calib is not None,
        "full_mapping": {"clipped_fraction": mapping.full_clipped, "kept": mapping.full_mapped}
        if run.params.full_mapping or run.budget is not None
        else None,
    }


def _adapt_orientation(
    proj: _Projection, mapping: _MappingOutcome, i: int, counted_here: list[CapturedSet]
) -> StrategyResult:
    """Steps 3 and 4 for the finest set ``specs[i]`` of one orientation: the adapted set, its
    refit, check, boost and top-up passes, its absolute phase. ``counted_here``: the sets
    captured before it that it is charged with (the exposure choice, the spare mapping sets)."""
    spec = proj.run.specs[i]
    full_mapped = mapping.full_mapped
    st = _capture_adapted_set(proj, spec)
    _refit_pass(proj, st, full_mapped)
    _check_passes(proj, st, full_mapped)
    _boost_pass(proj, st, full_mapped)
    took, topup_info = _topup_pass(proj, st, mapping.mp)
    st.captured[:0] = counted_here
    st.newly[:0] = [0] * len(counted_here)
    absolute, blur = _adapted_phase(proj, st, mapping, took, topup_info)
    return StrategyResult(
        images=st.composite,
        spec=spec,
        captured=st.captured,
        index_map=st.index,
        newly_unsaturated=st.newly,
        never_unsaturated=st.remaining,
        strategy="adaptive",
        details=_adapted_details(proj, st, mapping, topup_info, blur),
        absolute_phase=absolute,
        projector_migl_map=st.pmap.astype(np.float32),
        camera_migl=st.levels.astype(np.float32),
    )


def _run_adaptive(
    rig: Rig, specs: Sequence[FringeSpec], params: AdaptiveParams
) -> tuple[StrategyResult, ...]:
    """:func:`adaptive_sets` with its parameters grouped: the steps in order."""
    budget = params.max_images is not None
    defaults = (BUDGET_BLUR_PX, BUDGET_SMOOTH_PX) if budget else (BLUR_PX, SMOOTH_PX)
    params = dataclasses.replace(
        params,
        blur_px=defaults[0] if params.blur_px is None else params.blur_px,
        smooth_px=defaults[1] if params.smooth_px is None else params.smooth_px,
    )
    if budget:
        return _run_budget(rig, specs, params)
    specs, calib, m0 = _checked_inputs(rig, specs, params)
    exposure_ms, chosen, t_exposure = _choose_exposure_first(rig, specs, params)
    finest, pitches = _plan_ladders(rig, specs, calib)
    run = _Run(
        rig, specs, params, calib, exposure_ms, chosen, finest, pitches, {"exposure": t_exposure}
    )
    mapping = _map_camera_to_projector(run, m0)
    proj = _plan_projector_map(run, mapping)
    results = _mapping_set_results(run, mapping.mp)
    spare = _spare_mapping_migls(run, mapping.mp) + mapping.trial
    owner = min(finest.values())
    for i in finest.values():
        counted: list[CapturedSet] = []
        if i == owner:
            counted = [CapturedSet(migl=m, exposure_ms=t) for t, m in chosen] + [
                CapturedSet(migl=m, exposure_ms=exposure_ms) for m in spare
            ]
        results[i] = _adapt_orientation(proj, mapping, i, counted)
    out = tuple(r for r in results if r is not None)
    assert len(out) == len(specs)  # every spec is a mapping set or an adapted set
    return out


# ---------------------------------------------------------------------------------------------
# the image budget (max_images, issue 26)
# ---------------------------------------------------------------------------------------------


def _mapping_noise(
    rig: Rig,
    mp: _Mapping,
    first: FringeSpec,
    bits: int,
    completed: NDArray[np.bool_] | None,
) -> NoiseModel | None:
    """The camera's noise estimated from the mapping sets' own residuals
    (:func:`~hdrfringe.core.uncertainty.estimate_noise`), leaving out the pixels whose first
    set's first shift was computed from the others (``completed``: no residual); where no
    set allows an estimate, the noise the rig's camera description records (the virtual
    rig's, a replayed folder's manifest); else None."""
    describe = getattr(rig, "camera_manifest", None)
    replayed = getattr(rig, "captures", None)
    camera = describe() if callable(describe) else getattr(replayed, "camera", None)
    recorded = noise_from_manifest(camera) if isinstance(camera, dict) else None
    o0 = next(iter(mp.pitches))
    sets: list[tuple[Any, FringeSpec]] = []
    for orient, ps in mp.pitches.items():
        for k, (imgs, p) in enumerate(zip(mp.images[orient], ps, strict=True)):
            if k == 0 and orient == o0 and completed is not None:
                if completed.all():
                    continue
                imgs = imgs[:, ~completed][:, None, :]
            sets.append((imgs, _spec_at(first, orient, p, first.migl)))
    try:
        return estimate_noise(sets, bits) if sets else recorded
    except NoiseUnknownError:
        return recorded


def _exposure_from_mapping(
    mp: _Mapping,
    first: FringeSpec,
    bits: int,
    margin: float,
    reference_ms: float,
    noise: NoiseModel | None = None,
) -> float:
    """The adapted set's exposure from the mapping's response alone (thesis Sec. 7.3).

    Per mapped pixel the response ``I = g a + c`` (scaled by the exposure ratio ``s``) gives
    the modulation the per-pixel MIGL reaches at each exposure: ``s g (MIGL - imin) / 2`` at
    the full MIGL where that stays ``margin`` below clipping, else at the MIGL that does,
    ``(T - s (c + g imin)) / 2`` with ``T`` that level (a MIGL-limited pixel *loses*
    modulation with a longer exposure: its ambient and the fringe's ``imin`` grow with it).
    The exposure is the one of :data:`BUDGET_EXPOSURE_STEPS` per octave between
    1 / :data:`BUDGET_MAX_EXPOSURE_RATIO` and :data:`BUDGET_MAX_EXPOSURE_RATIO` times
    ``reference_ms`` that minimises the mean predicted phase variance
    ``sigma^2(I) / modulation^2`` over the pixels that carry a fringe at ``reference_ms``
    (``noise``: the camera's, read and shot noise at the pixel's mean intensity ``I`` at that
    exposure; None: alike for all), among
    those that leave at most :data:`BUDGET_CLIP_FRACTION` of them clipped at the lowest
    usable MIGL or below the detection modulation; ``reference_ms`` where it is within
    :data:`BUDGET_EXPOSURE_TOLERANCE` of that least variance. Pixels clipped in the mapping
    (no response) do not vote.
    """
    gain, ambient = mp.gain, mp.ambient
    ok = np.isfinite(gain) & np.isfinite(ambient) & (gain > 0) & ~mp.saturated
    if not ok.any():
        return reference_ms
    imin, full = float(first.imin), float(first.migl)
    det = detection_modulation(bits)
    lit = ok & (gain * (full - imin) / 2.0 >= det)
    if not lit.any():
        return reference_ms
    # no longer than what brings the darkest lit surface (1st percentile) to the target
    # modulation: beyond it the dim surface gains little, while the pixels clipped in the
    # mapping (no response: a glint) clip at the lowest usable MIGL ever more
    dark = float(np.percentile(gain[lit] * (full - imin) / 2.0, 1.0))
    target = default_target_modulation(first.steps, bits)
    longest = min(max(target / dark, 1.0), BUDGET_MAX_EXPOSURE_RATIO)
    g, c = gain[lit], np.maximum(ambient[lit], 0.0)
    if g.size > BUDGET_EXPOSURE_PIXELS:  # evenly spread: the objective is a mean
        pick = np.linspace(0, g.size - 1, BUDGET_EXPOSURE_PIXELS).astype(np.intp)
        g, c = g[pick], c[pick]
    top = (1.0 - margin) * full_scale(bits)
    floor = default_min_migl(first)
    n = round(float(np.log2(BUDGET_MAX_EXPOSURE_RATIO)) * BUDGET_EXPOSURE_STEPS)
    ratios = 2.0 ** (np.arange(-n, n + 1) / BUDGET_EXPOSURE_STEPS)
    ratios = np.unique(np.append(ratios[ratios < longest], longest))
    n = int(np.flatnonzero(ratios == 1.0)[0])  # the reference exposure's candidate
    s = ratios[:, None]
    migl = np.minimum(full, (top / s - c) / g)  # the highest safe MIGL at each exposure
    modulation = s * g * (migl - imin) / 2.0
    lost = (migl < floor) | (modulation < det)
    # the noise at each pixel's mean intensity at that exposure (shot noise grows with it)
    sigma2 = 1.0 if noise is None else noise.variance(s * (c + g * (migl + imin) / 2.0))
    variance = np.mean(sigma2 / np.maximum(modulation, det) ** 2, axis=1)
    feasible = np.mean(lost, axis=1) <= BUDGET_CLIP_FRACTION
    if not feasible.any():
        return reference_ms
    variance = np.where(feasible, variance, np.inf)
    best = int(np.argmin(variance))
    if feasible[n] and variance[n] <= (1.0 + BUDGET_EXPOSURE_TOLERANCE) * variance[best]:
        return reference_ms
    return float(f"{reference_ms * ratios[best]:.4g}")


def _completes_first_shift(spec: FringeSpec) -> bool:
    """Whether a set's first shift follows from its others (:func:`_with_first_shift`)."""
    return spec.pattern == "sinusoidal" and spec.steps == 4


def _with_first_shift(rest: NDArray, bits: int) -> NDArray:
    """A 4-step sinusoidal set from its shifts 1-3: ``I0 = I1 + I3 - I2`` (shifts a quarter
    period apart: ``I0 + I2 = I1 + I3``, twice the offset), clipped to the camera's range;
    full scale (a clipped shift) where one of the three clipped."""
    full = full_scale(bits)
    r = rest.astype(np.int64)
    first = np.clip(r[0] + r[2] - r[1], 0, full - 1)
    first = np.where((saturation_count(rest, bits) > 0), full, first)
    return np.concatenate([first[None].astype(rest.dtype), rest])


def _conventional_sets(
    run: _Run, probe_spec: FringeSpec, probe: NDArray, info: dict[str, Any]
) -> tuple[StrategyResult, ...]:
    """Nothing clipped in the full-MIGL probe: every set captured as the conventional
    measurement captures it (Requirement 4), the probe standing for its own set."""
    rig, bits, full = run.rig, run.bits, float(run.first.migl)
    out: list[StrategyResult] = []
    spare = 0
    used_probe = False
    for spec in run.specs:
        same = (spec.orientation, spec.pitch_px) == (probe_spec.orientation, probe_spec.pitch_px)
        if same and not used_probe:
            imgs, used_probe = probe, True
        else:
            imgs = _capture(rig, spec.frames(), run.settings)
        unsat = saturation_count(imgs, bits) == 0
        out.append(
            StrategyResult(
                images=imgs,
                spec=spec,
                captured=[CapturedSet(migl=full, exposure_ms=run.exposure_ms)],
                index_map=np.full(imgs.shape[1:], full, np.float32),
                newly_unsaturated=[int(unsat.sum())],
                never_unsaturated=~unsat,
                strategy="adaptive",
            )
        )
    if not used_probe:  # the probe was no measurement set: counted with the first result
        spare = 1
        out[0].captured.insert(0, CapturedSet(migl=full, exposure_ms=run.exposure_ms))
        out[0].newly_unsaturated.insert(0, 0)
    clipped = sum(int(r.never_unsaturated.sum()) for r in out[-1:])
    info |= {
        "images": sum(r.images_captured for r in out),
        "conventional": True,
        "unreached": {"clipped": clipped, "low_modulation": None, "no_order": None},
        "spare_sets": spare,
    }
    out[-1].details = {"budget": info}
    return tuple(out)


def _budget_run(
    rig: Rig, specs: Sequence[FringeSpec], params: AdaptiveParams
) -> tuple[_Run, float]:
    """The budget's settled inputs (:class:`_Run`, with its :class:`_Budget`) and the low
    mapping MIGL; InputError for what the budget cannot do."""
    for flag, given in (
        ("--adaptive-auto-exposure", params.auto_exposure),
        ("--mapping-migl", params.mapping_migl is not None),
    ):
        if given:
            raise InputError(
                f"adaptive --max-images chooses the exposure and the mapping itself; drop {flag}"
            )
    if not params.topup:
        raise InputError(
            "adaptive --max-images leaves the pixels that clip at the full MIGL to the top-up "
            "where the budget allows; drop --no-adaptive-topup"
        )
    specs, calib, m0 = _checked_inputs(rig, specs, params)
    own = getattr(rig, "stereo_calibration", None)
    if calib is None and callable(own) and all(s.orientation == "vertical" for s in specs):
        calib = _epipolar_calibration(rig, specs, True, None)  # the rig's: one ladder
    if params.depth_range_mm is not None and calib is None:
        raise InputError(
            "adaptive depth_range_mm orders the coarsest set from a projector-camera "
            "calibration; measure vertical sets with one (measure -c STEREO.h5 "
            "--adaptive-epipolar) or drop the depth range"
        )
    finest, pitches = _plan_ladders(rig, specs, calib, params.depth_range_mm is not None)
    # the measurement's own orientation first: its coarsest set is the conventional one
    pitches = {o: pitches[o] for o in sorted(pitches, key=lambda o: o not in finest)}
    steps = specs[0].steps
    minimum = steps * (sum(len(p) for p in pitches.values()) + len(finest))
    limit = params.max_images
    if isinstance(limit, bool) or not isinstance(limit, int | np.integer) or limit < minimum:
        raise InputError(
            f"adaptive --max-images {limit!r}: this measurement needs at least {minimum} "
            f"images ({minimum // steps} sets of {steps}: the mapping ladder "
            f"{', '.join(f'{o} {p}' for o, p in pitches.items())} px and one adapted set per "
            "orientation); raise it"
            + ("" if calib is not None else " or give a stereo calibration (one ladder)")
            + (
                ""
                if calib is None or params.depth_range_mm is not None
                else " or a depth range (--depth-range: no one-period set)"
            )
        )
    budget = _Budget(int(limit), int(limit))
    run = _Run(rig, specs, params, calib, params.exposure_ms, [], finest, pitches, {}, budget)
    run.seconds["exposure"] = 0.0
    return run, m0


@dataclass
class _Probe:
    """The budget's first set (internal, :func:`_capture_probe`): its spec at the full MIGL,
    what was captured of it, the pixels that clipped at the full MIGL, and how the set was
    completed: ``low_first`` (its other shifts at the low MIGL, the first computed, and the
    fraction its full-MIGL first shift clipped) or ``dimmed`` (:func:`_dimmed_probe`)."""

    spec: FringeSpec
    images: NDArray
    clipped: NDArray[np.bool_]
    low_first: tuple[NDArray, float] | None = None
    dimmed: _DimmedProbe | None = None

    @property
    def completed(self) -> NDArray[np.bool_] | None:
        """Pixels whose first mapping set's first shift was computed (no 4-step residual)."""
        if self.low_first is not None:
            return np.ones(self.clipped.shape, bool)
        if self.dimmed is not None:
            return self.dimmed.dimmed | ~self.dimmed.usable
        return None


def _capture_probe(run: _Run, m0: float) -> _Probe:
    """Step 0: the coarsest set at the full MIGL, its first shift alone first. Where that
    clips on much of the field (under a budget that cannot hold the full probe beside the
    family) the set's other shifts come at the low mapping MIGL and the first is completed
    from them; where it clips somewhere and a depth range orders the set, the other shifts
    are dimmed along the clipped pixels' epipolar segments; else the other shifts at the
    full MIGL."""
    rig, first, budget, pitches = run.rig, run.first, run.budget, run.pitches
    assert budget is not None
    steps = first.steps
    o0 = next(iter(pitches))
    spec = _spec_at(first, o0, pitches[o0][0], float(first.migl))
    frames = spec.frames()
    budget.afford("mapping", steps)
    shot = _capture(rig, frames[:1], run.settings)
    clipped_shot = float(np.mean(saturation_count(shot, run.bits) > 0))
    ladder = sum(len(p) for p in pitches.values())
    # a full probe that clips on much of the field is one set more than the family
    tight = budget.limit < steps * (1 + ladder + len(run.finest))
    if tight and clipped_shot > FULL_MAPPING_MAX_CLIPPED and _completes_first_shift(first):
        rest = _capture(rig, _spec_at(first, o0, pitches[o0][0], m0).frames()[1:], run.settings)
        low_first = (_with_first_shift(rest, run.bits), clipped_shot)
        # (the shot is not a set: reported only)
        return _Probe(spec, shot, saturation_count(shot, run.bits) > 0, low_first=low_first)
    if run.geometric is not None and clipped_shot > 0 and _completes_first_shift(first):
        # a highlight, and no later mapping set to measure it in: the probe's own other
        # shifts dimmed where its first shift clipped
        dimmed = _dimmed_probe(run, spec, shot)
        clipped = dimmed.clipped | (saturation_count(dimmed.images, run.bits) > 0)
        return _Probe(spec, dimmed.images, clipped, dimmed=dimmed)
    probe = np.concatenate([shot, _capture(rig, frames[1:], run.settings)])
    return _Probe(spec, probe, saturation_count(probe, run.bits) > 0)


def _budget_exposure(run: _Run, mp: _Mapping, probe: _Probe) -> float:
    """Step 2: the adapted set's exposure from the mapping (:func:`_exposure_from_mapping`,
    the noise from the mapping's residuals, :func:`_mapping_noise`), set on ``run``; returns
    its ratio to the mapping's."""
    params, rig, first = run.params, run.rig, run.first
    reference = run.exposure_ms if run.exposure_ms is not None else rig.camera_settings.exposure_ms
    if not (params.mapping_exposure and reference is not None and reference > 0):
        return 1.0
    noise = _mapping_noise(rig, mp, first, run.bits, probe.completed)
    t = _exposure_from_mapping(mp, first, run.bits, float(params.margin), float(reference), noise)
    if t == reference:
        return 1.0
    run.exposure_ms, run.topup_reference_ms = t, float(reference)
    return t / float(reference)


def _run_budget(
    rig: Rig, specs: Sequence[FringeSpec], params: AdaptiveParams
) -> tuple[StrategyResult, ...]:
    """:func:`adaptive_sets` with ``max_images``: every image a measurement image, planned to
    the budget (docs/adaptive.md, "Budget")."""
    run, m0 = _budget_run(rig, specs, params)
    budget, finest, steps = run.budget, run.finest, run.first.steps
    assert budget is not None
    probe = _capture_probe(run, m0)
    info: dict[str, Any] = {
        "max_images": budget.limit,
        "probe_images": int(probe.images.shape[0]),
        "first_shift_completed": probe.low_first is not None,
        "probe_clipped_fraction": round(float(probe.clipped.mean()), 6),
        "epipolar": run.calib is not None,
        "depth_range_mm": None if run.geometric is None else list(run.geometric_inputs[1]),
        "probe_dimmed": probe.dimmed is not None,
    }
    if not probe.clipped.any():
        return _conventional_sets(run, probe.spec, probe.images, info)
    # the rest of the mapping: at the full MIGL where only a highlight clipped in the probe,
    # else the low-MIGL ladder with the probe merged in (its bright repeat only if it fits)
    # (the bright repeat only follows the low ladder, itself ladder sets more)
    ladder = sum(len(p) for p in run.pitches.values())
    allow_bright = budget.left - steps * (ladder + len(finest)) >= steps * ladder
    if probe.dimmed is not None:
        mapping = _map_dimmed_probe(run, probe.dimmed)
    else:
        mapping = _map_camera_to_projector(
            run,
            m0,
            probe=None if probe.low_first is not None else probe.images,
            allow_bright=allow_bright,
            low_first=probe.low_first,
        )
    mp = mapping.mp
    n_map = ladder * (1 if mp.bright_migl is None else 2) + len(mapping.trial)
    budget.left = budget.limit - steps * n_map
    results = _mapping_set_results(run, mp)
    spare = _spare_mapping_migls(run, mp) + mapping.trial
    scale = _budget_exposure(run, mp, probe)
    info["exposure_ms"] = run.exposure_ms
    proj = _plan_projector_map(run, mapping, scale)
    owner = min(finest.values())
    region = proj.mapped | mp.saturated
    if mp.decoded is not None:  # and those a dimmed set left without a mapping phase
        region |= mp.decoded
    budget.left -= steps * len(finest)  # the adapted sets themselves are never skipped
    for i in finest.values():
        counted: list[CapturedSet] = []
        if i == owner:
            counted = [CapturedSet(migl=m, exposure_ms=params.exposure_ms) for m in spare]
        res = _adapt_orientation(proj, mapping, i, counted)
        if res.never_unsaturated.any():
            res.decoder = DecoderSettings(min_shifts=3)  # the tolerant pixels decode
        res.details["budget"] = {
            **info,
            "unreached": _unreached_of(res, region, run.bits),
        }
        results[i] = res
    out = tuple(r for r in results if r is not None)
    total = sum(r.images_captured for r in out)
    for r in out:
        if "budget" in r.details:
            r.details["budget"] |= {
                "images": total,
                "skipped": list(budget.skipped),
                "over_budget": max(0, total - budget.limit),
            }
    return out


def _map_dimmed_probe(run: _Run, dimmed: _DimmedProbe) -> _MappingOutcome:
    """Step 1 after the dimmed probe (:func:`_dimmed_probe`): the rest of the ladder at the
    full MIGL, the probe's response per pixel at the levels it received, the coarsest set
    ordered from the geometry."""
    t0 = time.perf_counter()
    full = float(run.first.migl)
    mp = _measure_mapping(
        run.rig,
        run.first,
        run.pitches,
        full,
        run.settings,
        auto=False,
        first_images=dimmed.images,
        first_window=BUDGET_FIRST_WINDOW,  # its dimmed pixels: three shifts at a low MIGL
        first_dim=dimmed,
        geometric=run.geometric,
    )
    u = mp.coords["vertical"]
    v = epipolar_rows(run.geometric_inputs[0], u)
    run.seconds["mapping"] = time.perf_counter() - t0
    return _MappingOutcome(mp, full, u, v, [], True, float(dimmed.clipped.mean()))


def _unreached_of(res: StrategyResult, region: NDArray[np.bool_], bits: int) -> dict[str, Any]:
    """What the budget could not reach of an adapted set, over ``region`` (the pixels the
    mapping decoded or saw clip): still clipped, below the modulation threshold, decoded
    without a fringe order."""
    absolute = res.absolute_phase
    assert absolute is not None
    lost = region & ~np.isfinite(absolute)
    clipped = lost & res.never_unsaturated
    dec = decode_set(res.images, res.spec, bits)
    low = lost & ~res.never_unsaturated & ~dec.valid
    no_order = lost & ~clipped & ~low
    n = max(int(region.sum()), 1)
    return {
        "pixels": int(region.sum()),
        "clipped": int(clipped.sum()),
        "low_modulation": int(low.sum()),
        "no_order": int(no_order.sum()),
        "reached_fraction": round(1.0 - float(lost.sum()) / n, 6),
    }


def adaptive_sets(
    rig: Rig,
    specs: Sequence[FringeSpec],
    *,
    margin: float = 0.015,
    iterations: int = 1,
    refit: bool = True,
    boost: bool = True,
    bias_correction: bool = True,
    mapping_migl: float | None = None,
    blur_px: float | None = None,
    smooth_px: float | None = None,
    exposure_ms: float | None = None,
    auto_exposure: bool = False,
    topup: bool = True,
    epipolar: bool = False,
    stereo_calibration: StereoCalibration | None = None,
    full_mapping: bool = False,
    max_images: int | None = None,
    mapping_exposure: bool = True,
    depth_range_mm: tuple[float, float] | None = None,
) -> tuple[StrategyResult, ...]:
    """Per-pixel adaptive projection for the sets ``specs`` of one measurement.

    Parameters
    ----------
    rig : Rig
        A rig whose projector shows projector images (the virtual rig, hardware).
    specs : sequence of FringeSpec
        The measurement's sets at their highest MIGL (sinusoidal, equal steps, imin and MIGL),
        e.g. one per pitch, coarsest first.
    margin : float
        Fraction of the camera's full scale kept free below clipping, in ``[0, 1)``.
    iterations : int
        Check passes at most, each only where a shift still clipped (>= 0).
    refit : bool
        Re-fit each pixel's level from the adapted set and capture once more where that
        gains a gray level or more.
    boost : bool
        Where the map gives pixels much less than their own level (a dim pixel next to a
        bright one), capture one more set with those raised
        (:func:`~hdrfringe.core.saturation.adaptive_map.boosted_map`) and keep it per pixel where
        its unclipped modulation is larger.
    bias_correction : bool
        Subtract the phase bias of the map's steps under the blur.
    mapping_migl : float, optional
        MIGL of the mapping sets; default (None) ``imin + 20`` for the first and, for the
        others, the highest MIGL its response says keeps every pixel 10 % below clipping.
    blur_px : float, optional
        Erosion beyond the camera pixel's footprint, projector pixels: projector defocus,
        mapping error and rounding (>= 0). None: :data:`BLUR_PX`, with ``max_images``
        :data:`BUDGET_BLUR_PX`.
    smooth_px : float, optional
        Smoothing of the map from below, projector pixels (>= 0). None: :data:`SMOOTH_PX`,
        with ``max_images`` :data:`BUDGET_SMOOTH_PX`.
    exposure_ms : float, optional
        Exposure time of every capture; None: the rig's own setting.
    auto_exposure : bool
        Choose the exposure first (thesis Sec. 7.3,
        :func:`~hdrfringe.strategies.exposure.choose_exposure` on the finest set at its
        highest MIGL: the darkest lit surface at the target modulation), then adapt the MIGL
        at it. Where that set has no saturated pixel the rig's exposure is kept (one set;
        Requirement 4). The choice's sets are counted (``images_per_step["exposure"]``).
        Not together with ``exposure_ms``.
    topup : bool
        Coverage top-up: where pixels still clip after the check passes at the lowest usable
        MIGL (or clipped in the mapping, response unknown), capture the finest set at its full
        MIGL at a shorter exposure chosen for them (at most :data:`TOPUP_MAX_SETS` sets),
        merge it per pixel by the larger unclipped modulation and give those pixels fringe
        orders from their neighbours' (spatial unwrapping anchored on a ring of known
        orders). Skipped, with the reason in ``details["topup"]``, where the rig cannot
        change its exposure (a replayed folder).
    epipolar : bool
        Map one orientation only, the measurement's (vertical fringes), and take each camera
        pixel's projector row from the epipolar constraint: its ray meets the plane of its
        projector column in one 3-D point whose projection gives the row
        (:func:`~hdrfringe.core.saturation.adaptive_map.epipolar_rows`). Saves the other
        orientation's ladder. Needs a projector-camera calibration: ``stereo_calibration``,
        else the rig's own (the virtual rig's ``stereo_calibration()``, its true geometry).
    stereo_calibration : StereoCalibration, optional
        The calibration for ``epipolar`` (camera and projector sizes of this rig).
    full_mapping : bool
        Capture the first mapping set at the full MIGL. Where at most
        :data:`FULL_MAPPING_MAX_CLIPPED` of the pixels clip in it (a highlight), the whole
        mapping stays at the full MIGL, the clipped pixels are left to the top-up (their
        response is unknown) and the refit, check and boost passes are not captured;
        otherwise the low-MIGL mapping follows, with that set (counted with the mapping)
        merged into its first set where it did not clip. Not with ``mapping_migl`` or
        without ``topup``.
    max_images : int, optional
        Image budget of the measurement (docs/adaptive.md, "Budget"): the first mapping set
        is captured at the full MIGL and the rig's exposure; where nothing clips in it every
        set is captured as the conventional measurement does (Requirement 4, exactly).
        Otherwise the full-MIGL mapping (the epipolar one where the rig has a calibration),
        one adapted set, and the refit, check, boost and top-up sets only while the budget
        allows; a clipped pixel of the adapted set is decoded from its unsaturated shifts.
        ``details["budget"]`` says what it could not reach. None: no budget.
    mapping_exposure : bool
        With ``max_images``: the adapted set's exposure chosen from the mapping's response
        (thesis Sec. 7.3: the darkest mapped surface to the target modulation, as far as the
        brightest keeps below clipping at the lowest usable MIGL).
    depth_range_mm : tuple of float, optional
        With ``max_images`` and a calibration (``stereo_calibration`` or the rig's own): the
        scene's depths along the camera axis, mm. The coarsest set is then ordered from the
        geometry (:func:`~hdrfringe.core.geometric_order.geometric_order`) and the mapping is
        the measurement's coarser sets alone, no one-period set (two pitches in 8 images);
        where the probe's first shift clips, its other shifts are dimmed along the clipped
        pixels' epipolar segments and its first shift completed from them (docs/adaptive.md,
        "Budget").

    Returns
    -------
    tuple of StrategyResult
        One per spec, in order. A coarser set is the mapping's own capture at its MIGL; the
        finest set of each orientation is the adapted composite: ``index_map`` holds the MIGL
        each camera pixel received, ``projector_migl_map`` (the projector's map of the last
        pass) and ``camera_migl`` (the camera-side levels), ``details`` the images, sets and
        seconds per step (``images_per_step``, ``sets_per_step``, ``seconds_per_step``; the
        mapping is counted once, with the first adapted set) and the blur fitted
        (``blur_sigma_px``), and ``absolute_phase``: the set's absolute phase, unwrapped with
        the mapping's orders.

    Raises
    ------
    InputError
        For sets the strategy cannot adapt or parameters out of range.

    References
    ----------
    Thesis Sec. 7.2 (future work: per-pixel adaptive projection), Eq. 5.1 (the merge);
    docs/adaptive.md.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48),
    ...                    lighting=Lighting(ambient_lux=600))
    >>> specs = [FringeSpec("sinusoidal", 4, p) for p in (1024.0, 64.0, 8.0)]
    >>> res = adaptive_sets(rig, specs)
    >>> [r.sets_captured for r in res], bool(res[-1].never_unsaturated.any())
    ([1, 1, 4], False)
    """
    params = AdaptiveParams(
        margin=margin,
        iterations=iterations,
        refit=refit,
        boost=boost,
        bias_correction=bias_correction,
        mapping_migl=mapping_migl,
        blur_px=blur_px,
        smooth_px=smooth_px,
        exposure_ms=exposure_ms,
        auto_exposure=auto_exposure,
        topup=topup,
        epipolar=epipolar,
        stereo_calibration=stereo_calibration,
        full_mapping=full_mapping,
        max_images=max_images,
        mapping_exposure=mapping_exposure,
        depth_range_mm=depth_range_mm,
    )
    return _run_adaptive(rig, specs, params)


def adaptive(
    rig: Rig,
    spec: FringeSpec,
    *,
    margin: float = 0.015,
    iterations: int = 1,
    refit: bool = True,
    boost: bool = True,
    bias_correction: bool = True,
    mapping_migl: float | None = None,
    blur_px: float | None = None,
    smooth_px: float | None = None,
    exposure_ms: float | None = None,
    auto_exposure: bool = False,
    topup: bool = True,
    epipolar: bool = False,
    stereo_calibration: StereoCalibration | None = None,
    full_mapping: bool = False,
    max_images: int | None = None,
    mapping_exposure: bool = True,
    depth_range_mm: tuple[float, float] | None = None,
) -> StrategyResult:
    """Per-pixel adaptive projection of one set (:func:`adaptive_sets` with ``[spec]``).

    The mapping ladder (one period down to within 16x of ``spec``'s pitch, both orientations)
    is captured for it; the result's ``absolute_phase`` is the set unwrapped with its orders.

    Parameters
    ----------
    rig : Rig
        A rig whose projector shows projector images.
    spec : FringeSpec
        The set at its highest MIGL.
    margin, iterations, refit, boost, bias_correction, mapping_migl, blur_px, smooth_px
        As :func:`adaptive_sets`.
    exposure_ms, auto_exposure, topup, epipolar, stereo_calibration, full_mapping
        As :func:`adaptive_sets`.
    max_images, mapping_exposure, depth_range_mm
        As :func:`adaptive_sets`.

    Returns
    -------
    StrategyResult

    References
    ----------
    Thesis Sec. 7.2 (future work); docs/adaptive.md.

    Examples
    --------
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> from hdrfringe.rig.scenes import white_plate
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=64, height=48),
    ...                    lighting=Lighting(ambient_lux=600))
    >>> res = adaptive(rig, FringeSpec("sinusoidal", 4, 8.0))
    >>> res.details["sets_per_step"]
    {'exposure': 0, 'mapping': 4, 'adapted': 1, 'refit': 1, 'check': 0, 'boost': 0, 'topup': 0}
    """
    (res,) = adaptive_sets(
        rig,
        [spec],
        margin=margin,
        iterations=iterations,
        refit=refit,
        boost=boost,
        bias_correction=bias_correction,
        mapping_migl=mapping_migl,
        blur_px=blur_px,
        smooth_px=smooth_px,
        exposure_ms=exposure_ms,
        auto_exposure=auto_exposure,
        topup=topup,
        epipolar=epipolar,
        stereo_calibration=stereo_calibration,
        full_mapping=full_mapping,
        max_images=max_images,
        mapping_exposure=mapping_exposure,
        depth_range_mm=depth_range_mm,
    )
    return res


@dataclass(frozen=True)
class AdaptiveParams:
    """Parameters of :func:`adaptive_sets`.

    Parameters
    ----------
    margin : float
        Fraction of the camera's full scale kept free below clipping (``--adaptive-margin``).
    iterations : int
        Check passes at most, only where clipping remains (``--adaptive-iterations``).
    refit : bool
        Re-fit the levels from the adapted set and capture once more.
    boost : bool
        One more set where pixels receive much less than their own level, merged per pixel
        by the larger unclipped modulation.
    bias_correction : bool
        Subtract the phase bias of the map's steps under the blur.
    mapping_migl : float, optional
        MIGL of the mapping sets (``--mapping-migl``); default: automatic.
    blur_px : float, optional
        Erosion beyond the camera pixel's footprint, projector pixels (None: 2, with
        ``max_images`` 0).
    smooth_px : float, optional
        Smoothing of the map from below, projector pixels (None: 3, with ``max_images`` 4).
    exposure_ms : float, optional
        Fixed exposure time of every capture (``--adaptive-exposure-ms``); None: the rig's.
    auto_exposure : bool
        Choose the exposure first, then the MIGL map (``--adaptive-auto-exposure``; thesis
        Sec. 7.3, "adaptive + exposure" in docs/compare.md).
    topup : bool
        Where pixels clip even at the lowest usable MIGL, one or two sets more at a shorter
        exposure for them, merged per pixel (docs/adaptive.md, "Top-up").
    epipolar : bool
        Map the vertical orientation only and take the projector row from the epipolar
        constraint (``--adaptive-epipolar``; docs/adaptive.md).
    stereo_calibration : StereoCalibration, optional
        The calibration ``epipolar`` uses; None: the rig's own (the virtual rig's true one).
    full_mapping : bool
        Map at the full MIGL where only a highlight clips in the first set, leaving it to
        the top-up; no refit, check or boost then (``--adaptive-full-mapping``).
    max_images : int, optional
        Image budget of the measurement (``--max-images``; docs/adaptive.md, "Budget").
    mapping_exposure : bool
        With ``max_images``: the adapted set's exposure chosen from the mapping's response.
    depth_range_mm : tuple of float, optional
        With ``max_images`` and a calibration: the scene's depth range (mm along the camera
        axis) from which the coarsest set takes its fringe order, no one-period set
        (``measure --depth-range``).

    References
    ----------
    Thesis Sec. 7.2 (future work); docs/adaptive.md.

    Examples
    --------
    >>> AdaptiveParams().margin
    0.015
    """

    margin: float = field(
        default=0.015,
        metadata={
            "help": "fraction of full scale kept free below clipping.",
            "cli": "--adaptive-margin",
        },
    )
    iterations: int = field(
        default=1,
        metadata={
            "help": "check passes at most, each only where clipping remains.",
            "cli": "--adaptive-iterations",
        },
    )
    refit: bool = field(
        default=True,
        metadata={
            "help": "re-fit each pixel's level from the adapted set at its own pitch (blur "
            "lowers a fine fringe's peak) and capture it once more.",
        },
    )
    boost: bool = field(
        default=True,
        metadata={
            "help": "one more set where the map gives pixels much less than their own level "
            "(a dim pixel next to a bright one), kept per pixel where its modulation is larger.",
            "cli": "--adaptive-boost",
        },
    )
    bias_correction: bool = field(
        default=True,
        metadata={
            "help": "subtract the phase bias of the map's steps under the blur (the blur "
            "fitted against the mapping).",
            "cli": "--adaptive-bias-correction",
        },
    )
    mapping_migl: float | None = field(
        default=None,
        metadata={
            "help": "MIGL of every mapping set (default: imin + 20 for the first, then the "
            "highest with 10 % headroom by its response).",
            "cli": "--mapping-migl",
        },
    )
    blur_px: float | None = field(
        default=None,
        metadata={
            "help": "erosion beyond the camera pixel's footprint (projector pixels; default 2, "
            "with max_images 0)."
        },
    )
    smooth_px: float | None = field(
        default=None,
        metadata={
            "help": "smoothing of the map from below (projector pixels; default 3, with "
            "max_images 4)."
        },
    )
    exposure_ms: float | None = field(
        default=None,
        metadata={
            "help": "fixed exposure time of every capture in ms (default: the rig's).",
            "cli": "--adaptive-exposure-ms",
        },
    )
    auto_exposure: bool = field(
        default=False,
        metadata={
            "help": "choose the exposure first (thesis Sec. 7.3: the darkest lit surface at "
            "the target modulation), then adapt the MIGL at it; the rig's exposure is kept "
            "where nothing saturates.",
            "cli": "--adaptive-auto-exposure",
        },
    )
    topup: bool = field(
        default=True,
        metadata={
            "help": "where pixels clip even at the lowest usable MIGL, the finest set at a "
            "shorter exposure for them, merged per pixel by the larger unclipped modulation.",
            "cli": "--adaptive-topup",
        },
    )
    epipolar: bool = field(
        default=False,
        metadata={
            "help": "map the vertical fringes only and take each pixel's projector row from "
            "the projector-camera calibration (epipolar constraint): the horizontal mapping "
            "ladder is not captured. Needs a calibration (the virtual rig has its own).",
            "cli": "--adaptive-epipolar",
        },
    )
    stereo_calibration: StereoCalibration | None = field(
        default=None,
        metadata={
            "help": "the projector-camera calibration the epipolar mapping uses (default: the "
            "rig's own).",
        },
    )
    full_mapping: bool = field(
        default=False,
        metadata={
            "help": "capture the first mapping set at the full MIGL; where at most 5 % of the "
            "pixels clip in it (a highlight) map at the full MIGL, leave the clipped pixels to "
            "the top-up and skip the refit, check and boost sets; else fall back to the "
            "low-MIGL mapping (the trial set merged into it where it did not clip).",
            "cli": "--adaptive-full-mapping",
        },
    )
    max_images: int | None = field(
        default=None,
        metadata={
            "help": "image budget of the whole measurement (issue 26): the first set at the "
            "full MIGL (nothing clipped: the conventional measurement), the mapping sets are "
            "the measurement's coarser sets, one adapted set at an exposure chosen from the "
            "mapping, further passes only while the budget allows; what it could not reach is "
            "reported.",
            "cli": "--max-images",
        },
    )
    mapping_exposure: bool = field(
        default=True,
        metadata={
            "help": "with max_images: the adapted set's exposure chosen from the mapping's "
            "response (thesis Sec. 7.3); False: the rig's.",
        },
    )
    depth_range_mm: tuple[float, float] | None = field(
        default=None,
        metadata={
            "help": "with max_images and a calibration: the scene's depths (mm) that order the "
            "coarsest set (default: measure's --depth-range).",
        },
    )


#: The entries of an adapted set's ``details`` that ``metrics.json`` records.
ADAPTIVE_METRICS = (
    "margin",
    "mapping_pitches",
    "mapping_migls",
    "erosion_radius_px",
    "blur_sigma_px",
    "refit_passes",
    "check_passes",
    "mapping_saturated",
    "mapping_bright_migl",
    "boost_passes",
    "exposure_ms",
    "topup",
    "epipolar",
    "full_mapping",
    "images_per_step",
    "sets_per_step",
    "seconds_per_step",
    "budget",
)


def adaptive_summary(results: Sequence[StrategyResult]) -> dict[str, Any]:
    """What ``metrics.json`` records of the adaptive projection, per adapted orientation.

    Parameters
    ----------
    results : sequence of StrategyResult
        One per set of the measurement.

    Returns
    -------
    dict
        Orientation -> the :data:`ADAPTIVE_METRICS` entries of its adapted set (the mapping
        is counted with the first adapted set; ``budget`` only with ``max_images``, alone
        where the budget's first set clipped nowhere and the conventional sets followed);
        empty for the other strategies.

    Examples
    --------
    >>> adaptive_summary([])
    {}
    """
    return {
        r.spec.orientation: {k: json_safe(r.details[k]) for k in ADAPTIVE_METRICS if k in r.details}
        for r in results
        if r.strategy == "adaptive" and ("images_per_step" in r.details or "budget" in r.details)
    }


@register
class Adaptive(FunctionStrategy):
    """The registry's ``adaptive``: :func:`adaptive_sets` over all sets of a measurement.

    Examples
    --------
    >>> Adaptive().describe(AdaptiveParams(margin=0.05))
    'Adaptive 5 %'
    """

    name = "adaptive"
    title = "Adaptive"
    help = (
        "per-pixel adaptive projection (beyond the thesis, Sec. 7.2): map camera to projector "
        "at a low MIGL, then one set with each projector pixel's highest safe MIGL"
    )
    Params = AdaptiveParams
    function = staticmethod(adaptive)

    def run_sets(
        self, rig: Rig, specs: Sequence[FringeSpec], params: AdaptiveParams
    ) -> tuple[StrategyResult, ...]:
        """Run on every set of a measurement at once (one mapping serves all of them).

        Parameters
        ----------
        rig : Rig
            A rig whose projector shows projector images.
        specs : sequence of FringeSpec
            The measurement's sets, coarsest first.
        params : AdaptiveParams
            The parameters.

        Returns
        -------
        tuple of StrategyResult
            One per spec.
        """
        return _run_adaptive(rig, specs, params)

    def describe(self, params: AdaptiveParams) -> str:
        """Label of a run: ``"Adaptive <margin> %"`` (``" + exposure"`` with the automatic one).

        Parameters
        ----------
        params : AdaptiveParams
            The parameters.

        Returns
        -------
        str

        Examples
        --------
        >>> Adaptive().describe(AdaptiveParams()), Adaptive().describe(AdaptiveParams(
        ...     auto_exposure=True))
        ('Adaptive 1.5 %', 'Adaptive 1.5 % + exposure')
        """
        label = f"Adaptive {100 * params.margin:g} %"
        return label + " + exposure" if params.auto_exposure else label

    def prepare(self, params: AdaptiveParams, context: RunContext) -> AdaptiveParams:
        """The epipolar mapping takes the projector-camera calibration the measurement was
        given (``measure --calibration STEREO.h5``) when the parameters name none; an image
        budget takes the measurement's depth range (``measure --depth-range``) likewise.

        Parameters
        ----------
        params : AdaptiveParams
            The parameters.
        context : RunContext
            What the measurement offers (``projector_geometry``, ``depth_range_mm``).

        Returns
        -------
        AdaptiveParams

        Examples
        --------
        >>> Adaptive().prepare(AdaptiveParams(epipolar=True), RunContext()).stereo_calibration
        >>> Adaptive().prepare(AdaptiveParams(max_images=8),
        ...                    RunContext(depth_range_mm=(1850.0, 1910.0))).depth_range_mm
        (1850.0, 1910.0)
        """
        given: dict[str, Any] = {}
        if params.epipolar and params.stereo_calibration is None:
            if context.projector_geometry is not None:
                given["stereo_calibration"] = context.projector_geometry
        if params.max_images is not None and params.depth_range_mm is None:
            if context.depth_range_mm is not None:
                given["depth_range_mm"] = tuple(context.depth_range_mm)
        return dataclasses.replace(params, **given) if given else params

    def metrics(
        self, results: Sequence[StrategyResult], context: MetricsContext
    ) -> StrategyMetrics:
        """The ``adaptive`` block: :func:`adaptive_summary` (none without an adapted set).

        Parameters
        ----------
        results : sequence of StrategyResult
            One per set of the measurement.
        context : MetricsContext
            Unused: the results carry what the block records.

        Returns
        -------
        StrategyMetrics

        Examples
        --------
        >>> Adaptive().metrics([], MetricsContext(AdaptiveParams()))
        StrategyMetrics(metrics={}, result={})
        """
        summary = adaptive_summary(results)
        return StrategyMetrics(metrics={"adaptive": summary} if summary else {})
