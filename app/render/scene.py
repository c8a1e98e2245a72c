"""Scene renderer: shadowed, lit, skinned batsman on a cricket ground, with overlays.

One ``SceneRenderer`` per GL context draws a ``SceneView`` as a short list of passes,
each a class of its own module drawing one part: the shadow maps (``shadow``), the static
scene (``static``), the batsman with the ball and target (``body``), the overlays
(``overlays``), the translucent ghost (``ghost``) and FXAA (``fxaa``).

The plain path draws every pass every frame, multisampled. On software GL (``app.softgl``)
the static scene and the ghost are cached layers redrawn only when the camera (or the
source pose) changes, the batsman's level of detail follows his size on screen, and each
render says what it changed over the static layer, for the window's partial present.

Matrices use the column-vector convention: ``p_clip = proj @ view @ p_world``.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import moderngl
import numpy as np

from app import softgl
from app.errors import UserError
from app.render.mesh import load_glb
from app.softgl import kernels
from engine.skeleton import bind_positions
from .body import BodyPass
from .fxaa import AntialiasPass
from .gl import copy_rect
from .ghost import GhostPass
from .overlays import OverlayPass
from .programs import SUN_DIR, build_programs, frame_uniforms  # noqa: F401  (SUN_DIR: the sun, for tests)
from .shadow import SHADOW_SIZE, ShadowPass, fit_sun  # noqa: F401  (fit_sun: for tests)
from .skinning import joint_boxes, skin_programs
from .static import BACKGROUND, StaticPass  # noqa: F401
from .transforms import look_at, perspective  # noqa: F401  (the public camera helpers)

PLAIN_MSAA = 4       # the plain path's samples for a single-sampled target


@dataclass
class SceneView:
    view: np.ndarray              # (4,4) world->camera, float32, column-vector convention
    proj: np.ndarray              # (4,4)
    size: tuple[int, int]         # (w, h) pixels
    skin_matrices: np.ndarray | None  # (J,4,4) float32, engine.skeleton.skinning_matrices; None: no batsman
    ghost_skin_matrices: np.ndarray | None = None  # source pose, drawn translucent
    ghost_alpha: float = 0.25
    skeleton_lines: list = ()     # [(global_positions (J,3), parents (J,), rgba)]
    ball_position: np.ndarray | None = None
    target_position: np.ndarray | None = None     # red-and-white target disc
    target_normal: tuple = (0, 0, 1)
    target_highlight: bool = False
    crosses: list = ()            # [(points (N,3), rgba, size_cm)] e.g. nine FK hit points
    points: list = ()             # [(points (N,3), rgba, size_px)]
    polylines: list = ()          # [(points (N,3), rgba, width_px)]
    show_pitch: bool = True
    terrain: object = None        # an app.render.props.terrain_prop Mesh (uneven ground) drawn in the static pass
    # optional extras
    origin: tuple[int, int] = (0, 0)  # lower-left corner of the view in the target (GL pixels)
    shadows: bool = True
    skeleton_width_px: float = 3.0
    skeleton_on_top: bool = True  # skeleton lines ignore depth (visible inside the mesh)
    antialias: bool = False       # single-sampled targets (software GL): FXAA over the view
    camera_moving: bool = False   # software GL: the cached static layer skips its 4x MSAA while orbiting
    detail: int | None = None     # the batsman's level of detail (0 finest); None: by his size on screen


@dataclass
class Frame:
    """What every pass of one render needs: the view, its camera and sun, where it is drawn."""
    view: SceneView
    vp: np.ndarray                # (4,4) float32 proj @ view
    eye: tuple
    origin: tuple[int, int]       # the view's lower-left corner in the framebuffer drawn into
    shadows: bool
    level: int                    # the batsman's level of detail
    shadow: ShadowPass


def offscreen_context():
    """A standalone (headless, EGL) moderngl context, GL 3.3 core or newer; without one,
    a UserError the CLI says in one line (exit 2)."""
    try:
        return moderngl.create_standalone_context(backend="egl", require=330)
    except Exception as e:          # moderngl says why in its own words: keep its first line
        reason = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise UserError(f"no offscreen OpenGL 3.3 context (Mesa's EGL: Debian's libegl-mesa0 and "
                        f"libgl1-mesa-dri): {reason}") from None


def _samples(fbo) -> int:
    return int(getattr(fbo, "samples", 0) or 0)


def _body_meshes(rig, meshes: dict, own: bool) -> tuple[list, object]:
    """The body's levels of detail (finest first) and its shadow caster: the batsman's
    (``own``: the rig is his), or capsules along the bones of another skeleton."""
    if not own:
        from app.render.bonebody import bone_body     # trimesh (~0.4 s): only for a user's skeleton
        return [bone_body(rig, rig.roles.get("head"), rig.bat)], None
    levels = [meshes["Batsman"]]         # a missing level ends the chain
    for name in ("BatsmanLod1", "BatsmanLod2"):
        if meshes.get(name) is None or meshes[name].joints is None:
            break
        levels.append(meshes[name])
    caster = meshes.get("BatsmanShadow")     # a third of the triangles, the same outline
    return levels, caster if caster is not None and caster.joints is not None else None


class SceneRenderer:
    def __init__(self, ctx, rig, glb_path=None, software_gl: bool | None = None):
        """Load ``assets/batsman.glb`` (or ``glb_path``) and the shaders; build the passes.
        ``software_gl``: the software-GL profile (None: ``app.softgl.enabled(ctx)``)."""
        self.ctx, self.rig = ctx, rig
        self.software_gl = softgl.enabled(ctx) if software_gl is None else bool(software_gl)
        self.bind_positions = bind_positions(rig.skeleton)
        try:
            meshes, own = load_glb(glb_path, rig), True
        except ValueError:     # a skeleton the batsman is not skinned to (a user's capture)
            meshes, own = load_glb(glb_path), False
        self.body_levels, self.shadow_mesh = _body_meshes(rig, meshes, own)
        self.body_mesh = self.body_levels[0]
        J = rig.skeleton.num_joints
        self.p = build_programs(ctx, 1.0 / SHADOW_SIZE)
        skin = skin_programs(ctx, J)
        self._joint_boxes = joint_boxes(self.body_mesh, J)
        self.body = BodyPass(ctx, self.p, skin, J, self.body_levels, self.shadow_mesh, meshes["Ball"], self._joint_boxes)
        self.static = StaticPass(ctx, self.p, None)
        self.shadow = ShadowPass(ctx, self.p, self.body.posed, self.body.ball, self.static.wickets,
                                 self.static.wickets_mesh, self._joint_boxes)
        self.static.shadow = self.shadow
        self.ghost = GhostPass(ctx, self.p, skin, J, self.body_levels)
        self.overlays = OverlayPass(ctx, self.p)
        self.antialias = AntialiasPass(ctx, self.p)
        self._msaa = None              # plain path: (size, framebuffer) drawn into, then resolved
        self.static_key = None         # software GL: the static layer under the last render
        self.changed = None            # and what it drew over it (softgl.screen_box.ChangedRegion)
        if self.software_gl:
            from app.softgl.layers import GhostLayer, StaticLayer     # they import app.render: a cycle at the top
            self.static_layer = StaticLayer(ctx, self.static)
            self.ghost_layer = GhostLayer(ctx, self.p, self.ghost, self._joint_boxes)

    @property
    def posed(self):
        """The posed batsman (``app.render.skinning.PosedBody``)."""
        return self.body.posed

    def render(self, view: SceneView, fbo=None) -> None:
        """Draw the scene into ``fbo`` (default: the screen) at ``view.origin``. The plain
        path draws a single-sampled framebuffer's view with 4x MSAA and resolves it there."""
        ctx = self.ctx
        target = fbo if fbo is not None else ctx.screen
        if self.software_gl or _samples(target) > 0 or target is ctx.screen:
            return self._render(self._frame(view, view.origin), target)
        size = tuple(view.size)
        if self._msaa is None or self._msaa[0] != size:
            samples = min(PLAIN_MSAA, ctx.max_samples)
            self._msaa = (size, ctx.framebuffer([ctx.renderbuffer(size, 4, samples=samples)],
                                                ctx.depth_renderbuffer(size, samples=samples)))
        self._render(self._frame(view, (0, 0)), self._msaa[1])
        copy_rect(ctx, target, self._msaa[1], dst_origin=view.origin, depth=False)

    def _frame(self, view: SceneView, origin) -> Frame:
        vp = np.asarray(view.proj, np.float32) @ np.asarray(view.view, np.float32)
        v = np.asarray(view.view, float)
        level = self.body.detail_level(view, vp, by_size=self.software_gl)
        self.body.posed.level = self.ghost.posed.level = level
        return Frame(view, vp, tuple(-v[:3, :3].T @ v[:3, 3]), tuple(origin), bool(view.shadows), level,
                     self.shadow)

    def _render(self, frame: Frame, target) -> None:
        """The passes in order: static scene, shadow maps, body, overlays, ghost, FXAA."""
        ctx, view = self.ctx, frame.view
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        ctx.depth_func = "<"
        layered = self.software_gl and self.static_layer.copy_into(frame, target)
        ghost_layer = layered and self.ghost.wanted(view) and kernels.ready()
        if ghost_layer:
            self.ghost_layer.update(frame)
        if not layered:
            self.static.draw(frame, target, frame.origin)
        light_vp, quad = self.shadow.update(view) if frame.shadows else (self.shadow.static_fit[0], None)
        target.use()
        ctx.viewport = (*frame.origin, *view.size)
        frame_uniforms(self.p, frame.vp, frame.eye, light_vp, frame.shadows, self.shadow.tex)
        self.body.draw(frame, quad)
        ctx.enable(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        lines, points = self.overlays.draw(frame)
        if ghost_layer:
            self.ghost_layer.composite(frame.origin)
        elif self.ghost.wanted(view):
            self.ghost.draw(frame, target)
        ctx.disable(moderngl.BLEND)
        if view.antialias and _samples(target) == 0 and target is not ctx.screen:
            self.antialias.draw(frame, target)
        self._note_changed(frame, layered, quad if view.show_pitch else None, lines, points)

    def _note_changed(self, frame: Frame, layered: bool, quad, lines, points) -> None:
        """Software GL: which static layer this render drew over (``static_key``; None when
        the scene was drawn whole) and what it drew over it (``changed``), for the window's
        partial present."""
        if not self.software_gl:
            return
        from app.softgl.screen_box import changed_region     # imports app.render: a cycle at the top
        self.static_key = self.static_layer.key if layered else None
        self.changed = changed_region(frame.view, frame.vp, self._joint_boxes, quad, lines, points)


def render_image(renderer: SceneRenderer, view: SceneView, samples: int = 4) -> np.ndarray:
    """Render ``view`` offscreen with MSAA (4x by default); ``(h, w, 3)`` uint8, top row first.
    Stills draw the finest batsman unless ``view.detail`` says otherwise."""
    if view.detail is None:
        view = replace(view, detail=0)
    w, h = view.size
    ctx = renderer.ctx
    samples = min(samples, ctx.max_samples)
    msaa = ctx.framebuffer([ctx.renderbuffer((w, h), 4, samples=samples)],
                           ctx.depth_renderbuffer((w, h), samples=samples))
    resolve = ctx.framebuffer([ctx.renderbuffer((w, h), 4)])
    try:
        renderer.render(view, msaa)
        ctx.copy_framebuffer(resolve, msaa)
        data = resolve.read(components=3, alignment=1)
    finally:
        for fbo in (msaa, resolve):
            for a in (*fbo.color_attachments, fbo.depth_attachment):
                if a is not None:
                    a.release()
            fbo.release()
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()
