"""Benchmark: writing report.html with plotly.js embedded gzip-compressed and the figure's typed
arrays stubbed through ``plotly.io.to_html`` (``hdrfringe.io.report``), against the way before
(plotly.js as text, the whole figure through ``to_html``).

Run ``.venv/bin/python benchmarks/bench_report.py`` (``--repeats N``, default 15; ``--size WxH``,
default the virtual rig's 648x494: at most 200 000 points shown). A few seconds. See
benchmarks/README.md.

The content: a smooth surface over the grid with three colourings (as ``measure`` with a
calibration shows), no previews. Each round writes one report per case, the cases in a seeded
random order; printed: the median time of :func:`hdrfringe.io.report.write_report` per case
(once the per-process plotly.js script is made: its time is printed apart), their ratio (before /
now), and report.html's size per case. Both pages carry the same figure (checked every round:
the JSON read back from the page, and plotly.js once inflated).
"""

from __future__ import annotations

import argparse
import base64
import gzip
import json
import random
import re
import statistics
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import plotly.io
from plotly.offline import get_plotlyjs

from hdrfringe.io import report
from hdrfringe.io.report import CLOUD_DIV_ID, CloudView, ReportContent, write_report


def _old_plotly_js() -> bytes:
    """plotly.js as text, as ``to_html(include_plotlyjs=True)`` puts it (the way before)."""
    return (
        "<script type=\"text/javascript\">window.PlotlyConfig = {MathJaxConfig: 'local'};"
        f'</script>\n<script charset="utf-8" type="text/javascript">{get_plotlyjs()}</script>'
    ).encode()


def _old_cloud_html(view: CloudView | None, max_points: int) -> tuple[str, str]:
    """The whole figure through ``plotly.io.to_html`` (the way before)."""
    assert view is not None
    figure, line = report.cloud_figure(view, max_points)
    div = plotly.io.to_html(figure, include_plotlyjs=False, full_html=False, validate=False,
                            div_id=CLOUD_DIV_ID,
                            config={"displaylogo": False, "responsive": True})  # fmt: skip
    return report._SCRIPT_MARK + div, line


@contextmanager
def _before() -> Iterator[None]:
    old_js = _old_plotly_js()
    with (
        mock.patch.object(report, "_plotly_js", lambda: old_js),
        mock.patch.object(report, "_cloud_html", _old_cloud_html),
    ):
        yield


def _figure_data(page: str) -> Any:
    """The figure's traces as the page gives them to ``Plotly.newPlot``."""
    call = re.search(rf'Plotly\.newPlot\(\s*"{CLOUD_DIV_ID}",\s*', page)
    assert call is not None
    return json.JSONDecoder().raw_decode(page[call.end() :])[0]


def main() -> None:
    """Time both ways interleaved and print the ratio."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--size", default="648x494")
    args = parser.parse_args()
    width, height = (int(v) for v in args.size.split("x"))
    rows, cols = np.indices((height, width), dtype=np.float64)
    z = np.sin(cols / 20.0) * np.cos(rows / 30.0)
    view = CloudView(cols, -rows, z, {"height (mm)": z, "intensity (DN)": 100 + 50 * z,
                                      "std (mm)": 0.01 + 0.001 * rows})  # fmt: skip
    content = ReportContent("bench", {"input": "none"}, {"rmse_mm": 0.05}, cloud=view)
    start = time.perf_counter()
    report._plotly_js()
    made = time.perf_counter() - start
    cases = {"before": _before, "now": contextmanager(lambda: iter([None]))}
    times: dict[str, list[float]] = {name: [] for name in cases}
    sizes: dict[str, int] = {}
    order = random.Random(0)
    with tempfile.TemporaryDirectory() as tmp:
        folders = {name: Path(tmp) / name for name in cases}
        for folder in folders.values():
            folder.mkdir()
        for _ in range(args.repeats):
            names = list(cases)
            order.shuffle(names)
            for name in names:
                with cases[name]():
                    start = time.perf_counter()
                    write_report(folders[name], content)
                    times[name].append(time.perf_counter() - start)
                sizes[name] = (folders[name] / "report.html").stat().st_size
            pages = {n: (folders[n] / "report.html").read_text() for n in cases}
            assert _figure_data(pages["now"]) == _figure_data(pages["before"])
        packed = re.search(r'atob\("([A-Za-z0-9+/=]+)"\)', pages["now"])
        assert packed is not None
        assert gzip.decompress(base64.b64decode(packed[1])) == get_plotlyjs().encode()
    med = {name: statistics.median(t) for name, t in times.items()}
    print(f"{width}x{height}, {args.repeats} rounds; plotly.js compressed once per process: "
          f"{1000 * made:.1f} ms")  # fmt: skip
    for name in cases:
        print(f"{name:>7}: write_report {1000 * med[name]:7.1f} ms, report.html "
              f"{sizes[name]:,} bytes")  # fmt: skip
    print(f"before / now: {med['before'] / med['now']:.2f}x faster, "
          f"{sizes['before'] / sizes['now']:.2f}x smaller")  # fmt: skip


if __name__ == "__main__":
    main()
