"""``hdrfringe capture`` stopped from outside on a real window (issue 13, last done-when item).

The command runs as a user runs it (a subprocess), on Xvfb with the projector window and the
loop camera. From another X client the test closes the window mid-run, as a window manager
does (WM_DELETE_WINDOW) and as ``xkill`` does (XKillClient: the window's connection is cut),
and sends SIGINT (Ctrl-C) mid-capture. The test follows the run by watching the X screen (a
screenshot per poll: each projected frame is a distinct screen), not through any hook in the
command. X calls go through pyglet's Xlib binding (pyglet is the projector's own dependency).
"""

from __future__ import annotations

import ctypes
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.conftest import xvfb_display

# The Xvfb tests share one group: one worker runs them (make test: --dist loadgroup).
pytestmark = pytest.mark.xdist_group("xvfb")

WIDTH, HEIGHT = 640, 480
#: Seconds each frame stays on screen at least (--settle): the screen poll sees every frame.
SETTLE = "0.3"


@pytest.fixture(scope="module")
def xdisplay() -> Iterator[str]:
    with xvfb_display(WIDTH, HEIGHT) as display:
        yield display


def start_capture(display: str, out: Path) -> subprocess.Popen[str]:
    camera = f"loop:checkerboard?display={display}&size=80x60"
    args = ["capture", "--projector", f"screen:0@{display}", "--camera", camera,
            "--pitch", "1024,64,8", "--settle", SETTLE, "-o", str(out)]  # fmt: skip
    # A shell that starts jobs in the background (CI may) hands them SIGINT ignored, and
    # Python then installs no KeyboardInterrupt handler: the child gets the default back, so
    # the Ctrl-C test's signal reaches the command (it ran to the end, exit 0, without this)
    return subprocess.Popen(
        [sys.executable, "-m", "hdrfringe.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def connect(display: str) -> object:
    """An Xlib connection; Xvfb refuses some connections opened in quick succession (about 1 in
    8 back to back on a loaded machine), so a refused one is tried again."""
    from pyglet.libs.x11 import xlib

    for _ in range(10):
        dpy = xlib.XOpenDisplay(display.encode())
        if dpy:
            return dpy
        time.sleep(0.05)
    raise AssertionError(f"cannot connect to {display}")


def wait_for_screens(display: str, proc: subprocess.Popen[str], count: int) -> None:
    """Poll the X screen until it has shown ``count`` different contents (the empty root
    window is the first), or fail if the command ends or 60 s pass.

    One X connection for the whole poll: a screenshot client per poll made Xvfb refuse some
    of the command's own connections."""
    from pyglet.libs.x11 import xlib

    dpy = connect(display)
    root = xlib.XDefaultRootWindow(dpy)
    seen, last = 0, b""
    deadline = time.monotonic() + 60
    try:
        while seen < count:
            assert proc.poll() is None, f"capture ended early: {proc.communicate()}"
            assert time.monotonic() < deadline, f"only {seen} screens seen"
            image = xlib.XGetImage(dpy, root, 0, 0, WIDTH, HEIGHT, xlib.XAllPlanes(),
                                   xlib.ZPixmap)  # fmt: skip
            assert image, "XGetImage failed"
            # the pixel pointer (pyglet declares the field char*, which ctypes reads as a string)
            data = ctypes.c_void_p.from_buffer(image.contents, xlib.XImage.data.offset).value
            shot = ctypes.string_at(data, image.contents.bytes_per_line * HEIGHT)
            xlib.XFree(data)  # what XDestroyImage does for XGetImage's image
            xlib.XFree(image)
            if shot != last:
                seen, last = seen + 1, shot
            time.sleep(0.05)  # poll, well below the settle time each frame stays
    finally:
        xlib.XCloseDisplay(dpy)


def projector_window(display: str) -> int:
    """The X id of the window titled "hdrfringe projector" (searched in the window tree)."""
    from pyglet.libs.x11 import xlib

    dpy = connect(display)
    try:
        stack = [xlib.XDefaultRootWindow(dpy)]
        while stack:
            window = stack.pop()
            name = ctypes.c_char_p()
            if xlib.XFetchName(dpy, window, ctypes.byref(name)) and name.value == (
                b"hdrfringe projector"
            ):
                return int(window)
            root, parent, n = xlib.Window(), xlib.Window(), ctypes.c_uint()
            children = ctypes.POINTER(xlib.Window)()
            if xlib.XQueryTree(dpy, window, ctypes.byref(root), ctypes.byref(parent),
                               ctypes.byref(children), ctypes.byref(n)):  # fmt: skip
                stack += [children[i] for i in range(n.value)]
        raise AssertionError("no projector window on the display")
    finally:
        xlib.XCloseDisplay(dpy)


def close_window(display: str, window: int, how: str) -> None:
    """Close the window from another client: ``wm`` sends WM_DELETE_WINDOW (a window
    manager's close button), ``kill`` calls XKillClient (``xkill``)."""
    from pyglet.libs.x11 import xlib

    dpy = connect(display)
    try:
        if how == "kill":
            xlib.XKillClient(dpy, window)
        else:
            event = xlib.XEvent()
            event.xclient.type = xlib.ClientMessage
            event.xclient.window = window
            event.xclient.message_type = xlib.XInternAtom(dpy, b"WM_PROTOCOLS", False)
            event.xclient.format = 32
            event.xclient.data.l[0] = xlib.XInternAtom(dpy, b"WM_DELETE_WINDOW", False)
            event.xclient.data.l[1] = xlib.CurrentTime
            assert xlib.XSendEvent(dpy, window, False, 0, ctypes.byref(event))
        xlib.XSync(dpy, False)
    finally:
        xlib.XCloseDisplay(dpy)


def leftovers(root: Path) -> list[str]:
    return sorted(p.name for p in root.iterdir())


@pytest.mark.parametrize(
    ("how", "message"),
    [
        ("wm", "was closed mid-run after frame"),
        ("kill", "its X connection was lost (the window was killed or the X server ended)"),
    ],
)
def test_window_closed_mid_capture_is_a_one_line_error_and_writes_nothing(
    xdisplay: str, tmp_path: Path, how: str, message: str
) -> None:
    out = tmp_path / "caps"
    proc = start_capture(xdisplay, out)
    try:
        # the root, the rig's mid-gray and white (its noise reference), the view check's black
        # and white, the first fringe
        wait_for_screens(xdisplay, proc, 6)
        close_window(xdisplay, projector_window(xdisplay), how)
        _, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
    # before the fix, XKillClient ended the process in Xlib's exit(1) with two XIO lines
    assert proc.returncode == 2, stderr
    assert stderr.count("\n") == 1 and stderr.startswith("error: the projector window")
    assert message in " ".join(stderr.split())
    assert leftovers(tmp_path) == []  # no output, no staging folder


@pytest.mark.parametrize(
    ("signum", "code", "stopped"),
    [
        (signal.SIGINT, 2, "interrupted (Ctrl-C)"),
        # issue 31: SIGTERM (a supervisor, systemd) discarded the sets captured so far
        (signal.SIGTERM, 143, "stopped by SIGTERM"),
    ],
)
def test_ctrl_c_mid_capture_keeps_the_complete_sets_and_says_so(
    xdisplay: str, tmp_path: Path, signum: int, code: int, stopped: str
) -> None:
    from hdrfringe.io.captures import read_capture_folder

    out = tmp_path / "caps"
    proc = start_capture(xdisplay, out)
    try:
        # the root, the rig's mid-gray and white, the view check's black and white, the four
        # frames of the first set, the second set's first
        wait_for_screens(xdisplay, proc, 10)
        os.kill(proc.pid, signum)
        _, stderr = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == code, stderr
    text = " ".join(stderr.split())
    assert stderr.count("error:") == 1 and f"capture {stopped} after" in text
    sets = int(text.split(f"{stopped} after ")[1].split()[0])
    assert sets in (1, 2)  # the second set may complete before the signal arrives
    caps = read_capture_folder(out)  # every image readable: nothing half-written
    assert len(caps.sets) == sets and len(caps.frames) == 4 * sets
    assert caps.sets[0].spec.pitch_px == 1024.0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["capture"]["complete"] is False
    assert manifest["capture"]["stopped"] == stopped
    assert leftovers(tmp_path) == ["caps"]  # no staging folder left beside it
