"""report.html and report.md (issue 27 item 1), and report.html's 3D view in a real browser.

One small measurement (a 64x48 mask under 600 lx, LPA on a MIGL sweep, a calibration from three
plate positions) is made once for the module; its report is opened from the file (``file://``)
in headless Chromium, Debian's package, driven over the DevTools protocol on a pipe
(``--remote-debugging-pipe``: no port, no extra package). The view must have drawn the points:
pixels in the colour map's colours (high chroma; the axes, grid and page are gray or white)
inside the 3D scene's area of a screenshot; and the page must log no error (console errors,
uncaught exceptions, failed loads). The network is closed here, so a report that loaded plotly.js
from a CDN instead of embedding it fails (``test_a_report_without_its_plotly_js_fails``), and a
figure with no points fails the pixel check (``test_the_view_with_its_points``, its last step).

Chromium is not optional: without it the tests fail and say how to install it (``make
install`` installs it where missing, as it installs Xvfb for the projector window tests).
"""

from __future__ import annotations

import base64
import gzip
import io
import json
import os
import re
import select
import shutil
import subprocess
import time
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path
from typing import Any
from unittest import mock

import numpy as np
import pytest
from PIL import Image

from hdrfringe.io.report import CLOUD_DIV_ID, PLOTLY_SCRIPT_ID, CloudView, cloud_figure
from hdrfringe.io.results import read_map_tiff
from tests.conftest import run_cli

#: The DevTools protocol's page and session waits (s): generous for a loaded 2-core machine.
TIMEOUT = 60.0


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """``measure --strategy lpa --remove-outliers`` of a 64x48 mask and ``phase`` of a plate,
    with reports."""
    root = tmp_path_factory.mktemp("report")
    steps = [
        ("simulate", "white_plate", "--series", "0:20:10", "--pitch", "1024,64,8",
         "--resolution", "64x48", "-o", str(root / "series")),
        ("calibrate", str(root / "series"), "-o", str(root / "cal.h5")),
        ("simulate", "mask", "--pitch", "1024,64,8", "--resolution", "64x48", "--ambient-lux",
         "600", "--migl-sweep", "255:175:40", "-o", str(root / "sweep")),
        ("measure", str(root / "sweep"), "-c", str(root / "cal.h5"), "--strategy", "lpa", "-o",
         str(root / "measured"), "--remove-outliers"),
        ("phase", str(root / "series" / "white_plate_010.00mm"), "-o", str(root / "phase")),
    ]  # fmt: skip
    for args in steps:
        res = run_cli(*args)
        assert res.returncode == 0, (args, res.stderr)
    return {"measure": root / "measured", "phase": root / "phase", "root": root}


# --- the report's content ----------------------------------------------------------------------


class _Page(HTMLParser):
    """What the tests read from report.html: the scripts' text, the images' sources, the ids."""

    def __init__(self) -> None:
        super().__init__()
        self.scripts: list[str] = []
        self.script_ids: list[str | None] = []  # each script's id attribute
        self.images: list[str] = []
        self.ids: list[str] = []
        self.open: list[str] = []
        self._in_script = False

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if a.get("id"):
            self.ids.append(str(a["id"]))
        if tag == "img":
            self.images.append(str(a.get("src")))
        elif tag == "script":
            self._in_script = True
            self.scripts.append("")
            self.script_ids.append(a.get("id"))
        if tag not in ("img", "meta", "br"):
            self.open.append(tag)

    def handle_endtag(self, tag: str) -> None:
        assert self.open and self.open[-1] == tag, (self.open[-3:], tag)  # well nested
        self.open.pop()
        self._in_script = False

    def handle_data(self, data: str) -> None:
        if self._in_script:
            self.scripts[-1] += data


def _typed(spec: dict[str, str]) -> np.ndarray:
    assert spec["dtype"] == "f4"
    return np.frombuffer(base64.b64decode(spec["bdata"]), dtype="<f4")


def _figure(text: str) -> dict[str, Any]:
    """The figure plotly.newPlot draws, read back from the page's script."""
    call = re.search(rf'Plotly\.newPlot\(\s*"{CLOUD_DIV_ID}",\s*', text)
    assert call is not None
    decoder = json.JSONDecoder()
    rest = text[call.end() :]
    data, end = decoder.raw_decode(rest)
    layout, _ = decoder.raw_decode(rest[end:].lstrip(", \n"))
    return {"data": data, "layout": layout}


