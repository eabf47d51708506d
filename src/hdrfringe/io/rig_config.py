"""Rig configuration files (TOML): read, check, and write (docs/hardware.md, "Rig configuration").

A lab describes its projector, camera, synchronisation and gamma once, in a small TOML file
(``docs/examples/rig.toml``), and gives it to ``capture``, ``rig check`` and ``measure --rig
hardware`` with ``--rig-config FILE``. :func:`load_rig_config` reads it with the bounded TOML
reader (size limit, no TOML bombs), resolves ``gamma = "gamma.json"`` (the file ``hdrfringe gamma
-o`` writes, relative to the configuration's folder) and checks every key
(:meth:`~hdrfringe.hardware.config.RigConfig.from_dict`); :func:`rig_config_toml` and
:func:`write_rig_config` write one (``rig check --write-config``).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from pathlib import Path
from typing import Any

from hdrfringe.errors import CaptureFormatError, InputError
from hdrfringe.hardware.config import DOC, RigConfig
from hdrfringe.io._read_limits import load_json_bounded, load_toml_bounded
from hdrfringe.io.results import staged_output_file

__all__ = [
    "MAX_RIG_CONFIG_BYTES",
    "gamma_from_report",
    "load_rig_config",
    "rig_config_toml",
    "write_rig_config",
]

#: Largest rig configuration file read (it holds a few settings).
MAX_RIG_CONFIG_BYTES = 64 << 10
#: The fits of a ``gamma.json`` in the order they are preferred.
GAMMA_FITS = ("uniform", "fringes")


def gamma_from_report(path: str | Path) -> float:
    """The gamma of a ``gamma.json`` written by ``hdrfringe gamma -o``.

    The uniform-gray fit (a direct measurement of the mapping) is taken when it is there and
    not degenerate, else the fringe-shape fit (docs/gamma.md).

    Parameters
    ----------
    path : str or Path
        The ``gamma.json``.

    Returns
    -------
    float
        The fitted gamma.

    Raises
    ------
    InputError
        A missing file, or one without a usable fit.
    CaptureFormatError
        A file that is not bounded JSON (:func:`~hdrfringe.io._read_limits.load_json_bounded`).

    References
    ----------
    Thesis Sec. 2.6, Eq. 2.16-2.17.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "gamma.json"
    >>> _ = p.write_text('{"uniform": {"gamma": 2.41, "degenerate": false}}')
    >>> gamma_from_report(p)
    2.41
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(
            f"{path}: gamma file does not exist; run hdrfringe gamma CAPTURES -o DIR and give "
            "DIR/gamma.json, or write the exponent as a number"
        )
    report = load_json_bounded(path)
    for fit in GAMMA_FITS:
        entry = report.get(fit) if isinstance(report, dict) else None
        if not isinstance(entry, dict) or entry.get("degenerate") is True:
            continue
        value = entry.get("gamma")
        if not isinstance(value, bool) and isinstance(value, int | float):
            if math.isfinite(value) and value > 0:
                return float(value)
    raise InputError(
        f"{path}: no usable gamma fit (uniform or fringes, not degenerate) in it; measure the "
        "gamma again (docs/gamma.md) or write the exponent as a number"
    )


