"""Saturation-avoidance strategies as plug-ins (thesis Ch. 4-6).

A strategy drives any :class:`~hdrfringe.rig.base.Rig` (the live virtual rig, a replay of a
capture folder, hardware) and returns a :class:`StrategyResult`: the composite phase-shifted
images, what it captured (:class:`CapturedSet` per set) and the per-pixel index map (the MIGL
index image N(x, y) of thesis Fig. 5.2c). The phase, unwrapping and height stages only see the
composite images; they do not know which strategy made them.

Built in, one module each (import the function from its module, e.g.
``from hdrfringe.strategies.lpa import lpa``):

* :mod:`~hdrfringe.strategies.conventional`: one set at the highest MIGL.
* :mod:`~hdrfringe.strategies.uniform`: one MIGL for every pixel (Ch. 4).
* :mod:`~hdrfringe.strategies.lpa`: LPA, pixel-wise MIGL in linear steps (Ch. 5, Eq. 5.1).
* :mod:`~hdrfringe.strategies.dpa`: DPA, pixel-wise MIGL in dynamic steps (Ch. 6).
* :mod:`~hdrfringe.strategies.tolerant`: one set, phase from the unsaturated shifts.
* :mod:`~hdrfringe.strategies.multiexposure`: sets at several exposure times (Zhang & Yau
  2009), with the exposure choice of :mod:`~hdrfringe.strategies.exposure` (Sec. 7.3).
* :mod:`~hdrfringe.strategies.adaptive`: per-pixel adaptive projection (beyond the thesis,
  its Sec. 7.2).

The thesis's requirement 4 holds for every one: when no pixel saturates at the highest MIGL,
the result is the conventional one, bit for bit, after one set. A new strategy is one module
that defines its ``Params`` and a class decorated with :func:`register` (docs/saturation.md,
"Writing a strategy"); a built-in one is also named in :data:`BUILTIN` (the registry keeps
this order: the thesis's chapters).
"""

from importlib import import_module

from hdrfringe.strategies.base import (
    DEFAULT_STRATEGY,
    CapturedSet,
    DecoderSettings,
    ExtraSet,
    FunctionStrategy,
    MetricsContext,
    RunContext,
    Strategy,
    StrategyMetrics,
    StrategyResult,
    available_strategies,
    capture_set,
    check_fringe_spec,
    default_min_migl,
    get_strategy,
    make_params,
    merge_into_composite,
    param_values,
    prepare_params,
    register,
    run_strategy,
    strategy_metrics,
    unregister,
)

__all__ = [
    "BUILTIN",
    "DEFAULT_STRATEGY",
    "CapturedSet",
    "DecoderSettings",
    "ExtraSet",
    "FunctionStrategy",
    "MetricsContext",
    "RunContext",
    "Strategy",
    "StrategyMetrics",
    "StrategyResult",
    "available_strategies",
    "capture_set",
    "check_fringe_spec",
    "default_min_migl",
    "get_strategy",
    "make_params",
    "merge_into_composite",
    "param_values",
    "prepare_params",
    "register",
    "run_strategy",
    "strategy_metrics",
    "unregister",
]

#: The built-in strategy modules, imported (and so registered) in this order.
BUILTIN = ("conventional", "uniform", "lpa", "dpa", "tolerant", "multiexposure", "adaptive")

for _module in BUILTIN:
    import_module(f"{__name__}.{_module}")
