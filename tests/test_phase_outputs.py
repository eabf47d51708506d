"""``phase``'s written maps: lossless read-back, final maps by default, every set's on request,
written on threads (issue 30)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hdrfringe.core.captures import Captures, ProjectorInfo
from hdrfringe.core.decode import decode_captures
from hdrfringe.core.patterns import FringeSpec, fringe_gray
from hdrfringe.errors import InputError
from hdrfringe.io.captures import write_capture_folder
from hdrfringe.io.phase_maps import SET_MAPS, write_phase_maps
from hdrfringe.io.report import REPORT_FILES
from hdrfringe.io.results import read_map_tiff
from tests.conftest import run_cli_in_process

PITCHES = (1024.0, 64.0, 8.0)


def _captures() -> Captures:
    """Three 4-step sets (64x48) of a tilted plane with a clipped band and noise: maps with
    NaN, fractions and every value a float32 can hold, not a smooth constant."""
    rng = np.random.default_rng(7)
    x = 10.0 + 14.0 * np.arange(64.0)[None, :] + 3.0 * np.arange(48.0)[:, None]
    gain = np.where((np.arange(64) > 40) & (np.arange(64) < 48), 1.3, 1.0)[None, :]
    frames = [f for p in PITCHES for f in FringeSpec("sinusoidal", 4, p, imin=40).frames()]
    images = np.stack(
        [gain * fringe_gray(x, f.spec, f.shift) + rng.normal(0.0, 1.5, x.shape) for f in frames]
    )
    images = np.clip(np.rint(images), 0, 255).astype(np.uint8)
    return Captures(frames, images, 8, projector=ProjectorInfo(width=1024))


def test_written_maps_read_back_equal_to_the_computed_arrays(tmp_path: Path) -> None:
    """Every TIFF holds its own array exactly (float32 maps: the array rounded to float32,
    unwrapped and absolute phase: the float64 array itself). Rejects a lossy codec or
    predictor, float16 maps, and a writer that mixes up which array goes to which file (a
    late-bound closure on the threads writes one array under every name)."""
    decoded = decode_captures(_captures())
    assert any(np.isnan(r.wrapped_phase).any() for r in decoded.set_results.values())
    write_phase_maps(tmp_path, decoded, "memory", previews=False)
    for s in decoded.sets:
        res = decoded.set_results[s.label]
        for stem, attr, _, _ in SET_MAPS:
            got = read_map_tiff(tmp_path / f"{stem}__{s.label}.tiff")
            want = np.asarray(getattr(res, attr))
            want = want.astype(np.float32) if want.dtype.kind == "f" else want
            assert got.dtype == want.dtype, (stem, s.label)
            np.testing.assert_array_equal(got, want, err_msg=f"{stem}__{s.label}")
    fam = decoded.primary
    for name, arr in (("unwrapped_phase", fam.unwrapped_phase), ("absolute_phase",
                                                                 fam.absolute_phase)):  # fmt: skip
        got = read_map_tiff(tmp_path / f"{name}_vertical.tiff")
        assert got.dtype == np.float64
        np.testing.assert_array_equal(got, arr, err_msg=name)


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_capture_folder(tmp_path_factory.mktemp("caps") / "caps", _captures())


def test_phase_writes_the_final_maps_unless_every_set_is_asked_for(
    folder: Path, tmp_path: Path
) -> None:
    """By default the finest set's maps, the unwrapped and absolute phase and their std, and
    the summary of every set; --per-set-maps adds each set's maps with the same bytes for the
    files both write. Rejects per-set maps written by default, or --per-set-maps ignored."""
    final, every = tmp_path / "final", tmp_path / "every"
    res = run_cli_in_process("phase", str(folder), "-o", str(final))
    assert res.returncode == 0, res.stderr
    assert "wrote 16 files to" in res.stdout
    res = run_cli_in_process("phase", str(folder), "-o", str(every), "--per-set-maps")
    assert res.returncode == 0, res.stderr
    names = sorted(p.name for p in final.iterdir() if p.name not in REPORT_FILES)
    assert all((final / name).is_file() for name in REPORT_FILES)  # beside the maps (not listed)
    stems = [stem for stem, *_ in SET_MAPS]
    assert names == sorted(
        [f"{m}.{e}" for m in [*stems, "phase_std", "unwrapped_phase_vertical",
                              "absolute_phase_vertical"]
         for e in ("tiff", "png")] + ["phase_summary.json"]
    )  # fmt: skip
    summary = json.loads((final / "phase_summary.json").read_text())
    assert summary["files"] == [n for n in names if n != "phase_summary.json"]
    assert [s["pitch_px"] for s in summary["sets"]] == list(PITCHES)
    both = json.loads((every / "phase_summary.json").read_text())
    labels = [s["label"] for s in both["sets"]]
    per_set = {f"{m}__{label}.{e}" for m in [*stems, "phase_std"] for label in labels
               for e in ("tiff", "png")}  # fmt: skip
    assert set(both["files"]) == set(summary["files"]) | per_set
    assert {k: v for k, v in both.items() if k != "files"} == {
        k: v for k, v in summary.items() if k != "files"
    }
    for name in names:
        if name.endswith(".tiff"):
            assert (final / name).read_bytes() == (every / name).read_bytes(), name


def test_final_quality_maps_keep_every_final_result_bit_for_bit() -> None:
    """quality_maps="final" (phase without --per-set-maps) drops the coarser sets' quality maps
    and phases only: the finest set's maps, every set's validity and saturation count, and the
    unwrapped and absolute phase are the bits of the full decode. Rejects a dropped map that
    unwrapping still needed (the phases would change) or the finest set's maps dropped."""
    caps = _captures()
    every = decode_captures(caps, map_dtype="float32")
    final = decode_captures(caps, map_dtype="float32", quality_maps="final")
    fine = every.primary.sets[-1].label
    assert [s.label for s in final.sets] == [s.label for s in every.sets]
    for label, res in every.set_results.items():
        got = final.set_results[label]
        np.testing.assert_array_equal(got.valid, res.valid)
        np.testing.assert_array_equal(got.saturation_count, res.saturation_count)
        for _, attr, _, _ in SET_MAPS:
            if label == fine:
                np.testing.assert_array_equal(getattr(got, attr), getattr(res, attr))
            elif attr != "saturation_count":
                assert np.isnan(getattr(got, attr)).all(), (label, attr)
    for name in ("unwrapped_phase", "absolute_phase"):
        np.testing.assert_array_equal(getattr(final.primary, name), getattr(every.primary, name))
    with pytest.raises(InputError, match="quality_maps"):
        decode_captures(caps, quality_maps="some")