def test_the_measure_report_holds_the_run(runs: dict[str, Path]) -> None:
    out = runs["measure"]
    metrics = json.loads((out / "metrics.json").read_text())
    md = (out / "report.md").read_text()
    # the metrics and their predicted uncertainty, as metrics.json has them
    assert f"| rmse_mm | {metrics['rmse_mm']:.4g} |" in md
    unc = metrics["uncertainty"]
    assert f"| height_std_median_mm | {unc['height_std_median_mm']:.4g} |" in md
    # the strategy: sets and images captured, the MIGLs per pitch, its figures
    assert f"| sets_captured | {metrics['sets_captured']} |" in md
    assert f"| images_captured | {metrics['images_captured']} |" in md
    assert "![migl_index](migl_index.png)" in md and "![migl_pie](migl_pie.png)" in md
    assert "| strategy | lpa |" in md and f"| calibration | {runs['root'] / 'cal.h5'} |" in md
    assert "<script" not in md and "interactive 3D view is in report.html" in md

    page = _Page()
    page.feed((out / "report.html").read_text(encoding="utf-8"))
    page.close()
    assert not page.open  # every element closed
    # plotly.js itself is in the file (no src= to load): gzip, base64, the plotly package's
    # plotly.js byte for byte once inflated; and the figure is drawn into the div
    assert CLOUD_DIV_ID in page.ids
    (loader,) = [s for s, i in zip(page.scripts, page.script_ids, strict=True)
                 if i == PLOTLY_SCRIPT_ID]  # fmt: skip
    packed = re.fullmatch(r'.*atob\("([A-Za-z0-9+/=]+)"\).*', loader, flags=re.DOTALL)
    assert packed is not None and 'DecompressionStream("gzip")' in loader
    from plotly.offline import get_plotlyjs

    assert gzip.decompress(base64.b64decode(packed[1])) == get_plotlyjs().encode("utf-8")
    # every image is embedded, and is the folder's PNG byte for byte
    for src in page.images:
        assert src.startswith("data:image/png;base64,")
    embedded = {base64.b64decode(src.split(",", 1)[1]) for src in page.images}
    assert (out / "height.png").read_bytes() in embedded
    assert (out / "migl_pie.png").read_bytes() in embedded
    # the view's points are points.ply's: height.tiff's valid pixels but the outliers
    # --remove-outliers left out (outliers.tiff), all of them (a 64x48 cloud), in row order
    view = [s for s in page.scripts if f'getElementById("{CLOUD_DIV_ID}")' in s]
    assert len(view) == 1  # the script drawing the view (plotly.js has a newPlot of its own)
    figure = _figure(view[0])
    trace = figure["data"][0]
    height = read_map_tiff(out / "height.tiff")
    shown = np.isfinite(height) & (read_map_tiff(out / "outliers.tiff") == 0)
    np.testing.assert_array_equal(_typed(trace["z"]), height[shown])
    # the file: plotly.js, the previews and the points: within 0.5 MB of plotly.js alone
    from hdrfringe.io.report import _plotly_js

    assert (out / "report.html").stat().st_size - len(_plotly_js()) < 500_000
    assert len(page.images) == 10  # 3 saturation and strategy figures, 7 maps
    labels = [b["label"] for b in figure["layout"]["updatemenus"][0]["buttons"]]
    assert labels == ["height (mm)", "mean intensity (DN)", "predicted height std (mm)"]
    assert f"{np.count_nonzero(shown)} of {np.count_nonzero(shown)} valid" in md


def test_a_large_cloud_is_subsampled_and_says_so() -> None:
    """At most ``max_points`` points, every k-th valid pixel, the count in the report's line;
    a colouring's missing values (NaN) are drawn gray, below its colour range."""
    rows, cols = np.indices((200, 300), dtype=np.float64)
    z = np.sin(cols / 20.0)
    z[:, :10] = np.nan  # 2000 invalid pixels: 58000 valid
    std = np.where(cols < 150, 0.01, np.nan)
    view = CloudView(cols, -rows, z, {"z (mm)": z, "std (mm)": std})
    figure, line = cloud_figure(view, max_points=999)
    trace = figure["data"][0]
    x, zz = _typed(trace["x"]), _typed(trace["z"])
    # 58000 valid points; every 59th (58 would leave 1000): 984 points, the last the 57977th
    assert x.size == zz.size == 984
    assert line.startswith("984 of 58000 valid points shown (one valid pixel in 59,")
    np.testing.assert_array_equal(zz, z[np.isfinite(z)][::59].astype(np.float32))
    args = figure["layout"]["updatemenus"][0]["buttons"][1]["args"][0]
    colour = _typed(args["marker.color"][0])
    gray = cols[np.isfinite(z)][::59] >= 150
    assert np.all(colour[gray] < args["marker.cmin"] + 0.34 * (args["marker.cmax"] - args[
        "marker.cmin"]))
    assert args["marker.colorscale"][0][0] == [0.0, "rgb(128,128,128)"]
    # 5.33 bytes per float32 value as base64: x, y, z and the colourings, the first twice
    values = 984 * (3 + 2 + 1)
    assert 5.3 * values < len(json.dumps(figure)) < 5.34 * values + 2000


