"""The OS window and GL context.

Interactive: a glfw window (GLX under X11). Headless: a standalone EGL context
(Mesa, no display needed, the same kind the renderer's own tests use - mixing
GLX and EGL contexts in one process makes X refuse the GLX one); when EGL is
not available, a hidden glfw window on a private Xvfb. Either way the viewer
runs the same loop; headless frames are composed into an offscreen
framebuffer, since a hidden window's back buffer need not hold pixels.
"""
from __future__ import annotations

import atexit
import os
import shutil
import signal
import subprocess
import sys
import time

import moderngl

from app import softgl
from app.softgl import present


class DisplayError(RuntimeError):
    """No way to open a GL window (no display and no Xvfb)."""


_xvfb: subprocess.Popen | None = None


def ensure_display() -> None:
    """Start ``Xvfb`` (a free display number) if ``DISPLAY`` is unset; once per process."""
    global _xvfb
    if os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return
    exe = shutil.which("Xvfb")
    if exe is None:
        raise DisplayError("no DISPLAY and no Xvfb: install xvfb or run under a display")
    read_fd, write_fd = os.pipe()
    # -displayfd picks a free display number and writes it to the pipe: no clash
    # with other Xvfb servers running on the same machine.
    _xvfb = subprocess.Popen([exe, "-displayfd", str(write_fd), "-screen", "0", "1920x1080x24",
                              "-nolisten", "tcp"], pass_fds=(write_fd,),
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                             start_new_session=True)  # a Ctrl+C or group signal is ours to handle
    os.close(write_fd)
    number = b""
    deadline = time.monotonic() + 10
    with os.fdopen(read_fd, "rb") as pipe:
        while not number.endswith(b"\n") and time.monotonic() < deadline:
            chunk = pipe.read(1)
            if not chunk:
                break
            number += chunk
    if not number.strip():
        _xvfb.kill()
        raise DisplayError("Xvfb did not start")
    os.environ["DISPLAY"] = ":" + number.decode().strip()
    atexit.register(_stop_xvfb)
    # A plain SIGTERM would skip atexit and leave our Xvfb running.
    if signal.getsignal(signal.SIGTERM) in (signal.SIG_DFL, None):
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))


def _stop_xvfb() -> None:
    global _xvfb
    if _xvfb is not None and _xvfb.poll() is None:
        _xvfb.terminate()
        try:
            _xvfb.wait(3)
        except subprocess.TimeoutExpired:
            _xvfb.kill()
    _xvfb = None


class Window:
    """A glfw window with a current GL 3.3 core context wrapped by moderngl."""

    def __init__(self, size: tuple[int, int], title: str = "Hitpoint", visible: bool = True):
        import glfw
        self.glfw = glfw
        if visible and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            # a window nobody can see would just run forever on a private Xvfb
            raise DisplayError("no display to open a window on: run `hitpoint view --headless "
                               "--screenshot out.png` for an image, or start a desktop session")
        ensure_display()
        if not glfw.init():
            raise DisplayError("glfw could not initialise (no usable display)")
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, True)
        glfw.window_hint(glfw.VISIBLE, visible)
        glfw.window_hint(glfw.SAMPLES, 0)
        self.handle = glfw.create_window(int(size[0]), int(size[1]), title, None, None)
        if not self.handle:
            glfw.terminate()
            raise DisplayError("glfw could not create a GL 3.3 window")
        glfw.make_context_current(self.handle)
        glfw.swap_interval(1 if visible else 0)
        self.ctx = moderngl.create_context()
        self.visible = visible
        # software GL only: does the back buffer keep its pixels (partial presents, app.softgl.present)?
        self.preserves_back_buffer = visible and softgl.enabled(self.ctx) and present.keeps_back_buffer(self)
        self._copy_sub_buffer = present.sub_buffer_copier(self) if self.preserves_back_buffer else None
        self._cursors = {"arrow": None, "hand": glfw.create_standard_cursor(glfw.HAND_CURSOR),
                         "move": glfw.create_standard_cursor(glfw.RESIZE_ALL_CURSOR)}
        self._cursor = "arrow"

    def show_regions(self, regions) -> bool:
        """Show just these rectangles (x, y, w, h; GL pixels) of the back buffer, if this
        window can (it keeps its back buffer and has a sub-buffer copy); False: swap instead."""
        if self._copy_sub_buffer is None:
            return False
        for rect in regions:
            self._copy_sub_buffer(*rect)
        return True

    @property
    def size(self) -> tuple[int, int]:
        """Window size in screen coordinates (what mouse positions use)."""
        return tuple(self.glfw.get_window_size(self.handle))

    @property
    def framebuffer_size(self) -> tuple[int, int]:
        return tuple(self.glfw.get_framebuffer_size(self.handle))

    def set_cursor(self, name: str) -> None:
        if name != self._cursor:
            self._cursor = name
            self.glfw.set_cursor(self.handle, self._cursors.get(name))

    def should_close(self) -> bool:
        return bool(self.glfw.window_should_close(self.handle))

    def poll(self) -> None:
        self.glfw.poll_events()

    def swap(self) -> None:
        self.glfw.swap_buffers(self.handle)

    def close(self) -> None:
        if self.handle:
            self.glfw.destroy_window(self.handle)
            self.handle = None
        self.glfw.terminate()


class HeadlessWindow:
    """The Window interface over a standalone EGL context: no OS window, no
    events (scripts call the input functions directly)."""

    def __init__(self, size: tuple[int, int]):
        self.glfw = None
        self.handle = None
        self.visible = False
        self.ctx = moderngl.create_standalone_context(require=330, backend="egl")
        self._size = (int(size[0]), int(size[1]))
        self.cursor = "arrow"

    @property
    def size(self) -> tuple[int, int]:
        return self._size

    framebuffer_size = size

    def set_cursor(self, name: str) -> None:
        self.cursor = name

    def should_close(self) -> bool:
        return False

    def poll(self) -> None:
        pass

    def swap(self) -> None:
        pass

    def show_regions(self, regions) -> bool:
        return False

    def close(self) -> None:
        if self.ctx is not None:
            self.ctx.release()
            self.ctx = None


def open_window(size: tuple[int, int], headless: bool):
    """A visible glfw window, or for headless runs an EGL context (falling
    back to a hidden glfw window, on Xvfb if there is no display)."""
    if not headless:
        return Window(size, visible=True)
    try:
        return HeadlessWindow(size)
    except Exception:   # no EGL: a hidden X window instead
        return Window(size, visible=False)
