"""Figures written as PNG files: the gamma mapping, the MIGL pie chart, DPA's saturation CDFs.

Every figure of the library is drawn here, with matplotlib's Agg backend (no display needed);
matplotlib is imported when a figure is drawn, not when this module is imported. The modules
that compute what is plotted (:mod:`hdrfringe.core.gamma`, :mod:`hdrfringe.strategies.dpa_analysis`)
never import matplotlib.

* :func:`plot_gamma_mapping`: thesis Fig. 2.6 b/c, input gray -> captured intensity without
  and with pre-compensation.
* :func:`plot_migl_pie`: thesis Fig. 5.6 b/d/f, pixels per MIGL of a composite.
* :func:`plot_dpa_cdfs`: thesis Fig. 6.3, DPA's estimated and actual CDFs of the saturated
  intensities.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core._validation import full_scale
from hdrfringe.core.gamma import GammaFit, line_deviation, measure_nonlinearity

if TYPE_CHECKING:
    from hdrfringe.core.saturation.dpa_rules import SaturationCDF
    from hdrfringe.strategies.dpa_analysis import DPACDFs

__all__ = ["plot_dpa_cdfs", "plot_gamma_mapping", "plot_migl_pie"]


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
        From :func:`~hdrfringe.core.gamma.fit_gamma_uniform` or
        :func:`~hdrfringe.core.gamma.fit_gamma_fringes`.
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
    >>> from hdrfringe.core.gamma import fit_gamma_uniform
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


def plot_migl_pie(
    path: str | Path, migl_index: ArrayLike, *, title: str = "pixels per MIGL", dpi: int = 100
) -> Path:
    """Pie chart of the pixels per MIGL of a composite (thesis Fig. 5.6 b/d/f) as a PNG.

    One slice per MIGL in the index map, highest MIGL first, clockwise from the top; slices
    of 2 % of the pixels or more carry their MIGL, and a legend beside the pie names every
    slice with its share (a thin slice's label would overlap its neighbours').

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    migl_index : array_like
        MIGL index map ``N(x, y)``: the MIGL each pixel of the composite was taken at.
    title : str
        Chart title.
    dpi : int
        Resolution of the PNG (the figure is 6 x 6 inches).

    Returns
    -------
    Path
        ``path``.

    References
    ----------
    Thesis Sec. 5.2.1, Fig. 5.6 (pie charts of the pixels per MIGL step).

    Examples
    --------
    >>> import tempfile
    >>> index = np.array([[255, 255, 240], [225, 255, 240]])
    >>> out = plot_migl_pie(Path(tempfile.mkdtemp()) / "migl_pie.png", index)
    >>> out.name, out.stat().st_size > 0
    ('migl_pie.png', True)
    """
    plt = _pyplot()
    fig = _migl_pie_figure(plt, migl_index, title, dpi)
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out


def _migl_pie_figure(plt: ModuleType, migl_index: ArrayLike, title: str, dpi: int) -> Any:
    """The figure of :func:`plot_migl_pie` (not saved): the pie and its legend."""
    levels, counts = np.unique(np.asarray(migl_index), return_counts=True)
    order = np.argsort(levels)[::-1]
    share = counts / counts.sum()
    fig, ax = plt.subplots(figsize=(6, 6), dpi=dpi)
    labels = [f"{levels[i]:g}" if share[i] > 0.02 else "" for i in order]
    wedges, _ = ax.pie(counts[order], labels=labels, startangle=90, counterclock=False)
    ax.legend(
        wedges,
        [f"{levels[i]:g}: {100 * share[i]:.1f} %" for i in order],
        title="MIGL: pixels",
        loc="center left",
        bbox_to_anchor=(1.0, 0.5),
        fontsize="small",
        ncols=-(-len(order) // 24),
    )
    ax.set_title(title)
    fig.tight_layout()
    return fig


def _cdf_curve(cdf: SaturationCDF, lo: int) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``(MIGL, F(MIGL))`` for the integer MIGLs ``lo..migl0`` of a SaturationCDF."""
    ms = np.arange(lo, cdf.migl0 + 1)
    return ms.astype(np.float64), np.asarray(cdf.values[lo:], dtype=np.float64)