def test_a_cloud_without_a_valid_point_says_so() -> None:
    """(``measure --rig hardware`` on the pylon emulation decodes no valid pixel.)"""
    z = np.full((4, 5), np.nan)
    figure, line = cloud_figure(CloudView(*np.indices((4, 5)), z, {"z (mm)": z}))
    assert _typed(figure["data"][0]["x"]).size == 0
    assert line == "No valid point to show: the view is empty."


def test_phase_writes_its_report_unless_told_not_to(runs: dict[str, Path]) -> None:
    out = runs["phase"]
    summary = json.loads((out / "phase_summary.json").read_text())
    md = (out / "report.md").read_text()
    for s in summary["sets"]:
        assert f"| {s['label']} | {s['pitch_px']:.4g} | vertical |" in md
    assert "absolute phase over the pixel grid, less its best-fit plane" in md
    text = (out / "report.html").read_text()
    assert '"label":"predicted phase std (rad)"' in text
    # the view's z is the absolute phase less a plane in column and row: the difference is
    # planar, and what is left has no plane of its own (a plate: nearly flat)
    phase = read_map_tiff(out / "absolute_phase_vertical.tiff").astype(np.float64)
    rows, cols = np.nonzero(np.isfinite(phase))
    z = _typed(_figure(text)["data"][0]["z"]).astype(np.float64)
    design = np.column_stack([cols, -rows, np.ones(cols.size)])
    diff = phase[rows, cols] - z
    coef, *_ = np.linalg.lstsq(design, diff, rcond=None)
    assert np.max(np.abs(diff - design @ coef)) < 1e-4  # z is stored in float32
    assert np.max(np.abs(np.linalg.lstsq(design, z, rcond=None)[0])) < 1e-4
    plain = runs["root"] / "phase_no_report"
    res = run_cli("phase", str(runs["root"] / "series" / "white_plate_010.00mm"), "-o", str(plain),
                  "--no-report", "--no-previews")  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert not list(plain.glob("report.*")) and (plain / "phase_summary.json").is_file()


def test_the_report_is_part_of_the_staged_output(runs: dict[str, Path]) -> None:
    """A report that fails leaves no result folder: it is written in the staging folder, before
    the move (a report written after the move would leave the maps without it)."""
    from hdrfringe.tasks.phase import PhaseOptions, phase

    target = runs["root"] / "failed"
    with (
        mock.patch("hdrfringe.io.report.write_report", side_effect=OSError(28, "No space")),
        pytest.raises(Exception, match="No space"),
    ):
        phase(runs["root"] / "series" / "white_plate_010.00mm", target, PhaseOptions())
    assert not target.exists()
    assert not [p for p in target.parent.iterdir() if p.name.startswith(".failed")]


# --- in a real browser -------------------------------------------------------------------------


def _above_4(fd: int) -> int:
    """``fd`` moved to a number of at least 10 (the old number closed)."""
    import fcntl

    moved = fcntl.fcntl(fd, fcntl.F_DUPFD_CLOEXEC, 10)
    os.close(fd)
    return moved


