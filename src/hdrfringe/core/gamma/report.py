"""The gamma report of a set of captures: every fit the captures allow, and its summary.

:func:`gamma_report` is what ``hdrfringe gamma`` computes (thesis Sec. 2.6, Eq. 2.16): a fit of
the uniform grays when there are at least :data:`MIN_UNIFORM_LEVELS` distinct levels
(:func:`uniform_gray_means`: the mean over the centre half of each image), with the residual
nonlinearity it predicts, and a shape fit of the wide sinusoidal sets
(:func:`~hdrfringe.core.gamma.select_gamma_sets`). It works on
:class:`~hdrfringe.core.captures.Captures` in memory; writing ``gamma.json`` and the plot is
:func:`hdrfringe.io.gamma_outputs.write_gamma_outputs`.

Examples
--------
>>> import numpy as np
>>> from hdrfringe.core.captures import Captures
>>> from hdrfringe.core.frames import UniformFrame
>>> levels = [0, 64, 128, 192, 255]
>>> images = np.stack([np.full((4, 4), 10 + 200 * (g / 255) ** 2.2) for g in levels])
>>> caps = Captures([UniformFrame(g) for g in levels], np.rint(images).astype(np.uint8), 8)
>>> rep = gamma_report(caps, source="demo")
>>> round(rep.uniform_fit.gamma, 1), sorted(rep.report), rep.report["warnings"]
(2.2, ['source', 'uniform', 'warnings'], [])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core._validation import full_scale
from hdrfringe.core.captures import Captures
from hdrfringe.core.gamma.fringes import fit_gamma_fringes
from hdrfringe.core.gamma.model import GammaFit
from hdrfringe.core.gamma.nonlinearity import line_deviation, predicted_nonlinearity
from hdrfringe.core.gamma.selection import select_gamma_sets
from hdrfringe.core.gamma.uniform import fit_gamma_uniform
from hdrfringe.errors import CaptureFormatError, InputError

__all__ = [
    "DEGENERATE_RELATIVE_STDERR",
    "FRINGE_NONLINEARITY_BINS",
    "GAMMA_FIT_BOUNDS",
    "LARGE_RESIDUAL_FRACTION",
    "MIN_UNIFORM_LEVELS",
    "GammaReport",
    "check_gamma_fit",
    "gamma_report",
    "residual_is_large",
    "uniform_gray_means",
]

#: Distinct uniform gray levels needed for a uniform fit (offset, scale, gamma and a check).
MIN_UNIFORM_LEVELS = 4
#: The range the fits search (``fit_gamma_uniform``, ``fit_gamma_fringes``): a fit that ends
#: on either end did not find a gamma.
GAMMA_FIT_BOUNDS = (0.05, 20.0)
#: A fit whose standard error exceeds this fraction of its gamma is reported as degenerate
#: (the captures hardly constrain gamma; e.g. 0.30 +- 257).
DEGENERATE_RELATIVE_STDERR = 0.25
#: A fit whose RMS residual exceeds this fraction of its signal range (the fitted scale
#: ``c1``, DN from gray 0 to full input) is reported with a warning: the power law does not
#: describe the captures (a light that changed, clipping, a response far from a power law).
#: Camera noise leaves far less: 0.4-0.6 % on kamino410's real fringes (1 DN of 172) and on
#: the synthetic benches (docs/gamma.md).
LARGE_RESIDUAL_FRACTION = 0.02
#: Bins of the fringe samples' measured residual nonlinearity (median per bin of level).
FRINGE_NONLINEARITY_BINS = 32


def check_gamma_fit(fit: GammaFit, what: str, source: str) -> bool:
    """Refuse a fit that cannot be a gamma; say whether it is degenerate.

    Parameters
    ----------
    fit : GammaFit
        A uniform-gray or fringe-shape fit.
    what : str
        Which fit, for the message (e.g. ``"uniform-gray"``).
    source : str
        Where the captures came from, for the message.

    Returns
    -------
    bool
        True when the standard error is not finite or above
        :data:`DEGENERATE_RELATIVE_STDERR` times gamma (report it with a warning).

    Raises
    ------
    InputError
        Gamma not finite or on an end of :data:`GAMMA_FIT_BOUNDS` (the search found no
        minimum), or a uniform fit whose camera signal does not rise with the gray level.

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.16 (the model fitted).

    Examples
    --------
    >>> from dataclasses import replace
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> check_gamma_fit(fit, "uniform-gray", "demo")
    False
    >>> check_gamma_fit(replace(fit, gamma=0.3, stderr=257.0), "uniform-gray", "demo")
    True
    """
    lo, hi = GAMMA_FIT_BOUNDS
    g = fit.gamma
    at_bound = math.isfinite(g) and (g <= lo * (1 + 1e-6) or g >= hi * (1 - 1e-6))
    flat = fit.method == "uniform" and not fit.scale > 0
    if not math.isfinite(g) or at_bound or flat:
        why = (
            "the camera signal does not rise with the gray level"
            if flat or g <= lo * (1 + 1e-6)
            else "the fit found no minimum"
        )
        raise InputError(
            f"{source}: the {what} fit gives gamma = {g:.4g}, on the end of the searched range "
            f"{lo:g}..{hi:g} ({why}), which cannot be a projector gamma; check that the "
            "projector lights the view and the exposure is neither black nor saturated"
        )
    se = fit.stderr
    return not (math.isfinite(se) and se <= DEGENERATE_RELATIVE_STDERR * g)


def uniform_gray_means(
    captures: Captures,
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """The uniform frames' gray levels and mean captured intensity over the centre half.

    Parameters
    ----------
    captures : Captures
        Any captures; only the uniform frames are used.

    Returns
    -------
    (levels, means) : pair of ndarray, or None
        One entry per uniform frame (in frame order): its input gray level, and the mean DN
        over rows ``h//4 : 3h//4`` and columns ``w//4 : 3w//4``. None when the uniform frames
        have fewer than :data:`MIN_UNIFORM_LEVELS` distinct levels.

    References
    ----------
    Thesis Sec. 2.6, Fig. 2.6 (input gray to captured intensity).

    Examples
    --------
    >>> from hdrfringe.core.frames import UniformFrame
    >>> images = np.zeros((4, 4, 4), np.uint8)
    >>> images[:, 1:3, 1:3] = [[[10]], [[20]], [[30]], [[40]]]  # the centre half
    >>> caps = Captures([UniformFrame(g) for g in (0, 50, 100, 150)], images, 8)
    >>> uniform_gray_means(caps)[1].tolist()
    [10.0, 20.0, 30.0, 40.0]
    """
    uniforms = captures.uniforms()
    if len({f.level for f, _ in uniforms}) < MIN_UNIFORM_LEVELS:
        return None
    h, w = captures.image_shape
    roi = (slice(h // 4, 3 * h // 4), slice(w // 4, 3 * w // 4))
    levels = np.array([f.level for f, _ in uniforms])
    means = np.array([float(np.mean(img[roi])) for _, img in uniforms])
    return levels, means


@dataclass(frozen=True, eq=False)
class GammaReport:
    """Every gamma fit a set of captures allows (made by :func:`gamma_report`).

    Parameters
    ----------
    report : dict
        JSON-ready: ``source``, and ``uniform`` and/or ``fringes`` when fitted (the content of
        ``gamma.json``).
    uniform_fit : GammaFit or None
        The fit of the uniform grays (None when the captures do not allow one).
    fringe_fit : GammaFit or None
        The shape fit of the sinusoidal sets (None when the captures do not allow one).
    lines : tuple of str
        The human summary, one line each, in order (fits, notes).

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.16-2.17.

    Examples
    --------
    >>> from hdrfringe.core.frames import UniformFrame
    >>> levels = [0, 64, 128, 192, 255]
    >>> images = np.stack([np.full((4, 4), 10 + 200 * (g / 255) ** 2.2) for g in levels])
    >>> caps = Captures([UniformFrame(g) for g in levels], np.rint(images).astype(np.uint8), 8)
    >>> rep = gamma_report(caps, source="demo")
    >>> rep.fitted, rep.fringe_fit is None, rep.lines[0][:29]
    (True, True, 'uniform grays: gamma = 2.2023')
    >>> GammaReport({"source": "empty"}, None, None, ()).check_fitted()
    Traceback (most recent call last):
    ...
    hdrfringe.errors.CaptureFormatError: empty: nothing to fit: give uniform frames at >= 4 ...
    """

    report: dict[str, Any]
    uniform_fit: GammaFit | None
    fringe_fit: GammaFit | None
    lines: tuple[str, ...]

    @property
    def fitted(self) -> bool:
        """True when at least one fit was made."""
        return self.uniform_fit is not None or self.fringe_fit is not None

    def check_fitted(self) -> None:
        """Refuse captures that allowed no fit.

        Raises
        ------
        CaptureFormatError
            Neither uniform grays at enough levels nor fittable sinusoidal sets.
        """
        if not self.fitted:
            raise CaptureFormatError(
                f"{self.report['source']}: nothing to fit: give uniform frames at >= "
                f"{MIN_UNIFORM_LEVELS} gray levels, or sinusoidal sets at two pre-compensation "
                "exponents (frame field gamma_precompensation) or with >= 4 steps"
            )


def residual_is_large(fit: GammaFit) -> bool:
    """Whether a fit's RMS residual exceeds :data:`LARGE_RESIDUAL_FRACTION` of its signal range.

    Parameters
    ----------
    fit : GammaFit
        A uniform-gray or fringe-shape fit.

    Returns
    -------
    bool
        True when ``rms_residual > LARGE_RESIDUAL_FRACTION * scale`` (or either is not finite).

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.16 (the model whose residual it is).

    Examples
    --------
    >>> from dataclasses import replace
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> residual_is_large(fit), residual_is_large(replace(fit, rms_residual=6.0))
    (False, True)
    """
    r, c = fit.rms_residual, fit.scale
    return not (math.isfinite(r) and math.isfinite(c) and r <= LARGE_RESIDUAL_FRACTION * c)


def _residual_note(fit: GammaFit, what: str) -> str:
    share = 100 * fit.rms_residual / fit.scale if fit.scale > 0 else math.inf
    return (
        f"warning: the {what} fit leaves an rms residual of {fit.rms_residual:.3g} DN, "
        f"{share:.2g} % of its {fit.scale:.0f} DN signal range (more than "
        f"{100 * LARGE_RESIDUAL_FRACTION:g} %): the power law does not describe these captures "
        "well (a light that changed, clipping, a response far from a power law); check the "
        "plots before using this gamma"
    )


def _degenerate_note(fit: GammaFit, what: str) -> str:
    return (
        f"warning: the {what} fit is degenerate (gamma {fit.gamma:.2f} +- {fit.stderr:.3g}): "
        "the captures hardly constrain gamma; do not use it, capture more levels or sets "
        "spanning the camera's range"
    )


def gamma_report(captures: Captures, *, source: str) -> GammaReport:
    """Fit the projector gamma with everything the captures allow (uniform grays, fringes).

    Uniform grays (:func:`uniform_gray_means`) give :func:`~hdrfringe.core.gamma.fit_gamma_uniform`
    and the residual nonlinearity predicted after pre-compensation with the fit, with the
    captures' own exponent and without any. Sinusoidal sets chosen by
    :func:`~hdrfringe.core.gamma.select_gamma_sets` (wide ones: narrow fringes are reshaped by
    projector pixels and blur, which a shape fit would read as gamma) give
    :func:`~hdrfringe.core.gamma.fit_gamma_fringes`.

    Parameters
    ----------
    captures : Captures
        The captures (projector bit depth and pre-compensation from ``captures.projector``;
        8 bits and 1.0 when it is unknown; a set's own exponent wins).
    source : str
        Where they came from (recorded in the report and named in messages).

    Returns
    -------
    GammaReport
        Call :meth:`GammaReport.check_fitted` to refuse captures that allowed no fit.

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.16-2.17; docs/gamma.md.

    Examples
    --------
    >>> from hdrfringe.core.frames import UniformFrame
    >>> caps = Captures([UniformFrame(128)], np.zeros((1, 2, 2), np.uint8), 8)
    >>> rep = gamma_report(caps, source="one gray")
    >>> rep.fitted, rep.report
    (False, {'source': 'one gray'})
    """
    proj_bits = captures.projector.bit_depth if captures.projector else 8
    gh0 = captures.projector.gamma_precompensation if captures.projector else 1.0
    report: dict[str, Any] = {"source": source}
    lines: list[str] = []
    warnings: list[str] = []
    uniform_fit = fringe_fit = None
    means = uniform_gray_means(captures)
    if means is not None:
        uniform_fit = fit_gamma_uniform(
            *means,
            camera_bit_depth=captures.camera_bit_depth,
            projector_bit_depth=proj_bits,
            gamma_precompensation=gh0,
        )
        mx_fit, rms_fit = predicted_nonlinearity(uniform_fit, uniform_fit.gamma)
        mx_cur, _ = predicted_nonlinearity(uniform_fit, gh0)
        mx_none, _ = predicted_nonlinearity(uniform_fit, 1.0)
        u_degenerate = check_gamma_fit(uniform_fit, "uniform-gray", source)
        u_large = residual_is_large(uniform_fit)
        report["uniform"] = {
            "gamma": uniform_fit.gamma,
            "stderr": uniform_fit.stderr if math.isfinite(uniform_fit.stderr) else None,
            "degenerate": u_degenerate,
            "residual_large": u_large,
            "offset_dn": uniform_fit.offset,
            "scale_dn": uniform_fit.scale,
            "rms_residual_dn": uniform_fit.rms_residual,
            "levels_used": uniform_fit.n_samples,
            "residual_nonlinearity_percent": {
                "precompensated_with_fit": mx_fit,
                "precompensated_with_fit_rms": rms_fit,
                f"precompensated_with_{gh0:g}": mx_cur,
                "no_precompensation": mx_none,
            },
        }
        lines += [
            f"uniform grays: gamma = {uniform_fit.gamma:.4f} +- {uniform_fit.stderr:.4f} "
            f"(rms residual {uniform_fit.rms_residual:.2f} DN, {uniform_fit.n_samples} levels)",
            f"residual nonlinearity (max, % of range): {mx_fit:.2f} % pre-compensated with the "
            f"fit, {mx_cur:.2f} % with {gh0:g}, {mx_none:.2f} % without",
        ]
        if u_degenerate:
            warnings.append(_degenerate_note(uniform_fit, "uniform-gray"))
        elif u_large:  # one warning per fit: a degenerate one is not to be used at all
            warnings.append(_residual_note(uniform_fit, "uniform-gray"))
        lines += warnings
    sets = captures.sets
    chosen = select_gamma_sets([(s.spec, s.gamma_precompensation or gh0) for s in sets])
    if chosen.too_narrow:
        lines.append(
            f"note: fringe sets narrower than {chosen.min_pitch_px:g} px not used for gamma: "
            + ", ".join(sets[i].label for i in chosen.too_narrow)
        )
    if chosen.fittable:
        used = [sets[i] for i in chosen.used]
        fringe_fit = fit_gamma_fringes(
            [(s.spec, s.gamma_precompensation or gh0, captures.set_images(s)) for s in used],
            camera_bit_depth=captures.camera_bit_depth,
            projector_bit_depth=proj_bits,
        )
        f_degenerate = check_gamma_fit(fringe_fit, "fringe-shape", source)
        f_large = residual_is_large(fringe_fit)
        fx_fit, frms_fit = predicted_nonlinearity(fringe_fit, fringe_fit.gamma)
        fx_none, _ = predicted_nonlinearity(fringe_fit, 1.0)
        fx_meas = _measured_nonlinearity(fringe_fit)
        report["fringes"] = {
            "gamma": fringe_fit.gamma,
            "stderr": fringe_fit.stderr if math.isfinite(fringe_fit.stderr) else None,
            "degenerate": f_degenerate,
            "residual_large": f_large,
            "rms_residual_dn": fringe_fit.rms_residual,
            "pixels_used": fringe_fit.n_samples,
            "sets": [s.label for s in used],
            "residual_nonlinearity_percent": {
                "precompensated_with_fit": fx_fit,
                "precompensated_with_fit_rms": frms_fit,
                "no_precompensation": fx_none,
                "measured_precompensated_with_fit": fx_meas,
            },
        }
        lines += [
            f"fringe shape: gamma = {fringe_fit.gamma:.4f} +- {fringe_fit.stderr:.4f} "
            f"(rms residual {fringe_fit.rms_residual:.2f} DN over {fringe_fit.n_samples} pixels)",
            f"residual nonlinearity (max, % of range): {fx_fit:.2f} % pre-compensated with the "
            f"fit ({_percent(fx_meas)} measured from the samples), {fx_none:.2f} % without",
        ]
        fringe_warnings = []
        if f_degenerate:
            fringe_warnings.append(_degenerate_note(fringe_fit, "fringe-shape"))
        elif f_large:
            fringe_warnings.append(_residual_note(fringe_fit, "fringe-shape"))
        lines += fringe_warnings
        warnings += fringe_warnings
    if uniform_fit is not None or fringe_fit is not None:
        report["warnings"] = warnings
    return GammaReport(report, uniform_fit, fringe_fit, tuple(lines))


def _measured_nonlinearity(fit: GammaFit) -> float | None:
    """Max nonlinearity (%) of the fringe samples re-indexed to pre-compensation with the fit
    (docs/gamma.md, "Residual nonlinearity"); None when too few samples for the bins."""
    full = float(full_scale(fit.projector_bit_depth, "projector bit depth"))
    level = full * (np.clip(fit.sent, 0.0, full) / full) ** fit.gamma
    try:
        nl = line_deviation(level, fit.dn, bins=FRINGE_NONLINEARITY_BINS)
    except InputError:
        return None
    return nl.max_percent if math.isfinite(nl.max_percent) else None


def _percent(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2f} %"
