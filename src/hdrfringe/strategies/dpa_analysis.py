"""DPA's saturation CDFs, estimated against actual (thesis Fig. 6.3), and their metrics.

:func:`dpa_cdfs` turns a DPA :class:`~hdrfringe.strategies.base.StrategyResult` into the CDFs
of thesis Fig. 6.3 (:class:`DPACDFs`): estimated from the first set and after the last update,
actual from the MIGL index image and, on a replayed step-1 sweep, exact from LPA with a step of
one gray level. :func:`dpa_set_metrics` and :class:`DPAMetrics` are their entry in a
measurement's metrics (``metrics.json``'s ``dpa`` block, docs/dpa.md); the figure is drawn by
:func:`hdrfringe.io.plots.plot_dpa_cdfs`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdrfringe.core.captures import Captures
from hdrfringe.core.patterns import FringeSpec, same_fringes
from hdrfringe.core.saturation.dpa_rules import SaturationCDF, index_image_cdf
from hdrfringe.rig.replay import ReplayRig
from hdrfringe.strategies.base import StrategyResult
from hdrfringe.strategies.lpa import lpa

__all__ = [
    "DPACDFs",
    "DPAMetrics",
    "DPASetMetrics",
    "dpa_cdfs",
    "dpa_set_metrics",
    "index_without_never",
]


@dataclass
class DPACDFs:
    """The CDFs of thesis Fig. 6.3 for one DPA set.

    Parameters
    ----------
    spec : FringeSpec
        The set at its highest MIGL.
    migls, rules : list
        MIGLs captured, in capture order, and the rule that asked for each (``"initial"`` first).
    saturated_at_top : int
        Pixels saturated at the highest MIGL (the CDFs' denominator).
    initial, final : SaturationCDF or None
        Estimated CDF from the first set and after the last update (None: nothing saturated).
    actual : SaturationCDF or None
        From the DPA index image over the pixels saturated at the top: each pixel counts at the
        MIGL of the capture where it became unsaturated, so the CDF is quantised to the captured
        MIGLs (at a captured MIGL it is the fraction unsaturated at or above it).
    exact : SaturationCDF or None
        From LPA with a step of 1 (every integer MIGL) on a replayed sweep, when the folder holds
        every integer MIGL down to DPA's lowest capture: the thesis's actual CDF (Eq. 6.3 is the
        same histogram of ``N(x, y)``).

    References
    ----------
    Thesis Sec. 6.1.3 (the CDF of the saturated intensities) and Fig. 6.3.

    Examples
    --------
    >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
    >>> nothing.max_abs_difference() is None  # no pixel saturated at the top: no CDF
    True
    """

    spec: FringeSpec
    migls: list[float]
    rules: list[str]
    saturated_at_top: int
    initial: SaturationCDF | None = None
    final: SaturationCDF | None = None
    actual: SaturationCDF | None = None
    exact: SaturationCDF | None = None

    def max_abs_difference(self, which: str = "actual") -> float | None:
        """Largest ``|F_initial(m) - F_actual(m)|`` of the first estimate against the truth.

        Parameters
        ----------
        which : {"actual", "exact"}
            ``"actual"``: over the captured MIGLs (where the quantised CDF is a sample of the
            exact one); ``"exact"``: over every integer MIGL from the top down to DPA's lowest
            capture.

        Returns
        -------
        float or None
            None when the CDF is not available.

        Examples
        --------
        >>> cdfs = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
        >>> cdfs.max_abs_difference("exact") is None
        True
        """
        other = self.actual if which == "actual" else self.exact
        if self.initial is None or other is None:
            return None
        if which == "actual":
            ms = [round(m) for m in self.migls]
        else:
            ms = list(range(round(min(self.migls)), self.initial.migl0 + 1))
        return float(max(abs(self.initial.at(m) - other.at(m)) for m in ms))


def index_without_never(result: StrategyResult) -> NDArray[np.float64]:
    """The MIGL index image with the pixels never unsaturated marked -1.

    Such pixels count as ``beyond`` the lowest MIGL in a CDF built from the index image
    (:func:`~hdrfringe.core.saturation.dpa_rules.index_image_cdf`).

    Parameters
    ----------
    result : StrategyResult
        A result whose index map holds MIGLs.

    Returns
    -------
    ndarray (H, W) float64

    References
    ----------
    Thesis Eq. 6.3 (the actual CDF from the index image ``N(x, y)``).

    Examples
    --------
    >>> from hdrfringe.strategies.base import CapturedSet
    >>> res = StrategyResult(
    ...     images=np.zeros((4, 1, 2), np.uint8), spec=FringeSpec("sinusoidal", 4, 8.0),
    ...     captured=[CapturedSet(migl=255.0)], index_map=np.full((1, 2), 255.0, np.float32),
    ...     newly_unsaturated=[1], never_unsaturated=np.array([[False, True]]), strategy="dpa")
    >>> index_without_never(res).tolist()
    [[255.0, -1.0]]
    """
    idx = np.asarray(result.migl_index, dtype=np.float64).copy()
    idx[result.never_unsaturated] = -1.0
    return idx


def dpa_cdfs(result: StrategyResult, replay: Captures | None = None) -> DPACDFs:
    """Estimated and actual CDFs (thesis Fig. 6.3) of a DPA :class:`StrategyResult`.

    Parameters
    ----------
    result : StrategyResult
        From :func:`hdrfringe.strategies.dpa.dpa` (``details`` holds ``initial_cdf``,
        ``final_cdf`` and ``saturated_at_top`` when a pixel saturated at the top).
    replay : Captures, optional
        The MIGL sweep DPA was replayed on. When it holds this set at every integer MIGL from the
        top down to DPA's lowest capture, LPA with step 1 runs on it (images are in memory) and
        its index image gives the exact actual CDF.

    Returns
    -------
    DPACDFs

    References
    ----------
    Thesis Sec. 6.1.3, Eq. 6.3 and Fig. 6.3.

    Examples
    --------
    >>> from hdrfringe.rig.scenes import white_plate
    >>> from hdrfringe.rig.simulated import CameraModel, Lighting, SimulatedRig
    >>> from hdrfringe.strategies.dpa import dpa
    >>> rig = SimulatedRig(white_plate(), camera=CameraModel(width=81, height=62),
    ...                    lighting=Lighting(ambient_lux=600))
    >>> cdfs = dpa_cdfs(dpa(rig, FringeSpec("sinusoidal", 4, 8.0)))
    >>> cdfs.rules[0], cdfs.saturated_at_top > 0, cdfs.actual.at(cdfs.migls[-1])
    ('initial', True, 1.0)
    """
    d = result.details
    rules = list(d.get("rules", ["initial"]))
    out = DPACDFs(result.spec, list(map(float, result.migls)), rules, 0)
    if "initial_cdf" not in d:  # requirement 4: nothing saturated, one set
        return out
    initial, final = d["initial_cdf"], d["final_cdf"]
    top = np.asarray(d["saturated_at_top"], dtype=bool)
    out.saturated_at_top = int(top.sum())
    out.initial, out.final = initial, final
    out.actual = index_image_cdf(
        index_without_never(result), top, initial.migl0, initial.lowest_migl
    )
    if replay is not None:
        spec = result.spec
        have = {
            float(s.spec.migl)
            for s in replay.sets
            if same_fringes(s.spec, spec) and s.spec.imin == spec.imin
        }
        lowest = round(min(out.migls))
        if all(float(m) in have for m in range(lowest, initial.migl0 + 1)):
            exact = lpa(ReplayRig(replay), spec, step=1.0, min_migl=float(lowest))
            out.exact = index_image_cdf(
                index_without_never(exact), top, initial.migl0, initial.lowest_migl
            )
    return out


@dataclass(frozen=True)
class DPASetMetrics:
    """The metrics entry of one DPA set: rules and CDFs at each captured MIGL.

    Parameters
    ----------
    set : str
        The set's label (:meth:`FringeSpec.label`, at its highest MIGL).
    pitch_px : float
    saturated_at_top : int
        Pixels saturated at the highest MIGL.
    rules : tuple of str
        The rule behind every capture, in capture order.
    captures : tuple of dict
        Per capture, in order: ``migl``, ``rule`` and the CDFs there (``estimated_initial``,
        ``estimated_final``, ``actual``, ``actual_exact``, each when available, rounded to 6
        decimals).
    lowest_migl : int or None
        DPA's lowest MIGL (None: nothing saturated at the top, no CDF).
    estimable_at_top : float or None
        Fraction of the saturated pixels the first set could estimate (the rest, more saturated
        shifts than the estimate handles, join the CDF only through its updates).
    max_abs_difference_initial_vs_actual : float or None
        Largest ``|initial - actual|`` over the captured MIGLs.
    max_abs_difference_initial_vs_exact : float or None
        The same against the exact CDF over every integer MIGL down to DPA's lowest capture
        (a replayed step-1 sweep only).

    References
    ----------
    Thesis Sec. 6.1.3 and Fig. 6.3.

    Examples
    --------
    >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
    >>> dpa_set_metrics(nothing).to_dict()["captures"]
    [{'migl': 255.0, 'rule': 'initial'}]
    """

    set: str
    pitch_px: float
    saturated_at_top: int
    rules: tuple[str, ...]
    captures: tuple[Mapping[str, Any], ...]
    lowest_migl: int | None = None
    estimable_at_top: float | None = None
    max_abs_difference_initial_vs_actual: float | None = None
    max_abs_difference_initial_vs_exact: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """The entry as ``metrics.json`` holds it (keys of unavailable CDFs left out).

        Returns
        -------
        dict

        Examples
        --------
        >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
        >>> list(dpa_set_metrics(nothing).to_dict())
        ['set', 'pitch_px', 'saturated_at_top', 'rules', 'captures']
        """
        entry: dict[str, Any] = {
            "set": self.set,
            "pitch_px": self.pitch_px,
            "saturated_at_top": self.saturated_at_top,
            "rules": list(self.rules),
            "captures": [dict(c) for c in self.captures],
        }
        if self.lowest_migl is not None:
            entry["lowest_migl"] = self.lowest_migl
            entry["estimable_at_top"] = self.estimable_at_top
            entry["max_abs_difference_initial_vs_actual"] = (
                self.max_abs_difference_initial_vs_actual
            )
            entry["actual_is"] = "DPA index image, quantised to the captured MIGLs"
        if self.max_abs_difference_initial_vs_exact is not None:
            entry["max_abs_difference_initial_vs_exact"] = self.max_abs_difference_initial_vs_exact
            entry["actual_exact_is"] = "LPA with step 1 on the replayed sweep"
        return entry


def dpa_set_metrics(cdfs: DPACDFs) -> DPASetMetrics:
    """The metrics entry of one DPA set (:class:`DPASetMetrics`) from its CDFs.

    Parameters
    ----------
    cdfs : DPACDFs
        From :func:`dpa_cdfs`.

    Returns
    -------
    DPASetMetrics

    Notes
    -----
    ``captures`` lists, in capture order, the MIGL, the rule that asked for it, and the CDF
    there: estimated from the first set (``estimated_initial``), after the last update
    (``estimated_final``), actual from the DPA index image (``actual``, quantised to the captured
    MIGLs) and, for a full step-1 sweep, exact from LPA with step 1 (``actual_exact``).

    References
    ----------
    Thesis Sec. 6.1.3 (the CDF of the saturated intensities) and Fig. 6.3.

    Examples
    --------
    >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
    >>> entry = dpa_set_metrics(nothing)  # no pixel saturated at the top: one set, no CDF
    >>> entry.set, entry.lowest_migl
    ('s4_p8_v_i40_g255', None)
    """
    captures = []
    for m, rule in zip(cdfs.migls, cdfs.rules, strict=True):
        row: dict[str, Any] = {"migl": float(m), "rule": rule}
        for key, cdf in (
            ("estimated_initial", cdfs.initial),
            ("estimated_final", cdfs.final),
            ("actual", cdfs.actual),
            ("actual_exact", cdfs.exact),
        ):
            if cdf is not None:
                row[key] = round(cdf.at(m), 6)
        captures.append(row)
    ini = cdfs.initial
    return DPASetMetrics(
        set=cdfs.spec.label(),
        pitch_px=float(cdfs.spec.pitch_px),
        saturated_at_top=cdfs.saturated_at_top,
        rules=tuple(cdfs.rules),
        captures=tuple(captures),
        lowest_migl=None if ini is None else int(ini.lowest_migl),
        estimable_at_top=(
            None if ini is None else (ini.accounted + ini.beyond) / ini.total if ini.total else 1.0
        ),
        max_abs_difference_initial_vs_actual=(
            None if ini is None else cdfs.max_abs_difference("actual")
        ),
        max_abs_difference_initial_vs_exact=(
            None if cdfs.exact is None else cdfs.max_abs_difference("exact")
        ),
    )


@dataclass(frozen=True)
class DPAMetrics:
    """The ``dpa`` block of a DPA measurement's metrics: settings and one entry per pitch.

    Parameters
    ----------
    threshold : float
        DPA's threshold (a fraction).
    correction : str
        The correction DPA used (its file, or ``"none (identity)"``).
    sets : tuple of DPASetMetrics
        One per pitch, coarsest first.
    bound_pending : bool
        Whether the pending-pixel bound was on (beyond the thesis, docs/dpa.md).

    References
    ----------
    Thesis Sec. 6.1.3 and Fig. 6.3.

    Examples
    --------
    >>> nothing = DPACDFs(FringeSpec("sinusoidal", 4, 8.0), [255.0], ["initial"], 0)
    >>> block = DPAMetrics.of([nothing], threshold=0.1, correction="none (identity)")
    >>> list(block.to_dict()), len(block.sets)
    (['threshold', 'correction', 'sets', 'bound_pending'], 1)
    """

    threshold: float
    correction: str
    sets: tuple[DPASetMetrics, ...]
    bound_pending: bool = False

    @classmethod
    def of(
        cls,
        all_cdfs: Sequence[DPACDFs],
        *,
        threshold: float,
        correction: str,
        bound_pending: bool = False,
    ) -> DPAMetrics:
        """The block of a DPA run from its CDFs, one :class:`DPACDFs` per pitch.

        Parameters
        ----------
        all_cdfs : sequence of DPACDFs
            One per pitch, coarsest first (:func:`dpa_cdfs`).
        threshold : float
            DPA's threshold.
        correction : str
            What correction DPA used.
        bound_pending : bool
            Whether the pending-pixel bound was on.

        Returns
        -------
        DPAMetrics

        Examples
        --------
        >>> DPAMetrics.of([], threshold=0.2, correction="none (identity)").threshold
        0.2
        """
        return cls(
            float(threshold),
            correction,
            tuple(dpa_set_metrics(c) for c in all_cdfs),
            bool(bound_pending),
        )

    def to_dict(self) -> dict[str, Any]:
        """The block as ``metrics.json`` holds it.

        Returns
        -------
        dict

        Examples
        --------
        >>> DPAMetrics(0.1, "none (identity)", ()).to_dict()["sets"]
        []
        """
        return {
            "threshold": self.threshold,
            "correction": self.correction,
            "sets": [s.to_dict() for s in self.sets],
            "bound_pending": self.bound_pending,
        }
