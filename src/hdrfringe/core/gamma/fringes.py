"""Projector gamma from phase-shifted fringes pre-distorted with known exponents (thesis Sec. 2.6).

:func:`fit_gamma_fringes` fits the exponent that makes every pixel's samples follow the
distorted wave (Eq. 2.16 applied to patterns pre-compensated by Eq. 2.17). Per pixel the phase
and (by default) the offset and scale are free, so ambient light, reflectivity and contrast
loss do not bias it; no Gray code is needed (docs/gamma.md has the derivation). The solver is
in :mod:`hdrfringe.core.gamma._solver`; this module checks the input, picks the pixels and
summarises the result.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import check_bit_depth, full_scale, is_saturated
from hdrfringe.core.gamma._solver import _basis, _Group, _offset_scale, _residual, _solve
from hdrfringe.core.gamma.model import MIN_FRINGE_PITCH_PX, MIN_MODULATION_FRACTION, GammaFit
from hdrfringe.core.gamma.selection import _region
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError

__all__ = ["fit_gamma_fringes"]

F64 = NDArray[np.float64]
#: ``normalization`` of :func:`fit_gamma_fringes`.
Normalization = Literal["shape", "black_white"]
#: ``weighting`` of :func:`fit_gamma_fringes`.
Weighting = Literal["levels", "samples"]
#: Sets with the same pitch and orientation share the per-pixel phase and scale.
_GroupKey = tuple[float, str]
_Member = tuple[FringeSpec, float, NDArray]


def fit_gamma_fringes(
    sets: Sequence[tuple[FringeSpec, float, ArrayLike]],
    *,
    camera_bit_depth: int,
    projector_bit_depth: int = 8,
    normalization: Normalization = "shape",
    black: ArrayLike | None = None,
    white: ArrayLike | None = None,
    offset_per_set: bool = True,
    weighting: Weighting = "levels",
    mask: ArrayLike | None = None,
    max_pixels: int = 10000,
    min_modulation: float | None = None,
    gamma_init: float = 2.0,
    seed: int = 0,
) -> GammaFit:
    """Fit the projector gamma to phase-shifted fringes pre-distorted with known exponents.

    A pattern value ``g_k = imin + (migl - imin) * (1 + P(phi + delta_k)) / 2`` (the contract's
    convention; ``P`` the sinusoidal or triangular profile, ``delta_k`` the set's shifts) is sent
    as ``full * (g_k/full)^(1/gamma-hat)`` (Eq. 2.17) and reaches the camera as

        ``I_k = o + s * (g_k/full)^(gamma / gamma-hat)``     (Eq. 2.16)

    with, per pixel, the phase ``phi``, the scale ``s`` (reflectivity, illumination,
    sensitivity) and the offset ``o`` (ambient light, black level, light scattered from the
    rest of the scene). Sets with the same pitch and orientation see the same ``phi`` and ``s``
    at a pixel. The global ``gamma`` and all per-pixel parameters are fitted jointly by
    Levenberg-Marquardt least squares on the captured DN over a random subsample of pixels, the
    per-pixel blocks eliminated by the Schur complement (each iteration costs O(pixels)); a
    coarse scan of gamma in 1..4 picks the start. Pixels whose RMS residual is an outlier (above
    the median plus 5 robust standard deviations: edges, specular spots, defects) are dropped
    once. docs/gamma.md has the derivation and the evidence for each modelling choice.

    ``normalization``:

    * "shape" (default): ``o`` and ``s`` free per pixel; only the distorted wave's shape
      enters, so ambient light, reflectivity and contrast loss cannot bias gamma, and no white
      or black frame is needed. ``offset_per_set`` (default) gives each set its own offset:
      scattered light grows with the mean light a pattern projects, which differs between
      pre-distortions. Each pixel needs more usable samples than unknowns: two pre-distortions
      of a 3-step set (6 samples, 4 unknowns), or one set of N >= 4 steps.
    * "black_white": ``o = black``, ``s = white - black`` from captures of full black and full
      white (gray ``2^Bp - 1``); only ``phi`` is free, so one 3-step set suffices. Biased when
      the fringes' offset and contrast differ from black/white (scattered light).

    ``weighting``: "levels" (default) weights the samples so that they are uniform over the
    linear level ``u = (sent/full)^gamma`` they represent (iterated three times), so the fit
    approximates the response evenly over the requested range, the range a pre-compensated
    pattern uses, whatever pre-distortion the captures happened to use; "samples" weights every
    sample equally. For a projector that follows the power law both give the same gamma.

    The model evaluates the pattern at a continuous phase: fringes must be wide enough that
    projector pixels and optical blur do not reshape them (a ``RuntimeWarning`` below
    ``MIN_FRINGE_PITCH_PX`` = 32 projector pixels; :func:`~hdrfringe.core.gamma.select_gamma_sets`
    picks the usable sets of a capture).

    Pixel selection: inside ``mask``; samples at 0 or ``2^B - 1`` are clipped and get zero
    weight (and in "black_white" mode, pixels with a clipped black or white are dropped); a
    pixel needs a peak-to-peak of its usable samples of at least ``min_modulation`` DN (default
    10 % of full scale), more usable samples than unknowns, and two usable samples per set when
    each set has its own offset.

    Parameters
    ----------
    sets : sequence of (FringeSpec, gamma_hat, images)
        Each set's pattern (shift ``k`` of ``spec`` at ``images[k]``), the pre-compensation
        exponent it was generated with, and its captures ``(N, H, W)``. The sets share the
        exposure.
    camera_bit_depth, projector_bit_depth : int
        Camera bit depth B (samples at 0 or ``2^B - 1`` are clipped) and projector bit depth
        Bp (``full = 2^Bp - 1``).
    normalization : {"shape", "black_white"}
        See above.
    black, white : array_like (H, W), optional
        Captures of full black and full white; required for "black_white".
    offset_per_set : bool
        "shape" mode: one offset per set at each pixel (default) or one for all sets.
    weighting : {"levels", "samples"}
        See above.
    mask : array_like of bool (H, W), optional
        Pixels that may be used.
    max_pixels : int
        Random subsample of usable pixels per group (deterministic with ``seed``).
    min_modulation : float, optional
        Minimum peak-to-peak DN of a pixel's usable samples (default 10 % of full scale).
    gamma_init : float
        Added to the coarse scan of starting values.
    seed : int
        Seed of the pixel subsampling.

    Returns
    -------
    GammaFit
        ``method = "fringes"``; ``stderr`` a sandwich estimate clustered by pixel (it allows
        for the weights and for noise that varies between pixels, not for model error shared
        by all pixels); ``offset``, ``scale`` medians of the per-pixel values;
        ``rms_residual`` unweighted, in DN; ``levels``, ``sent``, ``dn`` a subsample of the
        samples for plotting (see :class:`~hdrfringe.core.gamma.GammaFit`); ``n_samples`` and
        ``n_pixels`` the pixels used over all groups.

    Raises
    ------
    InputError
        Bad bit depths, options, set tuples, image shapes or types, exponents, MIGLs above the
        projector's maximum, values above ``2^B - 1``, missing black/white captures, or no
        pixel with enough unclipped, modulated samples.

    Warns
    -----
    RuntimeWarning
        For a set narrower than ``MIN_FRINGE_PITCH_PX`` projector pixels.

    References
    ----------
    Thesis Sec. 2.6: Eq. 2.16 (the power law) and Eq. 2.17 (pre-compensation); the fringes'
    offset and amplitude from ``imin`` and ``migl`` of Eq. 3.8-3.9. docs/gamma.md has the
    derivation.

    Examples
    --------
    Two 3-step sets pre-distorted with exponents 0.75 and 1.25 (Eq. 2.17, unrounded), seen by
    a camera with an offset, a varying reflectivity and a true gamma of 2.2:

    >>> from hdrfringe.core.patterns import FringeSpec, fringe_gray
    >>> spec = FringeSpec("sinusoidal", 3, 48.0)
    >>> x = np.tile(np.arange(0.0, 96.0, 0.5), (8, 1))  # projector column of each pixel
    >>> refl = np.linspace(0.6, 0.9, 8)[:, None]
    >>> sets = []
    >>> for gh in (0.75, 1.25):
    ...     light = [(fringe_gray(x, spec, k) / 255) ** (2.2 / gh) for k in range(3)]
    ...     sets.append((spec, gh, 12 + 200 * refl * np.stack(light)))
    >>> fit = fit_gamma_fringes(sets, camera_bit_depth=8)
    >>> round(fit.gamma, 6), fit.method
    (2.2, 'fringes')
    """
    check_bit_depth(camera_bit_depth, "camera bit depth")
    check_bit_depth(projector_bit_depth, "projector bit depth")
    if normalization not in ("shape", "black_white"):
        raise InputError(
            f"fringe gamma fit: normalization {normalization!r} unknown; use 'shape' or "
            "'black_white'"
        )
    if weighting not in ("levels", "samples"):
        raise InputError(
            f"fringe gamma fit: weighting {weighting!r} unknown; use 'levels' or 'samples'"
        )
    if not sets:
        raise InputError("fringe gamma fit: give at least one pre-distorted fringe set")
    full_c = float(full_scale(camera_bit_depth))
    full_p = float(full_scale(projector_bit_depth, "projector bit depth"))
    thr = MIN_MODULATION_FRACTION * full_c if min_modulation is None else float(min_modulation)
    bw_mode = normalization == "black_white"

    by_group, shape = _grouped_sets(sets, camera_bit_depth, full_p)
    sel = np.ones(shape, dtype=bool) if mask is None else _region(shape, None, mask)
    b_img = w_img = None
    if bw_mode:
        if black is None or white is None:
            raise InputError(
                "fringe gamma fit: normalization 'black_white' needs the black and white "
                "captures; pass black= and white= or use normalization='shape'"
            )
        b_img = np.asarray(black, dtype=np.float64)
        w_img = np.asarray(white, dtype=np.float64)
        if b_img.shape != shape or w_img.shape != shape:
            raise InputError(
                f"fringe gamma fit: black/white shapes {b_img.shape}/{w_img.shape} differ from "
                f"the fringe images {shape}; give captures of the same camera"
            )
        sel &= ~is_saturated(w_img, camera_bit_depth) & (b_img > 0) & (w_img - b_img >= thr)

    rng = np.random.default_rng(seed)
    groups: list[_Group] = []
    for members in by_group.values():
        grp = _pixel_group(
            members,
            sel,
            camera_bit_depth,
            full_p,
            thr,
            offset_per_set=offset_per_set,
            black=b_img,
            white=w_img,
            max_pixels=max_pixels,
            rng=rng,
        )
        if grp is not None:
            groups.append(grp)
    if not groups:
        need = "one set" if bw_mode else "two pre-distortions of a set (or N >= 4 steps)"
        raise InputError(
            f"fringe gamma fit: no pixel has enough unclipped, modulated samples; give {need} "
            f"captured without saturation and with a peak-to-peak above {thr:g} DN"
        )

    groups, params, gamma, stderr = _solve(
        groups,
        gamma_init,
        level_weights=weighting == "levels",
        keep_positive_scale=not bw_mode,
        rng=rng,
    )

    # summary and samples for plotting, mapped to the median offset and scale
    n_valid = sum(float(g.valid.sum()) for g in groups)
    ssr = sum(
        float(np.sum(g.valid * _residual(g, p, gamma) ** 2))
        for g, p in zip(groups, params, strict=True)
    )
    offs, scs = [], []
    for grp, prm in zip(groups, params, strict=True):
        off, sc = _offset_scale(grp, prm)
        offs.append(np.asarray(off).mean(axis=0))
        scs.append(np.asarray(sc)[0])
    offset = float(np.median(np.concatenate(offs)))
    scale = float(np.median(np.concatenate(scs)))
    levels, sent, dn = _plot_samples(groups, params, gamma, offset, scale, full_p, rng)
    n_pix = sum(g.y.shape[1] for g in groups)
    return GammaFit(
        gamma=float(gamma),
        stderr=stderr,
        ci95=(float(gamma - 1.96 * stderr), float(gamma + 1.96 * stderr)),
        offset=offset,
        scale=scale,
        rms_residual=float(np.sqrt(ssr / max(n_valid, 1.0))),
        method="fringes",
        normalization=normalization,
        levels=levels,
        sent=sent,
        dn=dn,
        used=np.ones(levels.size, dtype=bool),
        projector_bit_depth=int(projector_bit_depth),
        camera_bit_depth=int(camera_bit_depth),
        n_samples=int(n_pix),
        n_pixels=int(n_pix),
    )


def _grouped_sets(
    sets: Sequence[tuple[FringeSpec, float, ArrayLike]], camera_bit_depth: int, full_p: float
) -> tuple[dict[_GroupKey, list[_Member]], tuple[int, ...]]:
    """Check each set and group them by (pitch, orientation); also the common image shape."""
    full_c = float(full_scale(camera_bit_depth))
    by_group: dict[_GroupKey, list[_Member]] = {}
    shape: tuple[int, ...] | None = None
    for item in sets:
        if len(item) != 3:
            raise InputError("fringe gamma fit: give each set as (FringeSpec, gamma_hat, images)")
        spec, gh, imgs = item
        arr = np.asarray(imgs)
        if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has images of type {arr.dtype}; give "
                "numeric camera images"
            )
        shape = arr.shape[1:] if shape is None else shape
        if arr.ndim != 3 or arr.shape[0] != spec.steps or arr.shape[1:] != shape:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has images of shape {arr.shape}; expected "
                f"({spec.steps}, *{shape}), one image per shift, all the same size"
            )
        if not (math.isfinite(gh) and gh > 0):
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has gamma_hat {gh}; give its positive "
                "pre-compensation exponent"
            )
        if not spec.gray_levels_given:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} gives no imin/migl, and the fit models the "
                "pattern's gray levels; add imin and migl to the manifest's frames"
            )
        if spec.migl > full_p:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has migl {spec.migl:g} above the "
                f"projector's maximum {full_p:g}; check projector_bit_depth"
            )
        if np.nanmax(arr) > full_c:
            raise InputError(
                f"fringe gamma fit: set {spec.label()} has values up to {np.nanmax(arr):g}, above "
                f"2^{camera_bit_depth}-1; give the sensor's true bit depth"
            )
        if spec.pitch_px < MIN_FRINGE_PITCH_PX:
            warnings.warn(
                f"fringe gamma fit: set {spec.label()} has a pitch of {spec.pitch_px:g} projector "
                f"px; below {MIN_FRINGE_PITCH_PX:g} px projector pixels and blur reshape the "
                "fringes and bias gamma; use wide fringes (or uniform grays)",
                RuntimeWarning,
                stacklevel=3,  # the caller of fit_gamma_fringes
            )
        by_group.setdefault((spec.pitch_px, spec.orientation), []).append((spec, float(gh), arr))
    assert shape is not None
    return by_group, shape


def _pixel_group(
    members: list[_Member],
    sel: NDArray[np.bool_],
    camera_bit_depth: int,
    full_p: float,
    thr: float,
    *,
    offset_per_set: bool,
    black: F64 | None,
    white: F64 | None,
    max_pixels: int,
    rng: np.random.Generator,
) -> _Group | None:
    """The samples of one group's sets at its usable pixels (a random subsample), or None.

    A sample is usable when it is neither 0 nor saturated (and finite); a pixel when it is in
    ``sel``, has more usable samples than per-pixel unknowns, a peak-to-peak of its usable
    samples of at least ``thr`` DN and, with an offset per set, two usable samples per set.
    """
    full_c = float(full_scale(camera_bit_depth))
    bw_mode = black is not None
    y_all = np.concatenate([m[2].reshape(m[2].shape[0], -1) for m in members])
    n_sets = len(members)
    n_par = 1 if bw_mode else 2 + (n_sets if offset_per_set else 1)
    valid = (y_all > 0) & ~is_saturated(y_all, camera_bit_depth)
    if np.issubdtype(y_all.dtype, np.floating):
        valid &= np.isfinite(y_all)
    # peak-to-peak of the usable samples, without a float copy of the full images
    hi = np.max(np.where(valid, y_all, 0), axis=0).astype(np.float64)
    top = np.iinfo(y_all.dtype).max if np.issubdtype(y_all.dtype, np.integer) else full_c
    lo = np.min(np.where(valid, y_all, y_all.dtype.type(top)), axis=0).astype(np.float64)
    ok = sel.ravel() & (valid.sum(axis=0) > n_par) & (hi - lo >= thr)
    if offset_per_set and not bw_mode and n_sets > 1:
        start = 0
        for spec, _, _ in members:
            ok &= valid[start : start + spec.steps].sum(axis=0) >= 2
            start += spec.steps
    idx = np.flatnonzero(ok)
    if idx.size > max_pixels:
        idx = np.sort(rng.choice(idx, max_pixels, replace=False))
    if idx.size == 0:
        return None
    specs = [m[0] for m in members]
    return _Group(
        y=y_all[:, idx].astype(np.float64),
        valid=valid[:, idx].astype(np.float64),
        # the pattern phase of each frame: shift angle plus the set's offset (version 3)
        delta=np.concatenate([s.shifts + np.radians(s.phase_offset_deg) for s in specs]),
        lo=np.concatenate([np.full(s.steps, s.imin / full_p) for s in specs]),
        amp=np.concatenate([np.full(s.steps, (s.migl - s.imin) / full_p) for s in specs]),
        inv_gh=np.concatenate([np.full(m[0].steps, 1.0 / m[1]) for m in members]),
        pattern=[s.pattern for s in specs for _ in range(s.steps)],
        set_of=np.concatenate([np.full(s.steps, i) for i, s in enumerate(specs)]),
        offset_per_set=offset_per_set,
        black=None if black is None else black.ravel()[idx],
        span=None if white is None or black is None else (white - black).ravel()[idx],
    )


def _plot_samples(
    groups: list[_Group],
    params: list[F64],
    gamma: float,
    offset: float,
    scale: float,
    full_p: float,
    rng: np.random.Generator,
) -> tuple[F64, F64, F64]:
    """Linear level, sent gray and DN of a subsample of the usable samples (about 5000).

    Each pixel's DN are mapped to the common ``offset`` and ``scale`` so that all pixels share
    one curve (:class:`~hdrfringe.core.gamma.GammaFit`'s ``levels``, ``sent``, ``dn``).
    """
    lv, st, dn = [], [], []
    per = max(1, 5000 // len(groups))
    for grp, prm in zip(groups, params, strict=True):
        m = grp.y.shape[1]
        take = np.arange(m) if m <= per else np.sort(rng.choice(m, per, replace=False))
        sub, sp = grp.take(take), prm[:, take]
        h, _ = sub.pattern_value(sp[0])
        x = _basis(sub, sp[0], gamma)[3]
        off, sc = _offset_scale(sub, sp)
        good = sub.valid > 0
        lv.append((full_p * h)[good])
        st.append((full_p * x)[good])
        dn.append((offset + scale * (sub.y - off) / sc)[good])
    return np.concatenate(lv), np.concatenate(st), np.concatenate(dn)
