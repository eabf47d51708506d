"""hdrfringe: phase-shifting fringe projection that keeps working when the camera saturates."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("hdrfringe")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0+unknown"

from hdrfringe.errors import CaptureFormatError, HdrFringeError, InputError

__all__ = ["CaptureFormatError", "HdrFringeError", "InputError", "__version__"]
