"""``report.html`` and ``report.md``: a result folder a person can open and hand on (issue 27).

:func:`write_report` writes both into a result folder (the staging folder of ``measure`` or
``phase``, so the report is part of the same all-or-nothing output):

- the inputs and settings of the run;
- the metrics (``metrics.json`` or ``phase_summary.json``) with the predicted uncertainty;
- the saturation and strategy summary: the sets decoded, the sets and images a strategy
  captured, its MIGLs, and the MIGL maps and figures the run wrote;
- the key maps: the PNG previews and figures already in the folder, embedded in the HTML as
  base64 PNG (``report.md`` links the same files);
- in the HTML only, an interactive 3D view of the point cloud (rotate, zoom, colour by height,
  intensity or predicted std) drawn by plotly.js, which the file embeds: it opens from the file
  browser with no server and no network. The cloud is subsampled to at most
  :data:`MAX_POINTS` points (every k-th valid pixel), and the report says how many it shows.

The HTML is one self-contained file: plotly.js (4.8 MB for plotly 7.1; embedded
gzip-compressed, 2.0 MB, and inflated by the browser), the previews and the points (5.3 bytes
per coordinate and colouring); docs/report.md says why plotly, how to open the file and what
sets its size.
"""

from __future__ import annotations

import base64
import functools
import gzip
import html
import json
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "CLOUD_DIV_ID",
    "MAX_POINTS",
    "PLOTLY_SCRIPT_ID",
    "REPORT_FILES",
    "CloudView",
    "ReportContent",
    "cloud_figure",
    "subsample_cloud",
    "write_report",
]

#: Most points the 3D view shows: a larger cloud is subsampled (every k-th valid pixel); each
#: point adds 5.3 bytes per coordinate and colouring to the file (docs/report.md, "Size").
MAX_POINTS = 200_000

#: The files :func:`write_report` writes.
REPORT_FILES = ("report.html", "report.md")

#: The HTML id of the 3D view's element (the browser test finds the plot by it).
CLOUD_DIV_ID = "cloud"

#: Key maps, in the order the report shows them: file name patterns (glob) of the previews and
#: figures ``measure`` and ``phase`` write. Per-set previews (``__<set label>``) are not shown.
MAP_PATTERNS = (
    "height.png",
    "height_std.png",
    "absolute_phase_*.png",
    "unwrapped_phase_*.png",
    "phase_std*.png",
    "data_modulation.png",
    "mean_intensity.png",
    "regions_*.png",
)
#: The saturation and strategy figures, in order.
SATURATION_PATTERNS = (
    "saturation_count.png",
    "*_index.png",
    "*_pie.png",
    "projector_migl_map*.png",
    "camera_migl*.png",
    "dpa_cdf.png",
)
#: Metrics shown under "Saturation and strategy" rather than "Metrics".
SATURATION_KEYS = (
    "saturated_fraction",
    "saturated_fraction_measurement_pixels",
    "method",
    "sets_captured",
    "images_captured",
    "migls",
    "never_unsaturated_fraction",
    "dpa",
    "capture",
    "saturated",
)
#: Metrics blocks shown in their own section (or not as a table row).
_OWN_SECTION = ("uncertainty", "notes", "skipped", "sets", "families", "files")


