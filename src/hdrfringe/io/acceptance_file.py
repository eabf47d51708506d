"""The acceptance file (TOML): the MPEs and the artefacts' calibrated dimensions.

``hdrfringe acceptance`` compares the VDI/VDE 2634 Part 2 quantities with maximum permissible
errors and needs the calibrated size of each artefact (docs/acceptance.md, "The acceptance
file"; an example in ``docs/examples/acceptance.toml``). :func:`load_acceptance_file` reads one
with the bounded TOML reader and checks every key: an unknown or missing key, a value of the
wrong type, a non-finite or negative number is refused with one line naming the file, the key
and the fix.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hdrfringe.core.acceptance import Mpe, MpeSet, body_diagonal
from hdrfringe.errors import InputError
from hdrfringe.io._read_limits import load_toml_bounded

__all__ = [
    "MAX_ACCEPTANCE_FILE_BYTES",
    "AcceptanceFile",
    "BallBarArtefact",
    "PlaneArtefact",
    "SphereArtefact",
    "load_acceptance_file",
    "parse_acceptance",
]

#: Largest acceptance file read (it holds a few numbers).
MAX_ACCEPTANCE_FILE_BYTES = 64 << 10
DOC = "docs/acceptance.md"


@dataclass(frozen=True)
class SphereArtefact:
    """The calibrated sphere of the probing error test.

    Parameters
    ----------
    diameter_mm : float
        Calibrated diameter, mm.
    form_mm : float or None
        Its calibrated form deviation, mm, if the certificate states one (reported with PF,
        not subtracted from it).

    Examples
    --------
    >>> SphereArtefact(25.0).form_mm is None
    True
    """

    diameter_mm: float
    form_mm: float | None = None


@dataclass(frozen=True)
class BallBarArtefact:
    """The calibrated ball bar of the sphere-spacing test.

    Parameters
    ----------
    distance_mm : float
        Calibrated centre distance, mm.
    diameters_mm : tuple of float
        Calibrated diameters of sphere A and sphere B, mm.
    form_mm : tuple of float or None
        Their calibrated form deviations, mm, if stated.

    Examples
    --------
    >>> BallBarArtefact(150.0, (25.0, 25.0)).distance_mm
    150.0
    """

    distance_mm: float
    diameters_mm: tuple[float, float]
    form_mm: tuple[float, float] | None = None


@dataclass(frozen=True)
class PlaneArtefact:
    """The calibrated plane of the flatness test.

    Parameters
    ----------
    length_mm : float
        Length, mm (the length of a length-dependent MPE of F).
    width_mm : float
        Width, mm.
    flatness_mm : float or None
        Its calibrated flatness, mm, if stated (reported with F, not subtracted from it).

    Examples
    --------
    >>> PlaneArtefact(200.0, 50.0).length_mm
    200.0
    """

    length_mm: float
    width_mm: float
    flatness_mm: float | None = None


@dataclass(frozen=True)
class AcceptanceFile:
    """A checked acceptance file (:func:`load_acceptance_file`).

    Parameters
    ----------
    mpe : MpeSet
        The maximum permissible errors.
    sphere, ball_bar, plane : artefact or None
        The artefacts the file describes (at least one).
    name : str
        A label (the file's ``name``, else "").
    volume_mm : tuple of float or None
        The measuring volume's edge lengths, mm, if given.
    source : str
        The file's path ("" when parsed from a table).
    sha256 : str
        Digest of the file's bytes ("" when parsed from a table).

    Examples
    --------
    >>> spec = parse_acceptance({"mpe": {"pf": 0.03, "ps": 0.03, "sd": 0.05, "f": 0.04},
    ...                          "sphere": {"diameter": 25.0}, "volume_mm": [300, 200, 150]})
    >>> spec.sphere.diameter_mm, spec.ball_bar is None, round(spec.l0_mm, 3)
    (25.0, True, 390.512)
    """

    mpe: MpeSet
    sphere: SphereArtefact | None = None
    ball_bar: BallBarArtefact | None = None
    plane: PlaneArtefact | None = None
    name: str = ""
    volume_mm: tuple[float, float, float] | None = None
    source: str = ""
    sha256: str = ""

    @property
    def l0_mm(self) -> float | None:
        """L0, the body diagonal of the measuring volume (None without ``volume_mm``)."""
        return None if self.volume_mm is None else body_diagonal(self.volume_mm)


def _fail(where: str, key: str, what: str, fix: str) -> InputError:
    return InputError(f"{where}: '{key}' {what}; {fix}")


def _check_keys(
    table: Mapping[str, Any], allowed: Sequence[str], required: Sequence[str], where: str, at: str
) -> None:
    for key in table:
        if key not in allowed:
            close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else f"known keys: {', '.join(allowed)}"
            raise _fail(where, at + key, "is not a key of an acceptance file", hint)
    for key in required:
        if key not in table:
            raise _fail(where, at + key, "is missing", f"add it ({DOC})")


def _table(value: Any, where: str, key: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise _fail(where, key, f"must be a table, got {value!r}", f"write it as [{key}] ({DOC})")
    return value


def _number(value: Any, where: str, key: str, *, positive: bool) -> float:
    ok = not isinstance(value, bool) and isinstance(value, int | float)
    if not ok or not math.isfinite(value) or value < 0 or (positive and value == 0):
        kind = "a positive" if positive else "a non-negative"
        raise _fail(
            where, key, f"must be {kind} finite number of mm, got {value!r}", f"give {kind} number"
        )
    return float(value)


def _pair(value: Any, where: str, key: str, *, positive: bool) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise _fail(where, key, f"must be a list of two numbers (A, B), got {value!r}", "fix it")
    a, b = (_number(v, where, key, positive=positive) for v in value)
    return a, b


def _mpe(value: Any, where: str, key: str, *, constant: bool) -> Mpe:
    if isinstance(value, Mapping):
        if constant:
            raise _fail(where, key, "must be a number of mm (a constant MPE)", "give e.g. 0.03")
        _check_keys(value, ("a", "k"), ("a", "k"), where, key + ".")
        return Mpe(
            _number(value["a"], where, key + ".a", positive=False),
            _number(value["k"], where, key + ".k", positive=True),
        )
    return Mpe(_number(value, where, key, positive=False))


def _optional(t: Mapping[str, Any], key: str, where: str, at: str) -> float | None:
    return None if key not in t else _number(t[key], where, at + key, positive=False)


def parse_acceptance(table: Mapping[str, Any], source: str = "acceptance file") -> AcceptanceFile:
    """Check a table parsed from an acceptance file's TOML.

    Parameters
    ----------
    table : mapping
        The parsed document.
    source : str
        Where it came from, for messages.

    Returns
    -------
    AcceptanceFile

    Raises
    ------
    InputError
        An unknown or missing key, a wrong type, a non-finite or negative number.

    Examples
    --------
    >>> parse_acceptance({"mpe": {"pf": 0.03, "ps": 0.03, "sd": 0.05}}, "a.toml")
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: a.toml: 'mpe.f' is missing; add it (docs/acceptance.md)
    """
    where = source
    _check_keys(
        table, ("name", "volume_mm", "mpe", "sphere", "ball_bar", "plane"), ("mpe",), where, ""
    )
    name = table.get("name", "")
    if not isinstance(name, str):
        raise _fail(where, "name", f"must be a string, got {name!r}", "quote it")
    volume = None
    if "volume_mm" in table:
        v = table["volume_mm"]
        if not isinstance(v, list) or len(v) != 3:
            raise _fail(where, "volume_mm", f"must be three edge lengths, got {v!r}", "fix it")
        x, y, z = (_number(e, where, "volume_mm", positive=True) for e in v)
        volume = (x, y, z)
    m = _table(table["mpe"], where, "mpe")
    _check_keys(m, ("pf", "ps", "sd", "f"), ("pf", "ps", "sd", "f"), where, "mpe.")
    mpe = MpeSet(
        pf=_mpe(m["pf"], where, "mpe.pf", constant=True),
        ps=_mpe(m["ps"], where, "mpe.ps", constant=True),
        sd=_mpe(m["sd"], where, "mpe.sd", constant=False),
        f=_mpe(m["f"], where, "mpe.f", constant=False),
    )
    sphere = ball_bar = plane = None
    if "sphere" in table:
        t = _table(table["sphere"], where, "sphere")
        _check_keys(t, ("diameter", "form"), ("diameter",), where, "sphere.")
        sphere = SphereArtefact(
            _number(t["diameter"], where, "sphere.diameter", positive=True),
            _optional(t, "form", where, "sphere."),
        )
    if "ball_bar" in table:
        t = _table(table["ball_bar"], where, "ball_bar")
        _check_keys(
            t, ("distance", "diameters", "form"), ("distance", "diameters"), where, "ball_bar."
        )
        form = t.get("form")
        ball_bar = BallBarArtefact(
            _number(t["distance"], where, "ball_bar.distance", positive=True),
            _pair(t["diameters"], where, "ball_bar.diameters", positive=True),
            None if form is None else _pair(form, where, "ball_bar.form", positive=False),
        )
    if "plane" in table:
        t = _table(table["plane"], where, "plane")
        _check_keys(t, ("length", "width", "flatness"), ("length", "width"), where, "plane.")
        plane = PlaneArtefact(
            _number(t["length"], where, "plane.length", positive=True),
            _number(t["width"], where, "plane.width", positive=True),
            _optional(t, "flatness", where, "plane."),
        )
    if sphere is None and ball_bar is None and plane is None:
        raise InputError(
            f"{where}: no artefact; describe at least one of [sphere], [ball_bar], [plane] ({DOC})"
        )
    return AcceptanceFile(mpe, sphere, ball_bar, plane, name, volume)


def load_acceptance_file(path: str | Path) -> AcceptanceFile:
    """Read and check an acceptance file (TOML).

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file (docs/acceptance.md, "The acceptance file").

    Returns
    -------
    AcceptanceFile
        With ``source`` (the path) and ``sha256`` (of the bytes parsed).

    Raises
    ------
    InputError
        A missing, oversized or non-TOML file, or any key the checks refuse
        (:func:`parse_acceptance`).

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "acceptance.toml"
    >>> _ = p.write_text('[mpe]\\npf = 0.03\\nps = 0.03\\nsd = {a = 0.02, k = 20000}\\n'
    ...                  'f = 0.04\\n[plane]\\nlength = 200\\nwidth = 50\\n')
    >>> spec = load_acceptance_file(p)
    >>> spec.mpe.sd.at(200.0), spec.plane.length_mm, len(spec.sha256)
    (0.03, 200.0, 64)
    >>> _ = p.write_text('[mpe]\\npf = -1\\nps = 0.03\\nsd = 0.05\\nf = 0.04\\n')
    >>> load_acceptance_file(p)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: ...: 'mpe.pf' must be a non-negative finite number of mm, ...
    """
    path = Path(path)
    hasher = hashlib.sha256()
    table = load_toml_bounded(
        path,
        what="acceptance",
        max_bytes=MAX_ACCEPTANCE_FILE_BYTES,
        holds="holds a few numbers",
        doc=DOC,
        missing=f"give the TOML file with the MPEs and the artefacts ({DOC}, "
        "docs/examples/acceptance.toml)",
        on_bytes=hasher.update,
    )
    spec = parse_acceptance(table, str(path))
    return dataclasses.replace(spec, source=str(path), sha256=hasher.hexdigest())
