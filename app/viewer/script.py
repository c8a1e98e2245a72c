"""Scripted input for headless runs: a JSON list of timed events replayed
through the same input functions the window's callbacks call.

Each event has ``"frame": N`` (loop iteration) or ``"t": seconds`` (at 60
frames per second) and a ``"type"``:

- ``mouse_move {x, y}``, ``mouse_down/mouse_up {x, y, button}`` (window pixels;
  button ``left|right|middle``), ``scroll {dy, x?, y?}``
- ``drag {button, from: [x,y], to: [x,y], frames}``: press, move, release
- ``drag_target {to: [x,y,z] | to_px: [x,y], frames}``: grab the target where
  it is drawn and drag it to a world point on its plane (z = -60; another z is
  refused) or to a pixel
- ``drag_target_path {points: [[x,y,z], ...], frames}`` or ``{circle: {center:
  [x,y] | "target", radius, turns}, frames}``: keep dragging the target along a
  path, one mouse move per frame (a circle around "target" passes through it)
- ``set {key, value}`` (e.g. ``falloff``, ``solver``, ``overlays.flight``),
  ``scrub {to}`` (the frame shown), ``key {key}`` (``space``, ``left``, ``right``, ``h``,
  ``s``, ``[``, ``]``, ``f12``, ``r``), ``pcpad_drag {from: [s1,s2], to: [s1,s2],
  frames}`` (scores on the PC pad; ``pcpad_draw``, same fields, draws a path that
  becomes a take), ``pcpad {action, value?}`` (anything the pad's widget does:
  ``app.viewer.padrequests.PAD_ACTIONS``, e.g. ``mode draw``, ``preset aborted``, ``amount 0.7``,
  ``remake_preset``, ``take 0``, ``forget``, ``play``, ``seek 30`` (a frame of the take shown), ``back``, ``export``,
  ``fix_hand false``), ``screenshot {path}``, ``export {dir, formats?}`` (a new folder; formats from
  ``png mp4 bvh glb gltf``, default all but ``gltf``), ``reload`` (the panel's "Reload shot library").

Every event is checked when the script is loaded: numbers finite and in range,
``set`` only for real settings with a value of the setting's type, and nothing
past the run's frame budget (``--frames``, at most MAX_SCRIPT_FRAMES). Fields
an event does not use are ignored.
"""
from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from app.errors import MAX_POSITION_CM, UserError, number, shorten
from app.viewer.interaction import BUTTON_NAMES, KEY_NAMES, LEFT
from app.viewer.capture import check_formats
from app.jsonfile import read_json
from app.viewer.padrequests import PadRequest, check_request
from app.viewer.picking import TARGET_PLANE_Z
from app.viewer.settings import MAX_FRAME_SETTING, check_setting
from engine.synth import MAX_ABS_SCORE

SCRIPT_FPS = 60.0
# Bounds of a script (the messages name them). Fields an event does not use are ignored.
MAX_SCRIPT_BYTES = 4_000_000        # a script file
MAX_SCRIPT_EVENTS = 10_000          # events in one script
MAX_SCRIPT_FRAMES = 36_000          # ten minutes at 60 Hz: the frame budget without --frames (and its cap)
MAX_SCRIPT_ACTIONS = 200_000        # per-frame actions all events expand to, together
MAX_PIXEL = 100_000.0               # |window pixel| of a mouse position
MAX_SCROLL = 1_000.0                # |scroll step|
MAX_TURNS = 1_000.0                 # |turns| of a circle
MAX_PATH_CHARS = 4096
PLANE_TOLERANCE_CM = 0.5            # a drag_target's world point off the target plane by more: refused               # a screenshot or export path


def load_script(path: str | Path) -> list[dict]:
    """The events of a script file: a JSON list of at most MAX_SCRIPT_EVENTS
    objects, the file at most MAX_SCRIPT_BYTES (UserError otherwise)."""
    events = read_json(path, "script", MAX_SCRIPT_BYTES)
    _check_events(events, str(path))
    return events


def _check_events(events, where: str) -> None:
    if not isinstance(events, list) or not all(isinstance(e, dict) for e in events):
        raise UserError(f"{where}: a script is a JSON list of event objects")
    if len(events) > MAX_SCRIPT_EVENTS:
        raise UserError(f"{where}: {len(events)} events, more than MAX_SCRIPT_EVENTS ({MAX_SCRIPT_EVENTS})")


