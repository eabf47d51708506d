"""Every saturation strategy side by side on the virtual rig (``hdrfringe compare``).

For each scene of :data:`SCENES` one virtual rig is built and every method of :data:`METHODS`
measures the same three vertical sinusoidal 4-step sets on it (pitches 1024, 64 and the
finest ``pitch``, the ``measure`` command's default family; a row with :attr:`Method.coarse`
fewer of them, e.g. ``adaptive-8`` the two finer ones) through the product's own path,
:func:`hdrfringe.pipeline.measure` (the strategy, its decoder, temporal unwrapping, the fringe
orders a strategy unwrapped itself). The finest set's absolute phase is compared with the
rig's ground truth ``2 pi u / pitch`` (:class:`hdrfringe.rig.simulated.GroundTruth`) over the
pixels the truth calls valid:

* coverage: valid pixels with a finite absolute phase, over the valid pixels;
* bias, std and RMSE of the phase error (rad) over the covered pixels;
* images and sets captured (an automatic exposure choice's sets included).

The methods run in the order of :data:`METHODS` on the scene's one rig, so each capture draws
its own noise (the rig seeds a frame's noise by how often it was captured), as a real rig
would. A method whose strategy is not registered is a row "not available"; adding a method is
one line in :data:`METHODS`. The thesis's numbers (Tables 5.1, 5.2, 6.1, 6.2) stand beside
ours where the thesis has them, when the research package (``hdrfringe-thesis``, in
``research/``) is installed: it provides them through the entry-point group
:data:`REFERENCE_GROUP` (:func:`thesis_references`); the product imports none of it. They are
*height* errors in mm on the thesis's rig, ours are *phase* errors in rad, so only sets and the
ordering of the methods compare directly.

Examples
--------
>>> [m.name for m in METHODS][:5]
['conventional', 'uniform', 'lpa-1', 'lpa-5', 'lpa-15']
>>> sorted(SCENES)
['checkerboard', 'glossy', 'specular_part', 'white_plate_600lx']
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hdrfringe._renamed import renamed_fields, renamed_keyword
from hdrfringe.core import programs, strict_json
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.core.programs import DEFAULT_PITCHES_PX
from hdrfringe.errors import InputError
from hdrfringe.io.results import check_output_dir, staged_output_dir
from hdrfringe.pipeline import measure
from hdrfringe.rig.factory import virtual_rig
from hdrfringe.rig.simulated import SimulatedRig
from hdrfringe.strategies import available_strategies
from hdrfringe.strategies.exposure import FixedExposureRig, choose_exposure
from hdrfringe.tasks._progress import Progress, quiet

__all__ = [
    "BUDGET_METHODS",
    "COARSE_PITCHES",
    "DEPTH_RANGE_MM",
    "FULL_COVERAGE",
    "METHODS",
    "REFERENCE_GROUP",
    "SCENES",
    "CompareReport",
    "CompareRow",
    "Method",
    "ThesisRow",
    "budget_summary",
    "compare",
    "compare_markdown",
    "compare_plot",
    "compare_specs",
    "parse_names",
    "parse_resolution",
    "run_compare",
    "thesis_references",
    "write_compare",
]

#: The coarser sets of the family (the default ladder's), kept where coarser than the finest pitch
#: (1024: one period over the projector, so the family's phase is absolute without a centerline).
COARSE_PITCHES = DEFAULT_PITCHES_PX[:-1]
#: The scenes: name -> :func:`hdrfringe.rig.factory.virtual_rig` arguments.
SCENES: dict[str, dict[str, Any]] = {
    "checkerboard": {"scene": "checkerboard"},
    "white_plate_600lx": {"scene": "white_plate", "ambient_lux": 600.0},
    "glossy": {"scene": "glossy"},
    "specular_part": {"scene": "specular_part"},
}
#: Which thesis scene a scene of ours stands for (the keys of :func:`thesis_references`' rows).
_THESIS_SCENE = {"checkerboard": "checkerboard", "white_plate_600lx": "plate"}


@dataclass(frozen=True)
class ThesisRow:
    """The thesis's numbers for one method on one scene (height errors in mm).

    Parameters
    ----------
    source : str
        The table, e.g. ``"Table 5.2"``, with what differs from our run.
    sets : float or None
        Sets captured per measurement (None: the table does not say).
    bias_mm, std_mm, rmse_mm : float or None
        Height error mean, standard deviation and RMSE in mm (None: not in the table).

    Examples
    --------
    >>> ThesisRow("Table 5.2", 196, None, 0.47, 0.75).sets
    196
    """

    source: str
    sets: float | None
    bias_mm: float | None
    std_mm: float | None
    rmse_mm: float | None


@dataclass(frozen=True)
class Method:
    """One row of the comparison: a registered strategy with its parameters.

    Parameters
    ----------
    name : str
        Stable row name (what ``--strategies`` takes).
    label : str
        How tables and the plot name it.
    strategy : str
        Registry name (:func:`hdrfringe.strategies.available_strategies`).
    params : mapping
        The strategy's parameters by field name (the rest at their defaults).
    exposure : bool
        Choose the exposure first (:func:`hdrfringe.strategies.exposure.choose_exposure`,
        thesis Sec. 7.3) and run the strategy at it, the choice's last set reused.
    coarse : tuple of float, optional
        The coarser pitches this row measures beside the finest (None: all of
        :data:`COARSE_PITCHES`); a family without the one-period set takes its fringe order
        from elsewhere (the rig's calibration and :data:`DEPTH_RANGE_MM`).

    Examples
    --------
    >>> Method("lpa-5", "LPA S=5", "lpa", {"step": 5.0}).strategy
    'lpa'
    """

    name: str
    label: str
    strategy: str
    params: Mapping[str, Any] = field(default_factory=dict)
    exposure: bool = False
    coarse: tuple[float, ...] | None = None

    def family(self, specs: list[FringeSpec]) -> list[FringeSpec]:
        """The sets this row measures of the table's family ``specs`` (coarsest first).

        Parameters
        ----------
        specs : list of FringeSpec
            :func:`compare_specs`.

        Returns
        -------
        list of FringeSpec
            ``specs`` less the coarser sets :attr:`coarse` leaves out.

        Examples
        --------
        >>> m = Method("a", "a", "adaptive", coarse=(64.0,))
        >>> [s.pitch_px for s in m.family(compare_specs(8.0))]
        [64.0, 8.0]
        """
        if self.coarse is None:
            return list(specs)
        return [s for s in specs[:-1] if s.pitch_px in self.coarse] + list(specs[-1:])


#: The scenes' depths along the virtual rig's camera axis (mm) for the rows that take the
#: fringe order from the geometry: the four scenes lie 1870-1900 mm from the camera, and over
#: this range a 64 px pitch has one order at every pixel (the ray's projector column moves
#: less than the pitch less its margins; ``tests/test_adaptive_budget.py`` asserts both).
DEPTH_RANGE_MM = (1850.0, 1910.0)

#: The rows, in run order (a strategy added later is one more line here).
METHODS: tuple[Method, ...] = (
    Method("conventional", "conventional", "conventional"),
    Method("uniform", "uniform (auto trade-off)", "uniform"),
    Method("lpa-1", "LPA S=1", "lpa", {"step": 1.0}),
    Method("lpa-5", "LPA S=5", "lpa", {"step": 5.0}),
    Method("lpa-15", "LPA S=15", "lpa", {"step": 15.0}),
    Method("dpa", "DPA 10 %", "dpa", {"threshold": 0.1}),
    Method("dpa-bound", "DPA 10 % + bound", "dpa", {"threshold": 0.1, "bound_pending": True}),
    Method("multiexposure", "multi-exposure", "multiexposure"),
    Method("tolerant", "tolerant", "tolerant"),
    Method("tolerant-inverted", "tolerant + inverted", "tolerant", {"inverted": True}),
    Method("adaptive", "adaptive", "adaptive"),
    Method("adaptive-exposure", "adaptive + exposure", "adaptive", {"auto_exposure": True}),
    Method(
        "adaptive-epipolar",
        "adaptive, epipolar + full mapping, no bias corr.",
        "adaptive",
        {"epipolar": True, "full_mapping": True, "bias_correction": False},
    ),
    Method("adaptive-12", "adaptive, budget 12", "adaptive", {"max_images": 12}),
    Method("adaptive-16", "adaptive, budget 16", "adaptive", {"max_images": 16}),
    Method(
        "adaptive-8",
        "adaptive, budget 8, 64/8 px + depth range",
        "adaptive",
        {"max_images": 8, "depth_range_mm": DEPTH_RANGE_MM},
        coarse=(64.0,),
    ),
)

#: The rows with an image budget (issue 26) that :func:`budget_summary` sets beside the rest.
BUDGET_METHODS = ("adaptive-12", "adaptive-16", "adaptive-8")
#: Least coverage of a row :func:`budget_summary` counts among the "other strategies" (issue
#: 26's done-when: a std is compared at full coverage; a row covering half the field, e.g. the
#: conventional one on the checkerboard, reads a lower std on the easier half).
FULL_COVERAGE = 0.999

#: The entry-point group through which an installed package gives the thesis's numbers
#: (the research package ``hdrfringe-thesis``: ``hdrfringe_thesis.compare_references``). Each
#: entry point names a function without arguments returning ``{method name: {thesis scene:
#: ThesisRow}}``.
REFERENCE_GROUP = "hdrfringe.compare_references"


def thesis_references() -> dict[str, dict[str, ThesisRow]]:
    """The thesis's numbers by method and thesis scene, from the installed packages that give
    them (entry-point group :data:`REFERENCE_GROUP`); empty when none is installed.

    Returns
    -------
    dict
        Method name (:attr:`Method.name`) -> thesis scene (``"checkerboard"``, ``"plate"``)
        -> :class:`ThesisRow`.

    Examples
    --------
    >>> refs = thesis_references()  # {} without the research package
    >>> all(isinstance(row, ThesisRow) for rows in refs.values() for row in rows.values())
    True
    """
    from importlib.metadata import entry_points

    out: dict[str, dict[str, ThesisRow]] = {}
    for ep in entry_points(group=REFERENCE_GROUP):
        for method, rows in ep.load()().items():
            out.setdefault(method, {}).update(rows)
    return out


@dataclass
class CompareRow:
    """One method measured on one scene.

    Parameters
    ----------
    scene : str
        Scene name (:data:`SCENES`).
    method : str
        Row name (:attr:`Method.name`).
    label : str
        Row label.
    available : bool
        False: the strategy is not registered; every number is then None.
    images, sets : int or None
        Images and sets captured (exposure choice included).
    coverage : float or None
        Covered valid pixels over the valid pixels (0..1).
    bias_rad, std_rad, rmse_rad : float or None
        Phase error of the finest set's absolute phase over the covered pixels.
    order_errors : float or None
        Fraction of the covered pixels whose error exceeds pi: a wrong fringe order (one such
        pixel adds about ``2 pi sqrt(fraction)`` to the std).
    std_in_order_rad : float or None
        Phase error std over the covered pixels without those (|error| <= pi): the noise and
        the optics' own error, fringe-order errors aside.
    seconds : float or None
        Wall time of the measurement.
    note : str
        What the strategy chose (MIGLs, exposures), or why the row is not available.
    thesis : ThesisRow or None
        The thesis's numbers for this method and scene.

    Examples
    --------
    >>> CompareRow("glossy", "adaptive", "adaptive", False).to_dict()["available"]
    False
    """

    scene: str
    method: str
    label: str
    available: bool
    images: int | None = None
    sets: int | None = None
    coverage: float | None = None
    bias_rad: float | None = None
    std_rad: float | None = None
    rmse_rad: float | None = None
    order_errors: float | None = None
    std_in_order_rad: float | None = None
    seconds: float | None = None
    note: str = ""
    thesis: ThesisRow | None = None

    def to_dict(self) -> dict[str, Any]:
        """The row as JSON-ready values (NaN as None).

        Returns
        -------
        dict
        """
        d = dataclasses.asdict(self)
        for k, v in d.items():
            if isinstance(v, float) and not math.isfinite(v):
                d[k] = None
        return d


def compare_specs(pitch: float) -> list[FringeSpec]:
    """The family every method measures: vertical sinusoidal 4-step sets, coarsest first.

    Parameters
    ----------
    pitch : float
        The finest pitch in projector pixels (2 .. 1024).

    Returns
    -------
    list of FringeSpec
        Pitches :data:`COARSE_PITCHES` coarser than ``pitch``, then ``pitch``.

    Raises
    ------
    InputError
        A pitch that is not a finite number in 2 .. 1024.

    Examples
    --------
    >>> [s.pitch_px for s in compare_specs(8.0)]
    [1024.0, 64.0, 8.0]
    """
    if not (isinstance(pitch, (int, float)) and math.isfinite(pitch) and 2 <= pitch <= 1024):
        raise InputError(f"compare: --pitch must be a number in 2..1024 px, got {pitch!r}")
    pitches = [p for p in COARSE_PITCHES if p > pitch] + [float(pitch)]
    return programs.fringe_specs("sinusoidal", 4, pitches)


def parse_names(text: str | None, known: Sequence[str], what: str) -> list[str]:
    """Comma-separated names checked against ``known`` (None or ``"all"``: all of them).

    Parameters
    ----------
    text : str or None
        E.g. ``"checkerboard,glossy"``.
    known : sequence of str
        The names accepted, in their order.
    what : str
        The option, for the message (``"--scenes"``).

    Returns
    -------
    list of str
        The names, in the order given, without repeats.

    Raises
    ------
    InputError
        An unknown or empty name.

    Examples
    --------
    >>> parse_names("glossy,checkerboard", list(SCENES), "--scenes")
    ['glossy', 'checkerboard']
    >>> parse_names("moon", list(SCENES), "--scenes")
    Traceback (most recent call last):
        ...
    hdrfringe.errors.InputError: --scenes: unknown name 'moon'; use one of checkerboard, \
white_plate_600lx, glossy, specular_part (comma-separated) or all
    """
    if text is None or text.strip() == "all":
        return list(known)
    out: list[str] = []
    for raw in text.split(","):
        name = raw.strip()
        if name not in known:
            raise InputError(
                f"{what}: unknown name {name!r}; use one of {', '.join(known)} "
                "(comma-separated) or all"
            )
        if name not in out:
            out.append(name)
    return out


def parse_resolution(text: str | None) -> tuple[int, int] | None:
    """A camera size ``WIDTHxHEIGHT`` (e.g. ``160x120``); None or ``"default"``: the rig's.

    Parameters
    ----------
    text : str or None
        The option's value.

    Returns
    -------
    tuple of int or None
        ``(width, height)``, each 16 .. 4096.

    Raises
    ------
    InputError
        Anything else.

    Examples
    --------
    >>> parse_resolution("160x120"), parse_resolution(None)
    ((160, 120), None)
    """
    if text is None or text.strip() == "default":
        return None
    parts = text.lower().split("x")
    size: list[int] = []
    for part in parts:
        part = part.strip()
        if part.isdigit() and len(part) <= 5 and 16 <= int(part) <= 4096:
            size.append(int(part))
    if len(parts) != 2 or len(size) != 2:
        raise InputError(
            f"--resolution must be WIDTHxHEIGHT with each 16..4096 (e.g. 160x120), got {text!r}"
        )
    return size[0], size[1]


def _note(res: Any) -> str:
    """What a strategy chose, in a few words."""
    values = [s.migl for s in res.captured if s.migl is not None]
    exposures = sorted({s.exposure_ms for s in res.captured if s.exposure_ms is not None})
    parts = []
    if res.details.get("exposure_ms") is not None and res.strategy == "adaptive":
        parts.append(f"exposure {res.details['exposure_ms']:g} ms")
        exposures = []
    if "chosen_migl" in res.details:
        parts.append(f"MIGL {res.details['chosen_migl']:g}")
    elif values and min(values) < max(values):
        parts.append(f"MIGL {min(values):g}..{max(values):g}")
    if any(s.migl_map is not None for s in res.captured):
        parts.append("per-pixel MIGL")
    if len(exposures) > 1:
        parts.append(f"{exposures[0]:g}..{exposures[-1]:g} ms")
    elif exposures:
        parts.append(f"{exposures[0]:g} ms")
    return ", ".join(parts)


def _measure_one(rig: SimulatedRig, method: Method, specs: list[FringeSpec]) -> CompareRow:
    """Run one method on the scene's rig; the numbers against the rig's truth."""
    t0 = time.perf_counter()
    source: Any = rig
    extra_sets = 0
    if method.exposure:
        finest = specs[-1]
        choice = choose_exposure(rig, finest)
        last = choice.last_at_choice
        held = list(zip(finest.frames(), last, strict=True)) if last is not None else []
        source = FixedExposureRig(rig, choice.exposure_ms, held)
        extra_sets = choice.sets_captured
    result = measure(source, strategy=method.strategy, params=dict(method.params), specs=specs)
    seconds = time.perf_counter() - t0
    results = result.strategy_results
    if isinstance(source, FixedExposureRig):
        images = choice.images_captured + source.fresh_images
        # the choice's last set, when a strategy asks for it again, is served, not captured
        served = sum(r.images_captured for r in results) - source.fresh_images
        sets = extra_sets + sum(r.sets_captured for r in results) - served // specs[-1].steps
    else:
        images = sum(r.images_captured for r in results)
        sets = sum(r.sets_captured for r in results) + extra_sets
    fam = result.decoded.primary
    truth = rig.truth()
    pitch = specs[-1].pitch_px
    n_valid = int(truth.valid.sum())
    absolute = None if fam is None else fam.absolute_phase
    if absolute is None or n_valid == 0:
        err = np.full(truth.valid.shape, np.nan)
    else:
        err = absolute - 2 * np.pi * truth.u / pitch
    ok = truth.valid & np.isfinite(err)
    e = err[ok]
    nan = float("nan")
    note = "; ".join(_note(r) for r in results[-1:]) if results else ""
    if method.exposure:
        note = f"exposure {choice.exposure_ms:g} ms" + (f", {note}" if note else "")
    return CompareRow(
        scene="",
        method=method.name,
        label=method.label,
        available=True,
        images=int(images),
        sets=int(sets),
        coverage=float(ok.sum() / n_valid) if n_valid else nan,
        bias_rad=float(e.mean()) if e.size else nan,
        std_rad=float(e.std()) if e.size else nan,
        rmse_rad=float(np.sqrt(np.mean(e**2))) if e.size else nan,
        order_errors=float(np.mean(np.abs(e) > np.pi)) if e.size else nan,
        std_in_order_rad=float(e[np.abs(e) <= np.pi].std()) if (np.abs(e) <= np.pi).any() else nan,
        seconds=round(seconds, 2),
        note=note,
    )


def compare(
    scenes: Sequence[str] | None = None,
    strategies: Sequence[str] | None = None,
    *,
    resolution: tuple[int, int] | None = None,
    pitch: float = 8.0,
    seed: int = 0,
    progress: Callable[[str], Any] | None = None,
    methods: Sequence[str] | None = None,
) -> list[CompareRow]:
    """Measure every method on every scene of the virtual rig; one row per (scene, method).

    Parameters
    ----------
    scenes : sequence of str, optional
        Names of :data:`SCENES` (default all).
    strategies : sequence of str, optional
        Row names of :data:`METHODS` (default all), run in the table's order.
    resolution : tuple of int, optional
        Camera ``(width, height)``; None: the rig's 648 x 494.
    pitch : float
        Finest pitch in projector pixels (:func:`compare_specs`).
    seed : int
        Noise seed of every scene's rig.
    progress : callable, optional
        Called with ``"scene: label"`` after each row.
    methods : sequence of str, optional
        Deprecated spelling of ``strategies`` (a :class:`DeprecationWarning`).

    Returns
    -------
    list of CompareRow
        Scenes in the order given, methods in :data:`METHODS` order; a method whose strategy
        is not registered is a row with ``available`` False.

    Raises
    ------
    InputError
        An unknown scene or method, a bad pitch, resolution or seed.

    References
    ----------
    Thesis Ch. 4-6 (uniform, LPA, DPA) and Sec. 7.2-7.3 (per-pixel adaptive projection,
    exposure and MIGL together).

    Examples
    --------
    >>> rows = compare(["white_plate_600lx"], ["conventional", "lpa-15"], resolution=(64, 48),
    ...                pitch=16)
    >>> [(r.label, r.sets, round(r.coverage, 2)) for r in rows]  # 255 clips the whole plate
    [('conventional', 3, 0.0), ('LPA S=15', 19, 1.0)]
    """
    scene_names = parse_names(None if scenes is None else ",".join(scenes), list(SCENES), "scenes")
    strategies = renamed_keyword("compare", "strategies", strategies, "methods", methods)
    wanted = parse_names(
        None if strategies is None else ",".join(strategies),
        [m.name for m in METHODS],
        "strategies",
    )
    specs = compare_specs(pitch)
    registered = set(available_strategies())
    references = thesis_references()
    rows: list[CompareRow] = []
    for scene in scene_names:
        rig = virtual_rig(resolution=resolution, seed=seed, **SCENES[scene])
        thesis_scene = _THESIS_SCENE.get(scene)
        for m in METHODS:
            if m.name not in wanted:
                continue
            if m.strategy not in registered:
                row = CompareRow(
                    scene,
                    m.name,
                    m.label,
                    False,
                    note=f"not available: strategy {m.strategy!r} is not registered",
                )
            elif m.coarse is not None and len(m.family(specs)) < 2:
                row = CompareRow(
                    scene,
                    m.name,
                    m.label,
                    False,
                    note="not available: no coarser pitch of "
                    f"{', '.join(f'{p:g}' for p in m.coarse or ())} px above the finest "
                    f"{specs[-1].pitch_px:g} px",
                )
            else:
                row = _measure_one(rig, m, m.family(specs))
                row.scene = scene
            if thesis_scene is not None:
                row.thesis = references.get(m.name, {}).get(thesis_scene)
            rows.append(row)
            if progress is not None:
                progress(f"{scene}: {m.label}")
    return rows


def _fmt(value: float | None, fmt: str) -> str:
    return "—" if value is None or not math.isfinite(value) else format(value, fmt)


def _scene_summary(rows: Sequence[CompareRow]) -> str | None:
    """The issue's done-when on one scene: adaptive against LPA S=1 and DPA + bound."""
    by = {r.method: r for r in rows if r.available}
    lpa, dpa = by.get("lpa-1"), by.get("dpa-bound")
    parts = []
    for name in ("adaptive", "adaptive-exposure", "adaptive-epipolar"):
        ad = by.get(name)
        if ad is None or lpa is None or dpa is None:
            continue
        parts.append(
            f"{ad.label}: std / LPA S=1's = {_fmt((ad.std_rad or 0) / (lpa.std_rad or 1), '.3f')}, "
            f"images / DPA + bound's = {ad.images}/{dpa.images} = "
            f"{_fmt((ad.images or 0) / max(dpa.images or 1, 1), '.3f')}, "
            f"coverage {_fmt(100 * (ad.coverage or 0), '.2f')} %"
        )
    return "; ".join(parts) or None


def budget_summary(rows: Sequence[CompareRow]) -> list[str]:
    """Per scene and budget row: images, coverage and std in order beside the best other row's.

    The best other row is the one with the lowest std in order among the rows that are not
    budget rows (:data:`BUDGET_METHODS`) and cover at least :data:`FULL_COVERAGE` of the
    valid pixels (issue 26's done-when).

    Parameters
    ----------
    rows : sequence of CompareRow
        From :func:`compare`.

    Returns
    -------
    list of str
        One line per (scene, budget row) that ran.

    Examples
    --------
    >>> a = CompareRow("glossy", "adaptive-12", "adaptive, budget 12", True, images=12,
    ...                coverage=0.9998, std_in_order_rad=0.0182)
    >>> b = CompareRow("glossy", "multiexposure", "multi-exposure", True, images=56,
    ...                coverage=1.0, std_in_order_rad=0.01805)
    >>> budget_summary([b, a])[0]
    'glossy: adaptive, budget 12: 12 images, coverage 99.98 %, std in order 18.20 mrad; \
best other: multi-exposure 56 images, coverage 100.00 %, 18.05 mrad; ratio 1.008'
    """
    out = []
    scenes = list(dict.fromkeys(r.scene for r in rows))
    for scene in scenes:
        here = [r for r in rows if r.scene == scene and r.available]
        others = [
            r
            for r in here
            if r.method not in BUDGET_METHODS
            and r.std_in_order_rad is not None
            and math.isfinite(r.std_in_order_rad)
            and (r.coverage or 0.0) >= FULL_COVERAGE
        ]
        best = min(others, key=lambda r: r.std_in_order_rad or math.inf, default=None)
        for r in here:
            if r.method not in BUDGET_METHODS:
                continue
            line = (
                f"{scene}: {r.label}: {r.images} images, coverage "
                f"{_fmt(100 * (r.coverage or 0.0), '.2f')} %, std in order "
                f"{_fmt(1000 * (r.std_in_order_rad or math.nan), '.2f')} mrad"
            )
            if best is not None:
                ratio = (r.std_in_order_rad or math.nan) / (best.std_in_order_rad or math.nan)
                line += (
                    f"; best other: {best.label} {best.images} images, coverage "
                    f"{_fmt(100 * (best.coverage or 0.0), '.2f')} %, "
                    f"{_fmt(1000 * (best.std_in_order_rad or math.nan), '.2f')} mrad; "
                    f"ratio {_fmt(ratio, '.3f')}"
                )
            out.append(line)
    return out


def compare_markdown(rows: Sequence[CompareRow], *, header: str = "") -> str:
    """The comparison as markdown: one table per scene, the thesis's numbers beside ours.

    Parameters
    ----------
    rows : sequence of CompareRow
        From :func:`compare`.
    header : str
        A line put first (e.g. the run's resolution and pitches).

    Returns
    -------
    str

    Examples
    --------
    >>> md = compare_markdown([CompareRow("glossy", "adaptive", "adaptive", False,
    ...                                   note="not available")])
    >>> "| adaptive | not available |" in md
    True
    """
    lines = [header, ""] if header else []
    lines += [
        "Ours: phase error of the finest set's absolute phase (mrad) against the virtual rig's "
        "truth. Thesis: height error in mm on the thesis's rig (Tables 5.1-6.2); only the sets "
        "and the ordering of the methods compare directly.",
        "",
    ]
    scenes = list(dict.fromkeys(r.scene for r in rows))
    for scene in scenes:
        lines += [
            f"### {scene}",
            "",
            "| method | images | sets | coverage % | bias mrad | std mrad | RMSE mrad | "
            "order errors % | std mrad in order | s | note | thesis | thesis sets | "
            "thesis bias mm | thesis std mm | thesis RMSE mm |",
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|---:|---:|---:|---:|",
        ]
        here = [r for r in rows if r.scene == scene]
        for r in here:
            t = r.thesis
            thesis = (
                f"{t.source} | {_fmt(t.sets, 'g')} | {_fmt(t.bias_mm, '.2f')} | "
                f"{_fmt(t.std_mm, '.2f')} | {_fmt(t.rmse_mm, '.2f')}"
                if t is not None
                else "| | | |"
            )
            if not r.available:
                lines.append(f"| {r.label} | not available | | | | | | | | | {r.note} | {thesis} |")
                continue
            lines.append(
                f"| {r.label} | {r.images} | {r.sets} | {_fmt(100 * (r.coverage or 0), '.2f')} "
                f"| {_fmt(_m(r.bias_rad), '.2f')} | {_fmt(_m(r.std_rad), '.2f')} "
                f"| {_fmt(_m(r.rmse_rad), '.2f')} | {_fmt(_pct(r.order_errors), '.3f')} "
                f"| {_fmt(_m(r.std_in_order_rad), '.2f')} "
                f"| {_fmt(r.seconds, '.1f')} | {r.note} | "
                f"{thesis} |"
            )
        summary = _scene_summary(here)
        if summary:
            lines += ["", summary]
        lines.append("")
    return "\n".join(lines)


def _pct(x: float | None) -> float | None:
    return None if x is None else 100 * x


def _m(rad: float | None) -> float | None:
    return None if rad is None else 1e3 * rad


def compare_plot(rows: Sequence[CompareRow], path: Path) -> None:
    """Error std and coverage against images captured, one column of panels per scene.

    Parameters
    ----------
    rows : sequence of CompareRow
        From :func:`compare`; rows not available are left out.
    path : Path
        PNG to write.

    Examples
    --------
    >>> import tempfile
    >>> p = Path(tempfile.mkdtemp()) / "c.png"
    >>> compare_plot([CompareRow("glossy", "lpa-1", "LPA S=1", True, 40, 10, 1.0, 0.0,
    ...                          0.02, 0.02)], p)
    >>> p.stat().st_size > 0
    True
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    scenes = list(dict.fromkeys(r.scene for r in rows))
    fig, axes = plt.subplots(
        2, max(len(scenes), 1), figsize=(4.2 * max(len(scenes), 1), 7), squeeze=False
    )
    # one colour and marker per method across the panels, one legend for the figure
    order = {m.name: k for k, m in enumerate(METHODS)}
    palette = plt.get_cmap("tab20")
    handles: dict[str, Any] = {}
    for j, scene in enumerate(scenes):
        here = [r for r in rows if r.scene == scene and r.available and r.images]
        for r in here:
            k = order.get(r.method, len(order))
            style = {"color": palette(k % 20), "marker": "osD^v<>ph*"[k % 10], "ls": "none"}
            for i, y in enumerate((_m(r.std_rad), 100 * (r.coverage or 0.0))):
                if y is not None and math.isfinite(y):
                    axes[i, j].plot([r.images], [y], **style)
            handles.setdefault(r.label, axes[0, j].plot([], [], **style)[0])
        for i, ylabel in enumerate(("phase error std (mrad)", "coverage (%)")):
            ax = axes[i, j]
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())  # decades only: minor labels overlap
            if i == 0:  # a few wrong fringe orders put a row decades above the others
                ax.set_yscale("log")
            ax.set_xlabel("images captured")
            ax.set_ylabel(ylabel)
            ax.grid(True, which="both", alpha=0.3)
        axes[0, j].set_title(scene)
    if handles:
        fig.legend(list(handles.values()), list(handles), loc="lower center",
                   ncol=min(len(handles), 6), fontsize=8, frameon=False)  # fmt: skip
    fig.tight_layout(rect=(0, 0.08 if handles else 0, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_compare(
    output: Path,
    rows: Sequence[CompareRow],
    settings: Mapping[str, Any],
    *,
    force: bool = False,
) -> Path:
    """Write ``compare.md``, ``compare.json`` and ``compare.png`` into ``output``, staged.

    Parameters
    ----------
    output : Path
        The folder (a :class:`~hdrfringe.io.results.CheckedOutput` from the command's start).
    rows : sequence of CompareRow
        From :func:`compare`.
    settings : mapping
        What the run used (resolution, pitches, seed), recorded in the JSON and the header.
    force : bool
        Replace an existing non-empty folder.

    Returns
    -------
    Path
        ``output``.

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "cmp"
    >>> _ = write_compare(out, [CompareRow("glossy", "adaptive", "adaptive", False)], {})
    >>> sorted(p.name for p in out.iterdir())
    ['compare.json', 'compare.md', 'compare.png']
    """
    header = "Settings: " + ", ".join(f"{k} {v}" for k, v in settings.items())
    with staged_output_dir(output, force) as tmp:
        (tmp / "compare.md").write_text(
            "# Every strategy side by side\n\n" + compare_markdown(rows, header=header) + "\n"
        )
        doc = {"settings": dict(settings), "rows": [r.to_dict() for r in rows]}
        (tmp / "compare.json").write_text(strict_json.dumps(doc) + "\n")
        compare_plot(rows, tmp / "compare.png")
    return output


@renamed_fields(methods="strategies")
@dataclass(frozen=True)
class CompareReport:
    """What :func:`run_compare` did.

    Parameters
    ----------
    output : Path
        The folder written (compare.md, compare.json, compare.png).
    rows : list of CompareRow
        One row per (scene, method).
    scenes, strategies : list of str
        The scenes and strategy rows (:data:`METHODS` names) compared; ``methods`` before
        issue 29 (a deprecated alias).
    missing : list of str
        Rows whose strategy is not registered (rows without numbers).

    Examples
    --------
    >>> CompareReport(Path("out"), [], ["glossy"], ["lpa-1"], []).missing
    []
    """

    output: Path
    rows: list[CompareRow]
    scenes: list[str]
    strategies: list[str]
    missing: list[str]


def run_compare(
    output: Path,
    *,
    scenes: str | None = "all",
    strategies: str | None = None,
    resolution: str | None = "default",
    pitch: float = 8.0,
    seed: int = 0,
    force: bool = False,
    progress: Progress = quiet,
    methods: str | None = None,
) -> CompareReport:
    """``hdrfringe compare``: check the options and the output, measure every method on every
    scene of the virtual rig (:func:`compare`) and write the table, JSON and plot
    (:func:`write_compare`).

    Parameters
    ----------
    output : Path
        Folder for compare.md, compare.json and compare.png.
    scenes, strategies : str or None
        Comma-separated names of :data:`SCENES` and :data:`METHODS`, or ``all`` (None: all).
    resolution : str or None
        Camera ``WIDTHxHEIGHT``, or ``default`` (the rig's 648 x 494).
    pitch : float
        Finest pitch in projector pixels (:func:`compare_specs`).
    seed : int
        Noise seed of every scene's rig.
    force : bool
        Replace an existing output folder.
    progress : Progress
        The front end's progress (one unit per row).
    methods : str, optional
        Deprecated spelling of ``strategies`` (a :class:`DeprecationWarning`).

    Returns
    -------
    CompareReport

    Raises
    ------
    InputError
        An unknown scene or method, a bad resolution, pitch or seed, or an output that exists
        without ``force``: before any measurement.

    Examples
    --------
    >>> run_compare(Path("out"), scenes="moon")
    Traceback (most recent call last):
        ...
    hdrfringe.errors.InputError: --scenes: unknown name 'moon'; use one of checkerboard, ...
    """
    scene_names = parse_names(scenes, list(SCENES), "--scenes")
    strategies = renamed_keyword("run_compare", "strategies", strategies, "methods", methods)
    method_names = parse_names(strategies, [m.name for m in METHODS], "--strategies")
    size = parse_resolution(resolution)
    specs = compare_specs(pitch)
    virtual_rig("white_plate", seed=seed, resolution=size)  # refuses a bad seed before work
    output = check_output_dir(output, force)
    with progress("comparing", len(scene_names) * len(method_names)) as advance:
        rows = compare(
            scene_names,
            method_names,
            resolution=size,
            pitch=pitch,
            seed=seed,
            progress=lambda _label: advance(),
        )
    settings = {
        "resolution": "648x494" if size is None else f"{size[0]}x{size[1]}",
        "pitches_px": [s.pitch_px for s in specs],
        "steps": specs[-1].steps,
        "seed": seed,
    }
    write_compare(output, rows, settings, force=force)
    missing = sorted({r.method for r in rows if not r.available})
    return CompareReport(output, rows, scene_names, method_names, missing)
