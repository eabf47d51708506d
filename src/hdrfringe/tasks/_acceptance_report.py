"""The report of ``hdrfringe acceptance``: the table, ``acceptance.md``, the plots and the
residual maps, written staged (:mod:`hdrfringe.tasks.acceptance`)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe.core import acceptance as acc
from hdrfringe.core.strict_json import dumps, plain
from hdrfringe.tasks._acceptance_common import (
    ACCEPTANCE_JSON,
    ACCEPTANCE_MD,
    Artefacts,
)
from hdrfringe.tasks._acceptance_eval import (
    PositionOutcome,
    _rows,
)

__all__ = [
    "AcceptanceReport",
    "acceptance_markdown",
]

# --------------------------------------------------------------------------------- the report


@dataclass(frozen=True)
class AcceptanceReport:
    """What ``acceptance`` wrote.

    Parameters
    ----------
    output : Path
        The folder.
    outcomes : list of PositionOutcome
        Every position and strategy.
    summaries : dict
        Per strategy: its :class:`~hdrfringe.core.acceptance.AcceptanceSummary`.
    artefacts : Artefacts
        The artefacts and MPEs.
    setup : dict
        How the run was made (rig, size, calibration, volume, timings).

    Examples
    --------
    >>> from hdrfringe.tasks.acceptance import SIM_MPES
    >>> r = AcceptanceReport(Path("out"), [], {}, Artefacts(SIM_MPES, None, None, None, ""), {})
    >>> r.all_passed
    False
    """

    output: Path
    outcomes: list[PositionOutcome]
    summaries: dict[str, acc.AcceptanceSummary]
    artefacts: Artefacts
    setup: dict[str, Any]

    @property
    def all_passed(self) -> bool:
        """Whether every strategy passed every position."""
        return bool(self.summaries) and all(s.all_passed for s in self.summaries.values())

    def to_dict(self) -> dict[str, Any]:
        """``acceptance.json``: strict JSON types.

        Returns
        -------
        dict
        """
        return plain(
            {
                "setup": self.setup,
                "artefacts": self.artefacts.to_dict(),
                "strategies": {
                    name: {**s.to_dict(), "images": _images(self.outcomes, name)}
                    for name, s in self.summaries.items()
                },
                "positions": [o.to_dict() for o in self.outcomes],
            }
        )


def _images(outcomes: Sequence[PositionOutcome], strategy: str) -> dict[str, Any]:
    """Images captured by a strategy: per position (min, max) and in all."""
    counts = [o.images for o in outcomes if o.strategy == strategy and o.images is not None]
    if not counts:
        return {"total": None, "per_position_min": None, "per_position_max": None}
    return {"total": sum(counts), "per_position_min": min(counts), "per_position_max": max(counts)}


def _fmt(value: float | None, digits: int = 3) -> str:
    return "—" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def acceptance_markdown(report: AcceptanceReport) -> str:
    """``acceptance.md``: the verdict per strategy, the strategies side by side, every position.

    Parameters
    ----------
    report : AcceptanceReport
        The run.

    Returns
    -------
    str

    Examples
    --------
    >>> from hdrfringe.tasks.acceptance import SIM_MPES
    >>> arts = Artefacts(SIM_MPES, None, None, None, "doc")
    >>> acceptance_markdown(AcceptanceReport(Path("out"), [], {}, arts, {})).splitlines()[0]
    '# Acceptance test (VDI/VDE 2634 Part 2)'
    """
    s, mp = report.setup, report.artefacts.mpes
    lines = ["# Acceptance test (VDI/VDE 2634 Part 2)", ""]
    lines += [f"- {k}: {v}" for k, v in s.items() if not isinstance(v, (dict, list))]
    lines += [
        f"- artefacts and MPEs: {report.artefacts.source}",
        f"- MPE: PF {mp.pf.a_mm:g} mm, PS {mp.ps.a_mm:g} mm, SD {_mpe_text(mp.sd)}, "
        f"F {_mpe_text(mp.f)}",
        "",
        "## Strategies side by side (largest |value| over the positions; passed/positions)",
        "",
        "| strategy | images (total) | PF mm | PS mm | SD mm | F mm | verdict |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, summ in report.summaries.items():
        q = summ.to_dict()["quantities"]
        cells = []
        for key in ("PF", "PS", "SD", "F"):
            c = q.get(key)
            cells.append(
                "—" if c is None else f"{_fmt(c['max_abs_mm'])} ({c['passed']}/{c['positions']})"
            )
        images = _images(report.outcomes, name)["total"]
        verdict = "pass" if summ.all_passed else "FAIL"
        lines.append(
            f"| {name} | {images if images is not None else '—'} | "
            f"{' | '.join(cells)} | {verdict} |"
        )
    lines += [
        "",
        "## Positions",
        "",
        "| strategy | position | where | images | values (mm) | predicted std (mm) | "
        "points | outliers | saturated | note |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for o in report.outcomes:
        vals = ", ".join(f"{k} {_fmt(v)}" for k, v in o.values.items())
        std = ", ".join(f"{k} {_fmt(v)}" for k, v in o.details.get("predicted_std_mm", {}).items())
        lines.append(
            f"| {o.strategy} | {o.label} | {o.description} | {o.images or '—'} | {vals} | "
            f"{std or '—'} | {o.details.get('points', '—')} | "
            f"{o.details.get('outliers', '—')} | {_percent(o.details.get('saturated_fraction'))} | "
            f"{o.note} |"
        )
    return "\n".join(lines) + "\n"


def _percent(value: float | None) -> str:
    return "—" if value is None else f"{100 * value:.2f} %"


def _mpe_text(m: acc.Mpe) -> str:
    return f"{m.a_mm:g} mm" if m.k is None else f"{m.a_mm:g} mm + L/{m.k:g}"


def _plot_quantities(report: AcceptanceReport, path: Path) -> None:
    """PF, PS, SD and F per position, one series per strategy, against the MPE (+-MPE for
    the signed PS and SD)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(11, 7), squeeze=False)
    names = list(report.summaries)
    for ax, q in zip(axes.ravel(), ("PF", "PS", "SD", "F"), strict=True):
        labels = list(dict.fromkeys(o.label for o in report.outcomes if q in o.values))
        ax.set_title(q)
        ax.set_ylabel("mm")
        if not labels:
            ax.text(0.5, 0.5, "no positions", ha="center", transform=ax.transAxes)
            continue
        for k, name in enumerate(names):
            here = {o.label: o for o in report.outcomes if o.strategy == name and q in o.values}
            xs = [
                i + 0.08 * (k - (len(names) - 1) / 2)
                for i, lab in enumerate(labels)
                if lab in here and here[lab].values[q] is not None
            ]
            ys = [
                here[lab].values[q]
                for lab in labels
                if lab in here and here[lab].values[q] is not None
            ]
            ax.plot(xs, ys, "o", label=name, color=plt.get_cmap("tab10")(k % 10))
        rows = [r for s in report.summaries.values() for r in s.records if r.quantity == q]
        mpe = max(r.mpe_mm for r in rows)
        ax.axhline(mpe, color="k", ls="--", lw=1, label="MPE")
        if q in ("PS", "SD"):
            ax.axhline(-mpe, color="k", ls="--", lw=1)
            ax.axhline(0.0, color="0.7", lw=0.5)
        ax.set_xticks(range(len(labels)), labels, rotation=60, fontsize=7)
    seen: dict[str, Any] = {}
    for ax in axes.ravel():
        for handle, name in zip(*ax.get_legend_handles_labels(), strict=True):
            seen.setdefault(name, handle)
    if seen:
        fig.legend(
            list(seen.values()), list(seen), loc="upper center", ncol=min(len(seen), 8), fontsize=7
        )
    fig.subplots_adjust(left=0.07, right=0.98, top=0.9, bottom=0.14, hspace=0.55, wspace=0.2)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _write_residuals(outcome: PositionOutcome, folder: Path) -> None:
    """The residual map of one position: float32 TIFF (NaN off the artefact) and its preview
    (symmetric colour range)."""
    from hdrfringe.io.results import write_map_tiff, write_preview_png

    res = outcome.residual_map
    assert res is not None
    write_map_tiff(folder / f"{outcome.label}.tiff", res.astype(np.float32))
    lim = float(np.nanmax(np.abs(res))) if np.isfinite(res).any() else 1.0
    vals = ", ".join(f"{k} {_fmt(v)}" for k, v in outcome.values.items())
    write_preview_png(
        folder / f"{outcome.label}.png",
        res,
        title=f"{outcome.strategy}: {outcome.label} ({vals})",
        label="residual (mm)",
        vmin=-lim,
        vmax=lim,
    )


def _write_report(tmp: Path, report: AcceptanceReport) -> None:
    """acceptance.json, acceptance.md and the plots into the staging folder."""
    text = dumps(report.to_dict(), indent=1)
    (tmp / ACCEPTANCE_JSON).write_text(text + "\n", encoding="utf-8")
    (tmp / ACCEPTANCE_MD).write_text(acceptance_markdown(report), encoding="utf-8")
    _plot_quantities(report, tmp / "quantities.png")
    for o in report.outcomes:
        if o.residual_map is not None:
            folder = tmp / "residuals" / o.strategy
            folder.mkdir(parents=True, exist_ok=True)
            _write_residuals(o, folder)


def _summaries(outcomes: Sequence[PositionOutcome], artefacts: Artefacts) -> dict[str, Any]:
    out: dict[str, acc.AcceptanceSummary] = {}
    for name in dict.fromkeys(o.strategy for o in outcomes):
        rows = [r for o in outcomes if o.strategy == name for r in _rows(o, artefacts)]
        out[name] = acc.summarize(rows)
    return out
