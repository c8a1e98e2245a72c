"""Scripted input for headless runs: a JSON list of timed events replayed
through the same input functions the window's callbacks call.

Each event has ``"frame": N`` (loop iteration) or ``"t": seconds`` (at 60
frames per second) and a ``"type"``:

- ``mouse_move {x, y}``, ``mouse_down/mouse_up {x, y, button}`` (window pixels;
  button ``left|right|middle``), ``scroll {dy, x?, y?}``
- ``drag {button, from: [x,y], to: [x,y], frames}``: press, move, release
- ``drag_target {to: [x,y,z] | to_px: [x,y], frames}``: grab the target where
  it is drawn and drag it to a world point on its plane (or a pixel)
- ``drag_target_path {points: [[x,y,z], ...], frames}`` or ``{circle: {center:
  [x,y] | "target", radius, turns}, frames}``: keep dragging the target along a
  path, one mouse move per frame (a circle around "target" passes through it)
- ``set {key, value}`` (e.g. ``falloff``, ``solver``, ``overlays.flight``),
  ``scrub {frame}``, ``key {key}`` (``space``, ``left``, ``right``, ``h``,
  ``s``, ``[``, ``]``, ``f12``, ``r``), ``pcpad_drag {from: [s1,s2], to: [s1,s2],
  frames}`` (scores on the PC pad), ``screenshot {path}``, ``export {dir, formats?}`` (a new folder; formats from
  ``png mp4 bvh glb gltf``, default all but ``gltf``).
"""
from __future__ import annotations

import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from app.errors import UserError
from app.interaction import BUTTON_NAMES, KEY_NAMES, LEFT

SCRIPT_FPS = 60.0


def load_script(path: str | Path) -> list[dict]:
    path = Path(path)
    try:
        events = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise UserError(f"{path}: not valid JSON (line {e.lineno}: {e.msg})") from None
    if not isinstance(events, list) or not all(isinstance(e, dict) for e in events):
        raise UserError(f"{path}: a script is a JSON list of event objects")
    return events


