"""Figures written as PNG files.

Every figure of the library is drawn here, with matplotlib's Agg backend (no display needed);
matplotlib is imported when a figure is drawn, not when this module is imported. The core
modules compute what is plotted (:mod:`hdrfringe.gamma`) and
never import matplotlib.

* :func:`plot_gamma_mapping`: thesis Fig. 2.6 b/c, input gray -> captured intensity without
  and with pre-compensation.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np
from numpy.typing import ArrayLike

from hdrfringe._validation import full_scale
from hdrfringe.gamma import GammaFit, line_deviation, measure_nonlinearity

__all__ = ["plot_gamma_mapping"]


def _pyplot() -> ModuleType:
    """matplotlib.pyplot on the Agg backend (imported on first use)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_gamma_mapping(
    fit: GammaFit,
    path: str | Path,
    gamma_hat: float | None = None,
    *,
    measured_levels: ArrayLike | None = None,
    measured_dn: ArrayLike | None = None,
    title: str | None = None,
    dpi: int = 120,
) -> Path:
    """Thesis Fig. 2.6 b/c as a PNG: input gray -> captured intensity without and with correction.

    (b) the captured samples against the gray sent to the projector, with the fitted curve
    (excluded samples as crosses). (c) requested (linear) gray -> captured intensity after
    pre-compensation with ``gamma_hat``: the fit's prediction, the samples of (b) re-indexed by
    the requested level that would send their gray (``full * (sent/full)^gamma_hat``), captures
    made with that pre-compensation when given, and the ideal straight line
    ``offset + scale * g/full``. Works for uniform and fringe fits.

    Parameters
    ----------
    fit : GammaFit
        From :func:`~hdrfringe.gamma.fit_gamma_uniform` or
        :func:`~hdrfringe.gamma.fit_gamma_fringes`.
    path : str or Path
        PNG file to write.
    gamma_hat : float, optional
        Pre-compensation exponent of panel (c); default the fitted gamma.
    measured_levels, measured_dn : array_like, optional
        Requested levels and their captured DN, made with pre-compensation ``gamma_hat``
        (both or neither).
    title : str, optional
        Figure title.
    dpi : int
        Resolution of the PNG.

    Returns
    -------
    Path
        ``path``.

    References
    ----------
    Thesis Sec. 2.6, Fig. 2.6 b/c; Eq. 2.16 (the fitted curve) and Eq. 2.17 (pre-compensation).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.gamma import fit_gamma_uniform
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> out = plot_gamma_mapping(fit, Path(tempfile.mkdtemp()) / "gamma_mapping.png")
    >>> out.name, out.stat().st_size > 10_000
    ('gamma_mapping.png', True)
    """
    plt = _pyplot()
    gh = fit.gamma if gamma_hat is None else float(gamma_hat)
    full = float(full_scale(fit.projector_bit_depth, "projector bit depth"))
    g = np.arange(0.0, full + 1.0) if full <= 1023 else np.linspace(0.0, full, 1024)
    many = fit.sent.size > 300
    style = {"ms": 1, "alpha": 0.25} if many else {"ms": 4}
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.4), dpi=dpi)
    used = fit.used
    ax1.plot(fit.sent[used], fit.dn[used], "o", color="C0", label="captured", **style)
    if np.any(~used):
        ax1.plot(fit.sent[~used], fit.dn[~used], "x", color="C3", label="excluded (clipped)")
    ax1.plot(g, fit.predict(g), "-", color="C1", label=f"fit, gamma = {fit.gamma:.3f}")
    ax1.set(
        xlabel="gray level sent to the projector",
        ylabel="captured intensity (DN)",
        title="(b) without correction",
    )
    ax1.legend(loc="upper left")

    pred = fit.predict_precompensated(g, gh)
    nl = measure_nonlinearity(g, fit, gh, fit.projector_bit_depth)
    ideal = fit.offset + fit.scale * g / full
    remapped = full * (np.clip(fit.sent, 0, full) / full) ** gh
    ax2.plot(remapped[used], fit.dn[used], "o", color="C0", label="samples of (b)", **style)
    ax2.plot(g, pred, "-", color="C1", label=f"predicted, max dev. {nl.max_percent:.2f} %")
    if measured_levels is not None and measured_dn is not None:
        ml = np.asarray(measured_levels, dtype=np.float64)
        md = np.asarray(measured_dn, dtype=np.float64)
        mnl = line_deviation(ml, md)
        ax2.plot(ml, md, "s", color="C2", ms=4, label=f"measured, max dev. {mnl.max_percent:.2f} %")
    ax2.plot(g, ideal, "--", color="k", lw=1, label="ideal (linear)")
    ax2.set(
        xlabel="requested (linear) gray level",
        ylabel="captured intensity (DN)",
        title=f"(c) with pre-compensation, gamma-hat = {gh:.3f}",
    )
    ax2.legend(loc="upper left")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out
