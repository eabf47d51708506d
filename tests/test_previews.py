"""PNG previews of maps (io.results.write_preview_png): colours from the colour map's own table,
NaN gray, the colour bar spanning the range, sizes bounded."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib import colormaps
from PIL import Image

from hdrfringe.errors import InputError
from hdrfringe.io._colormaps import STORED_LUTS, colormap_lut
from hdrfringe.io.results import (
    PREVIEW_INVALID_GRAY,
    PREVIEW_MAX_WIDTH,
    PREVIEW_MIN_WIDTH,
    write_preview_png,
)


def _body(path: Path, shape: tuple[int, int]) -> np.ndarray:
    """The map area of a preview: its top-left corner is where the map is pasted (8, 22)."""
    img = np.asarray(Image.open(path).convert("RGB"))
    return img[22 : 22 + shape[0], 8 : 8 + shape[1]]


def test_colours_come_from_the_colour_map(tmp_path: Path) -> None:
    data = np.tile(np.linspace(0.0, 10.0, 300), (40, 1))
    data[5:9, 100:120] = np.nan
    path = tmp_path / "m.png"
    write_preview_png(path, data, cmap="magma", vmin=0.0, vmax=10.0)
    body = _body(path, data.shape).astype(int)
    # reference: matplotlib's colour map evaluated directly at the normalised values
    ref = np.rint(colormaps["magma"](data / 10.0)[..., :3] * 255).astype(int)
    finite = np.isfinite(data)
    # 256-level table: one level of quantisation at most (a colour step of a few DN)
    assert np.abs(body[finite] - ref[finite]).max() <= 6
    assert (body[~finite] == PREVIEW_INVALID_GRAY).all()
    # the broken variant, a reversed scale, is far off
    rev = np.rint(colormaps["magma"](1 - data / 10.0)[..., :3] * 255).astype(int)
    assert np.abs(body[finite] - rev[finite]).max() > 100


def test_percentile_range_and_bar(tmp_path: Path) -> None:
    data = np.linspace(0.0, 1.0, 400 * 300).reshape(300, 400)
    data[0, 0] = 1e9  # one outlier does not flatten the picture
    path = tmp_path / "p.png"
    write_preview_png(path, data, cmap="viridis", title="t", label="mm")
    img = np.asarray(Image.open(path).convert("RGB")).astype(int)
    lut = np.rint(colormaps["viridis"](np.linspace(0, 1, 256))[:, :3] * 255).astype(int)
    bar_x = 8 + 400 + 8 + 8  # map margin + width + two margins
    assert np.abs(img[22, bar_x] - lut[255]).max() <= 1  # top of the bar: vmax colour
    assert np.abs(img[22 + 299, bar_x] - lut[0]).max() <= 1  # bottom: vmin colour
    body = _body(path, data.shape)
    mid = np.abs(body[150, 200].astype(int) - lut[128]).max()
    assert mid <= 8  # the middle of the ramp maps near the middle of the table


def test_sizes_are_bounded(tmp_path: Path) -> None:
    big = np.zeros((50, 3 * PREVIEW_MAX_WIDTH + 5))
    write_preview_png(tmp_path / "big.png", big)
    small = np.zeros((3, 5))
    write_preview_png(tmp_path / "small.png", small)
    wb = Image.open(tmp_path / "big.png").width
    ws = Image.open(tmp_path / "small.png").width
    assert PREVIEW_MAX_WIDTH // 2 < wb < PREVIEW_MAX_WIDTH + 200
    assert ws >= PREVIEW_MIN_WIDTH


def test_all_invalid_map_and_bad_shapes(tmp_path: Path) -> None:
    write_preview_png(tmp_path / "nan.png", np.full((4, 4), np.nan))
    assert (_body(tmp_path / "nan.png", (4, 4)) == PREVIEW_INVALID_GRAY).all()
    with pytest.raises(InputError, match="2-D map"):
        write_preview_png(tmp_path / "bad.png", np.zeros(5))


@pytest.mark.parametrize("name", sorted(STORED_LUTS))
def test_stored_colour_tables_are_matplotlibs(name: str) -> None:
    """The tables stored so that previews need no matplotlib are matplotlib's own, entry for
    entry (a stale or mistyped table, or one of another colour map, differs)."""
    ref = np.rint(colormaps[name](np.linspace(0.0, 1.0, 256))[:, :3] * 255).astype(np.uint8)
    assert np.array_equal(colormap_lut(name), ref)
    assert not colormap_lut(name).flags.writeable


def test_an_unstored_colour_map_comes_from_matplotlib(tmp_path: Path) -> None:
    assert "coolwarm" not in STORED_LUTS
    ref = np.rint(colormaps["coolwarm"](np.linspace(0.0, 1.0, 256))[:, :3] * 255)
    assert np.array_equal(colormap_lut("coolwarm"), ref)
    data = np.tile(np.linspace(0.0, 1.0, 256), (4, 1))
    write_preview_png(tmp_path / "c.png", data, cmap="coolwarm", vmin=0.0, vmax=1.0)
    assert np.array_equal(_body(tmp_path / "c.png", (4, 256))[0], ref.astype(np.uint8))


_NO_MATPLOTLIB = """
import sys
import numpy as np
from hdrfringe.io.results import write_preview_png
for cmap in ("viridis", "magma", "twilight", "gray", "inferno", "tab10"):
    write_preview_png(sys.argv[1] + "/" + cmap + ".png", np.eye(5), cmap=cmap)
print(sorted(m for m in sys.modules if m.split(".")[0] == "matplotlib"))
"""


def test_previews_of_the_usual_maps_do_not_import_matplotlib(tmp_path: Path) -> None:
    import subprocess
    import sys

    run = subprocess.run(
        [sys.executable, "-c", _NO_MATPLOTLIB, str(tmp_path)],
        capture_output=True, text=True, check=True,
    )  # fmt: skip
    assert run.stdout.strip() == "[]"
    assert len(list(tmp_path.glob("*.png"))) == 6


@pytest.mark.parametrize("command", ["phase", "measure"])
def test_no_previews_writes_the_same_maps_without_pngs(
    capture_folder: Path, tmp_path: Path, command: str
) -> None:
    """``--no-previews`` leaves out exactly the PNG previews: the same TIFF maps, byte for byte,
    and a summary listing only what was written (a flag that dropped maps, or listed PNGs it
    did not write, fails)."""
    from tests.conftest import run_cli_in_process
    from tests.test_unwrap_identity import reseed_c_rand

    outs = {}
    for flag in ("--previews", "--no-previews"):
        out = tmp_path / f"{command}{flag}"
        reseed_c_rand()  # the spatial unwrapper's rand() state: the same for both runs
        run = run_cli_in_process(command, str(capture_folder), "-o", str(out), flag)
        assert run.returncode == 0, run.stderr
        outs[flag] = out
    with_png = {p.name for p in outs["--previews"].iterdir()}
    without = {p.name for p in outs["--no-previews"].iterdir()}
    pngs = {n for n in with_png if n.endswith(".png")}
    assert len(pngs) >= 7 and not any(n.endswith(".png") for n in without)
    assert without == with_png - pngs
    for name in without:
        if name.endswith(".tiff"):
            a, b = (outs[f] / name for f in ("--previews", "--no-previews"))
            assert a.read_bytes() == b.read_bytes(), name
    import json

    listed = json.loads((outs["--no-previews"] / "phase_summary.json").read_text())["files"]
    assert set(listed) == {n for n in without if n.endswith(".tiff")}
