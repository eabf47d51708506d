"""Fixtures of the research tests: the session's quick reproduction, and the product's test
helpers (``tests/conftest.py`` of the repository: running the command line)."""

from __future__ import annotations

from pathlib import Path

import pytest
from tests.conftest import run_cli, run_cli_in_process, run_cli_subprocess

__all__ = ["run_cli", "run_cli_in_process", "run_cli_subprocess"]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark the tests that use the quick reproduction (``quick_run``) ``quick_reproduction``:
    ``make test`` runs them in its narrowed numeric run only, so that the 90 s sweep runs once;
    and put them in the xdist group ``dask-cluster`` (one worker, one sweep): a test that used
    the fixture without the group made the other worker run a second sweep."""
    for item in items:
        if "quick_run" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.quick_reproduction)
            if item.get_closest_marker("xdist_group") is None:
                item.add_marker(pytest.mark.xdist_group("dask-cluster"))


@pytest.fixture(scope="session")  # once per xdist worker, even if modules interleave
def quick_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``hdrfringe reproduce all --quick`` (Ch. 4, 5 and 6 on the reduced grid), run once.

    Tests using it start a dask cluster: mark them ``xdist_group("dask-cluster")``.
    """
    out = tmp_path_factory.mktemp("repro") / "all"
    # a process of its own: it starts a Dask cluster (worker processes), which the test
    # process should not host
    res = run_cli_subprocess(
        "reproduce", "all", "--quick", "-o", str(out), "--workers", "2", timeout=600
    )
    assert res.returncode == 0, res.stderr
    return out
