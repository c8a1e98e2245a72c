"""Input handling: raw mouse/keyboard events (from glfw callbacks or from a
script, through the same functions) go to ImGui and, when ImGui does not want
them, to the scene: dragging the target, orbit/pan/zoom, playback keys.

Writes the settings (target, frame, playback), the camera, and the state's
hover/drag flags; never calls the engine.
"""
from __future__ import annotations

from dataclasses import dataclass

import glfw
import numpy as np
from imgui_bundle import imgui

from app.viewer import picking
from app.viewer.camera import OrbitCamera
from app.viewer.requests import Requests
from app.viewer.settings import SPEED_RANGE, ViewerSettings
from app.viewer.state import AppState

LEFT, RIGHT, MIDDLE = glfw.MOUSE_BUTTON_LEFT, glfw.MOUSE_BUTTON_RIGHT, glfw.MOUSE_BUTTON_MIDDLE

# Script key names -> glfw key codes.
KEY_NAMES = {
    "space": glfw.KEY_SPACE, "left": glfw.KEY_LEFT, "right": glfw.KEY_RIGHT, "h": glfw.KEY_H,
    "s": glfw.KEY_S, "[": glfw.KEY_LEFT_BRACKET, "]": glfw.KEY_RIGHT_BRACKET, "f12": glfw.KEY_F12,
    "r": glfw.KEY_R, "e": glfw.KEY_E, "home": glfw.KEY_HOME, "end": glfw.KEY_END,
    "escape": glfw.KEY_ESCAPE, "shift": glfw.KEY_LEFT_SHIFT,
}
BUTTON_NAMES = {"left": LEFT, "right": RIGHT, "middle": MIDDLE}


@dataclass
class Gesture:
    kind: str                 # "target" | "orbit" | "pan"
    button: int
    grab_offset: np.ndarray | None = None   # target centre - grabbed point on its plane


