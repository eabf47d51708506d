"""The saturation options ``phase`` and ``measure`` share, and their one validation."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from hdrfringe.errors import InputError

__all__ = [
    "KeepSaturatedOpt",
    "MinShiftsOpt",
    "SaturatedOpt",
    "check_saturation_options",
    "decoder_min_shifts",
]

KeepSaturatedOpt = Annotated[
    bool, typer.Option(help="Keep the (biased) phase of pixels with saturated shifts.")
]
SaturatedOpt = Annotated[
    str,
    typer.Option(
        help="flag: a pixel with a saturated shift is flagged (invalid unless "
        "--keep-saturated); exclude: its saturated shifts are left out and the phase is "
        "fitted from the others (at least --min-shifts; an inverted set in the folder "
        "joins its set), and shifts_used maps are written.",
    ),
]
MinShiftsOpt = Annotated[
    int, typer.Option(help="With --saturated exclude: least unsaturated shifts per pixel.")
]


def check_saturation_options(keep_saturated: bool, saturated: str, min_shifts: int) -> None:
    """Refuse an unknown ``--saturated`` mode or options that contradict each other.

    Parameters
    ----------
    keep_saturated : bool
        ``--keep-saturated``.
    saturated : str
        ``--saturated``: one of :data:`hdrfringe._validation.SATURATED_MODES`.
    min_shifts : int
        ``--min-shifts`` (3 unless given).

    Raises
    ------
    InputError
        One line: what is wrong and which option to drop or change.

    Examples
    --------
    >>> check_saturation_options(False, "exclude", 4)
    >>> check_saturation_options(False, "clip", 3)
    Traceback (most recent call last):
    ...
    hdrfringe.errors.InputError: --saturated 'clip' is unknown; give one of flag, exclude
    """
    from hdrfringe._validation import SATURATED_MODES

    if saturated not in SATURATED_MODES:
        raise InputError(
            f"--saturated {saturated!r} is unknown; give one of {', '.join(SATURATED_MODES)}"
        )
    if saturated == "exclude" and keep_saturated:
        raise InputError(
            "--keep-saturated keeps the biased phase of saturated pixels, --saturated exclude "
            "leaves their saturated shifts out; give one of them"
        )
    if saturated == "flag" and min_shifts != 3:
        raise InputError("--min-shifts applies to --saturated exclude; add it or drop --min-shifts")


def decoder_min_shifts(
    method: str | None, saturated: str, keep_saturated: bool, strategy_options: dict[str, Any]
) -> int:
    """``measure``'s ``--min-shifts``, checked as ``phase`` checks it.

    ``measure`` has ``--min-shifts`` from the tolerant strategy's options; with ``--method
    tolerant`` it stays the strategy's (which decodes with it), otherwise it is the decoder's
    (``--saturated exclude``) and is taken out of ``strategy_options``.

    Parameters
    ----------
    method : str or None
        ``--method``.
    saturated : str
        ``--saturated``.
    keep_saturated : bool
        ``--keep-saturated``.
    strategy_options : dict
        The command's strategy options by Python name (``min_shifts`` among them).

    Returns
    -------
    int
        The least unsaturated shifts per pixel.

    Examples
    --------
    >>> options = {"min_shifts": 4, "step": None}
    >>> decoder_min_shifts(None, "exclude", False, options), options
    (4, {'step': None})
    """
    if method == "tolerant":
        check_saturation_options(keep_saturated, saturated, 3)
        return int(strategy_options.get("min_shifts", 3))
    min_shifts = int(strategy_options.pop("min_shifts", 3))
    check_saturation_options(keep_saturated, saturated, min_shifts)
    return min_shifts
