"""The viewer's main loop: wires the window, ImGui, the input handling, the
per-frame update, render submission and capture together. Each piece lives in
its own module; this one only orders them, one way (``App.frame``):

    poll -> UI (panel, timeline: write settings, ask the PC pad) -> time (app.playback)
    -> update (engine, PC pad: writes state) -> SceneView -> SceneRenderer
    -> compose scene + UI -> present
"""
from __future__ import annotations

import gc
import time
from collections import deque

import moderngl
import numpy as np
from imgui_bundle import imgui, implot

from app.viewer import playback
from app import softgl
from app.viewer.camera import OrbitCamera
from app.render.compose import BACKGROUND, Compositor
from app.ui.imgui_gl import ImguiRenderer
from app.viewer.interaction import Interaction
from app.ui.panel import PANEL_WIDTH, draw_panel
from app.render.gl import flush
from app.render.scene import SceneRenderer
from app.viewer.settings import ViewerSettings
from app.viewer.outputs import Outputs
from app.viewer.requests import Requests
from app.viewer.state import AppState
from app.viewer.stats import FrameStats
from app.render.submit import build_scene_view
from app.ui.timeline import TIMELINE_HEIGHT, draw_timeline
from app.viewer.update import default_target, load_library, update
from app.viewer.warmup import EngineWarmup
from app.render.window import open_window

