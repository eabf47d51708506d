"""Which data a gamma fit uses: the fringe sets fit for a shape fit, and the pixels reduced.

:func:`select_gamma_sets` is the rule the ``hdrfringe gamma`` command applies to a capture
folder's fringe sets before :func:`~hdrfringe.core.gamma.fit_gamma_fringes` (thesis Sec. 2.6):
wide sinusoidal sets only, and only when they can be fitted by shape.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core.gamma.model import MIN_FRINGE_PITCH_PX
from hdrfringe.core.patterns import FringeSpec
from hdrfringe.errors import InputError

__all__ = ["GammaSetSelection", "select_gamma_sets"]

SetItem = TypeVar("SetItem", bound=tuple[Any, ...])


@dataclass(frozen=True)
class GammaSetSelection(Generic[SetItem]):
    """The fringe sets a shape fit of gamma uses, and those left out as too narrow.

    Made by :func:`select_gamma_sets`.

    Parameters
    ----------
    sets : tuple
        The usable items, as given (same order): ready for
        :func:`~hdrfringe.core.gamma.fit_gamma_fringes` when the items carry their images.
    used : tuple of int
        Indices of ``sets`` in the input.
    too_narrow : tuple of int
        Indices of the sinusoidal sets narrower than ``min_pitch_px`` (left out).
    fittable : bool
        True when the usable sets can be fitted by shape (``normalization="shape"``): at least
        two pre-compensation exponents among them, or a set of N >= 4 steps.
    min_pitch_px : float
        The narrowest pitch used, projector pixels.

    References
    ----------
    Thesis Sec. 2.6 (Eq. 2.16-2.17); docs/gamma.md ("Limits").

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> spec = FringeSpec("sinusoidal", 3, 48.0)
    >>> sel = select_gamma_sets([(spec, 0.75), (spec, 1.25)])
    >>> sel.used, sel.too_narrow, sel.fittable
    ((0, 1), (), True)
    """

    sets: tuple[SetItem, ...]
    used: tuple[int, ...]
    too_narrow: tuple[int, ...]
    fittable: bool
    min_pitch_px: float


def select_gamma_sets(
    sets: Sequence[SetItem], *, min_pitch_px: float = MIN_FRINGE_PITCH_PX
) -> GammaSetSelection[SetItem]:
    """Select the fringe sets a shape fit of the projector gamma can use.

    The rule (the ``hdrfringe gamma`` command's):

    * only sinusoidal sets are considered (triangular and other sets are ignored, not
      reported);
    * a sinusoidal set narrower than ``min_pitch_px`` projector pixels is left out and reported
      in ``too_narrow``: projector pixels and optical blur reshape narrow fringes, which the
      shape fit would read as gamma (on the virtual rig 3.18 at 8 px and 2.84 at 32 px for a
      true 2.812);
    * the remaining sets can be fitted by shape when each pixel has more samples than unknowns
      (phase, scale and an offset per set): sets at two or more pre-compensation exponents,
      or one set of N >= 4 steps (``fittable``).

    Only each item's first two entries are read; the items are passed through untouched, so
    they may carry their images as :func:`~hdrfringe.core.gamma.fit_gamma_fringes` expects.

    Parameters
    ----------
    sets : sequence of (FringeSpec, gamma_hat[, images, ...])
        Each fringe set's pattern and the pre-compensation exponent it was sent with; further
        entries (e.g. the captures) are carried along.
    min_pitch_px : float
        Narrowest usable pitch in projector pixels (default
        :data:`~hdrfringe.core.gamma.MIN_FRINGE_PITCH_PX`).

    Returns
    -------
    GammaSetSelection
        The usable items and their indices, the too-narrow indices, and whether a shape fit is
        possible.

    Raises
    ------
    InputError
        When an item does not start with a FringeSpec and its exponent.

    References
    ----------
    Thesis Sec. 2.6 (Eq. 2.16-2.17); docs/gamma.md ("Limits").

    Examples
    --------
    >>> from hdrfringe.core.patterns import FringeSpec
    >>> wide3, wide4 = FringeSpec("sinusoidal", 3, 48.0), FringeSpec("sinusoidal", 4, 64.0)
    >>> narrow = FringeSpec("sinusoidal", 4, 8.0)
    >>> sel = select_gamma_sets([(narrow, 1.0), (wide3, 1.0)])
    >>> sel.used, sel.too_narrow, sel.fittable  # one 3-step set at one exponent: no shape fit
    ((1,), (0,), False)
    >>> select_gamma_sets([(narrow, 1.0), (wide4, 1.0)]).fittable
    True
    """
    used: list[int] = []
    narrow: list[int] = []
    for i, item in enumerate(sets):
        if len(item) < 2 or not isinstance(item[0], FringeSpec):
            raise InputError(
                f"gamma set selection: item {i} is not (FringeSpec, gamma_hat, ...); give each "
                "set's pattern specification and pre-compensation exponent"
            )
        spec = item[0]
        if spec.pattern != "sinusoidal":
            continue
        (narrow if spec.pitch_px < min_pitch_px else used).append(i)
    exponents = {float(sets[i][1]) for i in used}
    fittable = bool(used) and (len(exponents) > 1 or any(sets[i][0].steps >= 4 for i in used))
    return GammaSetSelection(
        sets=tuple(sets[i] for i in used),
        used=tuple(used),
        too_narrow=tuple(narrow),
        fittable=fittable,
        min_pitch_px=float(min_pitch_px),
    )


def _region(shape: tuple[int, ...], roi: object, mask: ArrayLike | None) -> NDArray[np.bool_]:
    """Boolean selection of the pixels to reduce, from a mask and/or a region of interest."""
    sel = np.ones(shape, dtype=bool)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != shape:
            raise InputError(
                f"gamma fit: mask has shape {m.shape} but the images are {shape}; give a mask of "
                "the image size"
            )
        sel &= m
    if roi is not None:
        if isinstance(roi, tuple) and len(roi) == 2 and all(isinstance(s, slice) for s in roi):
            box = np.zeros(shape, dtype=bool)
            box[roi] = True
        elif isinstance(roi, Sequence) and len(roi) == 4:
            y0, y1, x0, x1 = (int(v) for v in roi)
            box = np.zeros(shape, dtype=bool)
            box[y0:y1, x0:x1] = True
        else:
            raise InputError(
                f"gamma fit: roi {roi!r} is not understood; give (row_slice, col_slice) or "
                "(y0, y1, x0, x1)"
            )
        sel &= box
    if not sel.any():
        raise InputError("gamma fit: the mask/roi selects no pixel; widen the region of interest")
    return sel
