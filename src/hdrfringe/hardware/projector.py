"""Projector back ends: a full-screen window on an X screen, or a folder for an external player.

A projector shows 8-bit images (gray ``(H, W)`` or RGB ``(H, W, 3)``) at its native size, one
at a time, and numbers them. :class:`ScreenProjector` opens a full-screen window on one screen
of an X display (an extended desktop's projector output) and puts each image there pixel for
pixel: the window is the screen's size, the image is drawn once at 1:1 with nearest-neighbour
sampling, no colour management; ``show`` returns after the buffer swap (vsync) has been
executed. :class:`FolderProjector` writes each image as a PNG plus a play list, for a player
that runs elsewhere. :func:`render_for_projector` turns any frame (line frames and 2-D
per-pixel frames alike) into such an image. docs/hardware.md ("Projector") describes both back
ends and how the window is tested against a screenshot of the X display.
"""

from __future__ import annotations

import ctypes
import os
from pathlib import Path
from types import TracebackType
from typing import Any, Protocol, Self, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hdrfringe.core import strict_json
from hdrfringe.core.frames import Frame, render_frame
from hdrfringe.errors import HdrFringeError, InputError, OutputExistsError

__all__ = [
    "FolderProjector",
    "Projector",
    "ProjectorError",
    "ScreenProjector",
    "render_for_projector",
]

#: The play list's ``format`` field (:class:`FolderProjector`).
PLAYLIST_FORMAT = "hdrfringe-playlist"

_INSTALL_HINT = "install the hardware extra: pip install 'hdrfringe[hardware]'"

#: ``void (*)(Display *, void *)``: libX11's IO-error exit handler (libX11 >= 1.7).
_IO_EXIT_HANDLER = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)
#: Addresses of the projector windows' X connections: Xlib's fatal-IO message is not printed
#: for them (the projector raises a one-line ProjectorError instead).
_WATCHED: set[int] = set()
_IO_HANDLER: list[Any] = []  # the installed global handler and the one before it (kept alive)


def _install_quiet_io_handler(xlib: Any) -> None:
    """Once per process: an Xlib IO-error handler that stays silent for the watched
    connections and passes the others to the handler that was installed before."""
    if _IO_HANDLER:
        return

    def handler(dpy: Any) -> int:
        address = ctypes.cast(dpy, ctypes.c_void_p).value
        if address in _WATCHED:
            return 0
        previous = _IO_HANDLER[1]
        return int(previous(dpy)) if previous else 0

    callback = xlib.XIOErrorHandler(handler)
    _IO_HANDLER[:] = [callback, None]
    _IO_HANDLER[1] = xlib.XSetIOErrorHandler(callback)


class ProjectorError(HdrFringeError):
    """A projector back end cannot go on: its window was closed, or it is not open.

    Examples
    --------
    >>> try:
    ...     FolderProjector("unused", 4, 2).show(np.zeros((2, 4), np.uint8))
    ... except ProjectorError as err:
    ...     print(err)
    the folder projector 'unused' is not open; open it (or use it in a with block) first
    """


# A protocol has no constructor: numpydoc reads the (*args, **kwargs) of typing.Protocol as one.
@runtime_checkable
class Projector(Protocol):  # numpydoc ignore=PR01
    """Anything that shows 8-bit images at its native size and numbers them.

    A structural type (:class:`ScreenProjector`, :class:`FolderProjector`). A projector is
    opened before use and closed after, most simply as a context manager.

    Attributes
    ----------
    size : tuple of int
        Native (width, height) in pixels; every image shown has shape (height, width[, 3]).
    frame_counter : int
        Number of the last frame shown (0 before the first).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp()) / "play"
    >>> with FolderProjector(folder, 4, 2) as projector:
    ...     isinstance(projector, Projector), projector.show(np.zeros((2, 4), np.uint8))
    (True, 1)
    """

    @property
    def size(self) -> tuple[int, int]:
        """Native (width, height) in pixels."""
        ...

    @property
    def frame_counter(self) -> int:
        """Number of the last frame shown (0 before the first)."""
        ...

    def open(self) -> None:
        """Acquire the output (window, folder); the projector is usable after it."""
        ...

    def close(self) -> None:
        """Release what :meth:`open` acquired; closing twice is harmless."""
        ...

    def __enter__(self) -> Self: ...

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None: ...

    def show(self, image: ArrayLike) -> int:
        """Show one image and return its frame number (1, 2, ...).

        Parameters
        ----------
        image : array_like of uint8, shape (height, width) or (height, width, 3)
            Gray or RGB, at the projector's native size.

        Returns
        -------
        int
            The frame number, also :attr:`frame_counter` afterwards.
        """
        ...