@dataclass(frozen=True)
class CloudView:
    """A point cloud for the report's 3D view: maps on the camera's pixel grid.

    Parameters
    ----------
    x, y, z : array_like, shape (H, W)
        The points' coordinates; a point is shown where all three are finite. Pixel
        coordinates can be broadcast views (``np.broadcast_to``): only the points shown are
        copied.
    colours : mapping of str to array_like, shape (H, W)
        The colourings the view offers, by label (e.g. ``"height (mm)"``); the first is shown
        first (after the z shown, when ``z_plane`` is given or there are none). NaN values
        are drawn in gray.
    axis_titles : tuple of str
        Titles of the x, y and z axes.
    true_scale : bool
        The three coordinates share one unit (mm): the view keeps their proportions. False
        (pixels and mm, or pixels and radians): each axis spans the same length.
    what : str
        One line under the view saying what the points are.
    z_plane : tuple of float, optional
        ``(a, b, c)``: the view shows ``z - (a x + b y + c)``, e.g. a phase less its ramp
        across the projector, whose slope would hide the surface's shape; None: ``z``.

    Examples
    --------
    >>> z = np.array([[0.0, 1.0], [np.nan, 2.0]])
    >>> view = CloudView(*np.indices((2, 2)), z, {"height (mm)": z})
    >>> list(view.colours)
    ['height (mm)']
    """

    x: ArrayLike
    y: ArrayLike
    z: ArrayLike
    colours: Mapping[str, ArrayLike]
    axis_titles: tuple[str, str, str] = ("x (mm)", "y (mm)", "z (mm)")
    true_scale: bool = True
    what: str = ""
    z_plane: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class ReportContent:
    """What a report says: the run's settings, its metrics, its sets and its cloud.

    Parameters
    ----------
    title : str
        The page title, e.g. ``"hdrfringe measure: caps"``.
    settings : mapping
        The inputs and settings of the run, by name (values shown as text).
    metrics : mapping
        ``metrics.json`` (``measure``) or ``phase_summary.json`` (``phase``) as written.
    sets : sequence of mapping
        The fringe sets decoded (the ``sets`` entries of ``phase_summary.json``).
    cloud : CloudView or None
        The 3D view's points; None: the report says there is none.
    notes : sequence of str
        Lines added to the notes (besides the metrics' ``notes`` and ``skipped``).

    Examples
    --------
    >>> ReportContent("hdrfringe phase: caps", {"input": "caps"}, {}).cloud is None
    True
    """

    title: str
    settings: Mapping[str, Any]
    metrics: Mapping[str, Any]
    sets: Sequence[Mapping[str, Any]] = ()
    cloud: CloudView | None = None
    notes: Sequence[str] = field(default_factory=tuple)


