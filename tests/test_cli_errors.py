"""Bad input: one-line error naming the problem, exit code 2, no traceback, no partial output."""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest

from tests.conftest import run_cli, run_cli_in_process


def _edit_manifest(folder: Path, edit: Callable[[dict], None]) -> None:
    m = json.loads((folder / "manifest.json").read_text())
    edit(m)
    (folder / "manifest.json").write_text(json.dumps(m))


def _assert_clean_failure(folder: Path, out: Path, *needles: str) -> None:
    # in-process: the CLI's entry point, with what a process would report (conftest)
    res = run_cli_in_process("phase", str(folder), "-o", str(out))
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, res.stderr
    assert "Traceback" not in res.stderr
    assert lines[0].startswith("error:")
    for n in needles:
        assert n in lines[0], lines[0]
    assert not out.exists()
    assert not [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.")]


def _first_fringe_file(folder: Path) -> str:
    m = json.loads((folder / "manifest.json").read_text())
    return next(f["file"] for f in m["frames"] if f["kind"] == "fringe")


def test_valid_folder_decodes(capture_folder: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = run_cli("phase", str(capture_folder), "-o", str(out))
    assert res.returncode == 0, res.stderr
    for name in (
        "wrapped_phase",
        "modulation",
        "mean_intensity",
        "data_modulation",
        "saturation_count",
        "unwrapped_phase_vertical",
        "absolute_phase_vertical",
    ):
        assert (out / f"{name}.tiff").is_file()
        assert (out / f"{name}.png").is_file()


def test_missing_manifest(capture_folder: Path, tmp_path: Path) -> None:
    (capture_folder / "manifest.json").unlink()
    _assert_clean_failure(capture_folder, tmp_path / "out", "no manifest.json")


def test_unknown_field_value(capture_folder: Path, tmp_path: Path) -> None:
    _edit_manifest(capture_folder, lambda m: m["frames"][0].update(pattern="sawtooth"))
    _assert_clean_failure(capture_folder, tmp_path / "out", "frame 0", "sawtooth", "use one of")


def test_missing_file(capture_folder: Path, tmp_path: Path) -> None:
    name = _first_fringe_file(capture_folder)
    (capture_folder / name).unlink()
    _assert_clean_failure(capture_folder, tmp_path / "out", name, "does not exist")


def test_path_leaving_folder(capture_folder: Path, tmp_path: Path) -> None:
    _edit_manifest(capture_folder, lambda m: m["frames"][1].update(file="../elsewhere/x.png"))
    _assert_clean_failure(capture_folder, tmp_path / "out", "leaves the capture folder")


def test_mixed_image_sizes(capture_folder: Path, tmp_path: Path) -> None:
    name = _first_fringe_file(capture_folder)
    iio.imwrite(capture_folder / name, np.zeros((10, 12), np.uint8))
    _assert_clean_failure(capture_folder, tmp_path / "out", "one size")


def test_values_above_bit_depth(capture_folder: Path, tmp_path: Path) -> None:
    _edit_manifest(capture_folder, lambda m: m["camera"].update(bit_depth=6))
    _assert_clean_failure(capture_folder, tmp_path / "out", "above 2^B - 1 = 63")


def test_set_with_wrong_number_of_shifts(capture_folder: Path, tmp_path: Path) -> None:
    _edit_manifest(capture_folder, lambda m: m["frames"].pop(2))
    _assert_clean_failure(capture_folder, tmp_path / "out", "has shifts [0, 1, 3]")


def test_truncated_png(capture_folder: Path, tmp_path: Path) -> None:
    name = _first_fringe_file(capture_folder)
    data = (capture_folder / name).read_bytes()
    (capture_folder / name).write_bytes(data[: len(data) // 2])
    _assert_clean_failure(capture_folder, tmp_path / "out", name, "corrupt or truncated")


def test_not_json(capture_folder: Path, tmp_path: Path) -> None:
    (capture_folder / "manifest.json").write_text("{ not json")
    _assert_clean_failure(capture_folder, tmp_path / "out", "not valid JSON")


def test_rgb_is_converted_to_luma_and_clipping_kept(capture_folder: Path, tmp_path: Path) -> None:
    """Documented conversion: BT.601 luma; a pixel with any clipped channel counts as saturated."""
    m = json.loads((capture_folder / "manifest.json").read_text())
    fringe = [f["file"] for f in m["frames"] if f["kind"] == "fringe"]
    gray0 = iio.imread(capture_folder / fringe[0])
    for name in fringe:
        g = iio.imread(capture_folder / name)
        rgb = np.stack([g, g, g], axis=-1)
        iio.imwrite(capture_folder / name, rgb)
    rgb0 = iio.imread(capture_folder / fringe[0])
    rgb0[0, 0] = (255, 10, 10)  # one clipped channel
    iio.imwrite(capture_folder / fringe[0], rgb0)
    out = tmp_path / "out"
    res = run_cli("phase", str(capture_folder), "-o", str(out))
    assert res.returncode == 0, res.stderr
    import tifffile

    sat = tifffile.imread(out / "saturation_count.tiff")
    assert sat[0, 0] == 1
    from hdrfringe.io.captures import read_capture_folder

    caps = read_capture_folder(capture_folder)
    assert np.allclose(caps.images[0][1:], gray0[1:], atol=1e-3)


def test_existing_output_is_kept_without_force(capture_folder: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    res = run_cli("phase", str(capture_folder), "-o", str(out))
    assert res.returncode == 2 and "--force" in res.stderr
    assert (out / "keep.txt").read_text() == "precious"
    res = run_cli("phase", str(capture_folder), "-o", str(out), "--force")
    assert res.returncode == 0, res.stderr
    assert not (out / "keep.txt").exists() and (out / "wrapped_phase.tiff").exists()


@pytest.mark.parametrize(
    "args",
    [["patterns", "-o", "{out}", "--steps", "2"], ["patterns", "-o", "{out}", "--pitch", "abc"]],
)
def test_patterns_bad_options(tmp_path: Path, args: list[str]) -> None:
    out = tmp_path / "pat"
    res = run_cli(*[a.format(out=out) for a in args])
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert not out.exists()


# --- resource limits and hostile numbers (issue 11, items 4 and 9) ------------------------------


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["simulate", "white_plate", "--steps", "100000"], "100000 phase shifts"),
        (["simulate", "white_plate", "--steps", "1001"], "more than the limit of 1000"),
        (["simulate", "white_plate", "--migl-sweep", "255:0:1e-6"], "limit of 10000"),
        (["simulate", "white_plate", "--series", "0:1e9:1"], "limit of 1000"),
        (["simulate", "white_plate", "--series", "0:1e300:1e-300"], "inf values in --series"),
        (["simulate", "white_plate", "--pitch", "9" * 400], "--pitch: '99999"),
        (["simulate", "white_plate", "--migl", "nan"], "give finite numbers"),
        (["simulate", "white_plate", "--seed", "-1"], "seed must be a non-negative integer"),
        (["simulate", "white_plate", "--orientation", "diag"], "unknown orientation 'diag'"),
        (["patterns", "--width", "1000000", "--height", "1000000"], "limit of 67108864"),
        (["patterns", "--steps", "100000"], "more than the limit of 1000"),
        (["modify", "{src}", "--seed", "-1", "--noise", "1"], "seed must be a non-negative"),
    ],
)
def test_limits_and_bad_numbers_are_one_line_errors(
    capture_folder: Path, tmp_path: Path, args: list[str], needle: str
) -> None:
    out = tmp_path / "out"
    before = _tree(capture_folder)
    # in-process: the CLI's entry point, with what a process would report (conftest)
    res = run_cli_in_process(*[a.format(src=capture_folder) for a in args], "-o", str(out))
    assert res.returncode == 2, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    assert needle in lines[0] and "Traceback" not in res.stderr
    assert len(lines[0]) < 300  # a 400-digit number is not echoed whole
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["caps"]  # no staging left
    assert _tree(capture_folder) == before


def test_parse_range_and_floats() -> None:
    from hdrfringe.cli._app import parse_floats, parse_range
    from hdrfringe.errors import InputError

    assert parse_range("2:6:2", "--x") == [2.0, 4.0, 6.0]
    assert parse_range("255:252:1", "--x") == [255.0, 254.0, 253.0, 252.0]  # downwards
    assert parse_range("255:252:-1", "--x") == [255.0, 254.0, 253.0, 252.0]
    assert parse_range("8, 64", "--x") == parse_floats("8,64", "--x") == [8.0, 64.0]
    assert parse_range("0:1:0.1", "--x")[-1] == 1.0
    assert len(parse_range("1:10000:1", "--x")) == 10_000  # at the limit
    assert len(parse_range("1:5:1", "--x", max_count=5)) == 5
    for text, kwargs, match in [
        ("0:10000:1", {}, "10001 values in --x 0:10000:1: more than the limit of 10000"),
        ("1:6:1", {"max_count": 5}, "more than the limit of 5"),
        ("0:1:1e-300", {}, "limit of 10000"),
        ("nan:1:1", {}, "holds nan"),
        ("0:inf:1", {}, "holds inf"),
        ("5:1:0", {}, "empty range"),
        ("a:b:c", {}, "cannot read 'a:b:c'"),
        ("1,2,1e999", {}, "holds inf"),
        (",", {}, "empty list"),
    ]:
        with pytest.raises(InputError, match=re.escape(match)):
            parse_range(text, "--x", **kwargs)


def test_error_text_with_brackets_prints_verbatim(tmp_path: Path) -> None:
    # The CLI prints errors through rich; a path with "[bold]" or "[a-z]" in it must not be
    # taken for markup (it was: "[camera]" vanished from a message).
    missing = tmp_path / "run[bold]" / "caps[a-z]"
    res = run_cli("phase", str(missing), "-o", str(tmp_path / "out"))
    assert res.returncode == 2, res.stderr
    assert "run[bold]" in res.stderr and "caps[a-z]" in res.stderr, res.stderr