class _ProjectorBase:
    """What both back ends share: the context manager, the counter, the image check."""

    _frame_counter: int = 0

    @property
    def size(self) -> tuple[int, int]:  # pragma: no cover - every back end defines it
        raise NotImplementedError

    def open(self) -> None:  # pragma: no cover - every back end defines it
        raise NotImplementedError

    def close(self) -> None:  # pragma: no cover - every back end defines it
        raise NotImplementedError

    @property
    def frame_counter(self) -> int:
        """Number of the last frame shown (0 before the first)."""
        return self._frame_counter

    def __enter__(self) -> Self:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _check_image(self, image: ArrayLike) -> NDArray[np.uint8]:
        """The image as a C-contiguous uint8 array of the projector's size, or InputError."""
        arr = np.asarray(image)
        width, height = self.size
        if arr.dtype != np.uint8:
            raise InputError(
                f"a projector image must be uint8, got {arr.dtype}; render it with "
                "hdrfringe.hardware.projector.render_for_projector"
            )
        if not (arr.ndim == 2 or (arr.ndim == 3 and arr.shape[2] == 3)):
            raise InputError(
                f"a projector image must have shape (height, width) or (height, width, 3), got "
                f"{arr.shape}"
            )
        if arr.shape[:2] != (height, width):
            raise InputError(
                f"a projector image of {arr.shape[1]}x{arr.shape[0]} pixels does not fit the "
                f"projector's native {width}x{height}; render it at the projector's size"
            )
        return np.ascontiguousarray(arr)


