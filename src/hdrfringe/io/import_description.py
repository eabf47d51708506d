"""Import descriptions: what was projected, read from a small TOML file (docs/import.md).

An import description tells ``hdrfringe import`` which camera image shows which projector frame:
the camera's bit depth, the projector's size, and groups of frames (``[[fringe]]``,
``[[uniform]]``), each with where its images are (a file-name template, a regular expression,
an explicit list, or a ``.npy``/``.npz`` stack) and what was projected (periods or pitch, shift
angles and their sign, cosine or sine profile, phase offset, gray levels). This module parses
and checks the description (unknown keys are refused with a did-you-mean) and compiles the
file-name templates; :mod:`hdrfringe.io.importer` finds the files and writes the capture folder.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hdrfringe.core.limits import MAX_PROGRAM_FRAMES, MAX_STEPS
from hdrfringe.core.patterns import ORIENTATIONS, PATTERNS
from hdrfringe.errors import InputError
from hdrfringe.io._read_limits import load_toml_bounded

__all__ = [
    "TEMPLATE_FIELDS",
    "Description",
    "FrameGroup",
    "Template",
    "compile_template",
    "parse_description",
    "read_description",
]

#: The fields a file-name template may hold, per group kind.
TEMPLATE_FIELDS = {
    "fringe": ("orientation", "periods", "pitch", "step", "index"),
    "uniform": ("index",),
    "graycode": ("orientation", "bit", "index"),
}
#: Largest description file read (a description lists groups, it holds no data).
MAX_DESCRIPTION_BYTES = 1 << 20

_TOP_KEYS = ("note", "camera", "projector", "fringe", "uniform", "graycode")
_CAMERA_KEYS = ("bit_depth", "float_scale", "frame_size", "crop_offset")
_PROJECTOR_KEYS = ("width", "height", "bit_depth", "gamma_precompensation")
_SOURCE_KEYS = ("files", "regex", "stack", "key", "axes", "stack_frames", "first_index")
_FRINGE_KEYS = (
    *_SOURCE_KEYS,
    "note",
    "orientation",
    "orientation_names",
    "periods",
    "pitch",
    "steps",
    "shifts_deg",
    "shift_sign",
    "step_numbers",
    "pattern",
    "profile",
    "phase_offset_deg",
    "imin",
    "migl",
    "gamma_precompensation",
    "exposure_ms",
)
_UNIFORM_KEYS = (*_SOURCE_KEYS, "note", "level", "exposure_ms")
_GRAYCODE_KEYS = (
    *_SOURCE_KEYS,
    "note",
    "orientation",
    "orientation_names",
    "bits",
    "stripe",
    "code",
    "inverse",
    "bit_order",
    "migl",
    "convention",
    "exposure_ms",
)
#: Gray-code word types (docs/capture_format.md, "Gray-code frames").
_CODES = ("gray", "binary")
_NUMBER = r"\d+(?:\.\d+)?"


def _fail(where: str, what: str, fix: str) -> InputError:
    return InputError(f"{where}: {what}; {fix}")


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
    for key in table:
        if key not in allowed:
            close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else f"known keys: {', '.join(allowed)}"
            raise _fail(where, f"unknown key '{key}'", hint)


def _num(value: Any, where: str, key: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise _fail(where, f"'{key}' must be a finite number, got {value!r}", "fix the description")
    if positive and value <= 0:
        raise _fail(where, f"'{key}' must be positive, got {value!r}", "fix the description")
    return float(value)


def _int(value: Any, where: str, key: str, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
        raise _fail(
            where, f"'{key}' must be an integer in {lo}..{hi}, got {value!r}", "fix the description"
        )
    return int(value)


def _list(value: Any) -> list[Any]:
    return list(value) if isinstance(value, list) else [value]


#: Seconds a description's regular expression may spend on all file names of the images
#: folder together (Template.parse): a catastrophically backtracking one is refused instead of
#: running for minutes.
REGEX_SECONDS = 2.0


@dataclass(frozen=True)
class Template:
    """A compiled file-name template or regular expression.

    Parameters
    ----------
    text : str
        The template (or the regular expression) as written in the description.
    regex : re.Pattern or regex.Pattern
        Matches a file's path relative to the images folder (POSIX ``/``), whole; a
        description's own regular expression is compiled with the ``regex`` module, whose
        timeout bounds it (:meth:`parse`).
    fields : tuple of str
        The fields it captures, in order.
    specs : dict
        Field -> Python format spec that the captured text must reproduce (``"03d"``).
    orientation_names : dict
        Text in file names -> orientation (``{"h": "horizontal"}``).
    where : str
        Where the template is (the description's group), for messages.

    Examples
    --------
    >>> t = compile_template("scan{orientation}_f{periods:03d}_n{step}.png", "fringe",
    ...                      {"": "vertical", "h": "horizontal"}, "example")
    >>> t.parse("scanh_f004_n2.png")
    {'orientation': 'horizontal', 'periods': 4.0, 'step': 2.0}
    >>> t.parse("scanh_f4_n2.png") is None  # {periods:03d}: three digits
    True
    """

    text: str
    regex: Any  # re.Pattern[str]; a regex.Pattern for a description's own expression
    fields: tuple[str, ...]
    specs: dict[str, str]
    orientation_names: dict[str, str]
    where: str = ""

    @property
    def user_regex(self) -> bool:
        """Whether this is a description's own regular expression (matched with a time bound)."""
        return not isinstance(self.regex, re.Pattern)

    def parse(self, rel: str, *, timeout: float = REGEX_SECONDS) -> dict[str, Any] | None:
        """The field values of file ``rel`` (relative POSIX path), or None if it does not match.

        Parameters
        ----------
        rel : str
            Path relative to the images folder.
        timeout : float
            Seconds a description's regular expression may take on ``rel`` (templates, which
            compile to expressions without nested repeats, are not bounded).

        Returns
        -------
        dict or None
            Orientation as ``"vertical"``/``"horizontal"``, numbers as float.

        Raises
        ------
        InputError
            The regular expression took longer than ``timeout`` (catastrophic backtracking).
        """
        if self.user_regex:
            try:
                m = self.regex.fullmatch(rel, timeout=max(timeout, 1e-3))
            except TimeoutError:
                raise _fail(
                    self.where,
                    f"the regular expression {self.text!r} takes more than {REGEX_SECONDS:g} s "
                    f"on the file names (at {rel!r}): it backtracks catastrophically (a repeat "
                    "that can match the same text in many ways, such as (a+)+ or (a|aa)+)",
                    "rewrite it without nested repeats, or use a file-name template",
                ) from None
        else:
            m = self.regex.fullmatch(rel)
        if m is None:
            return None
        out: dict[str, Any] = {}
        for name in self.fields:
            text = m.group(name)
            if name == "orientation":
                if text not in self.orientation_names:
                    return None
                out[name] = self.orientation_names[text]
                continue
            try:
                value = float(text)
            except ValueError:
                return None
            spec = self.specs.get(name)
            if spec:
                shown = int(value) if spec.endswith("d") and value.is_integer() else value
                try:
                    if format(shown, spec) != text:
                        return None
                except (ValueError, TypeError):
                    return None
            out[name] = value
        return out


def compile_template(
    text: str, kind: str, orientation_names: Mapping[str, str], where: str, *, regex: bool = False
) -> Template:
    """Compile a file-name template (or a regular expression with named groups).

    Template syntax: ``{field}`` or ``{field:spec}`` with a field of :data:`TEMPLATE_FIELDS`;
    numbers match any digits (``{step}`` matches ``2`` and ``02``) unless a Python format spec
    is given, which the text must reproduce exactly (``{step:02d}`` matches ``02`` only);
    ``{orientation}`` matches the group's orientation names; ``*`` matches any characters
    within one folder level, ``**/`` any number of folders; everything else is literal.

    Parameters
    ----------
    text : str
        The template or regular expression.
    kind : str
        Group kind (``"fringe"``, ``"uniform"``), which decides the fields allowed.
    orientation_names : mapping
        Text in file names -> orientation.
    where : str
        Where the template is, for messages.
    regex : bool
        ``text`` is a regular expression whose named groups are fields.

    Returns
    -------
    Template

    Raises
    ------
    InputError
        An unknown field (with a did-you-mean), a field given twice, or a bad expression.

    Examples
    --------
    >>> t = compile_template("pat{step:02d}.png", "fringe", {}, "example")
    >>> t.parse("pat07.png"), t.parse("pat7.png")
    ({'step': 7.0}, None)
    """
    allowed = TEMPLATE_FIELDS[kind]
    names = sorted(orientation_names, key=len, reverse=True)
    orient_re = "|".join(re.escape(n) for n in names)

    def check_field(name: str) -> None:
        if name not in allowed:
            close = difflib.get_close_matches(name, allowed, n=1, cutoff=0.5)
            hint = (
                f"did you mean '{close[0]}'?"
                if close
                else (f"fields here: {', '.join(allowed)}" if allowed else "give a plain path")
            )
            raise _fail(where, f"unknown template field {{{name}}} in {text!r}", hint)

    if regex:
        # the regex module, for its timeout (Template.parse): re cannot stop an expression
        # such as (a|aa)+b, which takes minutes on a 40-character file name
        import regex as regex_module

        try:
            compiled = regex_module.compile(text)
        except regex_module.error as exc:
            raise _fail(where, f"bad regular expression {text!r} ({exc})", "fix it") from None
        fields = tuple(compiled.groupindex)
        for name in fields:
            check_field(name)
        return Template(text, compiled, fields, {}, dict(orientation_names), where)
    parts: list[str] = []
    fields_l: list[str] = []
    specs: dict[str, str] = {}
    pos = 0
    for m in re.finditer(r"\{([^{}]*)\}|\*\*/|\*", text):
        parts.append(re.escape(text[pos : m.start()]))
        pos = m.end()
        token = m.group(0)
        if token == "**/":
            parts.append(r"(?:[^/]+/)*")
            continue
        if token == "*":
            parts.append(r"[^/]*")
            continue
        name, _, spec = m.group(1).partition(":")
        name = name.strip()
        check_field(name)
        if name in fields_l:
            raise _fail(where, f"field {{{name}}} appears twice in {text!r}", "give it once")
        fields_l.append(name)
        if name == "orientation":
            if spec:
                raise _fail(
                    where,
                    f"{{orientation}} takes no format spec in {text!r}",
                    "name the texts with 'orientation_names'",
                )
            parts.append(f"(?P<orientation>{orient_re})")
        else:
            if spec:
                try:
                    if any(len(n) > 3 or int(n) > 255 for n in re.findall(r"\d+", spec)):
                        # a width beyond a file name's 255 bytes; 1e11 would exhaust memory
                        raise ValueError("width or precision above 255")
                    format(1, spec) if spec.endswith("d") else format(1.0, spec)
                except ValueError:
                    raise _fail(
                        where,
                        f"bad format spec {spec!r} for {{{name}}} in {text!r}",
                        "use a Python format spec such as 03d or .2f",
                    ) from None
                specs[name] = spec
            parts.append(f"(?P<{name}>{_NUMBER})")
    rest = text[pos:]
    if "{" in rest or "}" in rest:
        raise _fail(where, f"unbalanced braces in template {text!r}", "write fields as {name}")
    parts.append(re.escape(rest))
    return Template(
        text, re.compile("".join(parts)), tuple(fields_l), specs, dict(orientation_names), where
    )


@dataclass(frozen=True)
class FrameGroup:
    """One group of frames of a description (a ``[[fringe]]``, ``[[graycode]]`` or ``[[uniform]]``
    table).

    Parameters
    ----------
    kind : {"fringe", "graycode", "uniform"}
    index : int
        Position among the groups of its kind (0-based), for messages.
    where : str
        The group's name in messages, e.g. ``"d.toml fringe group 2"``.
    files : Template or list of str or None
        Where the images are: a compiled template/regex, or explicit paths in frame order.
    stack : str or None
        A ``.npy``/``.npz`` stack holding the frames instead, with ``key``, ``axes`` and
        ``stack_frames``.
    key, axes, stack_frames
        The stack's array name (``.npz``), axis order (a permutation of ``"nyx"``), and the
        stack indices of the group's frames in frame order (default: all, in order).
    frames : list of dict
        The frames in order: manifest fields (without ``file``) plus ``_key``, the field
        values that select the frame's image, and ``_label``, its name in messages.

    Examples
    --------
    >>> d = parse_description({"camera": {"bit_depth": 8},
    ...                        "uniform": [{"files": "white.png", "level": "white"}]}, "ex")
    >>> d.groups[0].frames[0]["level"]
    255.0
    """

    kind: str
    index: int
    where: str
    files: Template | list[str] | None
    stack: str | None
    key: str | None
    axes: str
    stack_frames: list[int] | None
    frames: list[dict[str, Any]]


@dataclass(frozen=True)
class Description:
    """A parsed import description.

    Parameters
    ----------
    camera_bit_depth : int
        Sensor bit depth B.
    float_scale : float or None
        DN per unit of float images (None: float images are refused).
    projector : dict
        The manifest's ``projector`` entry (may be empty).
    groups : list of FrameGroup
        In the description's order.
    source : str
        The description's path, for messages.
    notes : list of str
        The description's ``note``, if any.
    frame_size : tuple of int or None
        ``(width, height)`` of the camera's full frame when the images are crops of it
        (``camera.frame_size``); None: the images are the frame.
    crop_offset : tuple of int or None
        ``(x0, y0)``: where the images start in that frame (``camera.crop_offset``, or the
        importer's ``crop_offset`` argument, which wins).

    Examples
    --------
    >>> d = parse_description({"camera": {"bit_depth": 12},
    ...                        "fringe": [{"files": "s{step}.png", "steps": 3, "pitch": 8}]}, "ex")
    >>> len(d.groups[0].frames), d.groups[0].frames[2]["_shift_deg"]
    (3, 240.0)
    """

    camera_bit_depth: int
    float_scale: float | None
    projector: dict[str, Any]
    groups: list[FrameGroup]
    source: str
    notes: list[str] = field(default_factory=list)
    frame_size: tuple[int, int] | None = None
    crop_offset: tuple[int, int] | None = None


def read_description(path: str | Path) -> Description:
    """Read and check an import description (TOML, docs/import.md).

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.

    Returns
    -------
    Description

    Raises
    ------
    InputError
        A missing, oversized or unparsable file, or any field breaking docs/import.md.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "d.toml"
    >>> _ = p.write_text('[camera]\\nbit_depth = 8\\n'
    ...                  '[[uniform]]\\nfiles = "w.png"\\nlevel = 255\\n')
    >>> read_description(p).groups[0].kind
    'uniform'
    """
    path = Path(path)
    table = load_toml_bounded(
        path,
        what="description",
        max_bytes=MAX_DESCRIPTION_BYTES,
        holds="lists frame groups and holds no data",
        doc="docs/import.md",
        missing="give the TOML description",
    )
    return parse_description(table, str(path))


def parse_description(table: Mapping[str, Any], source: str) -> Description:
    """Check a description already parsed from TOML and expand its groups into frames.

    Parameters
    ----------
    table : mapping
        The parsed TOML document.
    source : str
        Its path (for messages).

    Returns
    -------
    Description

    Raises
    ------
    InputError
        Unknown keys (with a did-you-mean), missing or inconsistent fields.

    Examples
    --------
    >>> d = parse_description({"camera": {"bit_depth": 8}, "projector": {"width": 1920,
    ...     "height": 1080}, "fringe": [{"files": "v{periods}_{step}.png", "steps": 4,
    ...     "periods": [1, 16], "profile": "sine"}]}, "ex")
    >>> [f["pitch"] for f in d.groups[0].frames[::4]]
    [1920.0, 120.0]
    """
    _check_keys(table, _TOP_KEYS, source)
    camera = table.get("camera")
    if not isinstance(camera, dict):
        raise _fail(source, "no camera table", "add a camera table with bit_depth = B")
    _check_keys(camera, _CAMERA_KEYS, f"{source} camera")
    if "bit_depth" not in camera:
        raise _fail(f"{source} camera", "missing 'bit_depth'", "give the sensor's bit depth")
    bit_depth = _int(camera["bit_depth"], f"{source} camera", "bit_depth", 1, 16)
    float_scale = None
    if "float_scale" in camera:
        float_scale = _num(camera["float_scale"], f"{source} camera", "float_scale", positive=True)
    frame_size = crop_offset = None
    if "frame_size" in camera:
        frame_size = _pair(camera["frame_size"], f"{source} camera", "frame_size", 1)
    if "crop_offset" in camera:
        crop_offset = _pair(camera["crop_offset"], f"{source} camera", "crop_offset", 0)
        if frame_size is None:
            raise _fail(
                f"{source} camera",
                "crop_offset without frame_size",
                "give frame_size = [WIDTH, HEIGHT], the full frame the crops come from",
            )
    projector_in = table.get("projector", {})
    if not isinstance(projector_in, dict):
        raise _fail(source, "'projector' must be a table", "write it as a TOML table")
    pw = f"{source} projector"
    _check_keys(projector_in, _PROJECTOR_KEYS, pw)
    projector: dict[str, Any] = {}
    for key in ("width", "height"):
        if key in projector_in:
            projector[key] = _int(projector_in[key], pw, key, 1, 1 << 20)
    projector["bit_depth"] = _int(projector_in.get("bit_depth", 8), pw, "bit_depth", 1, 16)
    if "gamma_precompensation" in projector_in:
        projector["gamma_precompensation"] = _num(
            projector_in["gamma_precompensation"], pw, "gamma_precompensation", positive=True
        )
    groups: list[FrameGroup] = []
    for kind in ("fringe", "graycode", "uniform"):
        tables = table.get(kind, [])
        if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
            raise _fail(
                source, f"'{kind}' must be tables", f"write each {kind} group as a TOML table"
            )
        for i, t in enumerate(tables):
            where = f"{source} {kind} group {i + 1}"
            if kind == "fringe":
                group = _fringe_group(t, i, where, projector)
            elif kind == "graycode":
                group = _graycode_group(t, i, where)
            else:
                group = _uniform_group(t, i, where, projector)
            groups.append(_number_frames(group, t, where))
    if not groups:
        raise _fail(source, "no frame groups", "add fringe, graycode or uniform tables")
    total = sum(len(g.frames) for g in groups)
    if total > MAX_PROGRAM_FRAMES:
        raise _fail(
            source, f"{total} frames, more than {MAX_PROGRAM_FRAMES}", "import in several parts"
        )
    notes = [str(table["note"])] if "note" in table else []
    return Description(
        bit_depth, float_scale, projector, groups, source, notes, frame_size, crop_offset
    )


def _pair(value: Any, where: str, key: str, lo: int) -> tuple[int, int]:
    """Two whole numbers ``[a, b]``, each ``>= lo``."""
    if not isinstance(value, list) or len(value) != 2:
        raise _fail(where, f"'{key}' must be two whole numbers [x, y]", f"write {key} = [x, y]")
    a, b = (_int(v, where, key, lo, 1 << 20) for v in value)
    return a, b


def _source(t: Mapping[str, Any], kind: str, where: str, names: Mapping[str, str]) -> Any:
    given = [k for k in ("files", "regex", "stack") if k in t]
    if len(given) != 1:
        raise _fail(
            where,
            "give exactly one of 'files', 'regex' and 'stack'"
            + (f" (got {', '.join(given)})" if given else ""),
            "say where the group's images are",
        )
    for key in ("key", "axes", "stack_frames"):
        if key in t and "stack" not in t:
            raise _fail(where, f"'{key}' applies to a 'stack' only", "remove it or use 'stack'")
    if "regex" in t:
        if not isinstance(t["regex"], str):
            raise _fail(where, "'regex' must be a string", "fix the description")
        return compile_template(t["regex"], kind, names, where, regex=True)
    if "stack" in t:
        if not isinstance(t["stack"], str) or not t["stack"]:
            raise _fail(where, "'stack' must be a file name", "name the .npy or .npz file")
        return None
    files = t["files"]
    if isinstance(files, str):
        return compile_template(files, kind, names, where)
    if isinstance(files, list) and files and all(isinstance(f, str) and f for f in files):
        return list(files)
    raise _fail(where, "'files' must be a template string or a list of paths", "fix it")


def _stack_fields(t: Mapping[str, Any], where: str) -> tuple[str | None, str, list[int] | None]:
    key = t.get("key")
    if key is not None and not isinstance(key, str):
        raise _fail(where, "'key' must be a string (the .npz array name)", "fix it")
    axes = t.get("axes", "nyx")
    if not isinstance(axes, str) or sorted(axes) not in (["n", "x", "y"], ["x", "y"]):
        raise _fail(
            where,
            f"'axes' must order the letters n (frame), y (row), x (column), got {axes!r}",
            'e.g. "nyx" for (frames, rows, columns) or "yxn"',
        )
    sel = t.get("stack_frames")
    if sel is not None:
        sel = [_int(v, where, "stack_frames", 0, MAX_PROGRAM_FRAMES) for v in _list(sel)]
    return key, axes, sel


def _orientation_names(t: Mapping[str, Any], where: str) -> dict[str, str]:
    given = t.get("orientation_names", {o: o for o in ORIENTATIONS})
    if not isinstance(given, dict):
        raise _fail(where, "'orientation_names' must be a table", 'e.g. { vertical = "v" }')
    _check_keys(given, ORIENTATIONS, f"{where} orientation_names")
    names: dict[str, str] = {}
    for o, text in given.items():
        if not isinstance(text, str):
            raise _fail(where, f"orientation_names.{o} must be a string", "fix it")
        if text in names:
            raise _fail(where, f"both orientations are named {text!r}", "give distinct names")
        names[text] = o
    return names


def _fringe_orientations(t: Mapping[str, Any], where: str) -> list[Any]:
    """A fringe group's orientations: known ones, each once."""
    orients = _list(t.get("orientation", "vertical"))
    for o in orients:
        if o not in ORIENTATIONS:
            close = difflib.get_close_matches(str(o), ORIENTATIONS, n=1)
            hint = f"did you mean '{close[0]}'?" if close else "use vertical or horizontal"
            raise _fail(where, f"unknown orientation {o!r}", hint)
    if len(set(orients)) != len(orients):
        raise _fail(where, "an orientation is listed twice", "list each once")
    return orients


def _fringe_pattern(t: Mapping[str, Any], where: str) -> tuple[Any, Any]:
    """A fringe group's pattern and profile (cosine or sine)."""
    pattern = t.get("pattern", "sinusoidal")
    if pattern not in PATTERNS:
        raise _fail(where, f"unknown pattern {pattern!r}", f"use one of {', '.join(PATTERNS)}")
    profile = t.get("profile", "cosine")
    if profile not in ("cosine", "sine"):
        raise _fail(where, f"unknown profile {profile!r}", "use cosine or sine")
    if profile == "sine" and pattern != "sinusoidal":
        raise _fail(where, "profile 'sine' is for sinusoidal fringes", "use phase_offset_deg")
    return pattern, profile


def _fringe_shifts(
    t: Mapping[str, Any], where: str, pattern: str
) -> tuple[int, list[float], int, list[int]]:
    """The shifts: steps N, angles (default 360*k/N), sign, numbers in file names."""
    shifts = t.get("shifts_deg")
    steps = t.get("steps")
    if shifts is not None:
        shifts = [_num(v, where, "shifts_deg") for v in _list(shifts)]
        if steps is not None and _int(steps, where, "steps", 2, MAX_STEPS) != len(shifts):
            raise _fail(
                where,
                f"steps = {steps} but shifts_deg lists {len(shifts)} angles",
                "give one angle per step",
            )
        steps = len(shifts)
    if steps is None:
        raise _fail(where, "missing 'steps' (or 'shifts_deg')", "give the number of shifts N")
    min_steps = 3 if pattern == "sinusoidal" else 2
    steps = _int(steps, where, "steps", min_steps, MAX_STEPS)
    if shifts is None:
        shifts = [360.0 * k / steps for k in range(steps)]
    sign = t.get("shift_sign", 1)
    if sign not in (1, -1) or isinstance(sign, bool):
        raise _fail(where, f"'shift_sign' must be 1 or -1, got {sign!r}", "see docs/import.md")
    numbers = t.get("step_numbers", list(range(steps)))
    numbers = [_int(v, where, "step_numbers", 0, 1 << 30) for v in _list(numbers)]
    if len(numbers) != steps:
        raise _fail(
            where,
            f"step_numbers lists {len(numbers)} numbers for {steps} steps",
            "give one file number per step",
        )
    if len(set(numbers)) != len(numbers):
        raise _fail(where, "step_numbers repeats a number", "give each step its own number")
    return steps, shifts, sign, numbers


def _fringe_levels(t: Mapping[str, Any], where: str) -> tuple[str, list[float]]:
    """Periods across the projector, or pitch in projector px: the key and its values."""
    if ("periods" in t) == ("pitch" in t):
        raise _fail(where, "give exactly one of 'periods' and 'pitch'", "see docs/import.md")
    level_key = "periods" if "periods" in t else "pitch"
    levels = [_num(v, where, level_key, positive=True) for v in _list(t[level_key])]
    if len(set(levels)) != len(levels):
        raise _fail(where, f"a value of '{level_key}' is listed twice", "list each once")
    return level_key, levels


def _fringe_extra(t: Mapping[str, Any], where: str, projector: Mapping[str, Any]) -> dict[str, Any]:
    """Gray levels (both or neither: then not written, capture format version 3, "levels
    unknown"), gamma pre-compensation and exposure."""
    extra: dict[str, Any] = {}
    if ("imin" in t) != ("migl" in t):
        raise _fail(
            where,
            "give both 'imin' and 'migl' or neither",
            "leave both out when the pattern's gray levels are not known",
        )
    if "imin" in t:
        full = float((1 << int(projector["bit_depth"])) - 1)
        imin = _num(t["imin"], where, "imin")
        migl = _num(t["migl"], where, "migl")
        if not 0 <= imin < migl <= full:
            raise _fail(
                where,
                f"need 0 <= imin < migl <= {full:g}, got imin={imin:g}, migl={migl:g}",
                "fix the gray levels (or the projector bit_depth)",
            )
        extra.update(imin=imin, migl=migl)
    for k in ("gamma_precompensation", "exposure_ms"):
        if k in t:
            extra[k] = _num(t[k], where, k, positive=True)
    return extra


def _check_fringe_template(
    files: Template | list[str] | None,
    where: str,
    counts: Mapping[str, int],
    level_key: str,
) -> None:
    """A file template names every field the group has several values of, and the level
    key the group gives. ``counts``: orientation, level key, step -> number of values."""
    if isinstance(files, Template) and "index" not in files.fields:
        present = set(files.fields)
        for fld, count in counts.items():
            if count > 1 and fld not in present:
                raise _fail(
                    where,
                    f"the template {files.text!r} has no {{{fld}}} field but the group has "
                    f"{count} values of it",
                    f"add {{{fld}}} to the template",
                )
    if isinstance(files, Template):
        other = "pitch" if level_key == "periods" else "periods"
        if other in files.fields:
            raise _fail(
                where,
                f"the template uses {{{other}}} but the group gives '{level_key}'",
                f"write {{{level_key}}} in the template",
            )


def _fringe_pitch(
    level_key: str, value: float, orient: str, where: str, projector: Mapping[str, Any]
) -> float:
    """The pitch in projector px of a ``periods`` or ``pitch`` value."""
    if level_key != "periods":
        return value
    extent_key = "width" if orient == "vertical" else "height"
    if extent_key not in projector:
        raise _fail(
            where,
            f"'periods' needs the projector {extent_key} ({orient} fringes)",
            f"add {extent_key} to the projector table or give 'pitch'",
        )
    return projector[extent_key] / value


def _fringe_group(
    t: Mapping[str, Any], index: int, where: str, projector: Mapping[str, Any]
) -> FrameGroup:
    _check_keys(t, _FRINGE_KEYS, where)
    names = _orientation_names(t, where)
    files = _source(t, "fringe", where, names)
    key, axes, sel = _stack_fields(t, where)
    orients = _fringe_orientations(t, where)
    pattern, profile = _fringe_pattern(t, where)
    steps, shifts, sign, numbers = _fringe_shifts(t, where, pattern)
    offset = _num(t.get("phase_offset_deg", 0.0), where, "phase_offset_deg")
    level_key, levels = _fringe_levels(t, where)
    extra = _fringe_extra(t, where, projector)
    counts = {"orientation": len(orients), level_key: len(levels), "step": steps}
    _check_fringe_template(files, where, counts, level_key)
    frames: list[dict[str, Any]] = []
    for o in orients:
        for value in levels:
            pitch = _fringe_pitch(level_key, value, o, where, projector)
            for step in range(steps):
                entry = {
                    "kind": "fringe",
                    "pattern": pattern,
                    "steps": steps,
                    "pitch": pitch,
                    "orientation": o,
                    **extra,
                    # the phase convention of this frame, resolved by the importer
                    "_shift_deg": sign * shifts[step],
                    "_offset_deg": offset - (90.0 if profile == "sine" else 0.0),
                    "_key": {
                        "orientation": o,
                        level_key: value,
                        "step": float(numbers[step]),
                    },
                    "_label": f"{o} {level_key} {value:g} step {step}",
                }
                frames.append(entry)
    return FrameGroup("fringe", index, where, files, t.get("stack"), key, axes, sel, frames)


def _uniform_group(
    t: Mapping[str, Any], index: int, where: str, projector: Mapping[str, Any]
) -> FrameGroup:
    _check_keys(t, _UNIFORM_KEYS, where)
    files = _source(t, "uniform", where, {})
    key, axes, sel = _stack_fields(t, where)
    full = float((1 << int(projector["bit_depth"])) - 1)
    if "level" not in t:
        raise _fail(where, "missing 'level'", 'give the gray level shown, or "white"/"black"')
    level = t["level"]
    if level == "white":
        level = full
    elif level == "black":
        level = 0.0
    level = _num(level, where, "level")
    if not 0 <= level <= full:
        raise _fail(where, f"level {level:g} outside 0..{full:g}", "fix it or the projector")
    count = len(files) if isinstance(files, list) else len(sel) if sel is not None else 1
    entry: dict[str, Any] = {"kind": "uniform", "level": level}
    if "exposure_ms" in t:
        entry["exposure_ms"] = _num(t["exposure_ms"], where, "exposure_ms", positive=True)
    frames = [
        {**entry, "_key": {}, "_label": f"uniform {level:g}" + (f" #{i}" if count > 1 else "")}
        for i in range(count)
    ]
    return FrameGroup("uniform", index, where, files, t.get("stack"), key, axes, sel, frames)


def _number_frames(group: FrameGroup, t: Mapping[str, Any], where: str) -> FrameGroup:
    """Give every frame its ``index`` (position in the group + ``first_index``)."""
    first = _int(t.get("first_index", 0), where, "first_index", 0, 1 << 30)
    for i, frame in enumerate(group.frames):
        frame["_key"]["index"] = float(first + i)
    return group


def _graycode_group(t: Mapping[str, Any], index: int, where: str) -> FrameGroup:
    _check_keys(t, _GRAYCODE_KEYS, where)
    names = _orientation_names(t, where)
    files = _source(t, "graycode", where, names)
    key, axes, sel = _stack_fields(t, where)
    orients = _list(t.get("orientation", "vertical"))
    for o in orients:
        if o not in ORIENTATIONS:
            raise _fail(where, f"unknown orientation {o!r}", "use vertical or horizontal")
    if len(set(orients)) != len(orients):
        raise _fail(where, "an orientation is listed twice", "list each once")
    if "bits" not in t:
        raise _fail(where, "missing 'bits'", "give the number of bits of the code")
    bits = _int(t["bits"], where, "bits", 1, 24)
    if "stripe" not in t:
        raise _fail(where, "missing 'stripe'", "give the finest stripe width in projector px")
    stripe = _num(t["stripe"], where, "stripe", positive=True)
    code = t.get("code", "gray")
    if code not in _CODES:
        raise _fail(where, f"unknown code {code!r}", f"use one of {', '.join(_CODES)}")
    inverse = t.get("inverse", False)
    if not isinstance(inverse, bool):
        raise _fail(where, f"'inverse' must be true or false, got {inverse!r}", "fix it")
    order = t.get("bit_order", "msb_first")
    if order not in ("msb_first", "lsb_first"):
        raise _fail(where, f"unknown bit_order {order!r}", "use msb_first or lsb_first")
    entry: dict[str, Any] = {"kind": "graycode", "bits": bits, "stripe": _plain_num(stripe)}
    if code != "gray":
        entry["code"] = code
    if "migl" in t:
        entry["migl"] = _num(t["migl"], where, "migl", positive=True)
    if "convention" in t:
        if not isinstance(t["convention"], str):
            raise _fail(where, "'convention' must be a string label", "fix it")
        entry["convention"] = t["convention"]
    if "exposure_ms" in t:
        entry["exposure_ms"] = _num(t["exposure_ms"], where, "exposure_ms", positive=True)
    if isinstance(files, Template) and "index" not in files.fields:
        for fld, count in (("orientation", len(orients)), ("bit", bits)):
            if count > 1 and fld not in files.fields:
                raise _fail(
                    where,
                    f"the template {files.text!r} has no {{{fld}}} field but the group has "
                    f"{count} values of it",
                    f"add {{{fld}}} (or {{index}}) to the template",
                )
        if inverse:
            raise _fail(
                where,
                f"the template {files.text!r} cannot tell a bit's pattern from its inverse",
                "use {index} (frames counted in projection order), a list or a regex",
            )
    sequence = range(bits - 1, -1, -1) if order == "msb_first" else range(bits)
    frames: list[dict[str, Any]] = []
    for o in orients:
        for b in sequence:
            for inv in (False, True) if inverse else (False,):
                frame = {**entry, "orientation": o, "bit": b}
                if inverse:
                    frame["inverse"] = inv
                frame["_key"] = {"orientation": o, "bit": float(b)}
                frame["_label"] = f"graycode {o} bit {b}" + (" inverse" if inv else "")
                frames.append(frame)
    # manifest field order: kind, orientation, bit, bits, stripe, ...
    order_keys = ("kind", "orientation", "bit", "bits", "stripe", "inverse")
    frames = [
        {**{k: f[k] for k in order_keys if k in f}, **{k: v for k, v in f.items()}} for f in frames
    ]
    return FrameGroup("graycode", index, where, files, t.get("stack"), key, axes, sel, frames)


def _plain_num(value: float) -> float | int:
    return int(value) if float(value).is_integer() else float(value)