def _lowest_bin(cdf: SaturationCDF) -> int:
    """Lowest MIGL holding a pixel of the CDF (``migl0`` when it is empty)."""
    nz = np.flatnonzero(cdf.counts)
    return int(nz[0]) if nz.size else int(cdf.migl0)


def plot_dpa_cdfs(
    path: str | Path, all_cdfs: Sequence[DPACDFs], *, threshold: float, dpi: int = 100
) -> Path:
    """DPA's saturation CDFs (thesis Fig. 6.3) as a PNG, one panel per pitch.

    Each panel shows, over decreasing MIGL, the CDF estimated from the first set, the CDF after
    the last update, the actual CDF from the DPA index image over the pixels saturated at the
    top MIGL (quantised to the captured MIGLs, which are marked), and the exact actual CDF when
    a step-1 sweep gave one. A set with no pixel saturated at its top MIGL gets a panel that
    says so.

    Parameters
    ----------
    path : str or Path
        PNG file to write.
    all_cdfs : sequence of DPACDFs
        One per pitch, coarsest first (:func:`hdrfringe.strategies.dpa_analysis.dpa_cdfs`).
    threshold : float
        DPA's threshold (a fraction), for the titles.
    dpi : int
        Resolution of the PNG (each panel is 6.4 x 4.8 inches).

    Returns
    -------
    Path
        ``path``.

    References
    ----------
    Thesis Sec. 6.1.3 (the CDF and its updates) and Fig. 6.3; Eq. 6.2 (estimated) and Eq. 6.3
    (actual saturated intensities).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.strategies.dpa_analysis import DPACDFs
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
    >>> out = plot_dpa_cdfs(Path(tempfile.mkdtemp()) / "dpa_cdf.png", [nothing], threshold=0.1)
    >>> out.name, out.stat().st_size > 0
    ('dpa_cdf.png', True)
    """
    plt = _pyplot()
    n = len(all_cdfs)
    fig, axes = plt.subplots(1, n, figsize=(6.4 * n, 4.8), dpi=dpi, squeeze=False)
    for ax, c in zip(axes[0], all_cdfs, strict=True):
        title = f"{c.spec.label()}: DPA {100 * threshold:g} %"
        if c.initial is None:
            ax.text(
                0.5,
                0.5,
                f"no pixel saturated at MIGL {c.spec.migl:g}:\none set, no CDF",
                ha="center",
                va="center",
                transform=ax.transAxes,
            )
            ax.set_title(title, fontsize=10)
            ax.set_axis_off()
            continue
        assert c.final is not None and c.actual is not None  # set together with initial
        cands = [min(c.migls), _lowest_bin(c.initial), _lowest_bin(c.final)]
        lo = max(int(c.initial.lowest_migl), int(min(cands)) - 5)
        if c.exact is not None:
            x, y = _cdf_curve(c.exact, lo)
            ax.step(x, y, where="pre", color="black", lw=1.2, label="actual, exact (LPA step 1)")
        x, y = _cdf_curve(c.actual, lo)
        ax.step(
            x,
            y,
            where="pre",
            color="tab:green",
            lw=1.6,
            label=f"actual, DPA index image (quantised to the {len(c.migls)} captured MIGLs)",
        )
        at = [c.actual.at(m) for m in c.migls]
        ax.plot(c.migls, at, "o", color="tab:green", ms=4)
        x, y = _cdf_curve(c.initial, lo)
        ax.step(x, y, where="pre", color="tab:blue", ls="--", label="estimated, first set")
        x, y = _cdf_curve(c.final, lo)
        ax.step(x, y, where="pre", color="tab:orange", label="estimated, after last update")
        diff = c.max_abs_difference("actual") or 0.0
        ax.set_title(
            f"{title}; {c.saturated_at_top} px saturated at {c.spec.migl:g}\n"
            f"max |first estimate - actual| at captured MIGLs: {diff:.3f}",
            fontsize=10,
        )
        ax.set_xlim(c.initial.migl0 + 1, lo)  # the MIGL falls to the right (thesis Sec. 6.1.3)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("MIGL")
        ax.set_ylabel("fraction of the pixels saturated at the top MIGL")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out