def load_rig_config(path: str | Path) -> RigConfig:
    """Read and check a rig configuration file.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file (docs/hardware.md, "Rig configuration").

    Returns
    -------
    RigConfig
        With ``source`` (the path) and ``sha256`` (of the file's bytes); ``gamma`` read from
        the ``gamma.json`` it names, if it names one (``gamma_file``: that file's path).

    Raises
    ------
    InputError
        A missing file, a folder, an oversized, non-UTF-8 or non-TOML file, an unknown key
        (named by its key path), a value of the wrong type or range.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "rig.toml"
    >>> _ = p.write_text('name = "bench"\\ngamma = 2.2\\n[camera]\\nspec = "pylon:emu"\\n'
    ...                  'exposure_ms = 20\\n[sync]\\nsettle_s = 0.05\\n')
    >>> cfg = load_rig_config(p)
    >>> cfg.name, cfg.camera.exposure_ms, cfg.sync.settle_s, len(cfg.sha256)
    ('bench', 20.0, 0.05, 64)
    >>> _ = p.write_text('[camera]\\nexposure_ms = "fast"\\n')
    >>> load_rig_config(p)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: ...: 'camera.exposure_ms' must be a positive number of ...
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(
            f"{path}: is a folder, not a rig configuration file; give the TOML file ({DOC})"
        )
    hasher = hashlib.sha256()  # of exactly the bytes parsed (one read)
    table = load_toml_bounded(
        path,
        what="rig configuration",
        max_bytes=MAX_RIG_CONFIG_BYTES,
        holds="holds a few settings",
        doc=DOC,
        missing=f"give the TOML file that describes the rig ({DOC})",
        on_bytes=hasher.update,
    )
    extra: dict[str, Any] = {"source": str(path), "sha256": hasher.hexdigest()}
    gamma = table.get("gamma")
    if isinstance(gamma, str):
        if not gamma.strip():
            raise InputError(
                f"{path}: 'gamma' is empty; give the exponent (gamma = 2.2) or the gamma.json "
                f"of hdrfringe gamma -o ({DOC})"
            )
        gamma_path = Path(gamma).expanduser()
        if not gamma_path.is_absolute():
            gamma_path = path.parent / gamma_path
        try:
            value = gamma_from_report(gamma_path)
        except (InputError, CaptureFormatError) as exc:
            raise InputError(f"{path}: gamma: {exc}") from None
        table = {**table, "gamma": value}
        extra["gamma_file"] = str(gamma_path)
    return RigConfig.from_dict(table, where=str(path), **extra)


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise InputError(f"cannot write {value} to a rig configuration; give finite numbers")
        return repr(value)
    # a TOML basic string: JSON's escapes are TOML's, except DEL, which TOML wants escaped
    return json.dumps(str(value), ensure_ascii=False).replace("\x7f", "\\u007f")


def rig_config_toml(config: RigConfig, *, header: str = "", base: str | Path | None = None) -> str:
    """A rig configuration as TOML text that :func:`load_rig_config` reads back.

    Parameters
    ----------
    config : RigConfig
        The configuration; fields not set are left out.
    header : str
        Comment lines written first (each prefixed with ``#``).
    base : str or Path, optional
        The folder the file will be in: a ``gamma_file`` is written relative to it.

    Returns
    -------
    str

    Examples
    --------
    >>> cfg = RigConfig.from_dict({"name": "bench", "camera": {"spec": "pylon:emu"}})
    >>> print(rig_config_toml(cfg).splitlines()[0:4])
    ['name = "bench"', '', '[camera]', 'spec = "pylon:emu"']
    """
    table = {k: v for k, v in config.to_dict().items() if v != {}}
    gamma_file = table.pop("gamma_file", None)
    if gamma_file is not None:  # the file it was read from, not its value
        if base is not None:
            gamma_file = os.path.relpath(Path(gamma_file).resolve(), Path(base).resolve())
        table["gamma"] = gamma_file
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    lines += [f"{key} = {_toml_value(table[key])}" for key in ("name", "gamma") if key in table]
    for section in ("projector", "camera", "sync"):
        if section in table:
            lines += ["", f"[{section}]"]
            lines += [f"{k} = {_toml_value(v)}" for k, v in table[section].items()]
    text = "\n".join(lines) + "\n"
    if tomllib.loads(text) != table:  # what is written must read back as the same table
        raise InputError("the rig configuration does not survive TOML; report this as a bug")
    return text


def write_rig_config(
    path: str | Path, config: RigConfig, *, force: bool = False, header: str = ""
) -> Path:
    """Write a rig configuration file, staged (complete or not at all).

    Parameters
    ----------
    path : str, Path or CheckedOutput
        The ``.toml`` file (an existing one is replaced only with ``force``).
    config : RigConfig
        What to write.
    force : bool
        Replace an existing file.
    header : str
        Comment lines at the top.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OutputExistsError
        The file exists (without ``force``) or a folder is in the way.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "rig.toml"
    >>> cfg = RigConfig.from_dict({"camera": {"spec": "pylon:emu"}, "sync": {"discard": 3}})
    >>> _ = write_rig_config(p, cfg, header="written by a doctest")
    >>> load_rig_config(p).sync.discard
    3
    """
    target = Path(path)
    text = rig_config_toml(config, header=header, base=target.parent)
    with staged_output_file(path, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return target
