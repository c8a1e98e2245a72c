"""The software-GL profile: the few tricks that earn their place on a software rasteriser
(Mesa's llvmpipe, softpipe, swrast), where every shaded pixel costs CPU time. Elsewhere
(a GPU) the plain path runs: draw everything every frame, present the whole frame.

Each trick was measured at the hit frame of ``docs/bench_drag_hit.json`` in an Xvfb
window at 1280x720 on llvmpipe, alternating with and without it (3 runs each, medians);
kept only when it won at least 1 ms (2026-12-02):

* ``layers.StaticLayer``: the static scene drawn once per camera (with 4x MSAA) and
  copied in: 13.4 ms (2.3x);
* ``ui_damage``: the panel and timeline redraw only the bands whose triangles changed:
  4.2-7.7 ms (1.4-1.5x);
* ``layers.GhostLayer``: the ghost's nearest surface cached while the source pose and
  the camera hold still, blended in over its box: 2.6 ms (1.25x);
* the batsman's levels of detail by his size on screen (``app.render.body``): 3.5 ms (1.3x);
* ``present``: only what changed is drawn to a window that keeps its back buffer, and shown
  with glXCopySubBufferMESA: 2.4-9.0 ms (1.2-1.8x) for the partial draw, and the sub-buffer
  copy 0.1-8.0 ms more (it spares the X server's CPU: most when the machine is busy).

Deleted, for winning less: the blake2 scene key and cached scene image (-0.3 ms), the
held-pose layer (-0.2 ms), ghost tiles (0.4 / -1.4 ms), MSAA only after the camera settles
(-0.3 ms), timing blit against draw for the present (0.03 ms), and FXAA over the moving
boxes with a CPU readback (off by default: 0 ms; FXAA now filters the whole view).
"""
from __future__ import annotations

import os

MODES = ("auto", "on", "off")
SOFTWARE_RENDERERS = ("llvmpipe", "softpipe", "swrast")
_mode = os.environ.get("HITPOINT_SOFTWARE_GL", "auto")


def set_mode(mode: str) -> None:
    """``auto``: by the GL renderer's name; ``on``/``off``: forced (``hitpoint view --software-gl``)."""
    global _mode
    if mode not in MODES:
        raise ValueError(f"software GL mode {mode!r}: one of {', '.join(MODES)}")
    _mode = mode


def is_software(renderer: str) -> bool:
    """Does this GL renderer string name a software rasteriser?"""
    return any(name in renderer.lower() for name in SOFTWARE_RENDERERS)


def enabled(ctx) -> bool:
    """Whether the software-GL profile applies to ``ctx`` (asked once, when a renderer,
    compositor or UI renderer is made for it)."""
    if _mode != "auto":
        return _mode == "on"
    return is_software(str(ctx.info.get("GL_RENDERER", "")))
