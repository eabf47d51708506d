"""The sweep engine (hdrfringe_thesis.engine) on a cheap toy task: labelled values, reruns
that compute nothing, a killed worker and a Ctrl-C midway that lose nothing, refused stores.

The toy task records each call as a file in the folder named by ``$HDRFRINGE_SWEEP_TEST_DIR``
(set before the workers start), so the tests count real task executions on the workers.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
import signal
import subprocess
import sys
import time
import uuid
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr
import zarr

from hdrfringe.errors import InputError
from hdrfringe_thesis.engine import (
    DONE_VAR,
    PARTIAL_INFIX,
    RUNTIME_ATTRS,
    SweepError,
    SweepGrid,
    Variable,
    open_results,
    run_sweep,
    sweep_status,
)

# Tests that start dask clusters run in one xdist worker (make test: --dist loadgroup), so
# at most one local cluster runs at a time on the two cores.
pytestmark = pytest.mark.xdist_group("dask-cluster")

MARKERS_ENV = "HDRFRINGE_SWEEP_TEST_DIR"
SLEEP_ENV = "HDRFRINGE_SWEEP_TEST_SLEEP"
HERE = Path(__file__).resolve().parent  # on the path of the subprocesses that import this module

GRID = SweepGrid(
    dims={
        "lux": [0.0, 600.0],
        "pattern": ["sinusoidal-3", "triangular-2"],
        "pitch": [4, 6, 8],
        "migl": [255.0, 205.0, 155.0],
        "depth_mm": [2.0, 4.0],
    },
    variables=[
        Variable("rmse_mm", attrs={"units": "mm"}),
        Variable("saturated_fraction", "float32", extra_dims={"shift": [1, 2, 3]}),
        Variable("n_saturated", "int32", fill=-1),
    ],
    block_dims=["migl", "depth_mm"],
    attrs={"description": "toy sweep"},
)
PARAMS = {"seed": 7, "scale": [1.0, 2.0]}


def block_name(coords: dict[str, Any]) -> str:
    return f"{coords['lux']:g}-{coords['pattern']}-{coords['pitch']}"


def toy_values(coords: dict[str, Any], params: dict[str, Any]) -> dict[str, np.ndarray]:
    """Deterministic block values: a generator seeded by the block's coordinates."""
    key = [params["seed"], int(coords["lux"]), len(coords["pattern"]), coords["pitch"]]
    rng = np.random.default_rng(key)
    migl = np.asarray(coords["migl"])[:, None]
    depth = np.asarray(coords["depth_mm"])[None, :]
    rmse = params["scale"][0] * rng.random((migl.size, depth.size)) + migl / 255.0 * depth
    frac = rng.random((migl.size, depth.size, 3), dtype=np.float32)
    return {
        "rmse_mm": rmse,
        "saturated_fraction": frac,
        "n_saturated": (frac.sum(axis=-1) * 100).astype(np.int32),
    }


def toy_block(coords: dict[str, Any], params: dict[str, Any]) -> dict[str, np.ndarray]:
    """The task: records the call, dies once if asked to, sleeps if asked to."""
    markers = os.environ.get(MARKERS_ENV)
    if markers:
        name = block_name(coords)
        (Path(markers) / "calls" / f"{name}.{uuid.uuid4().hex}").touch()
        try:
            os.unlink(Path(markers) / f"kill-{name}")
        except FileNotFoundError:
            pass
        else:  # the kill request is consumed: this attempt takes its worker down
            os._exit(1)
    time.sleep(float(os.environ.get(SLEEP_ENV, "0")))
    return toy_values(coords, params)


def bad_block(coords: dict[str, Any], params: dict[str, Any]) -> dict[str, np.ndarray]:
    """A task with a bug: its arrays miss the depth axis."""
    return {k: v[:, 0] for k, v in toy_values(coords, params).items()}


def drive(store: str) -> None:
    """The interrupted run (in a subprocess): the default local cluster, one worker."""
    run_sweep(store, GRID, toy_block, PARAMS, n_workers=1, progress=False)


def calls(markers: Path, name: str = "") -> int:
    return sum(1 for p in (markers / "calls").iterdir() if p.name.startswith(name))