class ScriptPlayer:
    """Expands events into per-frame actions; ``apply(app, frame)`` runs them.

    Every event is checked here, before the run: an event that is malformed,
    sets a setting to a wrong value, or reaches past ``frame_budget`` (the
    run's --frames; at most MAX_SCRIPT_FRAMES) is one UserError naming the
    event. So expansion is bounded by the budget, and nothing fails mid-run."""

    def __init__(self, events: list[dict], where: str = "script", frame_budget: int | None = None):
        _check_events(events, where)
        self.actions: dict[int, list] = defaultdict(list)
        self.where = where
        self.budget_name = "--frames" if frame_budget and frame_budget <= MAX_SCRIPT_FRAMES else "MAX_SCRIPT_FRAMES"
        self.budget = min(frame_budget or MAX_SCRIPT_FRAMES, MAX_SCRIPT_FRAMES)
        self.count = 0
        for i, e in enumerate(events):
            try:
                self._expand(e)
            except KeyError as err:
                raise UserError(f"{where}: event {i} ({_kind(e)}): missing field {err}") from None
            except (TypeError, ValueError, IndexError, OverflowError, UserError) as err:
                raise UserError(f"{where}: event {i} ({_kind(e)}): {err}") from None

    @property
    def last_frame(self) -> int:
        return max(self.actions, default=-1)

    def apply(self, app, frame: int) -> None:
        for action in self.actions.get(frame, ()):
            action(app)

    # -- expansion ---------------------------------------------------------
    def _at(self, frame: int, action) -> None:
        if frame >= self.budget:
            raise ValueError(f"reaches frame {frame}, past the frame budget of {self.budget} ({self.budget_name})")
        self.count += 1
        if self.count > MAX_SCRIPT_ACTIONS:
            raise ValueError(f"the script expands to more than MAX_SCRIPT_ACTIONS ({MAX_SCRIPT_ACTIONS}) actions")
        self.actions[int(frame)].append(action)

    def _expand(self, e: dict) -> None:
        kind = e["type"]
        handler = getattr(self, f"_ev_{kind}", None) if isinstance(kind, str) else None
        if handler is None:
            raise ValueError(f"unknown type {shorten(repr(kind))}")
        if "frame" in e:
            f = self._within_budget(_whole, e["frame"], "frame", 0, self.budget - 1)
        else:
            t = self._within_budget(_num, e.get("t", 0.0), "t", 0.0, (self.budget - 1) / SCRIPT_FPS)
            f = int(round(t * SCRIPT_FPS))
        handler(f, e)

    def _frames(self, e: dict, default: int) -> int:
        """The ``frames`` an event lasts: a whole number 1..the budget (a drag of 1e9 frames is refused
        before anything is expanded)."""
        return self._within_budget(_whole, e.get("frames", default), "frames", 1, self.budget)

    def _within_budget(self, check, value, name: str, low, high):
        try:
            return check(value, low, high, name)
        except (ValueError, UserError) as err:
            raise ValueError(f"{err} (the frame budget is {self.budget}, {self.budget_name})") from None

    def _ev_mouse_move(self, f, e):
        x, y = _pixel(e["x"], "x"), _pixel(e["y"], "y")
        self._at(f, lambda app: app.interaction.mouse_move(x, y))

    def _ev_mouse_down(self, f, e, down=True):
        b = _button(e)
        x, y = (_pixel(e["x"], "x"), _pixel(e["y"], "y")) if "x" in e else (None, None)
        self._at(f, lambda app: app.interaction.mouse_button(b, down, x, y))

    def _ev_mouse_up(self, f, e):
        self._ev_mouse_down(f, e, down=False)

    def _ev_scroll(self, f, e):
        dy = _num(e.get("dy", 1.0), -MAX_SCROLL, MAX_SCROLL, "dy")
        if "x" in e:
            self._ev_mouse_move(f, e)
        self._at(f, lambda app: app.interaction.scroll(dy))

    def _ev_drag(self, f, e):
        b, n = _button(e), self._frames(e, 10)
        p0, p1 = _vector(e["from"], 2, "from", MAX_PIXEL, longer=True), _vector(e["to"], 2, "to", MAX_PIXEL, longer=True)
        # Move first (one frame early) so the UI knows where the mouse is when pressed.
        self._at(f, lambda app: app.interaction.mouse_move(*p0))
        self._at(f + 1, lambda app: app.interaction.mouse_button(b, True))
        for i in range(1, n + 1):
            p = p0 + (p1 - p0) * i / n
            self._at(f + 1 + i, lambda app, p=p: app.interaction.mouse_move(*p))
        self._at(f + 2 + n, lambda app: app.interaction.mouse_button(b, False))

    def _grab_target(self, f, memo):
        def move(app):
            memo["start_px"] = app.interaction.target_pixel()
            memo["start_world"] = np.asarray(app.settings.target, float).copy()
            app.interaction.mouse_move(*memo["start_px"])
        self._at(f, move)
        self._at(f + 1, lambda app: app.interaction.mouse_button(LEFT, True))

    def _ev_drag_target(self, f, e):
        n = self._frames(e, 10)
        memo: dict = {}
        to_world = _vector(e["to"], 3, "to", MAX_POSITION_CM) if "to" in e else None
        if to_world is not None and abs(to_world[2] - TARGET_PLANE_Z) > PLANE_TOLERANCE_CM:
            raise ValueError(f"'to' {shorten(str(e['to']))}: the target slides on the plane z = {TARGET_PLANE_Z:g} "
                             f"(behind the stumps); give [x, y, {TARGET_PLANE_Z:g}]")
        to_px = _vector(e["to_px"], 2, "to_px", MAX_PIXEL) if to_world is None and "to_px" in e else None
        if to_world is None and to_px is None:
            raise KeyError("to")
        self._grab_target(f, memo)

        def step(app, a):
            if to_world is not None:
                p = app.interaction.world_to_pixel(memo["start_world"] + (to_world - memo["start_world"]) * a)
            else:
                p = memo["start_px"] + (to_px - memo["start_px"]) * a
            if np.isfinite(p).all():
                app.interaction.mouse_move(*p)
        for i in range(1, n + 1):
            self._at(f + 1 + i, lambda app, a=i / n: step(app, a))
        self._at(f + 2 + n, lambda app: app.interaction.mouse_button(LEFT, False))

    def _ev_drag_target_path(self, f, e):
        n = self._frames(e, 60)
        relative = False
        if "circle" in e:
            c = e["circle"]
            if not isinstance(c, dict):
                raise ValueError("'circle' must be an object {center, radius, turns}")
            relative = c.get("center", "target") == "target"
            cx, cy = (0.0, 0.0) if relative else _vector(c["center"], 2, "center", MAX_POSITION_CM)
            r = _num(c["radius"], -MAX_POSITION_CM, MAX_POSITION_CM, "radius")
            turns = _num(c.get("turns", 1), -MAX_TURNS, MAX_TURNS, "turns")
            ang = np.linspace(0, 2 * np.pi * turns, n + 1)
            # Starts at the top of the circle; relative circles pass through the target itself.
            pts = np.stack([cx + r * np.sin(ang), cy + r * np.cos(ang) - (r if relative else 0.0)], -1)
        else:
            pts = _points(e["points"])
            s = np.linspace(0, len(pts) - 1, n + 1)
            i0 = np.floor(s).astype(int)
            i1 = np.minimum(i0 + 1, len(pts) - 1)
            a = (s - i0)[:, None]
            pts = (1 - a) * pts[i0] + a * pts[i1]
        memo: dict = {}
        self._grab_target(f, memo)

        def step(app, p):
            origin = memo["start_world"][:2] if relative else 0.0
            p = np.array([*(p + origin), app.settings.target[2]])
            px = app.interaction.world_to_pixel(p)
            if np.isfinite(px).all():
                app.interaction.mouse_move(*px)
        # One move per frame along the path, then release.
        for i in range(1, n + 2):
            self._at(f + 1 + i, lambda app, p=pts[i - 1]: step(app, p))
        self._at(f + 3 + n, lambda app: app.interaction.mouse_button(LEFT, False))

    def _ev_set(self, f, e):
        key, value = e["key"], check_setting(e["key"], e["value"])    # a bad key or value fails now
        self._at(f, lambda app: app.settings.set(key, value))

    def _ev_scrub(self, f, e):
        frame = _num(e["frame_to"] if "frame_to" in e else e["to"] if "to" in e else e["value"],
                     -MAX_FRAME_SETTING, MAX_FRAME_SETTING, "to")
        self._at(f, lambda app: app.scrub(frame))

    def _ev_key(self, f, e):
        name = _text(e["key"], "key").lower()
        if name not in KEY_NAMES:
            raise ValueError(f"unknown key {shorten(repr(name))} (known: {', '.join(KEY_NAMES)})")
        code = KEY_NAMES[name]
        self._at(f, lambda app: app.interaction.key(code, True))
        self._at(f, lambda app: app.interaction.key(code, False))

    def _ev_pcpad_drag(self, f, e):
        n = self._frames(e, 10)
        s0, s1 = _vector(e["from"], 2, "from", MAX_ABS_SCORE, longer=True), _vector(e["to"], 2, "to", MAX_ABS_SCORE, longer=True)
        for i in range(n + 1):
            s = s0 + (s1 - s0) * i / n
            self._ask(f + i, PadRequest("marker", s, final=(i == n)))

    def _ev_pcpad_draw(self, f, e):
        """``pcpad_drag`` in the pad's draw mode: the stroke becomes a drawn take (the pad stays in draw mode)."""
        self._ask(f, PadRequest("mode", "draw"))
        self._ev_pcpad_drag(f, e)

    def _ev_pcpad(self, f, e):
        """One of the pad widget's actions (``app.viewer.padrequests.PAD_ACTIONS``), checked now."""
        self._ask(f, check_request(e["action"], e.get("value")))

    def _ask(self, f, request: PadRequest) -> None:
        self._at(f, lambda app: app.requests.pad.append(request))

    def _ev_screenshot(self, f, e):
        path = _text(e["path"], "path", MAX_PATH_CHARS)
        self._at(f, lambda app: app.request_screenshot(path))

    def _ev_reload(self, f, e):
        self._at(f, lambda app: setattr(app.requests, "reload", True))

    def _ev_export(self, f, e):
        out = _text(e["dir"], "dir", MAX_PATH_CHARS)
        formats = check_formats(e["formats"]) if "formats" in e else None   # bad names fail at load
        self._at(f, lambda app: app.request_export(out, formats))


