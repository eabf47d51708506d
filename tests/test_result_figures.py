"""Figures that misled (issue 27): read back what was drawn, not only that a file exists.

- the demo overview's "saturated shifts" panel of a scene with nothing saturated was one solid
  red panel with a -0.1..0.1 colour bar (a colour range taken from all-zero data);
- ``migl_pie.png`` labelled only the slices of 2 % or more;
- ``regions.png`` coloured by tab10 drew a region in tab10's gray, the previews' invalid gray.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from hdrfringe.io._colormaps import LABEL_COLOURS, LABEL_LUT, colormap_lut, label_colour_index
from hdrfringe.io.plots import _migl_pie_figure, _pyplot
from hdrfringe.io.results import PREVIEW_INVALID_GRAY, write_preview_png
from hdrfringe.tasks.demo import _overview, _saturated_panel


def _rgb(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def _strong_red(rgb: np.ndarray) -> int:
    """Pixels a reader takes for "saturated": strongly red (Reds' top half; inferno's middle,
    the old panel's colour, is (188, 55, 84))."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return int(np.count_nonzero((r > 100) & (g < 90) & (b < 100) & (r - g > 80)))


def test_nothing_saturated_draws_no_red_and_says_so(tmp_path: Path) -> None:
    none = _saturated_panel("plate", np.zeros((48, 64), int), 3)
    some_count = np.zeros((48, 64), int)
    some_count[10:20, 10:40] = 3
    some = _saturated_panel("board", some_count, 3)
    assert none[0] == "plate: saturated shifts (none saturated)"
    assert some[0] == "board: saturated shifts (9.8 % of pixels)"
    assert none[-1] == some[-1] == (0.0, 3.0)  # fixed 0..N range, whatever the data
    _overview(tmp_path / "none.png", [none], cols=1)
    _overview(tmp_path / "some.png", [some], cols=1)
    pale = np.all(np.abs(_rgb(tmp_path / "none.png") - (255, 245, 240)) <= 2, axis=-1)
    assert pale.sum() > 0.9 * 48 * 64  # the map itself: Reds(0), the palest colour
    # the colour bar is red in both; the map adds the saturated block's 300 px (times the
    # figure's scale) only where something saturated
    red_none, red_some = _strong_red(_rgb(tmp_path / "none.png")), _strong_red(
        _rgb(tmp_path / "some.png")
    )
    assert red_some > red_none + 300
    # the old panel (colour range from the data, inferno) was red all over: the measure fails it
    old = ("plate: saturated shifts", np.zeros((48, 64)), "inferno", "")
    _overview(tmp_path / "old.png", [old], cols=1)
    assert _strong_red(_rgb(tmp_path / "old.png")) > red_none + 0.9 * 48 * 64


def test_the_migl_pie_names_every_slice() -> None:
    """Five MIGLs, two of them 1 % slices: the legend names all five with their shares."""
    index = np.array([[255] * 50 + [240] * 30 + [225] * 10 + [210] + [195]])
    plt = _pyplot()
    fig = _migl_pie_figure(plt, index, "pixels per MIGL", 50)
    try:
        legend = fig.axes[0].get_legend()
        texts = [t.get_text() for t in legend.get_texts()]
        slices = [t.get_text() for t in fig.axes[0].texts]
    finally:
        plt.close(fig)
    assert texts == ["255: 54.3 %", "240: 32.6 %", "225: 10.9 %", "210: 1.1 %", "195: 1.1 %"]
    assert [s for s in slices if s] == ["255", "240", "225"]  # the big slices' own labels


def test_no_region_is_drawn_in_the_invalid_gray(tmp_path: Path) -> None:
    """Labels 0..30 drawn as regions.png draws them: 0 is the invalid gray, every region a
    colour far from it, and neighbouring labels differ. tab10 over the same labels drew one
    (the old table holds the gray)."""
    labels = np.repeat(np.arange(31), 4)[None, :].repeat(8, axis=0)
    path = tmp_path / "regions.png"
    write_preview_png(
        path, label_colour_index(labels), cmap=LABEL_LUT, vmin=1.0, vmax=len(LABEL_COLOURS)
    )
    k = -(-256 // labels.shape[1])  # previews enlarge a narrow map by k (PREVIEW_MIN_WIDTH)
    rgb = _rgb(path)[22 : 22 + k * labels.shape[0], 8 : 8 + k * labels.shape[1]]  # the map
    grey = np.all(rgb == PREVIEW_INVALID_GRAY, axis=-1)
    near = np.all(np.abs(rgb - PREVIEW_INVALID_GRAY) <= 24, axis=-1)
    assert grey.any() and np.array_equal(near, grey)  # only label 0 is (exactly) the gray
    lut = colormap_lut(LABEL_LUT).astype(int)
    level = np.rint((label_colour_index(np.arange(1, 31)) - 1) / (len(LABEL_COLOURS) - 1) * 255)
    colours = lut[level.astype(int)]
    assert np.abs(colours - PREVIEW_INVALID_GRAY).max(axis=1).min() > 24
    assert np.all(np.any(colours[1:] != colours[:-1], axis=1))
    assert {tuple(c) for c in colours} == set(LABEL_COLOURS)  # all nine, each label one of them
    # the old table, tab10, holds the gray (127, 127, 127): a region's level can land on it
    tab10 = colormap_lut("tab10").astype(int)
    assert np.any(np.abs(tab10 - PREVIEW_INVALID_GRAY).max(axis=1) <= 1)