def without_runtime_attrs(ds: xr.Dataset) -> xr.Dataset:
    out = ds.load().copy()
    for k in RUNTIME_ATTRS:
        out.attrs.pop(k, None)
    return out


@pytest.fixture(scope="module")
def markers(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    path = tmp_path_factory.mktemp("sweep-markers")
    (path / "calls").mkdir()
    old = os.environ.get(MARKERS_ENV)
    os.environ[MARKERS_ENV] = str(path)
    yield path
    if old is None:
        del os.environ[MARKERS_ENV]
    else:
        os.environ[MARKERS_ENV] = old


@pytest.fixture(scope="module")
def scheduler(markers: Path) -> Iterator[str]:
    """Address of a two-worker local cluster shared by the tests (started after the markers
    variable is set, so its workers see it)."""
    from dask.distributed import LocalCluster

    with warnings.catch_warnings():  # another cluster on this machine may hold port 8787
        warnings.filterwarnings("ignore", message="Port .* is already in use")
        cluster = LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.ERROR,
        )
    with cluster:
        yield cluster.scheduler_address


@pytest.fixture(scope="module")
def reference(
    scheduler: str, markers: Path, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, xr.Dataset]:
    """An uninterrupted run: its store and its Dataset."""
    store = tmp_path_factory.mktemp("sweep-ref") / "ref.zarr"
    before = calls(markers)
    ds = run_sweep(store, GRID, toy_block, PARAMS, scheduler=scheduler, progress=False)
    assert calls(markers) - before == GRID.n_blocks
    return store, ds.load()


def test_a_fresh_run_stores_every_block_labelled(reference: tuple[Path, xr.Dataset]) -> None:
    store, ds = reference
    assert ds["rmse_mm"].dims == ("lux", "pattern", "pitch", "migl", "depth_mm")
    assert ds["saturated_fraction"].dims == (*ds["rmse_mm"].dims, "shift")
    assert ds[DONE_VAR].dims == ("lux", "pattern", "pitch") and bool(ds[DONE_VAR].all())
    assert ds["saturated_fraction"].dtype == np.float32 and ds["n_saturated"].dtype == np.int32
    assert ds["pattern"].values.tolist() == ["sinusoidal-3", "triangular-2"]
    assert ds["shift"].values.tolist() == [1, 2, 3]
    assert ds["rmse_mm"].attrs["units"] == "mm" and ds.attrs["description"] == "toy sweep"
    assert json.loads(ds.attrs["sweep_params"]) == PARAMS
    for index in GRID.block_indices():
        where = GRID.split_coords(index)
        want = toy_values(GRID.block_coords(index), PARAMS)
        for name, values in want.items():
            np.testing.assert_array_equal(ds[name].sel(where).values, values)
    # labels, not positions: one cell picked by its coordinates
    cell = ds["rmse_mm"].sel(lux=600.0, pattern="triangular-2", pitch=6, migl=205.0, depth_mm=4.0)
    coords = GRID.block_coords((1, 1, 1))
    assert float(cell) == toy_values(coords, PARAMS)["rmse_mm"][1, 1]
    status = sweep_status(store)
    assert status.complete and status.done == GRID.n_blocks == 12
    assert str(status) == "12 of 12 blocks done, 0 missing"


def test_a_rerun_computes_only_blocks_not_flagged_done(
    reference: tuple[Path, xr.Dataset], scheduler: str, markers: Path, tmp_path: Path
) -> None:
    ref_store, ref = reference
    store = tmp_path / "copy.zarr"
    shutil.copytree(ref_store, store)
    before = calls(markers)
    again = run_sweep(store, GRID, toy_block, PARAMS, scheduler=scheduler, progress=False)
    assert calls(markers) == before  # nothing recomputed
    xr.testing.assert_identical(again.load(), ref)

    # A driver killed after writing a block's data but before its flag: the flag is the truth.
    group = zarr.open_group(str(store), mode="r+")
    group["rmse_mm"][0, 1, 2] = 999.0
    group[DONE_VAR][0, 1, 2] = False
    status = sweep_status(store)
    assert status.done == 11 and status.missing == (
        {"lux": 0.0, "pattern": "triangular-2", "pitch": 8},
    )
    again = run_sweep(store, GRID, toy_block, PARAMS, scheduler=scheduler, progress=False)
    assert calls(markers) == before + 1
    assert calls(markers, "0-triangular-2-8.") == 2  # the reference run's call, and this one
    xr.testing.assert_identical(again.load(), ref)