def subsample_cloud(
    view: CloudView, max_points: int = MAX_POINTS
) -> tuple[NDArray[np.intp], int]:
    """The flat indices of the points the view shows, and the number of valid points.

    Every k-th valid pixel in row-major order, with the least k that leaves at most
    ``max_points``: the points stay spread over the whole surface. Found row by row from the
    valid pixels' count per row, so a 26 Mpx map needs no index of all its valid pixels
    (208 MB), only the selected ones.

    Parameters
    ----------
    view : CloudView
        The cloud.
    max_points : int
        Most points shown.

    Returns
    -------
    index : ndarray of intp
        Flat (row-major) indices into the maps.
    n_valid : int
        Points where x, y and z are all finite.

    Examples
    --------
    >>> z = np.arange(12.0).reshape(3, 4)
    >>> z[0, 0] = np.nan
    >>> index, n = subsample_cloud(CloudView(*np.indices((3, 4)), z, {}), max_points=4)
    >>> index.tolist(), n
    ([1, 4, 7, 10], 11)
    """
    valid = np.isfinite(view.x) & np.isfinite(view.y) & np.isfinite(view.z)
    valid = valid.reshape(-1, valid.shape[-1]) if valid.ndim else valid.reshape(1, 1)
    per_row = np.count_nonzero(valid, axis=1)
    ends = np.cumsum(per_row)
    n_valid = int(ends[-1]) if ends.size else 0
    step = max(1, -(-n_valid // max_points))
    ordinal = np.arange(0, n_valid, step)  # the selected valid pixels, counted in row order
    rows = np.searchsorted(ends, ordinal, side="right")
    index = np.empty(ordinal.size, dtype=np.intp)
    found, first = np.unique(rows, return_index=True)
    for r, a, b in zip(found, first, np.append(first[1:], ordinal.size), strict=False):
        cols = np.flatnonzero(valid[r])[ordinal[a:b] - (ends[r] - per_row[r])]
        index[a:b] = r * valid.shape[1] + cols
    return index, n_valid


def _at(values: ArrayLike, index: NDArray[np.intp]) -> NDArray[np.float32]:
    """A map's values at flat indices, as float32, without a copy of the whole map (a
    broadcast coordinate map stays a view)."""
    arr = np.asarray(values)
    return arr[np.unravel_index(index, arr.shape)].astype(np.float32)


def _typed(values: ArrayLike) -> dict[str, str]:
    """An array as plotly.js's typed-array form (float32, base64): about 5.3 bytes a value,
    against about 20 as JSON text, and decoded by the browser without parsing numbers."""
    data = np.ascontiguousarray(values, dtype="<f4")
    return {"dtype": "f4", "bdata": base64.b64encode(data.tobytes()).decode("ascii")}


def _colour_range(values: NDArray[np.float32]) -> tuple[float, float]:
    """The 0.5 and 99.5 percentiles of the finite values (as the PNG previews: a few outliers
    do not flatten the colours); (0, 1) without finite values."""
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return 0.0, 1.0
    lo, hi = (float(v) for v in np.percentile(finite, [0.5, 99.5]))
    return (lo, hi) if hi > lo else (lo - 0.5, lo + 0.5)


#: Viridis, the PNG previews' colour map (plotly.js knows it by name).
_VIRIDIS = "Viridis"
_GRAY = "rgb(128,128,128)"


def _colouring(label: str, values: NDArray[np.float32]) -> dict[str, Any]:
    """The marker properties of one colouring, as the arguments of a restyle (an array
    property wrapped in a list: one value per trace).

    Points without a value (NaN: e.g. no predicted std there) are drawn gray: they get a value
    below the range, and the colour scale a gray band there (the lower third of the bar)."""
    lo, hi = _colour_range(values)
    missing = ~np.isfinite(values)
    scale: Any = _VIRIDIS
    if missing.any():
        span = (hi - lo) / 2
        values = np.where(missing, np.float32(lo - span), values)
        scale = [[0.0, _GRAY], [0.333, _GRAY], [0.334, "#440154"], [0.5, "#3b528b"],
                 [0.667, "#21918c"], [0.833, "#5ec962"], [1.0, "#fde725"]]  # fmt: skip
        lo -= span
    return {
        "marker.color": [_typed(values)],
        "marker.colorscale": [scale],
        "marker.cmin": lo,
        "marker.cmax": hi,
        "marker.colorbar.title.text": label,
    }


def cloud_figure(view: CloudView, max_points: int = MAX_POINTS) -> tuple[dict[str, Any], str]:
    """The plotly figure (as a dict) of the 3D view and the line that says what it shows.

    Parameters
    ----------
    view : CloudView
        The cloud.
    max_points : int
        Most points shown.

    Returns
    -------
    figure : dict
        ``{"data": [...], "layout": {...}}``: one ``scatter3d`` trace; a menu switches the
        colouring.
    line : str
        ``"N of M valid points shown ..."``.

    Examples
    --------
    >>> z = np.arange(6.0).reshape(2, 3)
    >>> fig, line = cloud_figure(CloudView(*np.indices((2, 3)), z, {"height (mm)": z}))
    >>> fig["data"][0]["type"], line
    ('scatter3d', '6 of 6 valid points shown (all of them).')
    """
    index, n_valid = subsample_cloud(view, max_points)
    coords = [_at(a, index) for a in (view.x, view.y, view.z)]
    if view.z_plane is not None:
        a, b, c = view.z_plane
        ramp = a * coords[0].astype(np.float64) + b * coords[1].astype(np.float64) + c
        coords[2] = (coords[2] - ramp).astype(np.float32)
    colours = {label: _at(values, index) for label, values in view.colours.items()}
    if view.z_plane is not None or not colours:  # the z shown first: it is not among them
        colours = {view.axis_titles[2]: coords[2], **colours}
    options = [(label, _colouring(label, values)) for label, values in colours.items()]
    first = options[0][1]
    marker = {
        "size": 2 if index.size > 50_000 else 3,
        "color": first["marker.color"][0],
        "colorscale": first["marker.colorscale"][0],
        "cmin": first["marker.cmin"],
        "cmax": first["marker.cmax"],
        "showscale": True,
        "colorbar": {"title": {"text": first["marker.colorbar.title.text"], "side": "right"}},
    }
    trace = {
        "type": "scatter3d",
        "mode": "markers",
        "x": _typed(coords[0]),
        "y": _typed(coords[1]),
        "z": _typed(coords[2]),
        "marker": marker,
        "hoverinfo": "x+y+z",
    }
    buttons = [{"label": label, "method": "restyle", "args": [args]} for label, args in options]
    xt, yt, zt = view.axis_titles
    layout = {
        "height": 640,
        "margin": {"l": 0, "r": 0, "t": 30, "b": 0},
        "scene": {
            "aspectmode": "data" if view.true_scale else "cube",
            "xaxis": {"title": {"text": xt}},
            "yaxis": {"title": {"text": yt}},
            "zaxis": {"title": {"text": zt}},
        },
        "updatemenus": [
            {"buttons": buttons, "x": 0.0, "y": 1.0, "xanchor": "left", "yanchor": "top"}
        ],
    }
    if n_valid == 0:
        line = "No valid point to show: the view is empty."
    elif index.size == n_valid:
        line = f"{index.size} of {n_valid} valid points shown (all of them)."
    else:
        step = -(-n_valid // max_points)
        line = (
            f"{index.size} of {n_valid} valid points shown (one valid pixel in {step}, in row "
            f"order: at most {max_points} points in the view)."
        )
    return {"data": [trace], "layout": layout}, line


# --- text ----------------------------------------------------------------------------------


def _value(value: Any, key: str = "") -> str:
    """A metric or setting as text: floats to 4 significant digits, fractions with their
    percentage, lists and mappings as compact JSON."""
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if not math.isfinite(value):
            return str(value)
        text = f"{value:.4g}"
        if "fraction" in key and 0.0 <= value <= 1.0:
            text += f" ({100 * value:.1f} %)"
        return text
    if isinstance(value, int | str):
        return str(value)
    if isinstance(value, np.generic):
        return _value(value.item(), key)
    try:
        return json.dumps(value, default=str, separators=(", ", ": "))
    except (TypeError, ValueError):
        return str(value)


def _rows(block: Mapping[str, Any], prefix: str = "") -> list[tuple[str, str]]:
    """Key/value rows of a mapping, nested mappings flattened to dotted keys."""
    rows: list[tuple[str, str]] = []
    for key, value in block.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping) and value:
            rows += _rows(value, f"{name}.")
        else:
            rows.append((name, _value(value, str(key))))
    return rows


def _uncertainty_rows(block: Mapping[str, Any] | None) -> tuple[list[tuple[str, str]], str]:
    """The predicted-uncertainty rows and a sentence for the section."""
    if not block:
        return [], "The run did not predict the uncertainty (--no-uncertainty)."
    if not block.get("predicted", False):
        return [], f"Not predicted: {block.get('reason', 'no reason given')}"
    rows = _rows({k: v for k, v in block.items() if k not in ("predicted", "notes")})
    text = (
        "The predicted per-pixel std from the camera noise (docs/uncertainty.md): the maps "
        "phase_std.tiff and, with a calibration, height_std.tiff; the medians below."
    )
    return rows, text


def _set_rows(sets: Sequence[Mapping[str, Any]]) -> tuple[list[str], list[list[str]]]:
    """The sets table: one row per set."""
    columns = ["set", "pitch px", "orientation", "MIGL", "valid", "saturated"]
    rows = [
        [
            str(s.get("label", "")),
            _value(s.get("pitch_px")),
            str(s.get("orientation", "")),
            _value(s.get("migl")),
            _value(s.get("valid_fraction"), "fraction"),
            _value(s.get("saturated_fraction"), "fraction"),
        ]
        for s in sets
    ]
    return columns, rows


def _images(folder: Path, patterns: Iterable[str]) -> list[Path]:
    """The folder's files matching the patterns, in pattern order, without per-set files."""
    found: list[Path] = []
    for pattern in patterns:
        for path in sorted(folder.glob(pattern)):
            if "__" not in path.name and path not in found:
                found.append(path)
    return found


@dataclass
class _Sections:
    """The report as sections of (heading, blocks); a block is ("p", text), ("table",
    (columns, rows)) or ("images", [paths]). Rendered to HTML and Markdown alike."""

    items: list[tuple[str, list[tuple[str, Any]]]] = field(default_factory=list)

    def add(self, heading: str, *blocks: tuple[str, Any]) -> None:
        kept = [b for b in blocks if b[1]]
        if kept:
            self.items.append((heading, kept))


def _sections(folder: Path, content: ReportContent, view_line: str) -> _Sections:
    """The report's sections, in order (the 3D view's as a "view" block)."""
    from hdrfringe import __version__

    m = content.metrics
    out = _Sections()
    # no date: the same run writes the same bytes (`hdrfringe run` compares outputs by hash)
    out.add("", ("p", f"Written by hdrfringe {__version__}."))
    out.add(
        "Inputs and settings",
        ("table", (["setting", "value"], [[k, _value(v, k)] for k, v in content.settings.items()])),
    )
    rows = _rows({k: v for k, v in m.items() if k not in (*_OWN_SECTION, *SATURATION_KEYS)})
    out.add("Metrics", ("table", (["metric", "value"], [list(r) for r in rows])))
    unc_rows, unc_text = _uncertainty_rows(m.get("uncertainty"))
    out.add(
        "Predicted uncertainty",
        ("p", unc_text),
        ("table", (["quantity", "value"], [list(r) for r in unc_rows])),
    )
    out.add("3D view", ("p", view_line), ("view", content.cloud is not None))
    sat = _rows({k: m[k] for k in SATURATION_KEYS if k in m})
    out.add(
        "Saturation and strategy",
        ("table", (["quantity", "value"], [list(r) for r in sat])),
        ("table", _set_rows(content.sets) if content.sets else None),
        ("images", _images(folder, SATURATION_PATTERNS)),
    )
    maps = _images(folder, MAP_PATTERNS)
    out.add(
        "Maps",
        ("p", "The PNG previews of the maps (the data: the TIFF files of the same name)."),
        ("images", maps),
    )
    if not maps:
        out.add("Maps", ("p", "No previews were written (--no-previews): see the TIFF maps."))
    notes = [*content.notes, *m.get("notes", ()), *(f"skipped: {s}" for s in m.get("skipped", ()))]
    out.add("Notes", ("list", [str(n) for n in notes]))
    out.add("Files", ("list", sorted({p.name for p in folder.iterdir()} | set(REPORT_FILES))))
    return out


# --- rendering -----------------------------------------------------------------------------

_STYLE = """
body { font-family: sans-serif; margin: 1.5em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0 1em; }
td, th { border: 1px solid #ddd; padding: 2px 8px; text-align: left; vertical-align: top; }
th { background: #f3f3f3; }
figure { display: inline-block; margin: 0 1em 1em 0; vertical-align: top; }
figure img { max-width: 520px; border: 1px solid #eee; }
figcaption { font-size: 0.85em; color: #555; }
"""


def _html_block(kind: str, data: Any, view: str) -> str:
    esc = html.escape
    if kind == "view":
        return view
    if kind == "p":
        return f"<p>{esc(data)}</p>"
    if kind == "list":
        return "<ul>" + "".join(f"<li>{esc(item)}</li>" for item in data) + "</ul>"
    if kind == "table":
        columns, rows = data
        head = "".join(f"<th>{esc(c)}</th>" for c in columns)
        body = "".join(
            "<tr>" + "".join(f"<td>{esc(str(v))}</td>" for v in row) + "</tr>" for row in rows
        )
        return f"<table><tr>{head}</tr>{body}</table>"
    figures = []
    for path in data:
        png = base64.b64encode(path.read_bytes()).decode("ascii")
        figures.append(
            f'<figure><img alt="{esc(path.stem)}" src="data:image/png;base64,{png}">'
            f"<figcaption>{esc(path.name)}</figcaption></figure>"
        )
    return "<div>" + "".join(figures) + "</div>"


def _md_block(kind: str, data: Any) -> str:
    if kind == "view":
        return "The interactive 3D view is in report.html."
    if kind == "p":
        return str(data)
    if kind == "list":
        return "\n".join(f"- {item}" for item in data)
    if kind == "table":
        columns, rows = data

        def cells(values: Sequence[Any]) -> str:
            return "| " + " | ".join(str(v).replace("|", "\\|") for v in values) + " |"

        return "\n".join([cells(columns), cells(["---"] * len(columns)), *map(cells, rows)])
    return "\n".join(f"![{p.stem}]({p.name})" for p in data)


#: Where plotly.js goes in the page (before the view's element): marked while the page is
#: assembled as text, replaced by the script's bytes when the file is written.
_SCRIPT_MARK = "<!-- plotly.js -->"


#: The ``id`` of the ``<script>`` element that holds plotly.js (gzip-compressed, base64).
PLOTLY_SCRIPT_ID = "plotly-js"

#: The loader: plotly.js inflated by the browser's own gzip decoder (``DecompressionStream``:
#: Chromium 80, Firefox 113, Safari 16.4) and run as an inline script; ``window.plotlyLoaded``
#: settles when it has run. The view's script waits for it (:func:`_cloud_html`).
_LOADER = (
    "window.plotlyLoaded = new Response(new Blob([Uint8Array.from(atob(\"{packed}\"), "
    "c => c.charCodeAt(0))]).stream().pipeThrough(new DecompressionStream(\"gzip\"))).text()"
    ".then(js => {{ const s = document.createElement(\"script\"); s.text = js; "
    "document.head.appendChild(s); }});"
)


@functools.cache
def _plotly_js() -> bytes:
    """The ``<script>`` elements that put plotly.js in the page: the ``PlotlyConfig`` that
    ``plotly.io.to_html(include_plotlyjs=True)`` writes, and plotly.js as the plotly package
    bundles it (:func:`plotly.offline.get_plotlyjs`, 4.8 MB for plotly 7.1) gzip-compressed
    and base64-encoded (2.0 MB), inflated by the browser (:data:`_LOADER`). Made once per
    process (compressing takes about 0.1 s), not once per report."""
    from plotly.offline import get_plotlyjs

    packed = gzip.compress(get_plotlyjs().encode("utf-8"), compresslevel=6, mtime=0)
    loader = _LOADER.format(packed=base64.b64encode(packed).decode("ascii"))
    return (
        "<script type=\"text/javascript\">window.PlotlyConfig = {MathJaxConfig: 'local'};"
        f'</script>\n<script id="{PLOTLY_SCRIPT_ID}" type="text/javascript">{loader}</script>'
    ).encode("ascii")


#: A typed array's base64 data in the figure given to plotly.io.to_html: the index of the string
#: it stands for (:func:`_cloud_html` puts the strings back).
_BDATA_STUB = "hdrfringe-bdata-{}"
_BDATA_STUB_RE = re.compile(r'"hdrfringe-bdata-(\d+)"')


def _stub_bdata(obj: Any, arrays: list[str]) -> Any:
    """``obj`` (a figure of dicts and lists) with every typed array's ``bdata`` replaced by a
    :data:`_BDATA_STUB`, the strings appended to ``arrays``."""
    if isinstance(obj, dict):
        if isinstance(obj.get("bdata"), str):
            arrays.append(obj["bdata"])
            return {**obj, "bdata": _BDATA_STUB.format(len(arrays) - 1)}
        return {k: _stub_bdata(v, arrays) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_stub_bdata(v, arrays) for v in obj]
    return obj


def _cloud_html(view: CloudView | None, max_points: int) -> tuple[str, str]:
    """The 3D view's element and the script drawing it (after :data:`_SCRIPT_MARK`, where
    plotly.js goes), and its line for both reports.

    The figure goes through ``plotly.io.to_html`` with its typed arrays' base64 strings stubbed
    out, and the strings are put back into its JSON after: plotly's JSON writer encodes, parses
    and encodes the figure again and escapes it, which for the megabytes of base64 of a
    200 000-point view was most of a report's time (benchmarks/bench_report.py); base64 needs no
    escaping in JSON or in a script element. The script waits for plotly.js to be inflated
    (``window.plotlyLoaded``; run at once where a page loads plotly.js as a plain script)."""
    if view is None:
        return "", "The run has no point cloud to show."
    import plotly.io

    figure, line = cloud_figure(view, max_points)
    if view.what:
        line = f"The points: {view.what}. {line}"
    arrays: list[str] = []
    div = plotly.io.to_html(
        _stub_bdata(figure, arrays),
        include_plotlyjs=False,  # embedded by write_report (_plotly_js): opens offline
        full_html=False,
        validate=False,  # the figure is built here from plain types; no graph_objects needed
        div_id=CLOUD_DIV_ID,
        config={"displaylogo": False, "responsive": True},
    )
    head, body = div.split("<script>", 1)
    body, tail = body.rsplit("</script>", 1)
    body = _BDATA_STUB_RE.sub(lambda m: f'"{arrays[int(m[1])]}"', body)
    script = f"<script>Promise.resolve(window.plotlyLoaded).then(() => {{{body}}});</script>"
    return _SCRIPT_MARK + head + script + tail, line


def write_report(
    folder: str | Path, content: ReportContent, *, max_points: int = MAX_POINTS
) -> list[str]:
    """Write ``report.html`` and ``report.md`` into a result folder, after its other files.

    Parameters
    ----------
    folder : str or Path
        The result folder (the staging folder of the command), holding the maps, previews and
        figures the report shows.
    content : ReportContent
        The settings, metrics, sets and point cloud.
    max_points : int
        Most points in the 3D view (:data:`MAX_POINTS`).

    Returns
    -------
    list of str
        The files written (:data:`REPORT_FILES`).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> z = np.arange(6.0).reshape(2, 3)
    >>> content = ReportContent("hdrfringe measure: demo", {"input": "caps"},
    ...                         {"rmse_mm": 0.05}, cloud=CloudView(*np.indices((2, 3)), z, {}))
    >>> write_report(folder, content)
    ['report.html', 'report.md']
    >>> "| rmse_mm | 0.05 |" in (folder / "report.md").read_text()
    True
    """
    folder = Path(folder)
    view, view_line = _cloud_html(content.cloud, max_points)
    esc = html.escape
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{esc(content.title)}</title><style>{_STYLE}</style></head><body>",
        f"<h1>{esc(content.title)}</h1>",
    ]
    md = [f"# {content.title}"]
    for heading, blocks in _sections(folder, content, view_line).items:
        if heading:
            parts.append(f"<h2>{esc(heading)}</h2>")
            md.append(f"## {heading}")
        parts += [_html_block(kind, data, view) for kind, data in blocks]
        md += [_md_block(kind, data) for kind, data in blocks]
    parts.append("</body></html>\n")
    page = "\n".join(parts).encode("utf-8").split(_SCRIPT_MARK.encode("ascii"), 1)
    if len(page) == 2:  # plotly.js in the page, as include_plotlyjs=True would put it
        page.insert(1, _plotly_js())
    (folder / REPORT_FILES[0]).write_bytes(b"".join(page))
    (folder / REPORT_FILES[1]).write_text("\n\n".join(md) + "\n", encoding="utf-8")
    return list(REPORT_FILES)