def test_blocked_std_and_unwrapping_match_closed_forms_on_any_thread_count(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The least-squares std and the temporal unwrapping run block by block (on threads for the
    std): over several blocks, per pixel, the std is the closed form sqrt(2/N) sigma / b (read
    noise only, equal shifts) and the unwrapping returns the projector phase, with the same
    bits on one thread and on two. Rejects a block written to the wrong slice, a last partial
    block left out, or a float32 map widened after the arithmetic instead of before."""
    from hdrfringe.core._blockdecode import decode_threads
    from hdrfringe.core.uncertainty import NoiseModel, phase_std_least_squares
    from hdrfringe.core.unwrap import unwrap_temporal

    rng = np.random.default_rng(11)
    shape = (307, 311)  # 95477 px: three blocks of 32768 and a partial one
    phi = rng.uniform(0, 2 * np.pi, shape).astype(np.float32)
    b = rng.uniform(5, 80, shape).astype(np.float32)
    a = rng.uniform(90, 150, shape).astype(np.float32)
    b[0, 0] = 0.0  # not predicted
    stds = {}
    for threads in ("1", "2"):
        monkeypatch.setenv("HDRFRINGE_DECODE_THREADS", threads)
        assert decode_threads(10) == int(threads)
        stds[threads] = phase_std_least_squares([0, 90, 180, 270], phi, b, a, NoiseModel(2.0))
    np.testing.assert_array_equal(stds["1"], stds["2"])
    want = np.sqrt(2 / 4) * 2.0 / b.astype(np.float64).ravel()[1:]
    assert np.isnan(stds["1"][0, 0])
    np.testing.assert_allclose(stds["1"].ravel()[1:], want, rtol=1e-12)
    x = rng.uniform(0, 1000, shape)  # projector columns
    maps = [np.mod(2 * np.pi * x / p, 2 * np.pi).astype(np.float32) for p in PITCHES]
    got = unwrap_temporal(maps, PITCHES)
    np.testing.assert_allclose(got, 2 * np.pi * x / PITCHES[-1], atol=1e-4)
    widened = unwrap_temporal([m.astype(np.float64) for m in maps], PITCHES)
    np.testing.assert_array_equal(got, widened)


def test_gamma_capture_unwraps_each_exponent_within_its_family(tmp_path: Path) -> None:
    """Two vertical pitch ladders that differ in their gamma pre-compensation (a gamma
    capture, issue 31: the second was decoded and not unwrapped): each is unwrapped within
    itself, to the absolute phase of its own finest pitch (64 px and 32 px, so a family
    unwrapped with the other's sets, or not at all, fails), against the closed form
    2*pi*x/pitch of the projector column x the images were made from."""
    x = 10.0 + 14.0 * np.arange(64.0)[None, :] + 2.0 * np.arange(48.0)[:, None]  # < 1024
    ladders = ((1.0, (1024.0, 64.0)), (2.0, (1024.0, 32.0)))
    specs = [FringeSpec("sinusoidal", 4, p, migl=200.0) for _, ps in ladders for p in ps]
    frames = [f for spec in specs for f in spec.frames()]  # 200: no pixel saturates
    images = np.stack([fringe_gray(x, f.spec, f.shift) for f in frames])
    caps = Captures(
        frames, np.rint(images).astype(np.uint8), 8, projector=ProjectorInfo(width=1024),
        gamma_precompensation=[g for g, ps in ladders for _ in range(4 * len(ps))],
    )  # fmt: skip
    folder = write_capture_folder(tmp_path / "caps", caps)
    res = run_cli_in_process("phase", str(folder), "-o", str(tmp_path / "out"), "--no-previews")
    assert res.returncode == 0, res.stderr
    out = tmp_path / "out"
    summary = json.loads((out / "phase_summary.json").read_text())
    fine = [s["label"] for s in summary["sets"]][1::2]  # the 64 px and the 32 px sets
    assert [f["sets"][-1] for f in summary["families"]] == fine[:1]
    (other,) = summary["gamma_families"]
    assert other["sets"][-1] == fine[1] and other["gamma_precompensation"] == 2.0
    assert other["absolute_phase"] == f"absolute_phase_vertical__{fine[1]}.tiff"
    assert f"vertical ({', '.join(other['sets'])}): unwrapped by temporal" in res.stdout
    for name, pitch in (("absolute_phase_vertical.tiff", 64.0), (other["absolute_phase"], 32.0)):
        phase = read_map_tiff(out / name)
        np.testing.assert_allclose(phase, 2 * np.pi * x / pitch, atol=0.05, err_msg=name)
    unwrapped = read_map_tiff(out / other["unwrapped_phase"])
    assert np.isfinite(unwrapped).all()