def _kind(e) -> str:
    return shorten(str(e.get("type", "?")))


def _num(v, low: float, high: float, name: str) -> float:
    """A number (not a bool, not a string; numpy's from a Python caller) for field ``name``, finite, in low..high."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} must be a number, got {shorten(repr(v))}")
    if isinstance(v, int) and v.bit_length() > 64:     # float() of it may overflow; no field wants it
        raise ValueError(f"{name} must be between {low:g} and {high:g}, got a {v.bit_length()}-bit integer")
    return number(name, v, low, high)


def _whole(v, low: int, high: int, name: str) -> int:
    _num(v, low, high, name)
    return number(name, v, low, high, integer=True)


def _pixel(v, name: str) -> float:
    return _num(v, -MAX_PIXEL, MAX_PIXEL, name)


def _vector(v, n: int, name: str, limit: float, longer: bool = False) -> np.ndarray:
    """``v`` as ``n`` numbers within +-limit (the first ``n`` with ``longer``), or ValueError naming the field."""
    if not isinstance(v, (list, tuple)) or len(v) < n or (len(v) > n and not longer):
        raise ValueError(f"{name!r} needs {n} numbers, got {shorten(repr(v))}")
    return np.array([_num(x, -limit, limit, name) for x in v[:n]])


def _points(v) -> np.ndarray:
    """``points`` of a target path: 1..MAX_SCRIPT_ACTIONS world points [x, y, z?], as (N, 2)."""
    if not isinstance(v, list) or not 1 <= len(v) <= MAX_SCRIPT_ACTIONS:
        raise ValueError(f"'points' must be a list of 1..{MAX_SCRIPT_ACTIONS} points [x, y, z]")
    return np.array([_vector(p, 2, "points", MAX_POSITION_CM, longer=True) for p in v])


def _text(v, name: str, limit: int = 40) -> str:
    if not isinstance(v, str) or not 0 < len(v) <= limit:
        raise ValueError(f"{name!r} must be a text of 1..{limit} characters, got {shorten(repr(v))}")
    return v


def _button(e: dict) -> int:
    name = _text(e.get("button", "left"), "button").lower()
    if name not in BUTTON_NAMES:
        raise ValueError(f"unknown button {shorten(repr(name))}")
    return BUTTON_NAMES[name]
