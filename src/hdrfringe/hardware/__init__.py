"""Hardware back ends: projector windows and cameras (issue 13)."""

__all__: list[str] = []