class ScreenProjector(_ProjectorBase):
    """A full-screen window on one screen of an X display, showing images pixel for pixel.

    The window covers the whole screen at the screen's current mode (the projector's native
    size when the desktop runs the projector at its native resolution); each image is uploaded
    to a texture of exactly that size and drawn once at 1:1 with nearest-neighbour sampling, so
    no pixel is scaled, filtered or colour-managed. With ``vsync`` the buffer swap waits for the
    vertical retrace; :meth:`show` returns when the GPU has executed it (``glFinish``), i.e.
    when the frame is on its way to the projector. The mouse cursor is hidden over the window.
    The window is made with pyglet (``pip install 'hdrfringe[hardware]'``).

    Parameters
    ----------
    screen : int
        Index of the screen among the display's screens (pyglet's ``get_screens()``: one per
        monitor of an extended desktop, in the order the X server lists them).
    display : str, optional
        X display name such as ``":0"``; None: the ``DISPLAY`` environment variable.
    vsync : bool
        Synchronise buffer swaps with the vertical retrace.

    Raises
    ------
    InputError
        From :meth:`open`: the display or the screen does not exist, or no display is named.
    ProjectorError
        From :meth:`open`: pyglet is missing or the window does not cover the screen 1:1;
        from :meth:`show`: the window was closed mid-run or the projector is not open.

    Examples
    --------
    A display that does not exist is refused when the projector opens:

    >>> projector = ScreenProjector(screen=0, display=":12345")
    >>> try:
    ...     projector.open()
    ... except InputError as err:
    ...     print(str(err).split(":")[0])
    X display '
    """

    def __init__(self, screen: int = 0, display: str | None = None, *, vsync: bool = True) -> None:
        if isinstance(screen, bool) or not isinstance(screen, int) or screen < 0:
            raise InputError(f"the projector screen must be an integer >= 0, got {screen!r}")
        self.screen = screen
        self.display = display
        self.vsync = bool(vsync)
        self._window: Any = None
        self._texture: Any = None
        self._size: tuple[int, int] | None = None
        self._closed_mid_run = False
        self._connection_lost = False
        self._exit_handler: Any = None
        self._frame_counter = 0

    def __repr__(self) -> str:
        return f"ScreenProjector(screen={self.screen}, display={self.display!r})"

    @property
    def _where(self) -> str:
        return f"screen {self.screen} of X display {self.display or os.environ.get('DISPLAY')!r}"

    @property
    def size(self) -> tuple[int, int]:
        """Native (width, height) of the screen in pixels (known once open).

        Returns
        -------
        tuple of int
        """
        if self._size is None:
            raise ProjectorError(f"the projector on {self._where} is not open; open it first")
        return self._size

    def open(self) -> None:
        """Open the full-screen window on the screen (nothing happens when already open).

        Raises
        ------
        InputError
            No display named, or the display or the screen does not exist.
        ProjectorError
            pyglet is missing, or the window's framebuffer is not the screen's size.
        """
        if self._window is not None:
            return
        try:
            import pyglet
        except ImportError as err:
            raise ProjectorError(f"the screen projector needs pyglet; {_INSTALL_HINT}") from err
        # Without this, importing pyglet.window opens a hidden window on $DISPLAY.
        pyglet.options["shadow_window"] = False
        import pyglet.display
        import pyglet.window
        from pyglet import gl

        name = self.display or os.environ.get("DISPLAY")
        if not name:
            raise InputError("no X display to project on: DISPLAY is not set; name one (e.g. ':0')")
        try:
            display_module: Any = pyglet.display  # Display: the platform's class, not re-exported
            display = display_module.Display(name=name)
        except Exception as err:
            # pyglet has two classes of this name (pyglet.window's and the X back end's).
            if type(err).__name__ != "NoSuchDisplayException":
                raise
            raise InputError(
                f"X display {name!r} not found; start its X server or choose another display"
            ) from err
        screens = display.get_screens()
        if self.screen >= len(screens):
            listed = ", ".join(
                f"{i}: {s.width}x{s.height}+{s.x}+{s.y}" for i, s in enumerate(screens)
            )
            raise InputError(
                f"screen {self.screen} does not exist on X display {name!r} (it has {listed}); "
                "choose one of those"
            )
        scr = screens[self.screen]
        window = pyglet.window.Window(
            fullscreen=True, screen=scr, vsync=self.vsync, caption="hdrfringe projector"
        )
        fb = tuple(window.get_framebuffer_size())
        if fb != (scr.width, scr.height):
            window.close()
            raise ProjectorError(
                f"the projector window on {self._where} is {fb[0]}x{fb[1]} pixels, not the "
                f"screen's {scr.width}x{scr.height}; turn off desktop scaling for that screen"
            )
        self._connection_lost = False
        self._watch_connection(window)
        window.set_mouse_visible(False)
        window.push_handlers(on_close=self._on_close)
        self._texture = pyglet.image.Texture.create(
            scr.width,
            scr.height,
            internalformat=gl.GL_RGBA8,
            min_filter=gl.GL_NEAREST,
            mag_filter=gl.GL_NEAREST,
        )
        self._window = window
        self._size = (scr.width, scr.height)
        self._closed_mid_run = False
        self._frame_counter = 0

    def _watch_connection(self, window: Any) -> None:
        """Make a lost X connection a ProjectorError instead of the end of the process.

        When the window's client is killed (``xkill``, ``XKillClient``) or the X server ends,
        Xlib calls its IO-error handler, prints two lines and calls ``exit(1)``: no cleanup,
        no one-line error. With libX11 >= 1.7 an exit handler per connection replaces that
        ``exit``; this one notes the loss (the connection is then dead, and Xlib's calls on
        it return at once), and the next :meth:`show` raises. Older libX11: unchanged.
        """
        from pyglet.libs.x11 import xlib

        lib = xlib._lib
        if not hasattr(lib, "XSetIOErrorExitHandler"):
            return
        address = ctypes.cast(window._x_display, ctypes.c_void_p).value
        if address is None:
            return

        def lost(dpy: Any, data: Any) -> None:
            self._connection_lost = True

        handler = _IO_EXIT_HANDLER(lost)
        lib.XSetIOErrorExitHandler.argtypes = [ctypes.c_void_p, _IO_EXIT_HANDLER, ctypes.c_void_p]
        lib.XSetIOErrorExitHandler.restype = None
        lib.XSetIOErrorExitHandler(address, handler, None)
        self._exit_handler = handler  # kept alive as long as the connection may call it
        _WATCHED.add(address)
        _install_quiet_io_handler(xlib)

    def _on_close(self) -> bool:
        # The window system asked the window to close (a user, a window manager): remember it
        # and keep the window until close(), so that show() can say what happened.
        self._closed_mid_run = True
        return True  # pyglet.event.EVENT_HANDLED: the default handler does not run

    def close(self) -> None:
        """Close the window; closing twice is harmless."""
        if self._window is not None and self._connection_lost:
            # The connection is dead: pyglet's close would wait forever (or crash) for the
            # UnmapNotify of a window the server has already destroyed; only its Python
            # side is released.
            self._window._mapped = False
        if self._window is not None:
            self._window.close()
        self._window = None
        self._texture = None

    def _check_open(self) -> None:
        if self._window is None:
            raise ProjectorError(f"the projector on {self._where} is not open; open it first")
        if not self._connection_lost:
            self._window.dispatch_events()
        if self._connection_lost:
            raise ProjectorError(
                f"the projector window on {self._where} was closed mid-run after frame "
                f"{self._frame_counter}: its X connection was lost (the window was killed or "
                "the X server ended); keep it open until the capture ends"
            )
        if self._closed_mid_run:
            raise ProjectorError(
                f"the projector window on {self._where} was closed mid-run after frame "
                f"{self._frame_counter}; keep it open until the capture ends"
            )

    def _draw_texture(self, texture: Any, width: int, height: int) -> None:
        """Draw the frame's texture at 1:1 over the whole window."""
        texture.blit(0, 0, width=width, height=height)

    def show(self, image: ArrayLike) -> int:
        """Show one image full screen and return its frame number.

        Parameters
        ----------
        image : array_like of uint8, shape (height, width) or (height, width, 3)
            Gray or RGB, at the screen's native size; row 0 is the top of the screen.

        Returns
        -------
        int
            The frame number (1, 2, ...), also :attr:`frame_counter` afterwards.

        Raises
        ------
        InputError
            The image is not uint8 or not of the screen's size.
        ProjectorError
            The projector is not open or its window was closed mid-run.
        """
        self._check_open()
        img = self._check_image(image)
        import pyglet
        from pyglet import gl

        width, height = self.size
        rgba = np.empty((height, width, 4), np.uint8)
        rgba[..., :3] = img[..., None] if img.ndim == 2 else img
        rgba[..., 3] = 255
        # Rows top first: a negative pitch tells pyglet that row 0 is the top.
        data = pyglet.image.ImageData(width, height, "RGBA", rgba.tobytes(), pitch=-4 * width)
        window = self._window
        window.switch_to()
        self._texture.blit_into(data, 0, 0, 0)
        gl.glClearColor(0.0, 0.0, 0.0, 1.0)
        window.clear()
        self._draw_texture(self._texture, width, height)
        window.flip()
        gl.glFinish()
        self._check_open()
        self._frame_counter += 1
        return self._frame_counter


