"""The public API: ``import hdrfringe as hf`` offers the names a user needs, loaded lazily."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import hdrfringe

STUB = Path(hdrfringe.__file__).with_suffix(".pyi")

#: Heavy dependencies that ``import hdrfringe`` must not load (sweeps and figures only).
HEAVY = ("dask", "distributed", "matplotlib", "xarray", "zarr")


def _imported_after(code: str) -> list[str]:
    probe = f"import sys; {code}; print(' '.join(m for m in {HEAVY!r} if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    return out.stdout.split()


def test_import_pulls_in_neither_dask_nor_matplotlib() -> None:
    assert _imported_after("import hdrfringe") == []


def test_the_core_pipeline_names_load_without_the_heavy_dependencies() -> None:
    names = "wrapped_phase, decode_set, unwrap_temporal, Calibration, SimulatedRig, lpa, dpa"
    assert _imported_after(f"from hdrfringe import {names}") == []


def test_the_probe_sees_a_heavy_import() -> None:
    """The checks above can fail: the probe reports a heavy module once something loads it."""
    assert _imported_after("import hdrfringe, xarray") == ["xarray"]


def test_every_public_name_resolves_to_its_module_object() -> None:
    tree = ast.parse(STUB.read_text())
    expected = {}
    for node in tree.body:
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                expected[alias.asname or alias.name] = (f"hdrfringe.{node.module}", alias.name)
    assert set(hdrfringe.__all__) == {*expected, "__version__"}
    import importlib

    for public, (module, name) in expected.items():
        assert getattr(hdrfringe, public) is getattr(importlib.import_module(module), name)
    assert set(hdrfringe.__all__) <= set(dir(hdrfringe))


def test_an_unknown_name_is_an_attribute_error() -> None:
    import pytest

    with pytest.raises(AttributeError):
        hdrfringe.no_such_name  # noqa: B018


def test_version_is_the_installed_distribution_version() -> None:
    from importlib.metadata import version

    assert hdrfringe.__version__ == version("hdrfringe")


def test_the_package_is_typed() -> None:
    assert (Path(hdrfringe.__file__).parent / "py.typed").is_file()


def test_the_hardware_names_load_without_device_packages() -> None:
    """The rig configuration and hardware names are public and cheap: the device packages
    (pyglet, pypylon, harvesters, OpenCV) load only when a device is opened."""
    names = "RigConfig, load_rig_config, HardwareRig, SyncSettings, ScreenProjector, open_camera"
    probe = (
        f"import sys; from hdrfringe import {names}; "
        "print(' '.join(m for m in ('pyglet', 'pypylon', 'harvesters', 'cv2', *"
        f"{HEAVY!r}) if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert out.stdout.split() == []
    assert {"RigConfig", "load_rig_config", "HardwareRig", "open_camera"} <= set(hdrfringe.__all__)
