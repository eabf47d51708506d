"""The core: the method's equations on arrays, with no rig, no file and no plot.

Everything a measurement computes lives here, as functions on numpy arrays and frozen
dataclasses: what is projected (:mod:`~hdrfringe.core.patterns`, :mod:`~hdrfringe.core.frames`,
:mod:`~hdrfringe.core.programs`), what was captured (:mod:`~hdrfringe.core.captures`), the phase
and its quality (:mod:`~hdrfringe.core.phase`, :mod:`~hdrfringe.core.decode`,
:mod:`~hdrfringe.core.harmonics`, :mod:`~hdrfringe.core.uncertainty`), unwrapping and absolute
phase (:mod:`~hdrfringe.core.unwrap`, :mod:`~hdrfringe.core.graycode`,
:mod:`~hdrfringe.core.geometric_order`), phase to height or to points
(:mod:`~hdrfringe.core.calibration`, :mod:`~hdrfringe.core.reconstruct`,
:mod:`~hdrfringe.core.stereo`, :mod:`~hdrfringe.core.stereo_calibration`), the projector's gamma
(:mod:`~hdrfringe.core.gamma`) and saturation (:mod:`~hdrfringe.core.saturation`: estimating
clipped intensities, DPA's rules, the per-pixel MIGL map, the saturation-tolerant decoder).
Core modules import only :mod:`hdrfringe.errors` and each other (tests/test_layers.py).

The public names are re-exported by the package itself (``import hdrfringe as hf``).
"""

__all__: list[str] = []