class FolderProjector(_ProjectorBase):
    """Writes each shown image as a PNG plus a play list, for an external player.

    Frame ``n`` is written as ``NNNNNN.png`` (8-bit gray or RGB, lossless); after every frame
    the folder holds ``playlist.json`` (``format`` ``"hdrfringe-playlist"``, version 1: the
    size and one entry per frame with its number, file and mode) and ``playlist.m3u`` (the file
    names in order, for players such as mpv or feh). Each file is written under a temporary name
    and renamed, so the folder never holds a half-written image or list.

    Parameters
    ----------
    path : str or Path
        Output folder: created, or an existing empty one (a non-empty folder is refused).
    width, height : int
        The projector's native size in pixels.

    Raises
    ------
    InputError
        A size that is not a positive integer.
    OutputExistsError
        From :meth:`open`: the folder exists and is not empty.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp()) / "play"
    >>> with FolderProjector(folder, 4, 2) as projector:
    ...     projector.show(np.zeros((2, 4), np.uint8))
    ...     projector.show(np.full((2, 4, 3), 255, np.uint8))
    1
    2
    >>> strict_json.loads_strict((folder / "playlist.json").read_text())["frames"][1]
    {'frame': 2, 'file': '000002.png', 'mode': 'RGB'}
    >>> (folder / "playlist.m3u").read_text().split()
    ['000001.png', '000002.png']
    """

    def __init__(self, path: str | Path, width: int, height: int) -> None:
        for what, value in (("width", width), ("height", height)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise InputError(f"the projector {what} must be a positive integer, got {value!r}")
        self.path = Path(path)
        self._size = (width, height)
        self._entries: list[dict[str, Any]] = []
        self._open = False
        self._frame_counter = 0

    def __repr__(self) -> str:
        return f"FolderProjector({str(self.path)!r}, {self._size[0]}, {self._size[1]})"

    @property
    def size(self) -> tuple[int, int]:
        """Native (width, height) in pixels.

        Returns
        -------
        tuple of int
        """
        return self._size

    def open(self) -> None:
        """Create the folder (or take an empty one) and start an empty play list.

        Raises
        ------
        OutputExistsError
            The folder exists and is not empty.
        """
        if self._open:
            return
        if self.path.exists() and (not self.path.is_dir() or any(self.path.iterdir())):
            raise OutputExistsError(
                f"{self.path} exists and is not an empty folder; choose a new folder for the "
                "projector's frames"
            )
        self.path.mkdir(parents=True, exist_ok=True)
        self._entries = []
        self._frame_counter = 0
        self._open = True
        self._write_lists()

    def close(self) -> None:
        """Stop writing; the folder keeps every frame shown. Closing twice is harmless."""
        self._open = False

    def _replace(self, name: str, write: Any) -> None:
        tmp = self.path / f".{name}.tmp"
        write(tmp)
        os.replace(tmp, self.path / name)

    def _write_lists(self) -> None:
        manifest = {
            "format": PLAYLIST_FORMAT,
            "version": 1,
            "width": self._size[0],
            "height": self._size[1],
            "frames": self._entries,
        }
        text = strict_json.dumps(manifest, nonfinite="error") + "\n"
        m3u = "".join(e["file"] + "\n" for e in self._entries)
        self._replace("playlist.json", lambda p: p.write_text(text, encoding="utf-8"))
        self._replace("playlist.m3u", lambda p: p.write_text(m3u, encoding="utf-8"))

    def show(self, image: ArrayLike) -> int:
        """Write one image and add it to the play list; return its frame number.

        Parameters
        ----------
        image : array_like of uint8, shape (height, width) or (height, width, 3)
            Gray or RGB, at the projector's native size.

        Returns
        -------
        int
            The frame number (1, 2, ...), also :attr:`frame_counter` afterwards.

        Raises
        ------
        InputError
            The image is not uint8 or not of the projector's size.
        ProjectorError
            The projector is not open.
        """
        from PIL import Image

        if not self._open:
            raise ProjectorError(
                f"the folder projector '{self.path}' is not open; open it (or use it in a "
                "with block) first"
            )
        img = self._check_image(image)
        number = self._frame_counter + 1
        name = f"{number:06d}.png"
        mode = "L" if img.ndim == 2 else "RGB"
        self._replace(name, lambda p: Image.fromarray(img, mode).save(p, format="PNG"))
        self._entries.append({"frame": number, "file": name, "mode": mode})
        self._write_lists()
        self._frame_counter = number
        return number


def render_for_projector(
    frame: Frame, width: int, height: int, gamma_hat: float = 1.0, bit_depth: int = 8
) -> NDArray[np.uint8]:
    """The 8-bit image a projector back end shows for one frame.

    Any frame kind: line frames (fringes, centre lines, uniform gray, Gray codes) render one
    line broadcast over the image; per-pixel frames (:class:`~hdrfringe.core.frames.
    PixelwiseFringeFrame`, :class:`~hdrfringe.core.frames.ImageFrame`) render their 2-D data, which
    must be of the projector's size. The result is a writable C-contiguous ``(height, width)``
    uint8 array, the same levels :func:`hdrfringe.core.frames.render_frame` gives (and
    ``hdrfringe patterns`` writes).

    Parameters
    ----------
    frame : Frame
        Any frame.
    width, height : int
        The projector's native size in pixels.
    gamma_hat : float
        Gamma pre-compensation exponent (1.0: none).
    bit_depth : int
        Projector input bit depth; the back ends show 8-bit images, so it must be 8.

    Returns
    -------
    ndarray of uint8, shape (height, width)

    Raises
    ------
    InputError
        A bit depth other than 8, or a frame that does not fit the projector.

    Notes
    -----
    Gamma pre-compensation: thesis Eq. 2.17 (:func:`hdrfringe.core.frames.render_frame`).

    Examples
    --------
    >>> from hdrfringe.core.frames import CenterlineFrame, ImageFrame
    >>> render_for_projector(CenterlineFrame(1.0), 4, 2).tolist()
    [[0, 255, 0, 0], [0, 255, 0, 0]]
    >>> render_for_projector(ImageFrame(np.array([[0.0, 10.0], [20.0, 30.0]])), 2, 2).tolist()
    [[0, 10], [20, 30]]
    """
    if bit_depth != 8:
        raise InputError(
            f"the projector back ends show 8-bit images; render at bit_depth 8, got {bit_depth}"
        )
    image = render_frame(frame, width, height, gamma_hat, bit_depth)
    return np.array(image, dtype=np.uint8, order="C", copy=True)
