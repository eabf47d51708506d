"""Saturation avoidance by the projector's maximum input gray level (thesis Ch. 4-6).

The package itself exports nothing; import from its modules:

* :mod:`hdrfringe.core.saturation.estimate`: estimating the intensities a camera clipped at
  ``2^B - 1`` from the unsaturated shifts of the same pixel (thesis Sec. 6.1.1, Eq. 6.2 and its
  least-squares generalisation), and correcting the estimate with a polynomial trained on
  captures (Sec. 6.1.2, Eq. 6.3-6.4).
* :mod:`hdrfringe.core.saturation.dpa_rules`: the dynamic pixel-wise adaptive method's cumulative
  distribution of saturated intensities and its rules for the next MIGL to capture
  (Sec. 6.1.3).

The saturation rule itself (a value at ``2^B - 1``) is
:func:`hdrfringe.core._validation.is_saturated`.
"""

__all__: list[str] = []
