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

    def __init__(self, ctx: moderngl.Context):
        self.ctx = ctx
        self.prog = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        self.prog["tex"] = 0
        self.vbo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.ibo = ctx.buffer(reserve=1 << 16, dynamic=True)
        self.vao = self._make_vao()
        self.textures: dict[int, moderngl.Texture] = {}
        io = imgui.get_io()
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
    def _update_textures(self) -> None:
        for tex in imgui.get_platform_io().textures:
            if tex.status == imgui.ImTextureStatus.ok:
                continue
            if tex.status in (imgui.ImTextureStatus.want_create, imgui.ImTextureStatus.want_updates):
                self._upload(tex)
            elif tex.status == imgui.ImTextureStatus.want_destroy:
                gl_tex = self.textures.pop(int(tex.get_tex_id()), None)
                if gl_tex is not None:
                    gl_tex.release()
                tex.set_tex_id(0)
                tex.status = imgui.ImTextureStatus.destroyed

    def _upload(self, tex) -> None:
        pixels = np.asarray(tex.get_pixels_array(), dtype=np.uint8)
        gl_tex = self.textures.get(int(tex.get_tex_id()))
        if gl_tex is None or gl_tex.size != (tex.width, tex.height):
            if gl_tex is not None:
                self.textures.pop(gl_tex.glo).release()
            gl_tex = self.ctx.texture((tex.width, tex.height), 4, pixels.tobytes())
            gl_tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            gl_tex.repeat_x = gl_tex.repeat_y = False
            self.textures[gl_tex.glo] = gl_tex
            tex.set_tex_id(gl_tex.glo)
        else:  # atlas grew glyphs: re-upload it whole (small, and rare)
            gl_tex.write(pixels.tobytes())
        tex.status = imgui.ImTextureStatus.ok

    def register_texture(self, texture: moderngl.Texture) -> int:
        """Make an app texture usable with ``imgui.image`` (returns its id)."""
        self.textures[texture.glo] = texture
        return texture.glo

    # -- drawing ----------------------------------------------------------
    def render(self, draw_data, fbo: moderngl.Framebuffer) -> None:
        self._update_textures()
        width, height = draw_data.display_size
        if width <= 0 or height <= 0:
            return
        lists = [c for c in draw_data.cmd_lists if c.vtx_buffer.size() and c.idx_buffer.size()]
        if not lists:
            return
        vertices, indices, firsts = self._gather(lists)
        self._write(self.vbo, vertices)
        self._write(self.ibo, indices)
        ctx = self.ctx
        fbo.use()
        ctx.viewport = (0, 0, fbo.width, fbo.height)
        ctx.enable_only(moderngl.BLEND)
        ctx.blend_func = moderngl.SRC_ALPHA, moderngl.ONE_MINUS_SRC_ALPHA
        ctx.blend_equation = moderngl.FUNC_ADD
        sx, sy = fbo.width / width, fbo.height / height
        ox, oy = draw_data.display_pos
        proj = np.array([[2 / width, 0, 0, 0], [0, -2 / height, 0, 0], [0, 0, -1, 0],
                         [-(2 * ox + width) / width, (2 * oy + height) / height, 0, 1]], "f4")
        self.prog["proj"].write(proj.tobytes())
        try:
            for cmd_list, first in zip(lists, firsts):
                for cmd in cmd_list.cmd_buffer:
                    self._draw(cmd, first, fbo.height, sx, sy, ox, oy)
        finally:
            ctx.scissor = None
            ctx.disable(moderngl.BLEND)

    @staticmethod
    def _gather(lists):
        """One vertex array and one uint32 index array for all lists (indices
        rebased), and each list's first index in the latter."""
        vtx, idx, firsts = [], [], []
        base = start = 0
        itype = np.uint16 if imgui.INDEX_SIZE == 2 else np.uint32
        for c in lists:
            nv, ni = c.vtx_buffer.size(), c.idx_buffer.size()
            vtx.append(bytes((ctypes.c_char * (nv * imgui.VERTEX_SIZE)).from_address(c.vtx_buffer.data_address())))
            raw = (ctypes.c_char * (ni * imgui.INDEX_SIZE)).from_address(c.idx_buffer.data_address())
            idx.append(np.frombuffer(raw, itype).astype(np.uint32) + base)
            firsts.append(start)
            base, start = base + nv, start + ni
        return b"".join(vtx), np.concatenate(idx).tobytes(), firsts

    def _draw(self, cmd, first: int, fb_height: int, sx: float, sy: float, ox: float, oy: float) -> None:
        if cmd.elem_count == 0:
            return
        x0, y0, x1, y1 = cmd.clip_rect
        x0, x1 = (x0 - ox) * sx, (x1 - ox) * sx
        y0, y1 = (y0 - oy) * sy, (y1 - oy) * sy
        if x1 <= x0 or y1 <= y0:
            return
        self.ctx.scissor = (int(x0), int(fb_height - y1), int(x1 - x0), int(y1 - y0))
        tex = self.textures.get(int(cmd.tex_ref.get_tex_id()))
        if tex is not None:
            tex.use(0)
        # Without RendererHasVtxOffset ImGui splits big lists, so vtx_offset is always 0.
        self.vao.render(moderngl.TRIANGLES, vertices=cmd.elem_count, first=first + cmd.idx_offset)

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