def test_progress_is_logged_without_a_terminal(
    scheduler: str, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    """No progress bar (no terminal, progress=False): the run still leaves a record, a line
    on the engine's logger when the last block is stored (and every LOG_EVERY_S before)."""
    with caplog.at_level(logging.INFO, logger="hdrfringe_thesis.engine"):
        run_sweep(
            tmp_path / "log.zarr", GRID, toy_block, PARAMS, scheduler=scheduler, progress=False
        )
    lines = [r.getMessage() for r in caplog.records]
    assert any("12 of 12 blocks stored" in m for m in lines), lines


def test_a_killed_worker_loses_nothing(
    reference: tuple[Path, xr.Dataset], scheduler: str, markers: Path, tmp_path: Path
) -> None:
    """A task kills its worker process on its first attempt: dask reruns it elsewhere."""
    victim = "600-sinusoidal-3-6"
    (markers / f"kill-{victim}").touch()
    before = calls(markers, f"{victim}.")
    ds = run_sweep(
        tmp_path / "k.zarr", GRID, toy_block, PARAMS, scheduler=scheduler, progress=False
    )
    assert not (markers / f"kill-{victim}").exists()  # the worker did die
    assert calls(markers, f"{victim}.") == before + 2  # the fatal attempt and the rerun
    xr.testing.assert_identical(without_runtime_attrs(ds), without_runtime_attrs(reference[1]))


def test_ctrl_c_midway_keeps_the_finished_blocks_and_a_rerun_completes_them(
    reference: tuple[Path, xr.Dataset], scheduler: str, markers: Path, tmp_path: Path
) -> None:
    """The driver (own process, default local cluster) gets SIGINT after 3 of 12 blocks."""
    store = tmp_path / "i.zarr"
    path = os.pathsep.join(filter(None, [str(HERE), os.environ.get("PYTHONPATH")]))
    env = {**os.environ, SLEEP_ENV: "0.4", "PYTHONPATH": path}
    # A shell that starts jobs in the background (CI may) hands them SIGINT ignored, and Python
    # then never raises KeyboardInterrupt: restore the default, as a terminal's process has it.
    code = (
        "import signal; signal.signal(signal.SIGINT, signal.default_int_handler); "
        f"from test_sweep_engine import drive; drive({str(store)!r})"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", code], cwd=HERE, env=env, stderr=subprocess.PIPE, text=True
    )
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                if sweep_status(store).done >= 3:
                    break
            except InputError:  # the store is not there yet
                pass
            assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
            time.sleep(0.05)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode != 0 and "KeyboardInterrupt" in err, err
    assert "blocks are stored in" in err and "rerun to compute the rest" in err

    status = sweep_status(store)
    assert 3 <= status.done < GRID.n_blocks
    partial = open_results(store).load()  # a valid store: done blocks right, the rest empty
    ref = reference[1]
    done = partial[DONE_VAR]
    for name in ("rmse_mm", "saturated_fraction"):
        xr.testing.assert_equal(partial[name].where(done), ref[name].where(done))
        assert bool(partial[name].where(~done).isnull().all())

    before = calls(markers)
    ds = run_sweep(store, GRID, toy_block, PARAMS, scheduler=scheduler, progress=False)
    assert calls(markers) - before == len(status.missing)  # only the missing blocks
    xr.testing.assert_identical(without_runtime_attrs(ds), without_runtime_attrs(ref))


KILL_WHILE_CREATING = """
import os, sys
import xarray as xr
from hdrfringe_thesis import engine
from test_sweep_engine import GRID, PARAMS, toy_block

to_zarr = xr.Dataset.to_zarr
def killed(self, *args, **kwargs):  # the metadata is written, then the process dies
    to_zarr(self, *args, **kwargs)
    os._exit(9)
xr.Dataset.to_zarr = killed
engine.run_sweep(sys.argv[1], GRID, toy_block, PARAMS, n_workers=1, progress=False)
"""


def test_a_store_killed_while_created_leaves_a_pid_named_folder_that_a_rerun_removes(
    scheduler: str, tmp_path: Path
) -> None:
    store = tmp_path / "s.zarr"
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]),
    }
    with subprocess.Popen(
        [sys.executable, "-c", KILL_WHILE_CREATING, str(store)],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    ) as child:
        _, err = child.communicate(timeout=120)
    assert child.returncode == 9, err[-2000:]
    (left,) = tmp_path.glob(f".s.zarr{PARTIAL_INFIX}*")  # its store never came into place
    assert not store.exists() and _pid_of(left) == child.pid  # named by the dead process
    # a live process's partial folder (another run creating the store now) is never touched;
    # names without a PID (an earlier version's) are not judged
    with subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"]) as alive:
        live = tmp_path / f".s.zarr{PARTIAL_INFIX}{alive.pid}-0123abcd"
        live.mkdir()
        (live / "zarr.json").write_text("{}")
        unnamed = tmp_path / f".s.zarr{PARTIAL_INFIX}01234567"  # all-digit hex: not a PID
        unnamed.mkdir()
        try:
            run_sweep(store, GRID, toy_block, PARAMS, scheduler=scheduler, progress=False)
            assert not left.exists()  # the dead run's folder is gone
            assert live.is_dir() and (live / "zarr.json").read_text() == "{}"
            assert unnamed.is_dir()
        finally:
            alive.kill()
    assert sweep_status(store).done == GRID.n_blocks