class Chromium:
    """Headless Chromium driven over the DevTools protocol on a pipe (fd 3 in, fd 4 out:
    ``--remote-debugging-pipe``, JSON messages ended by NUL)."""

    FLAGS = (
        "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        # WebGL on the CPU (SwiftShader) without the deprecation message of the implicit fallback
        "--enable-unsafe-swiftshader", "--window-size=800,600", "--remote-debugging-pipe",
    )  # fmt: skip

    def __init__(self, executable: str, profile: Path) -> None:
        # the browser's ends numbered from 10 up, so that bash's redirections to 3 and 4
        # cannot overwrite one before it is read (dash, Debian's sh, reads one digit only)
        to_browser, self._send_fd = os.pipe()
        self._recv_fd, from_browser = os.pipe()
        to_browser, from_browser = (_above_4(fd) for fd in (to_browser, from_browser))
        self.proc = subprocess.Popen(
            ["bash", "-c", f'exec "$0" "$@" 3<&{to_browser} 4>&{from_browser}', executable,
             *self.FLAGS, f"--user-data-dir={profile}", "about:blank"],
            pass_fds=(to_browser, from_browser), stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )  # fmt: skip
        os.close(to_browser)
        os.close(from_browser)
        self._buffer = b""
        self._id = 0
        self.events: list[dict[str, Any]] = []
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        attached = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})
        self.session = attached["sessionId"]
        for domain in ("Runtime", "Log", "Page"):
            self.call(f"{domain}.enable", session=True)

    def _message(self, deadline: float) -> dict[str, Any]:
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            ready, _, _ = select.select([self._recv_fd], [], [], max(left, 0.0))
            if not ready:
                raise TimeoutError("Chromium did not answer in time")
            chunk = os.read(self._recv_fd, 1 << 20)
            if not chunk:
                raise EOFError(f"Chromium closed its pipe (exit code {self.proc.poll()})")
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method: str, params: dict[str, Any] | None = None, *, session: bool = False
             ) -> dict[str, Any]:  # fmt: skip
        self._id += 1
        message: dict[str, Any] = {"id": self._id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = self.session
        os.write(self._send_fd, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + TIMEOUT
        while True:
            reply = self._message(deadline)
            if reply.get("id") == self._id:
                assert "error" not in reply, (method, reply["error"])
                return reply["result"]
            self.events.append(reply)

    def evaluate(self, expression: str) -> Any:
        """A JavaScript expression's value (a promise awaited)."""
        result = self.call(
            "Runtime.evaluate",
            {"expression": expression, "awaitPromise": True, "returnByValue": True},
            session=True,
        )
        assert "exceptionDetails" not in result, result["exceptionDetails"]
        return result["result"].get("value")

    def open(self, path: Path) -> None:
        """Load a file (``file://``) and wait for its load event."""
        self.events.clear()
        nav = self.call("Page.navigate", {"url": path.resolve().as_uri()}, session=True)
        assert "errorText" not in nav, nav
        deadline = time.monotonic() + TIMEOUT
        while not any(e.get("method") == "Page.loadEventFired" for e in self.events):
            self.events.append(self._message(deadline))

    def errors(self) -> list[str]:
        """The page's console errors, uncaught exceptions and failed loads so far."""
        found = []
        for e in self.events:
            method, p = e.get("method"), e.get("params", {})
            if method == "Runtime.exceptionThrown":
                found.append(p["exceptionDetails"].get("exception", {}).get("description", ""))
            elif method == "Runtime.consoleAPICalled" and p["type"] in ("error", "assert"):
                found.append(" ".join(str(a.get("value", a.get("description"))) for a in p["args"]))
            elif method == "Log.entryAdded" and p["entry"]["level"] == "error":
                found.append(f"{p['entry']['text']} {p['entry'].get('url', '')}")
        return found

    def screenshot(self, clip: dict[str, float]) -> np.ndarray:
        """The page's pixels in ``clip`` (page coordinates, CSS px), (H, W, 3) uint8."""
        shot = self.call(
            "Page.captureScreenshot",
            {"format": "png", "captureBeyondViewport": True, "clip": {**clip, "scale": 1}},
            session=True,
        )
        png = base64.b64decode(shot["data"])
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))

    def close(self) -> None:
        try:
            self.call("Browser.close")
        except (EOFError, TimeoutError, OSError):
            pass
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        os.close(self._send_fd)
        os.close(self._recv_fd)


@pytest.fixture(scope="module")
def browser(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Chromium]:
    executable = shutil.which("chromium")
    if executable is None:
        pytest.fail(
            "chromium not found: the report's browser test needs it; run `make install` (or "
            "`apt-get install -y --no-install-recommends chromium`)"
        )
    chromium = Chromium(executable, tmp_path_factory.mktemp("chromium-profile"))
    yield chromium
    chromium.close()


