"""The gamma command's output folder: ``gamma.json`` and, for every fit, the mapping plot
(thesis Fig. 2.6 b/c) and the residual nonlinearity plot.

Files: ``gamma.json`` (:attr:`~hdrfringe.core.gamma.GammaReport.report`); for the uniform-gray fit
``gamma_mapping.png`` and ``gamma_nonlinearity.png``; for the fringe-shape fit
``gamma_mapping_fringes.png`` and ``gamma_nonlinearity_fringes.png``.

Examples
--------
>>> import tempfile
>>> import numpy as np
>>> from hdrfringe.core.captures import Captures
>>> from hdrfringe.core.frames import UniformFrame
>>> from hdrfringe.core.gamma import gamma_report
>>> levels = [0, 64, 128, 192, 255]
>>> images = np.stack([np.full((4, 4), 10 + 200 * (g / 255) ** 2.2) for g in levels])
>>> caps = Captures([UniformFrame(g) for g in levels], np.rint(images).astype(np.uint8), 8)
>>> with tempfile.TemporaryDirectory() as tmp:
...     out = write_gamma_outputs(Path(tmp) / "g", gamma_report(caps, source="demo"))
...     names = sorted(p.name for p in out.iterdir())
>>> names
['gamma.json', 'gamma_mapping.png', 'gamma_nonlinearity.png']
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hdrfringe.core import strict_json
from hdrfringe.core._validation import full_scale
from hdrfringe.core.gamma import GammaFit, GammaReport, line_deviation
from hdrfringe.core.gamma.report import FRINGE_NONLINEARITY_BINS
from hdrfringe.io.plots import plot_gamma_mapping
from hdrfringe.io.results import staged_output_dir

__all__ = ["PLOT_NAMES", "plot_gamma_nonlinearity", "write_gamma_outputs"]

#: Report key of each fit -> (mapping plot, residual nonlinearity plot) file names.
PLOT_NAMES: dict[str, tuple[str, str]] = {
    "uniform": ("gamma_mapping.png", "gamma_nonlinearity.png"),
    "fringes": ("gamma_mapping_fringes.png", "gamma_nonlinearity_fringes.png"),
}


def _deviation(level: np.ndarray, dn: np.ndarray, slope: float, intercept: float) -> np.ndarray:
    """Deviation from the line ``slope * level + intercept`` in percent of its span."""
    span = abs(slope) * (float(level.max()) - float(level.min()))
    return 100.0 * (dn - (slope * level + intercept)) / span


def plot_gamma_nonlinearity(
    fit: GammaFit,
    path: str | Path,
    *,
    precompensation: float | None = None,
    title: str | None = None,
    dpi: int = 120,
) -> Path:
    """Residual nonlinearity of a fit as a PNG: deviation from a straight line per level.

    For every requested (linear) gray level, the deviation of the captured intensity from the
    straight line through the mapping, in percent of the captured range (the measure of
    :func:`~hdrfringe.core.gamma.measure_nonlinearity`): predicted by the fit after
    pre-compensation with the fitted gamma, without pre-compensation, and with the captures'
    own ``precompensation`` when given; and the fit's samples re-indexed to pre-compensation
    with the fitted gamma (each sample's sent gray is what that pre-compensation sends for
    ``full * (sent/full)^gamma``), as points for uniform grays and as medians of
    :data:`~hdrfringe.core.gamma.report.FRINGE_NONLINEARITY_BINS` bins over the faint samples for
    fringes. What is left after pre-compensation is what the fit cannot remove.

    Parameters
    ----------
    fit : GammaFit
        A uniform-gray or fringe-shape fit.
    path : str or Path
        PNG file to write.
    precompensation : float, optional
        The exponent the captures were made with (a third predicted curve).
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
    Thesis Sec. 2.6, Fig. 2.6 c and Eq. 2.17 (pre-compensation).

    Examples
    --------
    >>> import tempfile
    >>> from hdrfringe.core.gamma import fit_gamma_uniform
    >>> g = np.arange(0, 256, 16.0)
    >>> fit = fit_gamma_uniform(g, 12 + 200 * (g / 255) ** 2.2, camera_bit_depth=8)
    >>> out = plot_gamma_nonlinearity(fit, Path(tempfile.mkdtemp()) / "nl.png")
    >>> out.name, out.stat().st_size > 10_000
    ('nl.png', True)
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    full = float(full_scale(fit.projector_bit_depth, "projector bit depth"))
    g = np.arange(0.0, full + 1.0) if full <= 1023 else np.linspace(0.0, full, 1024)
    curves = [(fit.gamma, f"pre-compensated with the fit ({fit.gamma:.3f})", "C1", "-")]
    if precompensation is not None and precompensation not in (1.0, fit.gamma):
        curves.append((precompensation, f"with {precompensation:g} (the captures')", "C2", "-."))
    curves.append((1.0, "without pre-compensation", "C7", "--"))
    fig, ax = plt.subplots(figsize=(7.5, 4.4), dpi=dpi)
    line = None
    for gh, label, color, style in curves:
        y = fit.predict_precompensated(g, gh)
        nl = line_deviation(g, y)
        line = line or nl  # the fit's own line: the samples are judged against it
        ax.plot(g, _deviation(g, y, nl.slope, nl.intercept), style, color=color,
                label=f"{label}: max {nl.max_percent:.2f} %")  # fmt: skip
    assert line is not None
    used = fit.used
    level = full * (np.clip(fit.sent[used], 0.0, full) / full) ** fit.gamma
    dev = _deviation(level, fit.dn[used], line.slope, line.intercept)
    if fit.method == "fringes" and level.size > FRINGE_NONLINEARITY_BINS:
        ax.plot(level, dev, ".", color="C0", ms=1, alpha=0.15)
        edges = np.linspace(level.min(), level.max(), FRINGE_NONLINEARITY_BINS + 1)
        idx = np.clip(np.digitize(level, edges) - 1, 0, FRINGE_NONLINEARITY_BINS - 1)
        pts = [(np.median(level[idx == b]), np.median(dev[idx == b])) for b in np.unique(idx)]
        ax.plot(*zip(*pts, strict=True), "s", color="C0", ms=4, label="samples (bin medians)")
    else:
        ax.plot(level, dev, "o", color="C0", ms=4, label="samples, re-indexed")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set(
        xlabel="requested (linear) gray level",
        ylabel="deviation from a straight line (% of range)",
        title=title or f"residual nonlinearity, {fit.method} fit",
    )
    ax.legend(loc="best", fontsize="small")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out)
    plt.close(fig)
    return out


