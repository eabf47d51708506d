"""The ``hdrfringe`` command line: one thin module per command, each calling the library.

Every command validates its input fully before writing anything; any
:class:`~hdrfringe.errors.HdrFringeError` is printed as one line on stderr with exit code 2, and
no partial output is left behind (outputs are staged and moved into place when complete).
"""

from __future__ import annotations

from hdrfringe.cli import (  # noqa: F401  (each module registers its command on ``app``)
    calibrate,
    calibrate_stereo,
    capture,
    capture_gamma,
    capture_poses,
    compare,
    demo,
    gamma,
    import_,
    measure,
    modify,
    patterns,
    phase,
    reproduce,
    rig_check,
    simulate,
    train,
)
from hdrfringe.cli._app import app

__all__ = ["app"]
