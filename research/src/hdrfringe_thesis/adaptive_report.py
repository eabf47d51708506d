"""Tables and figures of thesis Ch. 5 (LPA) and Ch. 6 (DPA) from the adaptive sweeps.

Inputs are the Datasets of :mod:`hdrfringe_thesis.adaptive` (``ch5_plate``,
``checkerboard``, ``ch6_plate``). Tables are rows of thesis / ours / ratio as in
:mod:`hdrfringe_thesis.ch4_report`; figures are matplotlib PNGs named after the thesis's.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from hdrfringe_thesis.ch4_report import (
    Notes,
    _bias_std,
    _plt,
    _residual_line,
    _table,
    _vs,
    model_residual_of,
)

if TYPE_CHECKING:
    import xarray as xr
    from matplotlib.figure import Figure

__all__ = [
    "CH6_MIN_PITCH",
    "FIG_6_3_PITCH",
    "TABLE_5_1_PITCH",
    "TABLE_5_2_PITCH",
    "THESIS_TABLE_5_1",
    "THESIS_TABLE_5_2",
    "THESIS_TABLE_6_1",
    "THESIS_TABLE_6_2",
    "THESIS_TRADEOFF_CHECKERBOARD",
    "differences_markdown",
    "figure_5_3",
    "figure_5_4",
    "figure_5_5",
    "figure_5_6",
    "figure_5_8",
    "figure_6_3",
    "figures",
    "method_label",
    "pooled_levels",
    "table_5_1",
    "table_5_2",
    "table_6",
    "tables_markdown",
    "uniform_tradeoff",
]

#: Table 5.1 (white plate, 600 lx, pitch 6): pattern -> (LPA S=5, MIGL 255, trade-off) RMSE mm.
THESIS_TABLE_5_1: dict[str, tuple[float, float, float]] = {
    "sinusoidal-3": (0.34, 0.68, 0.27),
    "triangular-3": (0.38, 0.53, 0.33),
    "triangular-2": (1.10, 1.14, 1.03),
}
#: Table 5.2 (checkerboard, 4-step, pitch 8): step -> (steps, mean RMSE, mean std) mm;
#: "uniform": the trade-off MIGL (96) measured alone.
THESIS_TABLE_5_2: dict[str, tuple[float, float, float]] = {
    "lpa-1": (196, 0.75, 0.47),
    "lpa-2": (98, 0.75, 0.47),
    "lpa-5": (40, 0.75, 0.47),
    "lpa-10": (20, 0.74, 0.47),
    "lpa-15": (14, 0.76, 0.48),
    "lpa-20": (10, 0.74, 0.48),
    "lpa-30": (6, 0.75, 0.48),
    "lpa-45": (5, 0.78, 0.50),
    "uniform": (1, 1.01, 0.83),
}
THESIS_TRADEOFF_CHECKERBOARD = 96.0
#: Tables 6.1 (white plate, 600 lx) and 6.2 (checkerboard), sinusoidal 4-step, means over
#: pitch 6..20 and depth: method -> (sets, bias, std, RMSE) mm.
THESIS_TABLE_6_1: dict[str, tuple[float, float, float, float]] = {
    "dpa-10": (12.86, -0.02, 0.25, 0.39),
    "dpa-20": (7.06, -0.01, 0.25, 0.38),
    "lpa-15": (13.75, -0.04, 0.25, 0.39),
    "lpa-20": (9.81, -0.04, 0.25, 0.39),
    "lpa-30": (7.81, -0.02, 0.25, 0.39),
}
THESIS_TABLE_6_2: dict[str, tuple[float, float, float, float]] = {
    "dpa-10": (29.33, -0.52, 0.56, 0.79),
    "dpa-20": (29.33, -0.52, 0.56, 0.79),
    "lpa-15": (14.0, -0.53, 0.56, 0.79),
    "lpa-20": (10.0, -0.53, 0.70, 0.91),
    "lpa-30": (7.0, -0.53, 0.71, 0.92),
}
#: Ch. 6 averages over the pitches of Fig. 6.4-6.6.
CH6_MIN_PITCH = 6
TABLE_5_1_PITCH = 6
TABLE_5_2_PITCH = 8
FIG_6_3_PITCH = 8


def method_label(method: str) -> str:
    """The label of a method name in tables and legends.

    Parameters
    ----------
    method : str
        ``"lpa-S"``, ``"dpa-P"`` or ``"dpab-P"`` (:class:`hdrfringe_thesis.adaptive.Experiment`);
        anything else is returned unchanged.

    Returns
    -------
    str
        E.g. ``LPA S=15``, ``DPA 10 %``.

    Examples
    --------
    >>> method_label("lpa-15"), method_label("dpa-10"), method_label("dpab-20")
    ('LPA S=15', 'DPA 10 %', 'DPA 20 % + bound (ours)')
    """
    kind, _, value = method.partition("-")
    if kind == "lpa":
        return f"LPA S={value}"
    if kind == "dpa":
        return f"DPA {value} %"
    if kind == "dpab":
        return f"DPA {value} % + bound (ours)"
    return method


def uniform_tradeoff(ds: xr.Dataset, pitch: int, pattern: str | None = None) -> tuple[float, int]:
    """(trade-off MIGL, its index) of the uniform sets at ``pitch``: the lowest mean RMSE over
    depth (the thesis's search of Sec. 4.2; the highest MIGL on ties).

    Parameters
    ----------
    ds : xarray.Dataset
        An adaptive sweep (:func:`hdrfringe_thesis.adaptive.adaptive_grid`), with
        ``uniform_rmse_mm`` over pattern, pitch, depth and uniform MIGL.
    pitch : int
        The pitch searched.
    pattern : str, optional
        The pattern searched (default the first).

    Returns
    -------
    tuple of (float, int)
        The trade-off MIGL and its index along ``uniform_migl``.

    Examples
    --------
    >>> import xarray as xr
    >>> rmse = [[[[0.9, 0.4, 0.6], [0.7, 0.4, 0.8]]]]
    >>> ds = xr.Dataset(
    ...     {"uniform_rmse_mm": (("pattern", "pitch", "depth_mm", "uniform_migl"), rmse)},
    ...     coords={"pitch": [8], "uniform_migl": [255.0, 250.0, 245.0]},
    ... )
    >>> uniform_tradeoff(ds, 8)
    (250.0, 1)
    """
    sel = ds["uniform_rmse_mm"].sel(pitch=pitch)
    sel = sel.isel(pattern=0) if pattern is None else sel.sel(pattern=pattern)
    curve = sel.mean("depth_mm").values
    migls = ds["uniform_migl"].values
    best = np.nanmin(curve)
    i = int(np.flatnonzero(curve == best)[np.argmax(migls[curve == best])])
    return float(migls[i]), i


def table_5_1(plate: xr.Dataset, pitch: int = TABLE_5_1_PITCH) -> list[dict[str, Any]]:
    """Table 5.1: per pattern at ``pitch``, the mean RMSE over depth of LPA S=5, MIGL 255 and
    the uniform trade-off.

    Parameters
    ----------
    plate : xarray.Dataset
        The ``ch5_plate`` sweep.
    pitch : int
        The pitch of the table (the thesis: 6 px).

    Returns
    -------
    list of dict
        Per pattern: ``pattern``, ``ours`` (LPA S=5, MIGL 255, trade-off RMSE in mm),
        ``bias_mm`` and ``std_mm`` (the same three, means over depth), ``tradeoff_migl`` and
        ``thesis`` (:data:`THESIS_TABLE_5_1`, None where it has no row).

    References
    ----------
    Thesis Sec. 5.2.1, Table 5.1.
    """
    rows: list[dict[str, Any]] = []
    for pattern in plate["pattern"].values:
        p = str(pattern)
        cell = plate.sel(pattern=p, pitch=pitch).mean("depth_mm")
        t_migl, i = uniform_tradeoff(plate, pitch, p)
        ours = (
            float(cell["rmse_mm"].sel(strategy="lpa-5")),
            float(cell["uniform_rmse_mm"].sel(uniform_migl=255.0)),
            float(cell["uniform_rmse_mm"].isel(uniform_migl=i)),
        )
        stats = {
            key: (
                float(cell[var].sel(strategy="lpa-5")),
                float(cell[f"uniform_{var}"].sel(uniform_migl=255.0)),
                float(cell[f"uniform_{var}"].isel(uniform_migl=i)),
            )
            for key, var in (("bias_mm", "mean_error_mm"), ("std_mm", "std_mm"))
        }
        rows.append(
            {
                "pattern": p,
                "ours": ours,
                "tradeoff_migl": t_migl,
                "thesis": THESIS_TABLE_5_1.get(p),
                **stats,
            }
        )
    return rows


def table_5_2(board: xr.Dataset, pitch: int = TABLE_5_2_PITCH) -> list[dict[str, Any]]:
    """Table 5.2: per method at ``pitch`` on the checkerboard, the mean sets, RMSE and error std
    over depth, then the uniform trade-off MIGL measured alone.

    Parameters
    ----------
    board : xarray.Dataset
        The ``checkerboard`` sweep.
    pitch : int
        The pitch of the table (the thesis: 8 px).

    Returns
    -------
    list of dict
        Per method, then ``"uniform"``: ``method``, ``ours`` (sets, RMSE, std in mm),
        ``bias_mm`` and ``thesis`` (:data:`THESIS_TABLE_5_2`); the uniform row also has
        ``tradeoff_migl``.

    References
    ----------
    Thesis Sec. 5.2.2, Table 5.2.
    """
    cell = board.sel(pitch=pitch).isel(pattern=0).mean("depth_mm")
    rows: list[dict[str, Any]] = []
    for method in board["strategy"].values:
        m = str(method)
        c = cell.sel(strategy=m)
        ours = (float(c["sets"]), float(c["rmse_mm"]), float(c["std_mm"]))
        rows.append(
            {
                "method": m,
                "ours": ours,
                "bias_mm": float(c["mean_error_mm"]),
                "thesis": THESIS_TABLE_5_2.get(m),
            }
        )
    t_migl, i = uniform_tradeoff(board, pitch)
    u = cell.isel(uniform_migl=i)
    rows.append(
        {
            "method": "uniform",
            "tradeoff_migl": t_migl,
            "ours": (1.0, float(u["uniform_rmse_mm"]), float(u["uniform_std_mm"])),
            "bias_mm": float(u["uniform_mean_error_mm"]),
            "thesis": THESIS_TABLE_5_2["uniform"],
        }
    )
    return rows


def table_6(ds: xr.Dataset, thesis: Mapping[str, tuple[float, ...]]) -> list[dict[str, Any]]:
    """Tables 6.1 / 6.2: per method, means over pitch (6..20) and depth of sets, bias, error
    std and RMSE.

    Parameters
    ----------
    ds : xarray.Dataset
        The ``ch6_plate`` (Table 6.1) or ``checkerboard`` (Table 6.2) sweep.
    thesis : mapping of str to tuple of float
        The thesis's table (:data:`THESIS_TABLE_6_1` or :data:`THESIS_TABLE_6_2`).

    Returns
    -------
    list of dict
        Per method: ``method``, ``ours`` (sets, bias, std, RMSE) and ``thesis`` (None for a
        method the thesis did not run).

    References
    ----------
    Thesis Sec. 6.3, Tables 6.1 and 6.2.
    """
    sel = ds.sel(pitch=ds["pitch"] >= CH6_MIN_PITCH).isel(pattern=0)
    mean = sel.mean(("pitch", "depth_mm"))
    rows = []
    for method in ds["strategy"].values:
        m = str(method)
        c = mean.sel(strategy=m)
        ours = tuple(float(c[v]) for v in ("sets", "mean_error_mm", "std_mm", "rmse_mm"))
        rows.append({"method": m, "ours": ours, "thesis": thesis.get(m)})
    return rows


def tables_markdown(
    plate: xr.Dataset | None,
    board: xr.Dataset | None,
    plate4: xr.Dataset | None,
    board6: xr.Dataset | None = None,
) -> dict[str, str]:
    """Tables 5.1 and 5.2 (``plate``, ``board``: the Ch. 5 sweeps) and 6.1 and 6.2 (``plate4``,
    ``board6``: the Ch. 6 sweeps) as Markdown, those whose sweeps are given.

    Parameters
    ----------
    plate : xarray.Dataset or None
        The ``ch5_plate`` sweep (Table 5.1).
    board : xarray.Dataset or None
        The ``checkerboard`` sweep, for Ch. 5 (Table 5.2).
    plate4 : xarray.Dataset or None
        The ``ch6_plate`` sweep (Table 6.1).
    board6 : xarray.Dataset or None
        The ``checkerboard`` sweep, for Ch. 6 (Table 6.2).

    Returns
    -------
    dict of str to str
        ``"5.1"``, ``"5.2"``, ``"6.1"``, ``"6.2"`` (those given): Markdown tables, thesis
        beside ours with the ratio.
    """
    from hdrfringe_thesis.ch4 import THESIS_DEPTHS_MM

    mm = "{:.3f}"
    out: dict[str, str] = {}
    if plate is not None:
        notes = Notes()
        rows = []
        for r in table_5_1(plate):
            th = r["thesis"] or (None, None, None)
            no = "a pattern the thesis did not measure"
            b, sd = r["bias_mm"], r["std_mm"]
            rows.append(
                [
                    r["pattern"],
                    *(
                        cell
                        for k in range(3)
                        for cell in (
                            _vs(th[k], r["ours"][k], mm, notes, missing=no),
                            _bias_std(b[k], sd[k]),
                        )
                    ),
                    f"{r['tradeoff_migl']:.0f}",
                ]
            )
        bs = "ours: bias / std (mm)"
        out["5.1"] = _table(
            [
                "pattern",
                "LPA S=5 RMSE (mm), thesis / ours (ratio)",
                bs,
                "MIGL 255 RMSE (mm)",
                bs,
                "trade-off RMSE (mm)",
                bs,
                "our trade-off MIGL",
            ],
            rows,
            notes,
            _residual_line(model_residual_of(plate, THESIS_DEPTHS_MM)),
        )
    if board is not None:
        notes = Notes()
        rows = []
        for r in table_5_2(board):
            label = method_label(r["method"])
            if r["method"] == "uniform":
                label = (
                    f"uniform trade-off (thesis MIGL {THESIS_TRADEOFF_CHECKERBOARD:.0f}, ours "
                    f"{r['tradeoff_migl']:.0f})"
                )
            no = _missing_5_2(r["method"])
            th = r["thesis"] or (None, None, None)
            rows.append(
                [
                    label,
                    _vs(th[0], r["ours"][0], "{:.1f}", notes, missing=no),
                    _vs(th[1], r["ours"][1], mm, notes, missing=no),
                    _vs(th[2], r["ours"][2], mm, notes, missing=no),
                    f"{r['bias_mm']:+.3f}",
                ]
            )
        out["5.2"] = _table(
            [
                "method",
                "sets, thesis / ours (ratio)",
                "mean RMSE (mm)",
                "mean std (mm)",
                "ours: bias (mm)",
            ],
            rows,
            notes,
            _residual_line(model_residual_of(board, THESIS_DEPTHS_MM)),
        )
    for key, ds, thesis in (("6.1", plate4, THESIS_TABLE_6_1), ("6.2", board6, THESIS_TABLE_6_2)):
        if ds is None:
            continue
        notes = Notes()
        rows = []
        for r in table_6(ds, thesis):
            no = _missing_6(r["method"], key)
            th = r["thesis"] or (None,) * 4
            rows.append(
                [
                    method_label(r["method"]),
                    _vs(th[0], r["ours"][0], "{:.2f}", notes, missing=no),
                    _vs(th[1], r["ours"][1], mm, notes, missing=no, ratio=False),
                    _vs(th[2], r["ours"][2], mm, notes, missing=no),
                    _vs(th[3], r["ours"][3], mm, notes, missing=no),
                ]
            )
        out[key] = _table(
            [
                "method",
                "sets, thesis / ours (ratio)",
                "bias (mm), thesis / ours",
                "std (mm)",
                "RMSE (mm)",
            ],
            rows,
            notes,
            "Bias: no ratio (the thesis's biases are near zero). "
            + _residual_line(model_residual_of(ds, THESIS_DEPTHS_MM)),
        )
    return out


def _missing_5_2(method: str) -> str:
    """Why Table 5.2 has no thesis value for ``method``."""
    if method.startswith("dpab"):
        return "beyond the thesis: DPA with the pending-pixel bound (docs/dpa.md)"
    if method.startswith("dpa"):
        return "the thesis ran DPA in Ch. 6 only (Table 6.2, means over pitch 6..20)"
    return "the thesis's Table 5.2 has S = 1, 2, 5, 10, 15, 20, 30, 45 only"


def _missing_6(method: str, table: str) -> str:
    """Why Table 6.1 / 6.2 has no thesis value for ``method``."""
    if method.startswith("dpab"):
        return "beyond the thesis: DPA with the pending-pixel bound (docs/dpa.md)"
    return (
        f"not in the thesis's Table {table} (it lists LPA S = 15, 20, 30 and DPA 10 %, 20 %); "
        "run here for Fig. 6.3-6.6 and Ch. 5"
    )


def differences_markdown(
    plate: xr.Dataset | None,
    board: xr.Dataset | None,
    plate4: xr.Dataset | None,
    board6: xr.Dataset | None = None,
) -> str:
    """What differs from the thesis in Ch. 5 and 6, with this run's numbers.

    Parameters
    ----------
    plate, board, plate4, board6 : xarray.Dataset or None
        As :func:`tables_markdown`.

    Returns
    -------
    str
        A Markdown bullet list.
    """
    from hdrfringe_thesis.ch4 import THESIS_DEPTHS_MM

    lines = []
    if plate is not None:
        t51 = table_5_1(plate)
        lines.append(
            "* **Table 5.1.** LPA S=5 against the uniform trade-off at pitch 6, error std ratio: "
            + ", ".join(f"{r['pattern']} {r['std_mm'][0] / r['std_mm'][2]:.2f}x" for r in t51)
            + " (RMSE ratio "
            + ", ".join(f"{r['ours'][0] / r['ours'][2]:.2f}x" for r in t51)
            + "; thesis, RMSE only: "
            + ", ".join(
                f"{r['thesis'][0] / r['thesis'][2]:.2f}x" for r in t51 if r["thesis"] is not None
            )
            + "). The thesis measured its trade-off in Ch. 4, on other captures; here both come "
            "from the same sweep, so the difference left is the method's alone."
        )
    if board is not None:
        t52 = {r["method"]: r for r in table_5_2(board)}
        s1, s45, uni = t52["lpa-1"]["ours"], t52["lpa-45"]["ours"], t52["uniform"]["ours"]
        lines.append(
            f"* **Table 5.2.** On the checkerboard at pitch 8 the error std grows from "
            f"{s1[2]:.3f} mm (S=1) to {s45[2]:.3f} mm (S=45) and the uniform trade-off "
            f"(MIGL {t52['uniform']['tradeoff_migl']:.0f}) reaches {uni[2]:.3f} mm, the thesis's "
            "order. The RMSE is dominated by the bias every method shares (the model residual, "
            "below), so its spread is smaller than the std's."
        )
    if board6 is not None:
        t = {r["method"]: r["ours"] for r in table_6(board6, THESIS_TABLE_6_2)}
        if "dpa-10" in t:
            lines.append(
                f"* **DPA sets on the checkerboard** ({t['dpa-10'][0]:.1f} and "
                f"{t['dpa-20'][0]:.1f} over pitch against the thesis's 29.33): DPA's estimate "
                "covers pixels with one saturated shift in four; the white squares saturate in "
                "three or four at the top MIGL, so the 0.01 % rule captures at every gray level "
                "while they wait (docs/dpa.md)."
            )
        if "dpab-10" in t:
            lines.append(
                f"* **Beyond the thesis: DPA with the pending-pixel bound** captures "
                f"{t['dpab-10'][0]:.1f} (10 %) and {t['dpab-20'][0]:.1f} (20 %) sets on the "
                f"checkerboard for an error std of {t['dpab-10'][2]:.3f} and "
                f"{t['dpab-20'][2]:.3f} mm (thesis-rule DPA: {t['dpa-10'][2]:.3f} mm, LPA S=1: "
                f"{t['lpa-1'][2]:.3f} mm in {t['lpa-1'][0]:.0f} sets)."
            )
    parts, residuals = [], []
    for name, ds in (("white plate", plate4 or plate), ("checkerboard", board6 or board)):
        if ds is None:
            continue
        sel = ds.sel(pitch=ds["pitch"] >= CH6_MIN_PITCH).isel(pattern=0)
        bias = sel["mean_error_mm"].mean(("pitch", "depth_mm"))
        lo, hi = float(bias.min()), float(bias.max())
        span = f"{lo:+.3f}" if f"{lo:+.3f}" == f"{hi:+.3f}" else f"{lo:+.3f} to {hi:+.3f}"
        parts.append(f"{name} {span} mm")
        res = model_residual_of(ds, THESIS_DEPTHS_MM)
        if res is not None:
            residuals.append(f"{name} {res.mean_mm:+.3f} mm")
    if parts:
        model = (
            f"; the linear model's residual on the rig's geometry at the same depths, computed "
            f"without noise (`hdrfringe_thesis.model_residual`), is {', '.join(residuals)}: "
            "the bias is the calibration model's, not the methods'"
            if residuals
            else ""
        )
        lines.append(
            f"* **Bias** ({', '.join(parts)} over the methods){model}. The thesis's biases are "
            "-0.01..-0.04 mm on the plate and -0.52 mm on the checkerboard (which it attributes "
            "to the black-plate calibration and the centerline). Methods are compared on the "
            "std."
        )
    if plate4 is not None:
        t6 = {r["method"]: r["ours"] for r in table_6(plate4, THESIS_TABLE_6_1)}
        pairs = [("dpa-10", "lpa-15"), ("dpa-20", "lpa-20")]
        if all(a in t6 and b in t6 for a, b in pairs):
            th = THESIS_TABLE_6_1
            lines.append(
                "* **Table 6.1, sets.** On the white plate "
                + "; ".join(
                    f"{method_label(a)} captures {t6[a][0]:.2f} sets against {method_label(b)}'s "
                    f"{t6[b][0]:.2f} ({'fewer' if t6[a][0] < t6[b][0] else 'not fewer'}; "
                    f"thesis {th[a][0]:g} and {th[b][0]:g}), std {t6[a][2]:.3f} vs "
                    f"{t6[b][2]:.3f} mm"
                    for a, b in pairs
                )
                + ". The comparable quantity is the ratio of DPA's sets to LPA's: "
                + ", ".join(
                    f"{method_label(a)} / {method_label(b)} {t6[a][0] / t6[b][0]:.2f} ours, "
                    f"{th[a][0] / th[b][0]:.2f} the thesis's"
                    for a, b in pairs
                )
                + "; our plate clears at a higher MIGL than the thesis's, so every method needs "
                "fewer sets."
            )
    return "\n".join(lines)


# --------------------------------------------------------------------------------------------
# figures
# --------------------------------------------------------------------------------------------
def _save(fig: Figure, path: Path) -> None:
    fig.tight_layout()
    fig.savefig(path)
    _plt().close(fig)


def figure_5_3(plate: xr.Dataset, path: Path) -> None:
    """Fig. 5.3: LPA S=5 RMSE over pitch and depth, one contour panel per pattern.

    Parameters
    ----------
    plate : xarray.Dataset
        The ``ch5_plate`` sweep.
    path : Path
        PNG file to write.
    """
    plt = _plt()
    patterns = [str(p) for p in plate["pattern"].values]
    fig, axes = plt.subplots(1, len(patterns), figsize=(5 * len(patterns), 4), dpi=100)
    for ax, p in zip(np.atleast_1d(axes), patterns, strict=True):
        z = plate["rmse_mm"].sel(pattern=p, strategy="lpa-5").transpose("depth_mm", "pitch")
        cs = ax.contourf(z["pitch"], z["depth_mm"], z.values, levels=12, cmap="viridis")
        fig.colorbar(cs, ax=ax, label="RMSE (mm)")
        ax.set(xlabel="pitch (px)", ylabel="depth (mm)", title=f"{p}, LPA S=5, 600 lx")
    _save(fig, path)


def figure_5_4(plate: xr.Dataset, path: Path) -> None:
    """Fig. 5.4: LPA S=5 mean RMSE over depth against pitch, per pattern.

    Parameters
    ----------
    plate : xarray.Dataset
        The ``ch5_plate`` sweep.
    path : Path
        PNG file to write.
    """
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    mean = plate["rmse_mm"].sel(strategy="lpa-5").mean("depth_mm")
    for p in plate["pattern"].values:
        c = mean.sel(pattern=p)
        ax.plot(c["pitch"], c.values, marker="o", label=str(p))
    ax.set(xlabel="pitch (px)", ylabel="mean RMSE (mm)", title="LPA S=5, white plate, 600 lx")
    ax.legend()
    _save(fig, path)


def figure_5_5(plate: xr.Dataset, path: Path, pitch: int = TABLE_5_1_PITCH) -> None:
    """Fig. 5.5: RMSE against depth at pitch 6: MIGL 255 (solid), trade-off (dashed), LPA S=5
    (dotted), per pattern.

    Parameters
    ----------
    plate : xarray.Dataset
        The ``ch5_plate`` sweep.
    path : Path
        PNG file to write.
    pitch : int
        The pitch shown.
    """
    plt = _plt()
    patterns = [str(p) for p in plate["pattern"].values]
    fig, axes = plt.subplots(1, len(patterns), figsize=(5 * len(patterns), 3.6), dpi=100)
    for ax, p in zip(np.atleast_1d(axes), patterns, strict=True):
        cell = plate.sel(pattern=p, pitch=pitch)
        t_migl, i = uniform_tradeoff(plate, pitch, p)
        d = cell["depth_mm"]
        ax.plot(d, cell["uniform_rmse_mm"].sel(uniform_migl=255.0), "k-", label="MIGL 255")
        ax.plot(d, cell["uniform_rmse_mm"].isel(uniform_migl=i), "k--", label=f"MIGL {t_migl:.0f}")
        ax.plot(d, cell["rmse_mm"].sel(strategy="lpa-5"), "k:", label="LPA S=5")
        ax.set(xlabel="depth (mm)", ylabel="RMSE (mm)", title=f"{p}, pitch {pitch}, 600 lx")
        ax.legend(fontsize=8)
    _save(fig, path)


def pooled_levels(plate: xr.Dataset, pattern: str, pitch: int) -> dict[str, Any]:
    """Fig. 5.6's data: per index MIGL, the pixel fraction and the RMSE, mean error and std of
    the pixels composed from it, pooled over depth (every depth measures as many pixels).

    Parameters
    ----------
    plate : xarray.Dataset
        The ``ch5_plate`` sweep (its ``level_*`` variables).
    pattern : str
        The pattern.
    pitch : int
        The pitch.

    Returns
    -------
    dict of str to ndarray
        ``migl`` (the index MIGLs holding pixels), ``fraction``, ``rmse``, ``mean``, ``std``.
    """
    cell = plate.sel(pattern=pattern, pitch=pitch)
    f = cell["level_fraction"].values  # (depth, level)
    rmse = cell["level_rmse_mm"].values
    mean = cell["level_mean_error_mm"].values
    w = np.nan_to_num(f)
    total = w.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        msq = np.nansum(w * rmse**2, axis=0) / total
        mu = np.nansum(w * mean, axis=0) / total
    keep = total > 0
    return {
        "migl": cell["index_migl"].values[keep],
        "fraction": total[keep] / f.shape[0],
        "rmse": np.sqrt(msq[keep]),
        "mean": mu[keep],
        "std": np.sqrt(np.maximum(msq[keep] - mu[keep] ** 2, 0.0)),
    }


def figure_5_6(plate: xr.Dataset, path: Path, pitch: int = TABLE_5_1_PITCH) -> None:
    """Fig. 5.6: per LPA step, RMSE (and mean +- std) of the pixels composed from it, and the
    pie chart of pixels per MIGL, per pattern (rows).

    Parameters
    ----------
    plate : xarray.Dataset
        The ``ch5_plate`` sweep.
    path : Path
        PNG file to write.
    pitch : int
        The pitch shown.
    """
    plt = _plt()
    patterns = [str(p) for p in plate["pattern"].values]
    fig, axes = plt.subplots(len(patterns), 2, figsize=(10, 3.4 * len(patterns)), dpi=100)
    axes = np.atleast_2d(axes)
    for row, p in zip(axes, patterns, strict=True):
        lv = pooled_levels(plate, p, pitch)
        shown = lv["fraction"] >= 0.005  # a handful of pixels make no RMSE
        lv = {**{k: v[shown] for k, v in lv.items()}, "rest": float(lv["fraction"][~shown].sum())}
        row[0].plot(lv["migl"], lv["rmse"], "k-", marker="o", label="RMSE")
        row[0].plot(lv["migl"], lv["mean"] + lv["std"], "k--", lw=0.8, label="mean +- std")
        row[0].plot(lv["migl"], lv["mean"] - lv["std"], "k--", lw=0.8)
        row[0].set(xlabel="MIGL of the composite", ylabel="error (mm)", title=f"{p}, pitch {pitch}")
        row[0].invert_xaxis()
        row[0].legend(fontsize=8)
        big = lv["fraction"] >= 0.02
        sizes = [*list(lv["fraction"][big]), float(lv["fraction"][~big].sum()) + lv["rest"]]
        labels = [f"{m:.0f}" for m in lv["migl"][big]] + ["other"]
        if sizes[-1] <= 0:
            sizes, labels = sizes[:-1], labels[:-1]
        row[1].pie(
            sizes,
            labels=labels,
            autopct=lambda pct: f"{pct:.0f}%" if pct >= 3 else "",
            textprops={"fontsize": 8},
        )
        row[1].set_title("pixels per MIGL (LPA S=5)")
    _save(fig, path)


def _per_pitch(
    ds: xr.Dataset, path: Path, var: str, methods: list[str], ylabel: str, title: str
) -> None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 4), dpi=100)
    mean = ds[var].isel(pattern=0).mean("depth_mm")
    for m in methods:
        if m in ds["strategy"].values:
            c = mean.sel(strategy=m)
            style = ":" if m.startswith("dpab") else "--" if m.startswith("dpa") else "-"
            ax.plot(c["pitch"], c.values, style, marker="o", ms=3, label=method_label(m))
    ax.set(xlabel="pitch (px)", ylabel=ylabel, title=title)
    ax.legend(fontsize=8)
    _save(fig, path)


def figure_5_8(board: xr.Dataset, path: Path, pitch: int = TABLE_5_2_PITCH) -> None:
    """Fig. 5.8: checkerboard at pitch 8, RMSE and error std against depth for LPA S=1, S=15
    and the uniform trade-off.

    Parameters
    ----------
    board : xarray.Dataset
        The ``checkerboard`` sweep.
    path : Path
        PNG file to write.
    pitch : int
        The pitch shown.
    """
    plt = _plt()
    cell = board.sel(pitch=pitch).isel(pattern=0)
    t_migl, i = uniform_tradeoff(board, pitch)
    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8), dpi=100)
    for ax, (var, uvar, label) in zip(
        axes,
        (("rmse_mm", "uniform_rmse_mm", "RMSE (mm)"), ("std_mm", "uniform_std_mm", "std (mm)")),
        strict=True,
    ):
        d = cell["depth_mm"]
        for m in ("lpa-1", "lpa-15"):
            ax.plot(d, cell[var].sel(strategy=m), marker="o", label=method_label(m))
        ax.plot(d, cell[uvar].isel(uniform_migl=i), "k--", label=f"uniform MIGL {t_migl:.0f}")
        ax.set(xlabel="depth (mm)", ylabel=label, title=f"checkerboard, 4-step, pitch {pitch}")
        ax.legend(fontsize=8)
    _save(fig, path)


def _nearest(values: ArrayLike, target: float) -> Any:
    values = np.asarray(values)
    return values[int(np.argmin(np.abs(values - target)))]


def figure_6_3(datasets: Mapping[str, xr.Dataset], path: Path, pitch: int = FIG_6_3_PITCH) -> None:
    """Fig. 6.3: actual CDF (LPA step-1 index image) against DPA's estimated CDF (from the first
    set, and after the last update), white plate and checkerboard, middle depth.

    Parameters
    ----------
    datasets : mapping of str to xarray.Dataset
        Panel title -> sweep with ``dpa-10`` and ``lpa-1`` among its strategies.
    path : Path
        PNG file to write.
    pitch : int
        The pitch shown (the nearest swept one).

    References
    ----------
    Thesis Sec. 6.1.3, Fig. 6.3.
    """
    plt = _plt()
    fig, axes = plt.subplots(1, len(datasets), figsize=(6 * len(datasets), 4), dpi=100)
    for ax, (name, ds) in zip(np.atleast_1d(axes), datasets.items(), strict=True):
        depth = _nearest(ds["depth_mm"].values, float(np.median(ds["depth_mm"].values)))
        cell = ds.sel(pitch=_nearest(ds["pitch"].values, pitch), depth_mm=depth).isel(pattern=0)
        m = cell["cdf_migl"]
        ax.plot(m, cell["cdf_actual"] * 100, "k-", label="actual (LPA S=1 index)")
        ax.step(
            m,
            cell["cdf_initial"].sel(strategy="dpa-10") * 100,
            "C0--",
            where="mid",
            label="estimated, first set",
        )
        ax.step(
            m,
            cell["cdf_final"].sel(strategy="dpa-10") * 100,
            "C1:",
            where="mid",
            label="estimated, after the last update (10 %)",
        )
        ax.set(
            xlabel="MIGL",
            ylabel="CDF (%)",
            title=f"{name}, pitch {int(cell['pitch'])}, {float(depth):g} mm",
        )
        ax.invert_xaxis()
        ax.legend(fontsize=8)
    _save(fig, path)


def figures(
    plate: xr.Dataset | None,
    board: xr.Dataset | None,
    plate4: xr.Dataset | None,
    board6: xr.Dataset | None,
    folder: Path,
) -> list[str]:
    """Write the Ch. 5 and 6 figures whose sweeps are given; return their file names.

    Parameters
    ----------
    plate, board, plate4, board6 : xarray.Dataset or None
        As :func:`tables_markdown`.
    folder : Path
        Folder of the PNG files (created).

    Returns
    -------
    list of str
        The file names written, named after the thesis's figures.
    """
    folder.mkdir(parents=True, exist_ok=True)
    draw: dict[str, Callable[[Path], None]] = {}
    if plate is not None:
        draw |= {
            "fig5_3_lpa_rmse_map.png": lambda p: figure_5_3(plate, p),
            "fig5_4_lpa_by_pitch.png": lambda p: figure_5_4(plate, p),
            "fig5_5_methods_by_depth.png": lambda p: figure_5_5(plate, p),
            "fig5_6_rmse_per_migl.png": lambda p: figure_5_6(plate, p),
        }
    if board is not None:
        lpa = [f"lpa-{s}" for s in (1, 5, 10, 15, 20, 30, 45)]
        draw |= {
            "fig5_7a_checkerboard_rmse.png": lambda p: _per_pitch(
                board, p, "rmse_mm", lpa, "mean RMSE (mm)", "checkerboard, 4-step, LPA"
            ),
            "fig5_7b_checkerboard_std.png": lambda p: _per_pitch(
                board, p, "std_mm", lpa, "mean error std (mm)", "checkerboard, 4-step, LPA"
            ),
            "fig5_8_checkerboard_pitch8.png": lambda p: figure_5_8(board, p),
        }
    given = {"white plate, 600 lx": plate4, "checkerboard": board6}
    ch6 = {k: v for k, v in given.items() if v is not None and "dpa-10" in v["strategy"].values}
    if ch6:
        draw["fig6_3_cdf.png"] = lambda p: figure_6_3(ch6, p)
    for key, ds in (("a", plate4), ("b", board6)):
        if ds is None:
            continue
        methods = ["dpa-10", "dpa-20", "dpab-10", "dpab-20"] + (
            ["lpa-10", "lpa-15", "lpa-20"] if key == "a" else ["lpa-15", "lpa-20", "lpa-30"]
        )
        name = "white plate" if key == "a" else "checkerboard"
        for fig, var, ylabel in (
            ("6_4", "rmse_mm", "mean RMSE (mm)"),
            ("6_5", "std_mm", "mean error std (mm)"),
            ("6_6", "sets", "sets captured"),
        ):
            draw[f"fig{fig}{key}_{var}.png"] = partial(
                _per_pitch, ds, var=var, methods=methods, ylabel=ylabel, title=f"{name}, 4-step"
            )
    for name, f in draw.items():
        f(folder / name)
    return list(draw)
