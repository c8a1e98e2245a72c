"""Small moderngl helpers: shader files with #include, dynamic buffers, matrices."""
from __future__ import annotations

import functools
import re
from pathlib import Path

import numpy as np

SHADER_DIR = Path(__file__).resolve().parent.parent.parent / "shaders"
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*$', re.M)


def shader_source(name: str) -> str:
    """GLSL text of ``shaders/name`` with ``#include "file"`` lines expanded (one level)."""
    text = (SHADER_DIR / name).read_text()
    return _INCLUDE.sub(lambda m: (SHADER_DIR / m.group(1)).read_text(), text)


def program(ctx, vertex: str, fragment: str, geometry: str | None = None, defines: tuple = ()):
    """A program from files in ``shaders/``, each with ``#define NAME`` for ``defines``."""
    def source(name):
        text = shader_source(name)
        return text.replace("#version 330", "#version 330\n" + "".join(f"#define {d}\n" for d in defines), 1)
    return ctx.program(vertex_shader=source(vertex), fragment_shader=source(fragment),
                       geometry_shader=source(geometry) if geometry else None)


@functools.cache
def _gl_library():
    """GLVND's libOpenGL (dispatches to the current context, EGL or GLX), or libGL;
    None where neither loads. For the few calls moderngl does not expose."""
    import ctypes
    import ctypes.util
    for name in ("libOpenGL.so.0", ctypes.util.find_library("OpenGL"), "libGL.so.1"):
        if not name:
            continue
        try:
            lib = ctypes.CDLL(name)
            lib.glFlush          # present, or try the next library
            return lib
        except (OSError, AttributeError):
            continue
    return None


def flush() -> None:
    """glFlush on the current context (moderngl has only finish): hands the commands
    issued so far to the driver, so llvmpipe's worker threads start rasterising them
    while this thread goes on; a no-op where no GL library exposes it."""
    lib = _gl_library()
    if lib is not None:
        lib.glFlush()


@functools.cache
def can_copy_regions() -> bool:
    """Can ``copy_rect`` copy to and from places other than the origin here?"""
    lib = _gl_library()
    return lib is not None and hasattr(lib, "glBindFramebuffer") and hasattr(lib, "glBlitFramebuffer")


_READ_FRAMEBUFFER, _DRAW_FRAMEBUFFER = 0x8CA8, 0x8CA9
_COLOR_BIT, _DEPTH_BIT, _NEAREST = 0x4000, 0x100, 0x2600


def copy_rect(ctx, dst, src, dst_origin=(0, 0), src_origin=(0, 0), depth: bool = True,
              size: tuple | None = None) -> None:
    """Copy a rectangle of framebuffer ``src`` from ``src_origin`` (lower-left corner, GL
    pixels) into ``dst`` at ``dst_origin``: colour, and depth with ``depth``; ``size`` (w, h)
    or as large as the smaller framebuffer allows (moderngl's copy_framebuffer copies only
    origin to origin). Leaves ``dst`` bound."""
    (dx, dy), (sx, sy) = (int(v) for v in dst_origin), (int(v) for v in src_origin)
    if size is None and (dx, dy, sx, sy) == (0, 0, 0, 0) and (
            depth or src.depth_attachment is None or dst.depth_attachment is None):
        ctx.copy_framebuffer(dst, src)
        dst.use()
        return
    if not can_copy_regions():
        raise RuntimeError("no GL library to copy a framebuffer region with")
    lib = _gl_library()
    w, h = min(src.width - sx, dst.width - dx), min(src.height - sy, dst.height - dy)
    if size is not None:
        w, h = min(w, int(size[0])), min(h, int(size[1]))
    if w <= 0 or h <= 0:
        return
    lib.glBindFramebuffer(_READ_FRAMEBUFFER, src.glo)
    lib.glBindFramebuffer(_DRAW_FRAMEBUFFER, dst.glo)
    lib.glBlitFramebuffer(sx, sy, sx + w, sy + h, dx, dy, dx + w, dy + h,
                          _COLOR_BIT | (_DEPTH_BIT if depth else 0), _NEAREST)
    dst.use()      # moderngl binds its own framebuffer again (read and draw)


def depth_writes(ctx, on: bool) -> None:
    """Turn depth writes of the bound framebuffer on or off (blended layers test depth without
    writing it). moderngl keeps the mask per framebuffer: ``Context`` has no ``depth_mask``,
    and setting one there silently did nothing."""
    ctx.fbo.depth_mask = on


def color_writes(ctx, on: bool) -> None:
    """Turn colour writes of the bound framebuffer on or off (a depth-only pre-pass).
    moderngl 5 stores a framebuffer's colour mask when it is set but hands it to GL only when
    the framebuffer is bound (``use``, or a ``clear``): set alone, draws kept writing colour."""
    fbo = ctx.fbo
    fbo.color_mask = (on,) * 4
    fbo.use()


def mat_bytes(m: np.ndarray) -> bytes:
    """Row-major (..., 4, 4) column-vector matrices as GLSL (column-major) bytes."""
    m = np.asarray(m, np.float32)
    return np.ascontiguousarray(np.swapaxes(m, -1, -2)).tobytes()


def set_uniform(prog, name: str, value) -> None:
    """Set a uniform if the (optimising) compiler kept it."""
    u = prog.get(name, None)      # (``name in prog`` walks every member)
    if u is not None:
        if isinstance(value, np.ndarray) and value.shape[-2:] == (4, 4):
            u.write(mat_bytes(value))
        elif isinstance(value, (bytes, bytearray)):
            u.write(value)
        else:
            u.value = tuple(value) if isinstance(value, (list, tuple, np.ndarray)) else value


class DynamicBuffer:
    """A vertex buffer refilled every frame in place (orphaned), grown only when too small."""

    def __init__(self, ctx, capacity_bytes: int = 1 << 16):
        self.ctx = ctx
        self.capacity = capacity_bytes
        self.buffer = ctx.buffer(reserve=capacity_bytes, dynamic=True)
        self.generation = 0   # bumps when the buffer object is replaced (VAOs must be rebuilt)

    def update(self, data: bytes) -> None:
        if len(data) > self.capacity:
            self.capacity = max(len(data), 2 * self.capacity)
            self.buffer.release()
            self.buffer = self.ctx.buffer(reserve=self.capacity, dynamic=True)
            self.generation += 1
        else:
            self.buffer.orphan(self.capacity)
        if data:
            self.buffer.write(data)
