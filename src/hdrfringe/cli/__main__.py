"""``python -m hdrfringe.cli``: the command line."""

from hdrfringe.cli import app

__all__: list[str] = []

if __name__ == "__main__":  # pragma: no cover
    app()
