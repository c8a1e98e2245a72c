"""Dear ImGui draw data rendered with moderngl (no PyOpenGL).

imgui-bundle's own Python backend issues raw PyOpenGL calls, which must match
PyOpenGL's platform (GLX vs EGL) and fight moderngl's cached state; drawing
the few hundred vertices of the panel through moderngl keeps one GL wrapper
and lets the UI go into any framebuffer (the offscreen frame in headless mode).
"""
from __future__ import annotations

import ctypes

import moderngl
import numpy as np
from imgui_bundle import imgui

from app import softgl
from app.softgl import kernels
from app.softgl.ui_damage import Batch, DamageTracker, UiGeometry

_VERTEX = """
#version 330
uniform mat4 proj;
in vec2 in_pos; in vec2 in_uv; in vec4 in_col;
out vec2 uv; out vec4 col;
void main() { uv = in_uv; col = in_col; gl_Position = proj * vec4(in_pos, 0.0, 1.0); }
"""
_FRAGMENT = """
#version 330
uniform sampler2D tex;
in vec2 uv; in vec4 col;
out vec4 color;
void main() { color = col * texture(tex, uv); }
"""


class ImguiRenderer:
    """Uploads ImGui textures (font atlas, on demand) and draws ``ImDrawData``."""

    def __init__(self, ctx: moderngl.Context, software_gl: bool | None = None):
        """``software_gl``: redraw only what changed (None: ``app.softgl.enabled(ctx)``)."""
        self.ctx = ctx
        self.prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        self.prog["tex"] = 0
        self.vbo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.ibo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.vao = self._make_vao()
        self.textures: dict[int, moderngl.Texture] = {}
        self._atlas_ids: set[int] = set()      # textures ImGui made (app textures keep their filter)
        software_gl = softgl.enabled(ctx) if software_gl is None else software_gl
        self.damage = DamageTracker() if software_gl else None
        self.drawn_rects: list[tuple] = []     # software GL: (x, y, w, h) GL pixels the last render drew into
        # At 1:1 scale glyphs sit on whole pixels, so nearest sampling gives the
        # same text at a fraction of llvmpipe's cost for bilinear; lines are
        # antialiased with geometry, which does not need the filtered texture.
        self._filter = (moderngl.NEAREST, moderngl.NEAREST)
        io = imgui.get_io()
        io.fonts.flags |= imgui.ImFontAtlasFlags_.no_baked_lines
        io.backend_flags |= imgui.BackendFlags_.renderer_has_textures
        max_size = ctx.info["GL_MAX_TEXTURE_SIZE"]
        imgui.get_platform_io().renderer_texture_max_width = max_size
        imgui.get_platform_io().renderer_texture_max_height = max_size

    def _make_vao(self) -> moderngl.VertexArray:
        assert imgui.VERTEX_SIZE == 20 and imgui.VERTEX_BUFFER_COL_OFFSET == 16  # pos 2f, uv 2f, col 4 bytes
        # All draw lists go into one vertex and one (32-bit) index buffer per frame:
        # rewriting a buffer between draws makes llvmpipe wait for the earlier draws.
        return self.ctx.vertex_array(self.prog, [(self.vbo, "2f 2f 4f1", "in_pos", "in_uv", "in_col")],
                                     index_buffer=self.ibo, index_element_size=4)

    # -- textures ---------------------------------------------------------
    def _update_textures(self) -> bool:
        """Create, update and destroy textures as ImGui asks; True if any changed."""
        changed = False
        for tex in imgui.get_platform_io().textures:
            if tex.status == imgui.ImTextureStatus.ok:
                continue
            changed = True
            if tex.status in (imgui.ImTextureStatus.want_create, imgui.ImTextureStatus.want_updates):
                self._upload(tex)
            elif tex.status == imgui.ImTextureStatus.want_destroy:
                gl_tex = self.textures.pop(int(tex.get_tex_id()), None)
                if gl_tex is not None:
                    gl_tex.release()
                tex.set_tex_id(0)
                tex.status = imgui.ImTextureStatus.destroyed
        return changed

    def _upload(self, tex) -> None:
        pixels = np.asarray(tex.get_pixels_array(), dtype=np.uint8)
        gl_tex = self.textures.get(int(tex.get_tex_id()))
        if gl_tex is None or gl_tex.size != (tex.width, tex.height):
            if gl_tex is not None:
                self.textures.pop(gl_tex.glo).release()
            gl_tex = self.ctx.texture((tex.width, tex.height), 4, pixels.tobytes())
            gl_tex.filter = self._filter
            gl_tex.repeat_x = gl_tex.repeat_y = False
            self.textures[gl_tex.glo] = gl_tex
            self._atlas_ids.add(gl_tex.glo)
            tex.set_tex_id(gl_tex.glo)
        else:  # atlas grew glyphs: re-upload it whole (small, and rare)
            gl_tex.write(pixels.tobytes())
        tex.status = imgui.ImTextureStatus.ok

    def register_texture(self, texture: moderngl.Texture) -> int:
        """Make an app texture usable with ``imgui.image`` (returns its id)."""
        self.textures[texture.glo] = texture
        return texture.glo

    # -- drawing ----------------------------------------------------------
    def invalidate(self) -> None:
        """Redraw the whole UI next frame (the target's pixels were overwritten)."""
        if self.damage is not None:
            self.damage.invalidate()

    def render(self, draw_data, fbo: moderngl.Framebuffer, keep: tuple = ()) -> None:
        """Draw ``draw_data`` into ``fbo``. ``keep`` holds rectangles (x, y, w, h,
        display pixels; not overlapping) of ``fbo`` that nothing but the UI draws
        into: on software GL only the bands that changed since the last call are redrawn
        there (``app.softgl.ui_damage``)."""
        self.drawn_rects = []
        if self._update_textures():
            self.invalidate()
        width, height = draw_data.display_size
        if width <= 0 or height <= 0:
            return
        self._set_filter(tuple(draw_data.framebuffer_scale))
        geo = self._geometry(draw_data)
        if geo is None:
            return
        ox, oy = draw_data.display_pos
        display = (ox, oy, ox + width, oy + height)
        boxes = [(x, y, x + w, y + h) for x, y, w, h in keep]
        if self.damage is None or not kernels.ready():
            indices, plan = geo.indices.reshape(-1), _every_command(geo)
        else:
            indices, plan = self.damage.plan(geo, display, boxes, (fbo.glo, fbo.size, tuple(draw_data.framebuffer_scale)))
        if not plan:
            return
        self._write(self.vbo, geo.words.tobytes())
        self._write(self.ibo, indices.tobytes())
        ctx = self.ctx
        fbo.use()
        ctx.viewport = (0, 0, fbo.width, fbo.height)
        ctx.enable_only(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        ctx.blend_equation = moderngl.FUNC_ADD
        sx, sy = fbo.width / width, fbo.height / height
        proj = np.array([[2 / width, 0, 0, 0], [0, -2 / height, 0, 0], [0, 0, -1, 0],
                         [-(2 * ox + width) / width, (2 * oy + height) / height, 0, 1]], "f4")
        self.prog["proj"].write(proj.tobytes())
        try:
            for batch in plan:
                x0, y0, x1, y1 = batch.rect
                x0, x1 = round((x0 - ox) * sx), round((x1 - ox) * sx)
                y0, y1 = round((y0 - oy) * sy), round((y1 - oy) * sy)
                if x1 <= x0 or y1 <= y0:
                    continue
                self.ctx.scissor = (x0, fbo.height - y1, x1 - x0, y1 - y0)
                bx0, by0, bx1, by1 = batch.bounds or batch.rect       # what its triangles touch
                bx0, bx1 = max(int((bx0 - ox) * sx) - 1, x0), min(int(np.ceil((bx1 - ox) * sx)) + 1, x1)
                by0, by1 = max(int((by0 - oy) * sy) - 1, y0), min(int(np.ceil((by1 - oy) * sy)) + 1, y1)
                if self.damage is not None and bx1 > bx0 and by1 > by0:
                    self.drawn_rects.append((bx0, fbo.height - by1, bx1 - bx0, by1 - by0))
                tex = self.textures.get(batch.texture)
                if tex is not None:
                    tex.use(0)
                self.vao.render(moderngl.TRIANGLES, vertices=batch.count, first=batch.first)
        finally:
            ctx.scissor = None
            ctx.disable(moderngl.BLEND)

    def _set_filter(self, scale: tuple) -> None:
        """Nearest sampling at 1:1, bilinear when the UI is scaled (HiDPI)."""
        mode = moderngl.NEAREST if scale == (1.0, 1.0) else moderngl.LINEAR
        if self._filter != (mode, mode):
            self._filter = (mode, mode)
            for tex in self._atlas_ids & self.textures.keys():
                self.textures[tex].filter = self._filter
            self.invalidate()

    @staticmethod
    def _geometry(draw_data) -> UiGeometry | None:
        """All draw lists flattened into one ``UiGeometry`` (indices rebased), or None."""
        words, tris, tri_cmd, clips, textures = [], [], [], [], []
        base = 0
        itype = np.uint16 if imgui.INDEX_SIZE == 2 else np.uint32
        for c in draw_data.cmd_lists:
            nv, ni = c.vtx_buffer.size(), c.idx_buffer.size()
            if not nv or not ni:
                continue
            raw = (ctypes.c_char * (nv * imgui.VERTEX_SIZE)).from_address(c.vtx_buffer.data_address())
            words.append(np.frombuffer(raw, np.uint32).reshape(nv, imgui.VERTEX_SIZE // 4))  # a view; copied below
            idx = np.frombuffer((ctypes.c_char * (ni * imgui.INDEX_SIZE)).from_address(
                c.idx_buffer.data_address()), itype).astype(np.uint32) + base
            for cmd in c.cmd_buffer:
                # Without RendererHasVtxOffset ImGui splits big lists, so vtx_offset is always 0.
                if cmd.elem_count == 0:
                    continue
                tris.append(idx[cmd.idx_offset:cmd.idx_offset + cmd.elem_count])
                tri_cmd.append(np.full(cmd.elem_count // 3, len(clips)))
                clips.append(tuple(cmd.clip_rect))
                textures.append(int(cmd.tex_ref.get_tex_id()))
            base += nv
        if not tris:
            return None
        all_words = np.concatenate(words)
        return UiGeometry(words=all_words, positions=np.ascontiguousarray(all_words[:, :2]).view(np.float32),
                          indices=np.concatenate(tris).reshape(-1, 3), tri_cmd=np.concatenate(tri_cmd),
                          clips=np.asarray(clips, np.float32), textures=np.asarray(textures, np.int64))

    @staticmethod
    def _write(buf: moderngl.Buffer, data: bytes) -> None:
        if len(data) > buf.size:
            buf.orphan(max(len(data), buf.size * 2))
        buf.write(data)

    def release(self) -> None:
        for t in self.textures.values():
            t.release()
        self.textures.clear()
        for obj in (self.vao, self.vbo, self.ibo, self.prog):
            obj.release()


def _every_command(geo: UiGeometry) -> list[Batch]:
    """One batch per draw command, scissored to its clip rectangle: the whole UI."""
    counts = np.bincount(geo.tri_cmd, minlength=len(geo.clips)) * 3
    firsts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    return [Batch(int(first), int(count), tuple(float(v) for v in clip), int(texture))
            for first, count, clip, texture in zip(firsts, counts, geo.clips, geo.textures) if count]