class Interaction:
    def __init__(self, settings: ViewerSettings, state: AppState, camera: OrbitCamera, imgui_io=None,
                 requests: Requests | None = None):
        self.settings, self.state, self.camera = settings, state, camera
        self.requests = Requests() if requests is None else requests     # F12 asks here
        self.io = imgui_io            # None: no ImGui (tests of the scene logic)
        self.mouse = np.array([-1.0, -1.0])
        self.shift = False
        self.gesture: Gesture | None = None
        self.buttons_down: set[int] = set()

    # -- helpers ----------------------------------------------------------
    def _ui_wants_mouse(self) -> bool:
        return self.io is not None and self.io.want_capture_mouse

    def _in_viewport(self, x: float, y: float) -> bool:
        vx, vy, vw, vh = self.state.viewport
        return vx <= x < vx + vw and vy <= y < vy + vh

    def _matrices(self):
        _, _, w, h = self.state.viewport
        return self.camera.view(), self.camera.proj(w / max(h, 1))

    def over_target(self, x: float, y: float) -> bool:
        if not self._in_viewport(x, y):
            return False
        view, proj = self._matrices()
        return picking.hits_target(x, y, self.state.viewport, view, proj, self.settings.target)

    def target_pixel(self) -> np.ndarray:
        view, proj = self._matrices()
        return picking.project(self.settings.target, self.state.viewport, view, proj)

    def world_to_pixel(self, p) -> np.ndarray:
        view, proj = self._matrices()
        return picking.project(p, self.state.viewport, view, proj)

    # -- events -----------------------------------------------------------
    def mouse_move(self, x: float, y: float) -> None:
        x, y = float(x), float(y)
        if not (np.isfinite(x) and np.isfinite(y)):
            return
        dx, dy = x - self.mouse[0], y - self.mouse[1]
        self.mouse[:] = (x, y)
        if self.io is not None:
            self.io.add_mouse_pos_event(x, y)
        g = self.gesture
        if g is None:
            self.state.hover_target = not self._ui_wants_mouse() and self.over_target(x, y)
        elif g.kind == "target":
            self._drag_target_to(x, y)
        elif g.kind == "orbit":
            self.camera.orbit(dx, dy)
        elif g.kind == "pan":
            self.camera.pan(dx, dy, self.state.viewport[2], self.state.viewport[3])
        self._update_cursor()

    def mouse_button(self, button: int, down: bool, x: float | None = None, y: float | None = None) -> None:
        if x is not None and y is not None:
            self.mouse_move(x, y)
        if self.io is not None:
            self.io.add_mouse_button_event(button, bool(down))
        if down:
            self.buttons_down.add(button)
            if self.gesture is None and not self._ui_wants_mouse() and self._in_viewport(*self.mouse):
                self.gesture = self._start_gesture(button)
                self.state.gesture = self.gesture.kind if self.gesture is not None else ""
        else:
            self.buttons_down.discard(button)
            if self.gesture is not None and self.gesture.button == button:
                self.gesture, self.state.gesture = None, ""
                self.state.dragging_target = False
                self.state.hover_target = self.over_target(*self.mouse)
        self._update_cursor()

    def _start_gesture(self, button: int) -> Gesture | None:
        x, y = self.mouse
        if button == LEFT and self.over_target(x, y):
            view, proj = self._matrices()
            hit = picking.target_plane_hit(x, y, self.state.viewport, view, proj)
            self.state.dragging_target = True
            return Gesture("target", button, np.asarray(self.settings.target, float) - hit)
        if button == MIDDLE or (button in (LEFT, RIGHT) and self.shift):
            return Gesture("pan", button)
        if button in (LEFT, RIGHT):
            return Gesture("orbit", button)
        return None

    def _drag_target_to(self, x: float, y: float) -> None:
        view, proj = self._matrices()
        hit = picking.target_plane_hit(x, y, self.state.viewport, view, proj)
        if hit is None:  # ray parallel to or away from the plane: keep the target where it is
            return
        self.settings.target = picking.clamp_target(hit + self.gesture.grab_offset)

    def scroll(self, dy: float, dx: float = 0.0) -> None:
        if self.io is not None:
            self.io.add_mouse_wheel_event(float(dx), float(dy))
        if not self._ui_wants_mouse() and self._in_viewport(*self.mouse) and np.isfinite(dy):
            self.camera.zoom(float(np.clip(dy, -20, 20)))

    def key(self, key: int, down: bool, mods: int = 0) -> None:
        if key in (glfw.KEY_LEFT_SHIFT, glfw.KEY_RIGHT_SHIFT):
            self.shift = bool(down)
        if self.io is not None:
            self._key_to_imgui(key, down)
        if not down or (self.io is not None and self.io.want_text_input):
            return
        s, last = self.settings, self.state.num_frames - 1
        if key == glfw.KEY_SPACE:
            s.playing = not s.playing
        elif key == glfw.KEY_LEFT:
            s.playing, s.frame = False, max(np.ceil(s.frame) - 1, 0)
        elif key == glfw.KEY_RIGHT:
            s.playing, s.frame = False, min(np.floor(s.frame) + 1, last)
        elif key == glfw.KEY_H:
            shot = self.state.shot
            s.playing, s.frame = False, float(shot.hit_frame if shot is not None else 0)
        elif key == glfw.KEY_S:
            s.slow_motion = not s.slow_motion
        elif key == glfw.KEY_LEFT_BRACKET:
            s.speed = float(np.clip(s.speed / 1.25, *SPEED_RANGE))
        elif key == glfw.KEY_RIGHT_BRACKET:
            s.speed = float(np.clip(s.speed * 1.25, *SPEED_RANGE))
        elif key == glfw.KEY_F12:
            self.requests.screenshot = True
        elif key == glfw.KEY_R:
            self.camera.reset()
        elif key == glfw.KEY_HOME:
            s.frame = 0.0
        elif key == glfw.KEY_END:
            s.frame = float(last)

    def _update_cursor(self) -> None:
        g = self.gesture
        if g is not None and g.kind == "target" or (g is None and self.state.hover_target):
            self.state.cursor = "hand"
        elif g is not None:
            self.state.cursor = "move"
        else:
            self.state.cursor = "arrow"

    def _key_to_imgui(self, key: int, down: bool) -> None:
        k = _IMGUI_KEYS().get(key)
        if k is not None:
            self.io.add_key_event(k, bool(down))
        if key in (glfw.KEY_LEFT_SHIFT, glfw.KEY_RIGHT_SHIFT):
            self.io.add_key_event(imgui.Key.mod_shift, bool(down))
        elif key in (glfw.KEY_LEFT_CONTROL, glfw.KEY_RIGHT_CONTROL):
            self.io.add_key_event(imgui.Key.mod_ctrl, bool(down))
        elif key in (glfw.KEY_LEFT_ALT, glfw.KEY_RIGHT_ALT):
            self.io.add_key_event(imgui.Key.mod_alt, bool(down))

    def char(self, codepoint: int) -> None:
        if self.io is not None and 0 < codepoint < 0x10000:
            self.io.add_input_character(codepoint)


_KEYMAP: dict | None = None


def _IMGUI_KEYS() -> dict:
    """glfw key -> ImGui key for the keys the panel's widgets use."""
    global _KEYMAP
    if _KEYMAP is None:
        K = imgui.Key
        _KEYMAP = {glfw.KEY_TAB: K.tab, glfw.KEY_LEFT: K.left_arrow, glfw.KEY_RIGHT: K.right_arrow,
                   glfw.KEY_UP: K.up_arrow, glfw.KEY_DOWN: K.down_arrow, glfw.KEY_HOME: K.home,
                   glfw.KEY_END: K.end, glfw.KEY_DELETE: K.delete, glfw.KEY_BACKSPACE: K.backspace,
                   glfw.KEY_ENTER: K.enter, glfw.KEY_ESCAPE: K.escape, glfw.KEY_SPACE: K.space,
                   glfw.KEY_KP_ENTER: K.keypad_enter, glfw.KEY_A: K.a, glfw.KEY_C: K.c,
                   glfw.KEY_V: K.v, glfw.KEY_X: K.x, glfw.KEY_Z: K.z,
                   glfw.KEY_LEFT_SHIFT: K.left_shift, glfw.KEY_RIGHT_SHIFT: K.right_shift,
                   glfw.KEY_LEFT_CONTROL: K.left_ctrl, glfw.KEY_RIGHT_CONTROL: K.right_ctrl}
    return _KEYMAP