def layout(window_size: tuple[int, int]) -> dict[str, tuple]:
    """Rectangles ``(x, y, w, h)`` in window pixels (top-left origin): the panel
    docked on the right, the timeline scrubber along the bottom left of it, the
    3D viewport what remains above the timeline (never under either)."""
    W, H = max(int(window_size[0]), 1), max(int(window_size[1]), 1)
    panel_w = min(PANEL_WIDTH, max(W // 2, 1))
    timeline_h = min(TIMELINE_HEIGHT, max(H // 4, 1))
    view_w, view_h = max(W - panel_w, 1), max(H - timeline_h, 1)
    return {"panel": (W - panel_w, 0, panel_w, H), "timeline": (0, view_h, view_w, H - view_h),
            "viewport": (0, 0, view_w, view_h)}


class App:
    def __init__(self, size=(1280, 720), headless: bool = False, manifest=None, started_at=None,
                 session=None):
        """``session``: an ``app.session.Autosave`` to restore from and autosave to (None: the
        run neither reads nor writes a session, as tests and benchmarks want). The engine
        compiles behind the window (``app.warmup``); headless runs wait for it here, so that
        scripted runs are reproducible."""
        self.stats = FrameStats(started_at)
        self.headless = headless
        self.manifest = manifest
        self.window = open_window(size, headless)
        self.stats.mark_window()
        self.ctx: moderngl.Context = self.window.ctx
        self.imgui_ctx = imgui.create_context()
        self.implot_ctx = implot.create_context()
        io = imgui.get_io()
        io.set_ini_filename("")
        io.display_size = imgui.ImVec2(*self.window.size)
        self.gui = ImguiRenderer(self.ctx)
        self.settings, self.state, self.camera = ViewerSettings(), AppState(), OrbitCamera()
        self.requests = Requests()      # one-off actions asked this frame (panel, keys, scripts)
        self.interaction = Interaction(self.settings, self.state, self.camera, io, self.requests)
        self._install_callbacks()
        if load_library(self.state, manifest):
            self.settings.target = default_target(self.state)
        self.session = session
        if session is not None:            # before the warm-up: it compiles for the restored settings
            session.restore(self.settings, self.state, self.camera)
            self.state.session_line = session.line
        if self.state.shots:
            self.state.engine_warmup = EngineWarmup(self.state, self.settings, apart=not headless,
                                                    softgl=softgl.enabled(self.ctx)).start()
        self.scene_renderer = self._make_scene_renderer()
        self.compositor = Compositor(self.ctx)
        if headless and self.state.engine_warmup is not None:
            self.state.engine_warmup.wait()
        self._opaque_windows()
        self.frame_index = 0
        self._ui_generation = -1
        self._in_flight = False          # a frame submitted but not yet shown / waited for
        self._camera_key = self.camera.view().tobytes()   # the camera starts still
        self._last_time = time.perf_counter()
        self._frame_stamps: deque = deque()
        self.outputs = Outputs(self.ctx, self.state, self.settings, lambda fbo: self.render_scene(fbo),
                               lambda: self.compositor.frame, lambda: self.compositor.viewport_px)
        # The ~150k objects made while starting (numba, imgui, the library) live as long as
        # the window: frozen, a full garbage collection no longer walks them, which froze a
        # drag for ~120 ms every few hundred frames.
        gc.collect()
        gc.freeze()

    # -- setup ----------------------------------------------------------------
    def _make_scene_renderer(self):
        if self.state.rig is None:
            self.state.status["renderer"] = "no rig loaded"
            return None
        try:
            renderer = SceneRenderer(self.ctx, self.state.rig)
        except Exception as e:  # a bad asset: say so, keep the window
            self.state.status["renderer"] = f"failed: {type(e).__name__}: {e}"
            return None
        self.state.status["renderer"] = "ok"
        return renderer

    def _install_callbacks(self) -> None:
        glfw, h, it = self.window.glfw, self.window.handle, self.interaction
        if glfw is None:   # headless EGL: input comes from scripts only
            return
        glfw.set_cursor_pos_callback(h, lambda _w, x, y: it.mouse_move(x, y))
        glfw.set_mouse_button_callback(h, lambda _w, b, action, mods: it.mouse_button(b, action == glfw.PRESS))
        glfw.set_scroll_callback(h, lambda _w, dx, dy: it.scroll(dy, dx))
        glfw.set_key_callback(h, lambda _w, key, sc, action, mods: it.key(key, action != glfw.RELEASE, mods))
        glfw.set_char_callback(h, lambda _w, cp: it.char(cp))
        # uncovered or resized: the next present shows the whole frame, not just what changed
        glfw.set_window_refresh_callback(h, lambda _w: self.compositor.damage.everything())

    @staticmethod
    def _opaque_windows() -> None:
        """Opaque panel and timeline (the frame is never cleared, see app.compose), and
        opaque popups and tooltips: a shot list over the panel's text was hard to read."""
        style = imgui.get_style()
        for col in (imgui.Col_.window_bg, imgui.Col_.popup_bg):
            c = style.color_(col)
            style.set_color_(col, imgui.ImVec4(c.x, c.y, c.z, 1.0))

    # -- one frame --------------------------------------------------------------
    def frame(self, dt: float | None = None, render: bool = True) -> None:
        """One loop iteration, one way: poll -> UI (writes settings, asks the PC pad) ->
        time -> update (engine; writes state) -> render -> present (the frame before is shown
        inside ``_render``). ``render=False`` stops after the update (long randomised tests)."""
        t0 = time.perf_counter()
        dt = (t0 - self._last_time) if dt is None else dt
        self._last_time = t0
        self.window.poll()
        rects = layout(self.window.size)
        self._draw_ui(rects, dt)
        t_ui = time.perf_counter()
        asked = self.requests.take()
        if asked.reload:
            load_library(self.state, self.manifest)
        if asked.screenshot:
            self.outputs.screenshot()
        if asked.export:
            self.outputs.export()
        playback.step(self.settings, self.state, dt)
        update(self.state, self.settings, dt, asked.pad)
        self._track_camera(dt)
        if self.session is not None:
            self.session.tick(self.settings, self.state, self.camera)
        t_engine = time.perf_counter()
        if render:
            t_wait, t_render = self._render(rects)
            self._record(t0, t_ui, t_engine, t_wait, t_render)
        self.window.set_cursor(self.state.cursor)
        self.frame_index += 1

    def _draw_ui(self, rects: dict, dt: float) -> None:
        """The panel and the timeline: they write the settings and the PC pad's requests."""
        self.state.viewport = rects["viewport"]
        io = imgui.get_io()
        io.display_size = imgui.ImVec2(*self.window.size)
        io.delta_time = max(float(dt), 1e-4)
        imgui.new_frame()
        draw_panel(self.settings, self.state, rects["panel"], self.requests)
        draw_timeline(self.settings, self.state, rects["timeline"], self.requests.pad)
        imgui.render()

    def _render(self, rects: dict) -> tuple[float, float]:
        """Show the frame before, draw this one's scene and UI; the times the wait and the
        scene's submission ended."""
        size = self.window.size
        # Only now is the previous frame shown (or, headless, waited for): its
        # rasterising on llvmpipe's worker threads overlapped this frame's input,
        # UI and engine work on this thread.
        self._finish_previous()
        t_wait = time.perf_counter()
        comp = self.compositor
        scene_size = comp.resize(self.window.framebuffer_size, rects["viewport"], size,
                                 self.settings.render_scale)
        view = self._scene_view(scene_size, comp.scene_origin)
        comp.draw_scene(lambda fbo: self.render_scene(fbo, view), self._scene_changed)
        flush()               # the scene rasterises while the UI's draws are planned
        t_render = time.perf_counter()

        if comp.frame_generation != self._ui_generation:     # a new frame: nothing of the UI in it
            self.gui.invalidate()
            self._ui_generation = comp.frame_generation
        self.gui.render(imgui.get_draw_data(), comp.frame, keep=(rects["panel"], rects["timeline"]))
        comp.damage.add(self.gui.drawn_rects)
        self.outputs.step()
        flush()
        self._in_flight = True
        return t_wait, t_render

    def _record(self, t0: float, t_ui: float, t_engine: float, t_wait: float, t_render: float) -> None:
        """The frame's timings into the readouts, the panel's timing display and the stats."""
        t_end = time.perf_counter()
        r = self.state.readouts
        r.render_ms, r.frame_ms = (t_end - t_engine) * 1e3, (t_end - t0) * 1e3
        r.fps = self._fps(t_end)
        self.state.timing.add(t_end, engine=r.engine_ms, solve=r.solve_ms, render=r.render_ms,
                              frame=r.frame_ms, fps=r.fps)
        self.stats.record(frame=r.frame_ms, ui=(t_ui - t0) * 1e3, engine=(t_engine - t_ui) * 1e3,
                          wait=(t_wait - t_engine) * 1e3, render=(t_render - t_wait) * 1e3,
                          compose=(t_end - t_render) * 1e3)

    def _track_camera(self, dt: float) -> None:
        """How long the camera has held still (``state.camera_still_s``)."""
        key = self.camera.view().tobytes()
        if key != self._camera_key:
            self._camera_key, self.state.camera_still_s = key, 0.0
        else:
            self.state.camera_still_s += float(dt)

    def _finish_previous(self) -> None:
        """Show the last submitted frame (window) and wait until it is drawn."""
        if not self._in_flight:
            return
        self._in_flight = False
        self.compositor.present(self.window)
        self.ctx.finish()

    def finish_frame(self) -> None:
        """Complete the frame in flight (before reading it back, or at the end of a run)."""
        self._finish_previous()

    def _fps(self, now: float) -> float:
        """Frames per wall-clock second over the last second (headless too)."""
        stamps = self._frame_stamps
        stamps.append(now)
        while len(stamps) > 2 and now - stamps[0] > 1.0:
            stamps.popleft()
        return (len(stamps) - 1) / max(stamps[-1] - stamps[0], 1e-6) if len(stamps) > 1 else 0.0

    def _scene_view(self, size, origin=(0, 0)):
        """This frame's SceneView for a view of ``size`` at ``origin`` (lower-left corner,
        GL pixels) in the framebuffer drawn into, or None (no renderer, or it failed to build)."""
        if self.scene_renderer is None or self.state.rig is None:
            return None
        try:
            view = build_scene_view(self.state, self.settings, self.camera, size)
        except Exception as e:
            self.state.report(f"render: {type(e).__name__}: {e}")
            return None
        view.origin = origin
        return view

    def _scene_changed(self):
        """What the last scene render drew over which static layer (``Compositor.draw_scene``)."""
        r = self.scene_renderer
        return None if r is None else (r.static_key, r.changed)

    def render_scene(self, fbo, view=None) -> bool:
        """Draw ``view`` (default: this frame's, filling ``fbo``) into ``fbo`` at
        ``view.origin``; on failure say why and return False (the last image stays)."""
        if self.scene_renderer is None or self.state.rig is None:
            fbo.use()
            comp = self.compositor
            rect = ((*view.origin, *view.size) if view is not None else
                    (*comp.scene_origin, *comp.viewport_px[2:]) if fbo is comp.frame else (0, 0, *fbo.size))
            fbo.clear(*BACKGROUND, viewport=rect)       # nothing to draw: an empty stage
            return True
        view = view if view is not None else self._scene_view(fbo.size)
        if view is None:
            return False
        try:
            self.scene_renderer.render(view, fbo=fbo)
        except Exception as e:
            self.state.report(f"render: {type(e).__name__}: {e}")
            return False
        return True

    # -- actions other modules ask for -------------------------------------------
    def scrub(self, frame: float) -> None:
        self.settings.playing = False
        self.settings.frame = float(np.clip(frame, 0, self.state.num_frames - 1))

    def request_screenshot(self, path=None) -> None:
        self.outputs.screenshot(path)

    def request_export(self, out_dir=None, formats=None) -> None:
        self.outputs.export(out_dir, formats)

    def screenshot(self) -> np.ndarray:
        """The last composed frame ``(h, w, 3)`` uint8."""
        return self.outputs.read_frame()

    def finish_exports(self) -> None:
        self.outputs.finish()

    # -- loops ------------------------------------------------------------------
    def run(self) -> None:
        while not self.window.should_close():
            self.frame()

    def close(self) -> None:
        gc.unfreeze()        # what this window froze can be collected again
        try:
            self.finish_exports()       # what the user asked for is written before the window goes
            if self.session is not None:
                self.session.close(self.settings, self.state, self.camera)
            self.gui.release()
            self.compositor.release()
        finally:
            implot.destroy_context(self.implot_ctx)
            imgui.destroy_context(self.imgui_ctx)
            self.window.close()