def _pid_of(entry: Path) -> int:
    """The PID in a ``.{store}.partial-{PID}-{random}`` name."""
    return int(entry.name.split(PARTIAL_INFIX)[1].split("-")[0])


def test_a_store_of_another_sweep_is_refused(reference: tuple[Path, xr.Dataset]) -> None:
    store = reference[0]
    with pytest.raises(InputError, match=r"another sweep \(its params \(seed\) differ\)"):
        run_sweep(store, GRID, toy_block, {**PARAMS, "seed": 8}, progress=False)
    other_grid = SweepGrid(
        dims={**GRID.dims, "pitch": [4, 6]},
        variables=GRID.variables,
        block_dims=GRID.block_dims,
        attrs=GRID.attrs,
    )
    with pytest.raises(InputError, match=r"its grid differ") as err:
        run_sweep(store, other_grid, toy_block, PARAMS, progress=False)
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="function"):
        run_sweep(store, GRID, bad_block, PARAMS, progress=False)
    with pytest.raises(InputError, match="not a sweep store"):
        run_sweep(Path(__file__), GRID, toy_block, PARAMS, progress=False)


def test_a_task_returning_wrong_shapes_stops_the_sweep_with_a_clear_error(
    scheduler: str, tmp_path: Path
) -> None:
    store = tmp_path / "bad.zarr"
    with pytest.raises(SweepError, match=r"rmse_mm has shape \(3,\), expected \(3, 2\)"):
        run_sweep(store, GRID, bad_block, PARAMS, scheduler=scheduler, progress=False)
    assert sweep_status(store).done == 0


def test_grids_are_validated() -> None:
    var = [Variable("v")]
    with pytest.raises(InputError, match="block_dims"):
        SweepGrid(dims={"a": [1, 2]}, variables=var, block_dims=["b"])
    with pytest.raises(InputError, match="mixes strings and numbers"):
        SweepGrid(dims={"a": [1, "x"]}, variables=var)
    with pytest.raises(InputError, match="repeat"):
        SweepGrid(dims={"a": [1, 1]}, variables=var)
    with pytest.raises(InputError, match="fill"):
        Variable("n", "int16")
    with pytest.raises(InputError, match="taken"):
        SweepGrid(dims={"a": [1]}, variables=[Variable("a")])
    grid = SweepGrid(dims={"b": ["x", "y"], "a": [1, 2, 3]}, variables=var, block_dims=["a"])
    assert grid.block_coords((1,)) == {"b": "y", "a": (1, 2, 3)}
    assert SweepGrid.from_json(json.loads(json.dumps(GRID.to_json()))) == GRID
