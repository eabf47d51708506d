"""Per-command workflows: paths and options in, a folder written and a report out; no printing,
no typer."""

__all__: list[str] = []
