"""Tables and figures of thesis Ch. 4 from the reproduction's Datasets.

Every table is returned as rows (dicts of ours, the thesis's values, and our bias and std) and
printed with one ``thesis / ours (ours / thesis)`` cell per quantity, our bias / std beside each
RMSE and the calibration model's residual under the table (:func:`model_residual_of`, issue
15); a blank thesis cell carries a footnote saying why (:class:`Notes`), and no ratio is given
of a near-zero bias or of the thesis's fringe-order failures (:data:`FAILURE_MM`). Every figure
is a matplotlib PNG named after the thesis's figure.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "FAILURE_MM",
    "THESIS_TABLE_4_1",
    "THESIS_TABLE_4_2",
    "THESIS_TABLE_4_3",
    "Notes",
    "differences_markdown",
    "error_budget",
    "figure_depth_maps",
    "figure_measured_vs_simulated",
    "figure_patterns_by_pitch",
    "figure_pitch6",
    "figure_rmse_maps",
    "figure_saturation_by_pitch",
    "figure_simulation",
    "figures",
    "model_residual_of",
    "saturation_onset",
    "table_4_1",
    "table_4_2",
    "table_4_3",
    "tables_markdown",
    "tradeoff",
]

#: Thesis Table 4.1 (simulation, sinusoidal 3-step, pitch 6): lux -> (trade-off MIGL, RMSE at
#: 255, RMSE at the trade-off), mm.
THESIS_TABLE_4_1: dict[float, tuple[float, float, float]] = {
    500.0: (225, 0.56, 0.31),
    600.0: (215, 0.86, 0.31),
    700.0: (210, 1.21, 0.32),
    800.0: (190, 85.05, 0.32),
    900.0: (190, 373.42, 0.32),
}
#: Thesis Table 4.2 (simulation, 600 lx, sinusoidal 3-step, pitch 6): sigma -> (trade-off
#: MIGL, RMSE at the trade-off).
THESIS_TABLE_4_2: dict[float, tuple[float, float]] = {
    1.0: (225, 0.32),
    2.0: (225, 0.34),
    3.0: (225, 0.37),
    4.0: (225, 0.40),
    5.0: (225, 0.45),
    6.0: (230, 0.49),
    7.0: (230, 0.53),
    8.0: (230, 0.58),
}
#: Thesis Table 4.3 (real, pitch 6): pattern -> (trade-off MIGL, RMSE 255 at 0 lx, RMSE 255 at
#: 600 lx, RMSE at the trade-off with 600 lx).
THESIS_TABLE_4_3: dict[str, tuple[float, float, float, float]] = {
    "sinusoidal-3": (225, 0.27, 0.68, 0.33),
    "triangular-3": (230, 0.33, 0.53, 0.36),
    "triangular-2": (215, 1.03, 1.35, 1.05),
}


def _ratio(ours: float, thesis: float) -> float:
    return float(ours) / float(thesis) if thesis else float("nan")


def tradeoff(curve: xr.DataArray) -> tuple[float, float]:
    """(MIGL, value) of the minimum of a 1-D DataArray over ``migl`` (highest MIGL on ties).

    The trade-off MIGL of thesis Sec. 4.2: lowering the MIGL removes saturation until the
    noise of the lower signal outweighs it; the minimum of the mean RMSE marks the best
    compromise. NaN cells (not computed) are ignored.

    Parameters
    ----------
    curve : xarray.DataArray
        Values (e.g. mean RMSE in mm) along a ``migl`` dimension.

    Returns
    -------
    tuple of float
        The MIGL of the minimum and the minimum.

    References
    ----------
    Thesis Sec. 4.2.2-4.2.3, Fig. 4.13 (the trade-off point).

    Examples
    --------
    >>> import xarray as xr
    >>> rmse = xr.DataArray([0.9, 0.3, 0.3, 0.5], coords={"migl": [255.0, 240.0, 225.0, 210.0]})
    >>> tradeoff(rmse)
    (240.0, 0.3)
    """
    values = np.asarray(curve.values, dtype=np.float64)
    migls = np.asarray(curve["migl"].values, dtype=np.float64)
    best = np.nanmin(values)
    i = int(np.flatnonzero(values == best)[np.argmax(migls[values == best])])
    return float(migls[i]), float(values[i])


def _setup_of(ds: xr.Dataset) -> Any:
    """The :class:`~hdrfringe_thesis.ch4.Ch4Setup` a sweep ran with (None: not recorded)."""
    from hdrfringe_thesis.ch4 import Ch4Setup

    try:
        return Ch4Setup(**json.loads(ds.attrs["sweep_params"])["setup"])
    except (KeyError, TypeError, ValueError):
        return None


def model_residual_of(ds: xr.Dataset, calibration_depths_mm: Sequence[float] | None = None) -> Any:
    """The linear model's residual (:func:`hdrfringe_thesis.model_residual.model_residual`)
    at a sweep's depths, for its setup and calibration depths.

    Parameters
    ----------
    ds : xarray.Dataset
        A reproduction sweep (its ``sweep_params`` attribute names the setup).
    calibration_depths_mm : sequence of float, optional
        The calibration's plate depths (default the sweep's own depths: Ch. 4 calibrates on
        the depths it measures).

    Returns
    -------
    ModelResidual or None
        Per depth of ``ds``, the bias and RMS the model alone leaves; None when the sweep does
        not record its setup.

    References
    ----------
    Thesis Eq. 2.15 (the linear model), Sec. 4.1.
    """
    from hdrfringe_thesis.model_residual import model_residual

    setup = _setup_of(ds)
    if setup is None:
        return None
    depths = [float(d) for d in ds["depth_mm"].values]
    cal = depths if calibration_depths_mm is None else [float(d) for d in calibration_depths_mm]
    return model_residual(setup, cal, depths)


def _mean(ds: xr.Dataset, var: str, **sel: Any) -> float:
    return float(ds[var].sel(**sel).mean("depth_mm"))


def table_4_3(ds: xr.Dataset, pitch: int = 6) -> list[dict[str, Any]]:
    """Table 4.3: per pattern at ``pitch``, the trade-off MIGL at 600 lx, the RMSE at 255 (0 and
    600 lx) and at the trade-off, each beside the thesis, with our bias and std.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep (:func:`hdrfringe_thesis.ch4.ch4_grid`); its ``rmse_mm``,
        ``mean_error_mm`` and ``std_mm`` are averaged over depth.
    pitch : int
        The pitch of the table (the thesis: 6 px).

    Returns
    -------
    list of dict
        Per pattern: ``pattern``, ``ours`` (trade-off MIGL, RMSE 255 at 0 lx, RMSE 255 at
        600 lx, RMSE at the trade-off), ``bias_mm`` and ``std_mm`` (the same three cells'
        mean error and error std, means over depth) and ``thesis`` (the same from
        :data:`THESIS_TABLE_4_3`, None for a pattern the thesis did not measure).

    References
    ----------
    Thesis Sec. 4.2.3, Table 4.3.
    """
    mean = ds["rmse_mm"].sel(pitch=pitch).mean("depth_mm")
    rows = []
    for pattern in ds["pattern"].values:
        p = str(pattern)
        m = mean.sel(pattern=p)
        t_migl, t_rmse = tradeoff(m.sel(lux=600.0))
        ours = (
            t_migl,
            float(m.sel(lux=0.0, migl=255.0)),
            float(m.sel(lux=600.0, migl=255.0)),
            t_rmse,
        )
        cells = ((0.0, 255.0), (600.0, 255.0), (600.0, t_migl))
        stats = {
            f"{v}": tuple(
                _mean(ds, f"{v}_mm", pattern=p, pitch=pitch, lux=lux, migl=mg) for lux, mg in cells
            )
            for v in ("mean_error", "std")
            if f"{v}_mm" in ds
        }
        row: dict[str, Any] = {"pattern": p, "ours": ours, "thesis": THESIS_TABLE_4_3.get(p)}
        if stats:
            row |= {"bias_mm": stats["mean_error"], "std_mm": stats["std"]}
        rows.append(row)
    return rows


def saturation_onset(sim: xr.Dataset, pattern: str = "sinusoidal-3") -> dict[float, float]:
    """Per added light of the Sec. 4.3 sweep, the highest MIGL at which no measurement pixel
    saturates at any depth: where saturation starts on the rig's response.

    Parameters
    ----------
    sim : xarray.Dataset
        The Sec. 4.3 sweep, with ``saturated_fraction_light``.
    pattern : str
        The pattern.

    Returns
    -------
    dict of float to float
        Added lux -> MIGL (NaN when every MIGL of the sweep saturates somewhere).

    References
    ----------
    Thesis Sec. 4.3.1 (saturation begins above the trade-off MIGL).

    Examples
    --------
    >>> import xarray as xr
    >>> sat = xr.DataArray(
    ...     np.array([[[0.3, 0.5], [0.0, 0.2]], [[0.0, 0.1], [0.0, 0.0]]])[None],
    ...     dims=("pattern", "migl", "depth_mm", "added_lux"),
    ...     coords={"pattern": ["p"], "migl": [255.0, 225.0], "added_lux": [300.0, 900.0]},
    ... )
    >>> saturation_onset(xr.Dataset({"saturated_fraction_light": sat}), "p")
    {300.0: 225.0, 900.0: nan}
    """
    sat = sim["saturated_fraction_light"].sel(pattern=pattern).max("depth_mm")
    out = {}
    for lux in sat["added_lux"].values:
        c = sat.sel(added_lux=lux)
        clear = c["migl"].values[c.values == 0]
        out[float(lux)] = float(clear.max()) if clear.size else float("nan")
    return out


def _onset_words(onset: float) -> str:
    """Where saturation starts, in words (NaN: some pixel saturates at every MIGL swept)."""
    if np.isfinite(onset):
        return f"no pixel saturated at or below MIGL {onset:.0f}"
    return "some pixel saturated at every MIGL of the sweep"


def table_4_1(sim: xr.Dataset, pattern: str = "sinusoidal-3") -> list[dict[str, Any]]:
    """Table 4.1: per added light, the trade-off MIGL, the RMSE at 255 and at the trade-off
    (Eq. 4.1 simulation), with our bias and std and where saturation starts.

    Parameters
    ----------
    sim : xarray.Dataset
        The Sec. 4.3 sweep (:func:`hdrfringe_thesis.ch4.ch4_simulation_grid`).
    pattern : str
        The pattern of the table (the thesis: sinusoidal 3-step).

    Returns
    -------
    list of dict
        Per added light: ``lux``, ``ours`` (trade-off MIGL, RMSE at 255, RMSE at the
        trade-off), ``bias_mm`` and ``std_mm`` (at 255 and at the trade-off),
        ``saturation_onset_migl`` (:func:`saturation_onset`), ``saturated_fraction_at_tradeoff``
        (pixels saturated in any shift at the trade-off MIGL, mean over depth) and ``thesis``
        (:data:`THESIS_TABLE_4_1`, None where it has no row).

    References
    ----------
    Thesis Sec. 4.3.1, Table 4.1.
    """
    mean = sim["rmse_light_mm"].sel(pattern=pattern).mean("depth_mm")
    onset = saturation_onset(sim, pattern) if "saturated_fraction_light" in sim else {}
    rows = []
    for lux in mean["added_lux"].values:
        curve = mean.sel(added_lux=lux)
        t_migl, t_rmse = tradeoff(curve)
        ours = (t_migl, float(curve.sel(migl=255.0)), t_rmse)
        row: dict[str, Any] = {
            "lux": float(lux),
            "ours": ours,
            "thesis": THESIS_TABLE_4_1.get(float(lux)),
        }
        if "std_light_mm" in sim:
            for key, var in (("bias_mm", "mean_error_light_mm"), ("std_mm", "std_light_mm")):
                row[key] = tuple(
                    _mean(sim, var, pattern=pattern, added_lux=lux, migl=m) for m in (255.0, t_migl)
                )
        if onset:
            row["saturation_onset_migl"] = onset[float(lux)]
            row["saturated_fraction_at_tradeoff"] = _mean(
                sim, "saturated_fraction_light", pattern=pattern, added_lux=lux, migl=t_migl
            )
        rows.append(row)
    return rows


def table_4_2(sim: xr.Dataset, pattern: str = "sinusoidal-3") -> list[dict[str, Any]]:
    """Table 4.2: per noise sigma at 600 lx, the trade-off MIGL and the RMSE there, with our
    bias and std.

    Parameters
    ----------
    sim : xarray.Dataset
        The Sec. 4.3 sweep (:func:`hdrfringe_thesis.ch4.ch4_simulation_grid`).
    pattern : str
        The pattern of the table (the thesis: sinusoidal 3-step).

    Returns
    -------
    list of dict
        Per sigma: ``sigma``, ``ours`` (trade-off MIGL, RMSE there), ``bias_mm`` and
        ``std_mm`` at the trade-off and ``thesis`` (:data:`THESIS_TABLE_4_2`, None where it
        has no row).

    References
    ----------
    Thesis Sec. 4.3.2, Table 4.2.
    """
    mean = sim["rmse_noise_mm"].sel(pattern=pattern).mean("depth_mm")
    rows = []
    for sigma in mean["noise_sigma"].values:
        ours = tradeoff(mean.sel(noise_sigma=sigma))
        row: dict[str, Any] = {
            "sigma": float(sigma),
            "ours": ours,
            "thesis": THESIS_TABLE_4_2.get(float(sigma)),
        }
        if "std_noise_mm" in sim:
            sel = {"pattern": pattern, "noise_sigma": sigma, "migl": ours[0]}
            row["bias_mm"] = _mean(sim, "mean_error_noise_mm", **sel)
            row["std_mm"] = _mean(sim, "std_noise_mm", **sel)
        rows.append(row)
    return rows


def _markdown(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


#: A thesis value above this (mm) is a fringe-order failure, not a measurement error: no ratio.
FAILURE_MM = 10.0


class Notes:
    """Footnotes of one table: each reason once, marked ``[a]``, ``[b]``, ... in its cells.

    Examples
    --------
    >>> n = Notes()
    >>> n.mark("not in the thesis"), n.mark("a failure"), n.mark("not in the thesis")
    ('[a]', '[b]', '[a]')
    >>> print(n.markdown())
    [a] not in the thesis; [b] a failure
    """

    def __init__(self) -> None:
        self._texts: list[str] = []

    def mark(self, text: str) -> str:
        """The marker of ``text`` (added on first use).

        Parameters
        ----------
        text : str
            The reason, one sentence.

        Returns
        -------
        str
            ``[a]``, ``[b]``, ...
        """
        if text not in self._texts:
            self._texts.append(text)
        return f"[{chr(ord('a') + self._texts.index(text))}]"

    def markdown(self) -> str:
        """The footnotes as one paragraph (empty when there is none).

        Returns
        -------
        str
            ``[a] reason; [b] reason``.
        """
        return "; ".join(f"[{chr(ord('a') + i)}] {t}" for i, t in enumerate(self._texts))


def _vs(
    thesis: float | None,
    ours: float,
    fmt: str,
    notes: Notes,
    *,
    missing: str = "",
    ratio: bool = True,
    failures: bool = False,
) -> str:
    """One ``thesis / ours (ratio)`` cell; a missing thesis value says why (a footnote), a
    ratio is left out where it would mislead (a near-zero bias, ``ratio=False``; with
    ``failures``, a thesis error in mm above :data:`FAILURE_MM`: fringe-order failures)."""
    if thesis is None:
        return f"- {notes.mark(missing)} / {fmt.format(ours)}" if missing else fmt.format(ours)
    cell = f"{fmt.format(thesis)} / {fmt.format(ours)}"
    if ratio and failures and abs(thesis) > FAILURE_MM:
        return (
            cell
            + " "
            + notes.mark(
                "no ratio: the thesis's value is dominated by fringe-order failures (height jumps "
                "of whole fringes), not the saturation error measured here"
            )
        )
    if ratio and thesis:
        cell += f" ({_ratio(ours, thesis):.2f})"
    return cell


def _bias_std(bias: float, std: float) -> str:
    return f"{bias:+.3f} / {std:.3f}"


def _table(header: list[str], rows: list[list[str]], notes: Notes, *extra: str) -> str:
    out = _markdown(header, rows)
    tail = [t for t in (notes.markdown(), *extra) if t]
    return out + ("\n\n" + "\n\n".join(tail) if tail else "")


def _residual_line(res: Any) -> str:
    if res is None:
        return ""
    return (
        f"Model residual at these depths (the linear model, Eq. 2.15, fitted noise-free on the "
        f"rig's geometry: `hdrfringe_thesis.model_residual`): mean {res.mean_mm:+.3f} mm, "
        f"RMS {res.rms_total_mm:.3f} mm; every cell of the table carries it, so the std is the "
        "measurement's own error."
    )


NO_4_1_ROW = "the thesis's Table 4.1 lists 500..900 lx only (below 500 lx little saturates)"
NO_4_2_ROW = "the thesis's Table 4.2 has sigma 1..8 only"


def tables_markdown(ds: xr.Dataset, sim: xr.Dataset) -> dict[str, str]:
    """Tables 4.1, 4.2 and 4.3 as Markdown: thesis / ours (ratio ours/thesis) per quantity,
    our bias / std beside each RMSE, the model residual under each table.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep (Table 4.3).
    sim : xarray.Dataset
        The Sec. 4.3 sweep (Tables 4.1 and 4.2).

    Returns
    -------
    dict of str to str
        ``"4.1"``, ``"4.2"``, ``"4.3"``: each table as a Markdown table with its footnotes.
    """
    mm, level, nan2 = "{:.3f}", "{:.0f}", (float("nan"), float("nan"))
    residual = _residual_line(model_residual_of(sim))
    n41 = Notes()
    rows41 = []
    for r in table_4_1(sim):
        th = r["thesis"] or (None, None, None)
        b, s = r.get("bias_mm", nan2), r.get("std_mm", nan2)
        onset = r.get("saturation_onset_migl", float("nan"))
        at = r.get("saturated_fraction_at_tradeoff", float("nan"))
        rows41.append(
            [
                f"{r['lux']:g}",
                _vs(th[0], r["ours"][0], level, n41, missing=NO_4_1_ROW, ratio=False),
                (f"{onset:.0f}" if np.isfinite(onset) else "-") + f" / {100 * at:.1f} %",
                _vs(th[1], r["ours"][1], mm, n41, missing=NO_4_1_ROW, failures=True),
                _bias_std(b[0], s[0]),
                _vs(th[2], r["ours"][2], mm, n41, missing=NO_4_1_ROW, failures=True),
                _bias_std(b[1], s[1]),
            ]
        )
    n42 = Notes()
    rows42 = []
    for r in table_4_2(sim):
        th = r["thesis"] or (None, None)
        rows42.append(
            [
                f"{r['sigma']:g}",
                _vs(th[0], r["ours"][0], level, n42, missing=NO_4_2_ROW, ratio=False),
                _vs(th[1], r["ours"][1], mm, n42, missing=NO_4_2_ROW, failures=True),
                _bias_std(r.get("bias_mm", nan2[0]), r.get("std_mm", nan2[0])),
            ]
        )
    n43 = Notes()
    rows43 = []
    for r in table_4_3(ds):
        th = r["thesis"] or (None,) * 4
        b, s = r.get("bias_mm", nan2 + nan2[:1]), r.get("std_mm", nan2 + nan2[:1])
        no = "a pattern the thesis did not measure"
        rows43.append(
            [
                r["pattern"],
                _vs(th[0], r["ours"][0], level, n43, missing=no, ratio=False),
                _vs(th[1], r["ours"][1], mm, n43, missing=no, failures=True),
                _bias_std(b[0], s[0]),
                _vs(th[2], r["ours"][2], mm, n43, missing=no, failures=True),
                _bias_std(b[1], s[1]),
                _vs(th[3], r["ours"][3], mm, n43, missing=no, failures=True),
                _bias_std(b[2], s[2]),
            ]
        )
    bs = "ours: bias / std (mm)"
    return {
        "4.1": _table(
            [
                "added light (lx)",
                "trade-off MIGL, thesis / ours",
                "ours: no pixel saturated at or below MIGL / saturated at the trade-off",
                "RMSE at 255 (mm), thesis / ours (ratio)",
                bs,
                "RMSE at trade-off (mm), thesis / ours (ratio)",
                bs,
            ],
            rows41,
            n41,
            residual,
        ),
        "4.2": _table(
            [
                "sigma (gray level)",
                "trade-off MIGL, thesis / ours",
                "RMSE at trade-off (mm), thesis / ours (ratio)",
                bs,
            ],
            rows42,
            n42,
            residual,
        ),
        "4.3": _table(
            [
                "pattern",
                "trade-off MIGL (600 lx), thesis / ours",
                "RMSE 255, 0 lx (mm)",
                bs,
                "RMSE 255, 600 lx (mm)",
                bs,
                "RMSE trade-off, 600 lx (mm)",
                bs,
            ],
            rows43,
            n43,
            _residual_line(model_residual_of(ds)),
        ),
    }


def error_budget(ds: xr.Dataset, pitch: int = 6, pattern: str = "sinusoidal-3") -> dict[str, Any]:
    """Our RMSE at 0 lx and MIGL 255 split into the model residual and the measurement's own
    error, beside the thesis's RMSE there (Table 4.3).

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    pitch : int
        The pitch (the thesis: 6 px).
    pattern : str
        The pattern (the thesis's Table 4.3 row).

    Returns
    -------
    dict
        ``rmse_mm``, ``bias_mm``, ``std_mm`` (means over depth), ``model_rms_mm`` and
        ``model_mean_mm`` (:func:`model_residual_of`, None without a recorded setup) and
        ``thesis_rmse_mm``.

    References
    ----------
    Thesis Table 4.3; Eq. 2.15 (the model whose residual is separated).
    """
    sel = {"pattern": pattern, "pitch": pitch, "lux": 0.0, "migl": 255.0}
    res = model_residual_of(ds)
    thesis = THESIS_TABLE_4_3.get(pattern)
    return {
        "rmse_mm": _mean(ds, "rmse_mm", **sel),
        "bias_mm": _mean(ds, "mean_error_mm", **sel),
        "std_mm": _mean(ds, "std_mm", **sel),
        "model_rms_mm": None if res is None else res.rms_total_mm,
        "model_mean_mm": None if res is None else res.mean_mm,
        "thesis_rmse_mm": None if thesis is None else thesis[1],
    }


def _order_failure_note(sim: xr.Dataset) -> str:
    """What the reproduction's own fringe orders did at MIGL 255 under the heaviest light."""
    wrong = sim.get("order_error_fraction")
    params = json.loads(sim.attrs.get("sweep_params", "{}"))
    if wrong is None or params.get("unwrap", "known") != "centerline":
        return (
            "This run took fringe orders from the known plate position, so its saturation "
            "error stays below half a fringe (`--unwrap centerline` measures the failures)."
        )
    at255 = wrong.sel(pattern="sinusoidal-3", migl=255.0).mean("depth_mm")
    cells = ", ".join(
        f"{lux:g} lx {100 * float(at255.sel(added_lux=lux)):.3g} %"
        for lux in at255["added_lux"].values
    )
    return (
        "With the thesis's pipeline (spatial unwrapping and a captured centerline) the pixels "
        f"with a wrong fringe order at MIGL 255 (sinusoidal 3-step, mean over depth) are: {cells}"
        ' (`order_error_fraction`; research/docs/reproduction.md, "Fringe-order failures").'
    )


def differences_markdown(ds: xr.Dataset, sim: xr.Dataset) -> str:
    """What differs from the thesis and why, with the numbers of this run.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    sim : xarray.Dataset
        The Sec. 4.3 sweep.

    Returns
    -------
    str
        A Markdown bullet list (empty when no table has a thesis value to compare).
    """
    ratios = []
    for r in table_4_3(ds):
        if r["thesis"]:
            ratios += [r["ours"][i] / r["thesis"][i] for i in (1, 2, 3)]
    for r in table_4_2(sim):
        if r["thesis"]:
            ratios.append(r["ours"][1] / r["thesis"][1])
    t41 = [r for r in table_4_1(sim) if r["thesis"]]
    for r in t41:
        ratios += [r["ours"][i] / r["thesis"][i] for i in (1, 2) if r["thesis"][i] < FAILURE_MM]
    lines = []
    if ratios and "std_mm" in ds:
        eb = error_budget(ds)
        model = (
            ""
            if eb["model_rms_mm"] is None
            else f"the linear model's own residual on the rig's geometry, {eb['model_rms_mm']:.3f}"
            f" mm RMS at these depths (mean {eb['model_mean_mm']:+.3f} mm), computed without "
            "noise (`hdrfringe_thesis.model_residual`), and "
        )
        thesis = eb["thesis_rmse_mm"]
        share = (
            f"{eb['std_mm'] / thesis:.2f} of the thesis's RMSE ({thesis:g} mm); " if thesis else ""
        )
        lines.append(
            f"* **RMSE against the thesis's: not one scale factor.** Ours / thesis runs from "
            f"{min(ratios):.2f} to {max(ratios):.2f} over Tables 4.1-4.3. Split at pitch 6, "
            f"sinusoidal 3-step, 0 lx, MIGL 255: our RMSE {eb['rmse_mm']:.3f} mm is {model}"
            f"an error std over pixels of {eb['std_mm']:.3f} mm (bias {eb['bias_mm']:+.3f} mm, "
            "means over depth). The random part is "
            + share
            + "the model residual is a fixed bias per depth that the thesis's rig shows far "
            "less of (its Table 6.1 plate bias -0.01..-0.04 mm). Two RMSEs made of different "
            "parts do not scale; methods are compared on the std."
        )
    heavy = [r for r in t41 if r["thesis"][1] > FAILURE_MM]
    if heavy:
        lines.append(
            "* **RMSE at MIGL 255 under heavy added light** ("
            + ", ".join(
                f"{r['lux']:g} lx: {r['thesis'][1]:g} vs {r['ours'][1]:.2f} mm" for r in heavy
            )
            + "): the thesis's values include fringe-order failures (whole-fringe height jumps). "
            + _order_failure_note(sim)
            + " No ratio is given for them."
        )
    if t41 and "saturation_onset_migl" in t41[0]:
        sigmas = table_4_2(sim)
        t42 = [r["ours"][0] for r in sigmas]
        lines.append(
            "* **Trade-off MIGL under added light** (Table 4.1, thesis vs ours): "
            + ", ".join(f"{r['lux']:g} lx {r['thesis'][0]:.0f} vs {r['ours'][0]:.0f}" for r in t41)
            + ". The trade-off follows where saturation starts on the rig's response, a few "
            "MIGL above it (ours: "
            + ", ".join(
                f"{r['lux']:g} lx: {_onset_words(r['saturation_onset_migl'])}, trade-off "
                f"{r['ours'][0]:.0f} with "
                f"{100 * r['saturated_fraction_at_tradeoff']:.1f} % of the pixels saturated"
                for r in t41
            )
            + "; the thesis's saturation began near its 190, Sec. 4.3.1). Noise barely "
            f"moves it: sigma {sigmas[0]['sigma']:g}..{sigmas[-1]['sigma']:g} at 600 lx gives "
            f"trade-offs {min(t42):.0f}..{max(t42):.0f} (Table 4.2; at 900 lx "
            "`research/studies/error_budget.py`). The difference is where each rig's response "
            "saturates under Eq. 4.1's added light, not its noise level."
        )
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# figures
# --------------------------------------------------------------------------------------------
def _plt() -> ModuleType:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def figure_rmse_maps(ds: xr.Dataset, path: Path, lux: float) -> None:
    """Fig. 4.2-4.4 (0 lx) and 4.6-4.8 (600 lx): mean RMSE over depth against pitch and MIGL,
    one contour panel per pattern.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    path : Path
        PNG file to write.
    lux : float
        The added light shown (0 or 600 lx).
    """
    plt = _plt()
    mean = ds["rmse_mm"].sel(lux=lux).mean("depth_mm")
    patterns = [str(p) for p in ds["pattern"].values]
    fig, axes = plt.subplots(1, len(patterns), figsize=(5 * len(patterns), 4), dpi=100)
    for ax, p in zip(np.atleast_1d(axes), patterns, strict=True):
        z = mean.sel(pattern=p).transpose("migl", "pitch")
        cs = ax.contourf(z["pitch"], z["migl"], z.values, levels=12, cmap="viridis")
        ax.contour(z["pitch"], z["migl"], z.values, levels=12, colors="k", linewidths=0.3)
        fig.colorbar(cs, ax=ax, label="mean RMSE (mm)")
        ax.set(xlabel="pitch (px)", ylabel="MIGL", title=f"{p}, {lux:g} lx")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure_saturation_by_pitch(ds: xr.Dataset, path: Path, migl: float = 255.0) -> None:
    """Fig. 4.5: percentage of pixels saturated in 1, 2, 3 shifts at 600 lx, by pitch.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    path : Path
        PNG file to write.
    migl : float
        The MIGL shown.
    """
    plt = _plt()
    sat = ds["saturated_fraction"].sel(lux=600.0, migl=migl).mean("depth_mm") * 100
    patterns = [str(p) for p in ds["pattern"].values]
    fig, axes = plt.subplots(1, len(patterns), figsize=(5 * len(patterns), 3.6), dpi=100)
    pitches = sat["pitch"].values
    for ax, p in zip(np.atleast_1d(axes), patterns, strict=True):
        bottom = np.zeros(len(pitches))
        for k in sat["saturated_shifts"].values:
            v = sat.sel(pattern=p, saturated_shifts=k).values
            ax.bar(pitches, v, bottom=bottom, label=f"{k} shift(s)")
            bottom += v
        ax.set(xlabel="pitch (px)", ylabel="saturated pixels (%)", title=f"{p}, 600 lx")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure_pitch6(ds: xr.Dataset, path: Path, pitch: int = 6) -> None:
    """Fig. 4.13: mean RMSE against MIGL at pitch 6, 0 and 600 lx, per pattern.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    path : Path
        PNG file to write.
    pitch : int
        The pitch shown.
    """
    plt = _plt()
    mean = ds["rmse_mm"].sel(pitch=pitch).mean("depth_mm")
    patterns = [str(p) for p in ds["pattern"].values]
    fig, axes = plt.subplots(1, len(patterns), figsize=(5 * len(patterns), 3.6), dpi=100)
    for ax, p in zip(np.atleast_1d(axes), patterns, strict=True):
        for lux in mean["lux"].values:
            c = mean.sel(pattern=p, lux=lux)
            ax.plot(c["migl"], c.values, marker=".", label=f"{lux:g} lx")
        ax.set(xlabel="MIGL", ylabel="mean RMSE (mm)", title=f"{p}, pitch {pitch}")
        ax.legend()
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure_simulation(sim: xr.Dataset, path: Path, var: str, dim: str, unit: str) -> None:
    """Fig. 4.15 (added light) / 4.16 (noise): mean RMSE against MIGL per level and pattern.

    Parameters
    ----------
    sim : xarray.Dataset
        The Sec. 4.3 sweep.
    path : Path
        PNG file to write.
    var : str
        The variable shown: ``"rmse_light_mm"`` or ``"rmse_noise_mm"``.
    dim : str
        Its level dimension: ``"added_lux"`` or ``"noise_sigma"``.
    unit : str
        Unit of the levels in the legend.
    """
    plt = _plt()
    mean = sim[var].mean("depth_mm")
    patterns = [str(p) for p in sim["pattern"].values]
    fig, axes = plt.subplots(1, len(patterns), figsize=(5 * len(patterns), 3.6), dpi=100)
    for ax, p in zip(np.atleast_1d(axes), patterns, strict=True):
        for level in mean[dim].values:
            c = mean.sel(pattern=p, **{dim: level})
            ax.plot(c["migl"], c.values, label=f"{level:g} {unit}")
        ax.set(xlabel="MIGL", ylabel="mean RMSE (mm)", title=p, yscale="log")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure_depth_maps(ds: xr.Dataset, path: Path, pattern: str, migls: Sequence[float]) -> None:
    """Fig. 4.9-4.11: RMSE over pitch and depth at 600 lx for one pattern, one contour panel per
    MIGL (the thesis: 255 and 225).

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    path : Path
        PNG file to write.
    pattern : str
        The pattern shown.
    migls : sequence of float
        One panel per MIGL.
    """
    plt = _plt()
    fig, axes = plt.subplots(1, len(migls), figsize=(5 * len(migls), 4), dpi=100)
    for ax, m in zip(np.atleast_1d(axes), migls, strict=True):
        z = ds["rmse_mm"].sel(pattern=pattern, lux=600.0, migl=m).transpose("depth_mm", "pitch")
        cs = ax.contourf(z["pitch"], z["depth_mm"], z.values, levels=12, cmap="viridis")
        ax.contour(z["pitch"], z["depth_mm"], z.values, levels=12, colors="k", linewidths=0.3)
        fig.colorbar(cs, ax=ax, label="RMSE (mm)")
        ax.set(xlabel="pitch (px)", ylabel="depth (mm)", title=f"{pattern}, 600 lx, MIGL {m:g}")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure_patterns_by_pitch(ds: xr.Dataset, path: Path, migls: Sequence[float]) -> None:
    """Fig. 4.12: mean RMSE over depth against pitch at 600 lx, one panel per MIGL, one line
    per pattern.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    path : Path
        PNG file to write.
    migls : sequence of float
        One panel per MIGL.
    """
    plt = _plt()
    mean = ds["rmse_mm"].sel(lux=600.0).mean("depth_mm")
    fig, axes = plt.subplots(1, len(migls), figsize=(5.5 * len(migls), 3.8), dpi=100)
    for ax, m in zip(np.atleast_1d(axes), migls, strict=True):
        for p in ds["pattern"].values:
            c = mean.sel(pattern=p, migl=m)
            ax.plot(c["pitch"], c.values, marker="o", ms=3, label=str(p))
        ax.set(xlabel="pitch (px)", ylabel="mean RMSE (mm)", title=f"600 lx, MIGL {m:g}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figure_measured_vs_simulated(
    ds: xr.Dataset, sim: xr.Dataset, path: Path, sigma: float = 1.0
) -> None:
    """Fig. 4.17: RMSE against depth at pitch 6 and MIGL 255: measured with 0 and 600 lx, and
    the Eq. 4.1 simulation of 600 lx with noise sigma 1, per pattern.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    sim : xarray.Dataset
        The Sec. 4.3 sweep (its ``pitch`` attribute is the pitch shown).
    path : Path
        PNG file to write.
    sigma : float
        The simulated noise level shown.
    """
    plt = _plt()
    pitch = int(sim.attrs.get("pitch", 6))
    patterns = [str(p) for p in ds["pattern"].values]
    fig, axes = plt.subplots(1, len(patterns), figsize=(5 * len(patterns), 3.6), dpi=100)
    for ax, p in zip(np.atleast_1d(axes), patterns, strict=True):
        meas = ds["rmse_mm"].sel(pattern=p, pitch=pitch, migl=255.0)
        ax.plot(meas["depth_mm"], meas.sel(lux=0.0), "k-", marker=".", label="0 lx")
        ax.plot(meas["depth_mm"], meas.sel(lux=600.0), "k--", marker=".", label="600 lx")
        s = sim["rmse_noise_mm"].sel(pattern=p, migl=255.0, noise_sigma=sigma)
        ax.plot(s["depth_mm"], s, "C3:", marker=".", label=f"simulated 600 lx, sigma {sigma:g}")
        ax.set(xlabel="depth (mm)", ylabel="RMSE (mm)", title=f"{p}, pitch {pitch}, MIGL 255")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def figures(ds: xr.Dataset, sim: xr.Dataset, folder: Path) -> list[str]:
    """Write the Ch. 4 figures into ``folder``; return their file names.

    Parameters
    ----------
    ds : xarray.Dataset
        The Sec. 4.2 sweep.
    sim : xarray.Dataset
        The Sec. 4.3 sweep.
    folder : Path
        Folder of the PNG files (created).

    Returns
    -------
    list of str
        The file names written, named after the thesis's figures.
    """
    folder.mkdir(parents=True, exist_ok=True)
    migls = [m for m in (255.0, 225.0) if m in ds["migl"].values]
    written: dict[str, Callable[[Path], None]] = {
        "fig4_2-4_4_rmse_0lx.png": lambda p: figure_rmse_maps(ds, p, 0.0),
        "fig4_6-4_8_rmse_600lx.png": lambda p: figure_rmse_maps(ds, p, 600.0),
        "fig4_5_saturation_by_pitch.png": lambda p: figure_saturation_by_pitch(ds, p),
        **{
            f"fig4_{9 + i}_{pattern}_depth_maps.png": partial(
                figure_depth_maps, ds, pattern=pattern, migls=migls
            )
            for i, pattern in enumerate(str(x) for x in ds["pattern"].values)
        },
        "fig4_12_patterns_by_pitch.png": lambda p: figure_patterns_by_pitch(ds, p, migls),
        "fig4_13_pitch6.png": lambda p: figure_pitch6(ds, p),
        "fig4_15_added_light.png": lambda p: figure_simulation(
            sim, p, "rmse_light_mm", "added_lux", "lx"
        ),
        "fig4_16_added_noise.png": lambda p: figure_simulation(
            sim, p, "rmse_noise_mm", "noise_sigma", "DN"
        ),
        "fig4_17_measured_vs_simulated.png": lambda p: figure_measured_vs_simulated(ds, sim, p),
    }
    for name, draw in written.items():
        draw(folder / name)
    return list(written)
