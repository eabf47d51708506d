"""The ``hdrfringe`` command line: one thin module per command, each calling the library.

Every command validates its input fully before writing anything; any
:class:`~hdrfringe.errors.HdrFringeError` is printed as one line on stderr with exit code 2, and
no partial output is left behind (outputs are staged and moved into place when complete).

A command's module is imported when the command runs (``cli._app.COMMAND_MODULES``), so that
``hdrfringe phase`` does not pay for the modules (and their imports) of the other commands.

Another installed package adds commands through the entry-point group :data:`PLUGIN_GROUP`
(``hdrfringe.commands``; the research package's ``reproduce``): the entry point names a typer
command function, run under the same error handling; it prints with :data:`console`.
"""

from __future__ import annotations

from hdrfringe.cli._environment import prepare_process

prepare_process()  # before numpy and OpenCV load (their BLAS reads its thread count once)

from hdrfringe.cli._app import PLUGIN_GROUP, app, console  # noqa: E402

__all__ = ["PLUGIN_GROUP", "app", "console"]
