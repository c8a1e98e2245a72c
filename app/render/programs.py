"""The scene's shader programs, built from one table of shader files, and the lighting
they share (a high sun on the off side, a little behind the batsman's front)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from . import props
from .gl import program, set_uniform

SUN_DIR = np.array([-0.55, 0.78, -0.30]) / np.linalg.norm([-0.55, 0.78, -0.30])
FILL_DIR = np.array([0.6, 0.35, 0.55]) / np.linalg.norm([0.6, 0.35, 0.55])
LIGHTING = {
    "u_sun_dir": tuple(SUN_DIR), "u_sun_color": (1.75, 1.66, 1.52),
    "u_fill_dir": tuple(FILL_DIR), "u_fill_color": (0.26, 0.28, 0.34),
    "u_sky_ambient": (0.30, 0.36, 0.47), "u_ground_ambient": (0.17, 0.20, 0.13),
    "u_haze_color": (0.80, 0.87, 0.95), "u_haze_density": 1.0 / 22000.0,
}
ZENITH, HORIZON = (0.24, 0.46, 0.82), (0.80, 0.87, 0.95)
GHOST_RGB = (0.55, 0.78, 1.0)

# name: (vertex, fragment, geometry or None, defines)
PROGRAMS = {
    "static": ("static.vert", "lit.frag", None, ()),                 # pixel-lit meshes
    "vertex_lit": ("lit_vertex.vert", "vertex_color.frag", None, ()),  # the target disc
    # the batsman's coarser levels: vertex-lit, the shadow per pixel
    "body_lit": ("lit_vertex.vert", "vertex_lit_shadow.frag", None, ("PIXEL_SHADOW",)),
    "depth": ("depth_static.vert", "depth.frag", None, ()),
    "ground": ("ground.vert", "ground.frag", None, ()),
    "receiver": ("receiver.vert", "receiver.frag", None, ()),
    "receiver_cov": ("receiver.vert", "receiver_coverage.frag", None, ()),
    "sky": ("sky.vert", "sky.frag", None, ()),
    "line": ("line.vert", "line.frag", "line.geom", ()),
    "point": ("line.vert", "point.frag", "point.geom", ()),
    "ghost": ("ghost_composite.vert", "ghost_composite.frag", None, ()),
    "fxaa": ("fxaa.vert", "fxaa.frag", None, ()),
}
LIT = ("static", "vertex_lit", "body_lit")                     # take tint, alpha, ghost mode
SHADOWED = LIT + ("ground", "receiver", "receiver_cov")       # take the frame's camera and sun


def build_programs(ctx, shadow_texel: float) -> SimpleNamespace:
    """Every program of ``PROGRAMS`` (attributes by name), with the uniforms that never change."""
    p = SimpleNamespace(**{name: program(ctx, *spec) for name, spec in PROGRAMS.items()})
    for name in LIT + ("ground", "receiver"):
        prog = getattr(p, name)
        for k, v in LIGHTING.items():
            set_uniform(prog, k, v)
        set_uniform(prog, "u_shadow_texel", shadow_texel)   # the receiver's: set per use
        set_uniform(prog, "u_shadow_map", 0)
    light, tint = ground_light()
    set_uniform(p.ground, "u_light", light)
    for prog in (p.receiver, p.receiver_cov):
        set_uniform(prog, "u_shadow_tint", tint)
    for name in LIT:
        prog = getattr(p, name)
        set_uniform(prog, "u_mode", 0)
        set_uniform(prog, "u_alpha", 1.0)
        set_uniform(prog, "u_tint", (1.0, 1.0, 1.0))
        set_uniform(prog, "u_emissive", (0.0, 0.0, 0.0))
        set_uniform(prog, "u_ghost_color", tuple(np.power(GHOST_RGB, 2.2)))
    set_uniform(p.sky, "u_sun_dir", tuple(SUN_DIR))
    set_uniform(p.sky, "u_zenith", ZENITH)
    set_uniform(p.sky, "u_horizon", HORIZON)
    return p


def frame_uniforms(p: SimpleNamespace, vp, eye, light_vp, shadows: bool, shadow_tex) -> None:
    """The camera and the sun's map for every shadowed program (``shadow_tex`` on unit 0)."""
    shadow_tex.use(0)
    for name in SHADOWED:
        prog = getattr(p, name)
        set_uniform(prog, "u_view_proj", vp)
        set_uniform(prog, "u_eye", eye)
        set_uniform(prog, "u_light_vp", light_vp)
        set_uniform(prog, "u_shadow_on", 1.0 if shadows else 0.0)


def _aces(c):
    c = np.asarray(c, float)
    return np.sqrt(np.clip((c * (2.51 * c + 0.03)) / (c * (2.43 * c + 0.59) + 0.14), 0, 1))


def ground_light() -> tuple[tuple, tuple]:
    """Linear irradiance on the flat ground, and the display-space ratio shadowed/lit (grass)."""
    L = {k: np.asarray(v, float) for k, v in LIGHTING.items() if k != "u_haze_density"}
    ambient = L["u_sky_ambient"] + L["u_fill_color"] * max(L["u_fill_dir"][1], 0)
    lit = ambient + L["u_sun_color"] * max(L["u_sun_dir"][1], 0)
    grass = np.power(props.GRASS, 2.2)
    return tuple(lit), tuple(_aces(grass * ambient) / _aces(grass * lit))