class ScriptPlayer:
    """Expands events into per-frame actions; ``apply(app, frame)`` runs them."""

    def __init__(self, events: list[dict], where: str = "script"):
        self.actions: dict[int, list] = defaultdict(list)
        self.where = where
        for i, e in enumerate(events):
            try:
                self._expand(e)
            except (KeyError, TypeError, ValueError, IndexError) as err:
                raise UserError(f"{where}: event {i} ({e.get('type', '?')}): bad or missing field {err}") from None

    @property
    def last_frame(self) -> int:
        return max(self.actions, default=-1)

    def apply(self, app, frame: int) -> None:
        for action in self.actions.get(frame, ()):
            action(app)

    # -- expansion ---------------------------------------------------------
    def _at(self, frame: int, action) -> None:
        self.actions[int(frame)].append(action)

    def _expand(self, e: dict) -> None:
        kind = e["type"]
        f = int(e["frame"]) if "frame" in e else int(round(float(e.get("t", 0.0)) * SCRIPT_FPS))
        if f < 0:
            raise ValueError("frame < 0")
        handler = getattr(self, f"_ev_{kind}", None)
        if handler is None:
            raise ValueError(f"unknown type {kind!r}")
        handler(f, e)

    def _ev_mouse_move(self, f, e):
        x, y = _num(e["x"]), _num(e["y"])
        self._at(f, lambda app: app.interaction.mouse_move(x, y))

    def _ev_mouse_down(self, f, e, down=True):
        b = _button(e)
        x, y = (_num(e["x"]), _num(e["y"])) if "x" in e else (None, None)
        self._at(f, lambda app: app.interaction.mouse_button(b, down, x, y))

    def _ev_mouse_up(self, f, e):
        self._ev_mouse_down(f, e, down=False)

    def _ev_scroll(self, f, e):
        dy = _num(e.get("dy", 1.0))
        if "x" in e:
            self._ev_mouse_move(f, e)
        self._at(f, lambda app: app.interaction.scroll(dy))

    def _ev_drag(self, f, e):
        b, n = _button(e), max(int(e.get("frames", 10)), 1)
        p0, p1 = np.asarray(e["from"], float)[:2], np.asarray(e["to"], float)[:2]
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
        n = max(int(e.get("frames", 10)), 1)
        memo: dict = {}
        self._grab_target(f, memo)
        to_world = _vector(e["to"], 3, "to") if "to" in e else None
        to_px = _vector(e["to_px"], 2, "to_px") if to_world is None and "to_px" in e else None
        if to_world is None and to_px is None:
            raise KeyError("to")

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
        n = max(int(e.get("frames", 60)), 1)
        relative = False
        if "circle" in e:
            c = e["circle"]
            relative = c.get("center", "target") == "target"
            cx, cy = (0.0, 0.0) if relative else (_num(c["center"][0]), _num(c["center"][1]))
            r, turns = _num(c["radius"]), _num(c.get("turns", 1))
            ang = np.linspace(0, 2 * np.pi * turns, n + 1)
            # Starts at the top of the circle; relative circles pass through the target itself.
            pts = np.stack([cx + r * np.sin(ang), cy + r * np.cos(ang) - (r if relative else 0.0)], -1)
        else:
            pts = np.asarray(e["points"], float)
            if pts.ndim != 2 or pts.shape[1] < 2 or len(pts) < 1:
                raise ValueError("points must be a list of [x, y, z]")
            s = np.linspace(0, len(pts) - 1, n + 1)
            i0 = np.floor(s).astype(int)
            i1 = np.minimum(i0 + 1, len(pts) - 1)
            a = (s - i0)[:, None]
            pts = (1 - a) * pts[i0, :2] + a * pts[i1, :2]
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
        key, value = str(e["key"]), e["value"]
        self._at(f, lambda app: app.settings.set(key, value))

    def _ev_scrub(self, f, e):
        frame = _num(e["frame_to"] if "frame_to" in e else e["to"] if "to" in e else e["value"])
        self._at(f, lambda app: app.scrub(frame))

    def _ev_key(self, f, e):
        name = str(e["key"]).lower()
        if name not in KEY_NAMES:
            raise ValueError(f"unknown key {name!r} (known: {', '.join(KEY_NAMES)})")
        code = KEY_NAMES[name]
        self._at(f, lambda app: app.interaction.key(code, True))
        self._at(f, lambda app: app.interaction.key(code, False))

    def _ev_pcpad_drag(self, f, e):
        n = max(int(e.get("frames", 10)), 1)
        s0, s1 = np.asarray(e["from"], float)[:2], np.asarray(e["to"], float)[:2]
        for i in range(n + 1):
            s = s0 + (s1 - s0) * i / n
            self._at(f + i, lambda app, s=s, last=(i == n): app.pcpad_drag(s, last))

    def _ev_screenshot(self, f, e):
        path = str(e["path"])
        self._at(f, lambda app: app.request_screenshot(path))

    def _ev_export(self, f, e):
        from app.capture import check_formats
        out = str(e["dir"])
        formats = check_formats(e["formats"]) if "formats" in e else None   # bad names fail at load

        def export(app):
            if formats is not None:   # picked up with the folder by App._captures
                app.extras.setdefault("export_formats", {})[str(Path(out))] = formats
            app.request_export(out)
        self._at(f, export)


def _vector(v, n: int, name: str) -> np.ndarray:
    """``v`` as ``n`` numbers, or ValueError naming the field."""
    a = np.asarray(v, float).reshape(-1)
    if a.shape != (n,):
        raise ValueError(f"{name!r} needs {n} numbers, got {a.size}")
    return a


def _num(v) -> float:
    v = float(v)
    if not np.isfinite(v):
        raise ValueError("non-finite number")
    return v


def _button(e: dict) -> int:
    name = str(e.get("button", "left")).lower()
    if name not in BUTTON_NAMES:
        raise ValueError(f"unknown button {name!r}")
    return BUTTON_NAMES[name]
