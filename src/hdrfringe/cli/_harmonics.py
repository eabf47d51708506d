"""``--harmonics`` of ``phase`` and ``measure``: the option and the lines it prints."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any

import typer

from hdrfringe.cli._app import console

__all__ = ["HarmonicsOpt", "check_harmonics", "print_harmonics"]

HarmonicsOpt = Annotated[
    str,
    typer.Option(
        "--harmonics",
        help="Fringe-harmonic (projector nonlinearity) compensation: off (default); auto: "
        "estimate each sinusoidal set's harmonic phase error from its own wrapped phase and "
        "remove it where it is significant; a number K (1..8): remove K orders (N, 2N, .. "
        "cycles per period) whatever their size (docs/harmonics.md).",
    ),
]


def check_harmonics(value: str, conflict: str | None = None) -> None:
    """Refuse a bad ``--harmonics`` value, or one given with a saturation-tolerant decode.

    Parameters
    ----------
    value : str
        The option's value.
    conflict : str, optional
        The option that asks for the saturation-tolerant decoder (``--saturated exclude``,
        ``--strategy tolerant``), when given: harmonic compensation models every shift in each
        pixel's phase.

    Raises
    ------
    InputError
        One line naming the option.
    """
    from hdrfringe.core.harmonics import harmonics_mode
    from hdrfringe.errors import InputError

    try:
        mode = harmonics_mode(value)[0]
    except InputError as exc:
        raise InputError(f"--{exc}") from None
    if mode != "off" and conflict is not None:
        raise InputError(
            f"--harmonics needs every shift in each pixel's phase; it does not apply to "
            f"{conflict} (drop one of them)"
        )


def print_harmonics(block: Mapping[str, Any] | None) -> None:
    """One line per set: the harmonic error removed, estimated and left, or why not estimated.

    Parameters
    ----------
    block : mapping or None
        ``phase_summary.json``'s / ``metrics.json``'s ``harmonics`` block (None: nothing).
    """
    if block is None:
        return
    for label, e in block["sets"].items():
        if "reason" in e:
            console.print(f"harmonics {label}: not estimated ({e['reason']})")
            continue
        orders = ", ".join(str(m) for m in e["orders"])
        what = "removed" if e["applied"] else "estimated (not significant, left as decoded)"
        console.print(
            f"harmonics {label}: {what} {e['rms_rad']:.4f} rad RMS, orders {orders} per period"
        )
