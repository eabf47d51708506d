"""The gamma command's output folder: ``gamma.json`` and the mapping plot (thesis Fig. 2.6 b/c).

Examples
--------
>>> import tempfile
>>> import numpy as np
>>> from hdrfringe.captures import Captures
>>> from hdrfringe.frames import UniformFrame
>>> from hdrfringe.gamma import gamma_report
>>> levels = [0, 64, 128, 192, 255]
>>> images = np.stack([np.full((4, 4), 10 + 200 * (g / 255) ** 2.2) for g in levels])
>>> caps = Captures([UniformFrame(g) for g in levels], np.rint(images).astype(np.uint8), 8)
>>> with tempfile.TemporaryDirectory() as tmp:
...     out = write_gamma_outputs(Path(tmp) / "g", gamma_report(caps, source="demo"))
...     names = sorted(p.name for p in out.iterdir())
>>> names
['gamma.json', 'gamma_mapping.png']
"""

from __future__ import annotations

import json
from pathlib import Path

from hdrfringe.gamma import GammaReport
from hdrfringe.io.plots import plot_gamma_mapping
from hdrfringe.io.results import staged_output_dir

__all__ = ["write_gamma_outputs"]


def write_gamma_outputs(path: str | Path, report: GammaReport, *, force: bool = False) -> Path:
    """Write a gamma report as a folder (staged: complete or not at all).

    Parameters
    ----------
    path : str or Path
        Output folder; refused if it exists and is not empty, unless ``force``.
    report : GammaReport
        From :func:`hdrfringe.gamma.gamma_report`.
    force : bool
        Replace an existing non-empty folder.

    Returns
    -------
    Path
        The folder: ``gamma.json`` (:attr:`GammaReport.report`) and, with a uniform fit,
        ``gamma_mapping.png`` (:func:`hdrfringe.io.plots.plot_gamma_mapping`).

    References
    ----------
    Thesis Sec. 2.6, Fig. 2.6 b/c.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from hdrfringe.captures import Captures
    >>> from hdrfringe.frames import UniformFrame
    >>> from hdrfringe.gamma import gamma_report
    >>> levels = [0, 64, 128, 192, 255]
    >>> images = np.stack([np.full((4, 4), 10 + 200 * (g / 255) ** 2.2) for g in levels])
    >>> caps = Captures([UniformFrame(g) for g in levels], np.rint(images).astype(np.uint8), 8)
    >>> out = write_gamma_outputs(Path(tempfile.mkdtemp()) / "g", gamma_report(caps, source="x"))
    >>> written = json.loads((out / "gamma.json").read_text(encoding="utf-8"))
    >>> written["source"], round(written["uniform"]["gamma"], 2), written["uniform"]["levels_used"]
    ('x', 2.2, 5)
    >>> (out / "gamma_mapping.png").is_file()
    True
    """
    with staged_output_dir(path, force=force) as tmp:
        text = json.dumps(report.report, indent=1) + "\n"
        (tmp / "gamma.json").write_text(text, encoding="utf-8")
        if report.uniform_fit is not None:
            plot_gamma_mapping(report.uniform_fit, tmp / "gamma_mapping.png")
    return Path(path)