def write_gamma_outputs(path: str | Path, report: GammaReport, *, force: bool = False) -> Path:
    """Write a gamma report as a folder (staged: complete or not at all).

    Parameters
    ----------
    path : str or Path
        Output folder; refused if it exists and is not empty, unless ``force``.
    report : GammaReport
        From :func:`hdrfringe.core.gamma.gamma_report`.
    force : bool
        Replace an existing non-empty folder.

    Returns
    -------
    Path
        The folder: ``gamma.json`` (:attr:`GammaReport.report`) and, for every fit made, its
        mapping plot (:func:`hdrfringe.io.plots.plot_gamma_mapping`) and residual
        nonlinearity plot (:func:`plot_gamma_nonlinearity`), named as :data:`PLOT_NAMES`.

    References
    ----------
    Thesis Sec. 2.6, Fig. 2.6 b/c.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from hdrfringe.core.captures import Captures
    >>> from hdrfringe.core.frames import UniformFrame
    >>> from hdrfringe.core.gamma import gamma_report
    >>> levels = [0, 64, 128, 192, 255]
    >>> images = np.stack([np.full((4, 4), 10 + 200 * (g / 255) ** 2.2) for g in levels])
    >>> caps = Captures([UniformFrame(g) for g in levels], np.rint(images).astype(np.uint8), 8)
    >>> out = write_gamma_outputs(Path(tempfile.mkdtemp()) / "g", gamma_report(caps, source="x"))
    >>> written = strict_json.loads_strict((out / "gamma.json").read_text(encoding="utf-8"))
    >>> written["source"], round(written["uniform"]["gamma"], 2), written["uniform"]["levels_used"]
    ('x', 2.2, 5)
    >>> (out / "gamma_mapping.png").is_file(), (out / "gamma_nonlinearity.png").is_file()
    (True, True)
    """
    source = report.report.get("source", "")
    fits = {"uniform": report.uniform_fit, "fringes": report.fringe_fit}
    what = {"uniform": "uniform grays", "fringes": "fringe shape"}
    with staged_output_dir(path, force=force) as tmp:
        text = strict_json.dumps(report.report) + "\n"
        (tmp / "gamma.json").write_text(text, encoding="utf-8")
        for key, fit in fits.items():
            if fit is None:
                continue
            mapping, nonlinearity = PLOT_NAMES[key]
            title = f"{source}: {what[key]}" if source else what[key]
            plot_gamma_mapping(fit, tmp / mapping, title=title)
            plot_gamma_nonlinearity(
                fit, tmp / nonlinearity, title=f"{title}: residual nonlinearity"
            )
    return Path(path)