#: Once plotly.js is inflated and run (``window.plotlyLoaded``: the page's loader) and after two
#: animation frames: where the plot's 3D scene lies on the page, the colourings its menu offers,
#: the number of points drawn. Null when the plot was not made.
_SCENE = """Promise.resolve(window.plotlyLoaded).catch(() => null).then(() => new Promise(done => {
  const gd = document.getElementById('CLOUD');
  if (!gd || !window.Plotly || !gd._fullLayout) { done(null); return; }
  requestAnimationFrame(() => requestAnimationFrame(() => {
    gd.scrollIntoView();
    const r = gd.getBoundingClientRect(), s = gd._fullLayout._size;
    const d = gd._fullLayout.scene.domain;
    done({x: r.left + window.scrollX + s.l + d.x[0] * s.w,
          y: r.top + window.scrollY + s.t + (1 - d.y[1]) * s.h,
          width: (d.x[1] - d.x[0]) * s.w, height: (d.y[1] - d.y[0]) * s.h,
          canvases: gd.querySelectorAll('canvas').length,
          menu: gd.layout.updatemenus[0].buttons.map(b => b.label),
          points: gd._fullData[0].x.length});
  }));
}))""".replace("CLOUD", CLOUD_DIV_ID)


def coloured_fraction(pixels: np.ndarray) -> float:
    """Fraction of pixels in a colour map's colours: chroma (max - min of R, G, B) over 50.
    Viridis's darkest is 83 (#440154); the page, axes, grid, labels and menu are gray or white
    (chroma under 10)."""
    p = pixels.astype(np.int16)
    return float(np.mean(p.max(axis=2) - p.min(axis=2) > 50))


def test_the_view_with_its_points(runs: dict[str, Path], browser: Chromium) -> None:
    browser.open(runs["measure"] / "report.html")
    scene = browser.evaluate(_SCENE)
    assert scene is not None, browser.errors()
    height = read_map_tiff(runs["measure"] / "height.tiff")
    outliers = read_map_tiff(runs["measure"] / "outliers.tiff")
    assert scene["canvases"] >= 1
    assert scene["points"] == np.count_nonzero(np.isfinite(height) & (outliers == 0)) > 2500
    assert scene["menu"] == ["height (mm)", "mean intensity (DN)", "predicted height std (mm)"]
    clip = {k: scene[k] for k in ("x", "y", "width", "height")}
    drawn = coloured_fraction(browser.screenshot(clip))
    assert drawn > 0.05, drawn  # the mask's 3072 points cover about a third of the scene
    # the menu's last colouring (the predicted std) applies as its button applies it
    title = browser.evaluate(
        f"(() => {{ const gd = document.getElementById('{CLOUD_DIV_ID}');"
        " return Plotly.restyle(gd, gd.layout.updatemenus[0].buttons[2].args[0])"
        ".then(() => gd._fullData[0].marker.colorbar.title.text); })()"
    )
    assert title == "predicted height std (mm)"
    assert browser.errors() == []
    # the same check rejects the figure without its points: the scene drawn, nothing coloured
    browser.evaluate(
        f"Plotly.react('{CLOUD_DIV_ID}', [{{type: 'scatter3d', mode: 'markers', x: [], y: [],"
        " z: []}], document.getElementById('" + CLOUD_DIV_ID + "').layout).then(() => true)"
    )
    empty = browser.evaluate(_SCENE)
    assert empty["points"] == 0
    assert coloured_fraction(browser.screenshot(clip)) < 0.001


def test_a_report_without_its_plotly_js_fails(runs: dict[str, Path], browser: Chromium) -> None:
    """The report as ``include_plotlyjs="cdn"`` would write it: the network is closed, so
    plotly.js does not load, the page logs the failed load and ``Plotly is not defined``, and no
    scene is drawn: the checks of the test above reject it."""
    text = (runs["measure"] / "report.html").read_text(encoding="utf-8")
    start = text.index(f'<script id="{PLOTLY_SCRIPT_ID}"')
    end = text.index("</script>", start) + len("</script>")
    variant = runs["root"] / "report_cdn.html"
    variant.write_text(
        text[:start]
        + '<script charset="utf-8" src="https://cdn.plot.ly/plotly-3.0.1.min.js"></script>'
        + text[end:],
        encoding="utf-8",
    )
    browser.open(variant)
    assert browser.evaluate(_SCENE) is None
    errors = browser.errors()
    assert any("Failed to load resource" in e for e in errors), errors
    assert any("Plotly is not defined" in e for e in errors), errors
