"""``hdrfringe reproduce``'s bad inputs: each is one line on stderr, exit code 2, nothing written.

Moved from the product's tests with the command (issue 29): the argument cases of
tests/test_fuzz.py and tests/test_cli_errors.py, and the Dask scheduler address of
tests/test_damaged_inputs.py (issue 11: before, an 87-line traceback or a hang). A last case
checks that the command reaches ``hdrfringe`` through its entry point, not a product module.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from tests.conftest import run_cli, run_cli_in_process

from hdrfringe.errors import InputError
from hdrfringe_thesis.engine import SCHEDULER_TIMEOUT_S, check_scheduler


def _one_line_failure(res, *needles: str) -> None:
    assert res.returncode == 2, res.stdout + res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), res.stderr
    assert "Traceback" not in res.stderr
    for n in needles:
        assert n in lines[0], lines[0]


def _tree(root: Path) -> dict[str, str]:
    """Every path under root (folders too) with the SHA-256 of each file's bytes."""
    return {
        str(p.relative_to(root)): (
            hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        )
        for p in sorted(root.rglob("*"))
    }


N400 = "4" * 400
#: (id, arguments, text the one line must hold or None); argument errors only: no cluster is
#: started. {r}: a folder holding notes.txt (a file); {o}: a new folder in it.
CASES: list[tuple[str, list[str], str | None]] = [
    ("reproduce-unknown-chapter", ["reproduce", "ch9", "-o", "{o}"], None),
    ("reproduce-workers-0", ["reproduce", "ch4", "-o", "{o}", "--workers", "0"],
     "--workers (n_workers) must be at least 1"),
    ("reproduce-workers-negative", ["reproduce", "ch4", "-o", "{o}", "--workers", "-4"], None),
    ("reproduce-workers-400-digits", ["reproduce", "ch4", "-o", "{o}", "--workers", N400], None),
    ("reproduce-out-is-file", ["reproduce", "ch4", "-o", "{r}/notes.txt"], None),
    ("reproduce-bad-scheduler",
     ["reproduce", "ch4", "-o", "{o}", "--scheduler", "not an address"], None),
    ("reproduce-scheduler-bad-port",
     ["reproduce", "ch4", "-o", "{o}", "--scheduler", "tcp://127.0.0.1:99999"],
     "Port out of range"),
]  # fmt: skip


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path: Path, case: tuple) -> None:
    (tmp_path / "notes.txt").write_text("a file, not a folder\n")
    before = _tree(tmp_path)
    args = [a.format(r=tmp_path, o=tmp_path / "out") for a in case[1]]
    res = run_cli_in_process(*args)  # the CLI's entry point in-process (tests/conftest.py)
    _one_line_failure(res, *([case[2]] if case[2] else []))
    assert len(res.stderr.strip()) < 300  # a 400-digit number is not echoed whole
    assert _tree(tmp_path) == before  # nothing new, nothing removed, every byte the same


def test_the_command_comes_from_the_entry_point() -> None:
    """``reproduce`` is this package's entry point (research/pyproject.toml), not a product
    command: without the entry point the product would say it is not installed."""
    from hdrfringe.cli._app import COMMAND_MODULES, plugin_commands

    assert "reproduce" not in COMMAND_MODULES
    assert plugin_commands()["reproduce"] == "hdrfringe_thesis.cli:reproduce"
    res = run_cli_in_process("reproduce", "--help")
    assert res.returncode == 0 and "--scheduler" in res.stdout, res.stderr


# --------------------------------------------------------------------------------------------
# reproduce --scheduler: the address must answer as a Dask scheduler, before anything is written
# --------------------------------------------------------------------------------------------
@contextlib.contextmanager
def _tcp_server(reply: bytes | None) -> Iterator[str]:
    """A local TCP service in a thread: sends ``reply`` to every client (None: stays silent)."""
    server = socket.create_server(("127.0.0.1", 0))
    server.settimeout(0.2)
    stop = threading.Event()
    conns: list[socket.socket] = []

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            conns.append(conn)
            if reply is not None:
                conn.sendall(reply)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join()
        for conn in conns:
            conn.close()
        server.close()


HTTP_REPLY = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\nConnection: keep-alive\r\n\r\n"


@pytest.mark.parametrize(
    ("reply", "needle"), [(HTTP_REPLY, "another protocol"), (None, "within 2 s")]
)
def test_check_scheduler_refuses_a_non_scheduler_within_the_timeout(
    reply: bytes | None, needle: str
) -> None:
    """Before: an 87-line traceback ("Unable to allocate 3.07 EiB") or a hang past 120 s."""
    with _tcp_server(reply) as address:
        start = time.monotonic()
        with pytest.raises(InputError, match="no Dask scheduler answered") as info:
            check_scheduler(address, timeout=2)
        assert time.monotonic() - start < 4
    assert "\n" not in str(info.value) and needle in str(info.value)


def test_check_scheduler_accepts_a_dask_scheduler_only() -> None:
    from distributed import Scheduler, Worker

    async def main() -> tuple[str, str]:
        async with Scheduler(dashboard_address=None) as s, Worker(s.address) as w:
            loop = asyncio.get_running_loop()
            await loop.run_in_executor(None, check_scheduler, s.address, 5.0)
            try:
                await loop.run_in_executor(None, check_scheduler, w.address, 5.0)
            except InputError as exc:
                return s.address, str(exc)
            return s.address, ""

    _, worker_error = asyncio.run(main())
    assert "the peer is Worker" in worker_error


def test_cli_reproduce_with_a_bad_scheduler_writes_nothing(tmp_path: Path) -> None:
    """A web server at the scheduler address: the command (a process of its own) answers in
    one line before anything is written."""
    out = tmp_path / "repro"
    with _tcp_server(HTTP_REPLY) as address:
        start = time.monotonic()
        res = run_cli("reproduce", "ch4", "--quick", "-o", str(out), "--scheduler", address)
        assert time.monotonic() - start < SCHEDULER_TIMEOUT_S + 8
    _one_line_failure(res, "no Dask scheduler answered", address)
    assert not out.exists()


def test_cli_reproduce_with_a_silent_scheduler_gives_up_after_the_timeout(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A peer that accepts and never answers: the command waits SCHEDULER_TIMEOUT_S (read when
    the check runs; 1 s here instead of the 10 s default, so the case costs 1 s), then says so
    in one line and writes nothing."""
    import hdrfringe_thesis.engine as engine

    monkeypatch.setattr(engine, "SCHEDULER_TIMEOUT_S", 1.0)
    out = tmp_path / "repro"
    with _tcp_server(None) as address:
        res = run_cli_in_process(
            "reproduce", "ch4", "--quick", "-o", str(out), "--scheduler", address
        )
    _one_line_failure(res, "no Dask scheduler answered", address)
    assert "within 1 s" in res.stderr  # the timeout read when the check ran
    assert not out.exists()


def test_second_run_on_a_locked_folder_is_refused(tmp_path: Path) -> None:
    """Two ``reproduce`` runs on one folder both ran the whole sweep (issue 31). The first
    run's lock is taken here as another process takes it (``flock`` on the folder, through an
    open file of its own); the second run is refused in one line before it writes anything."""
    import fcntl
    import os

    out = tmp_path / "repro"
    out.mkdir()
    fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        res = run_cli_in_process("reproduce", "ch4", "--quick", "-o", str(out))
    finally:
        os.close(fd)
    _one_line_failure(res, "another reproduce run is writing this folder")
    assert list(out.iterdir()) == []
