"""The viewer's session, autosaved: the settings (overlays included), the target
and pinned shot, the camera and every PC-pad take of every shot (drawn paths,
presets), so that nothing the user makes is lost to a crash, a kill or a close.

Where: ``session.json`` in ``$HITPOINT_DATA_DIR`` if set, else in
``platformdirs.user_data_dir("hitpoint")``. When: once the session has held
still for AUTOSAVE_QUIET_S after a change (or at most AUTOSAVE_MAX_WAIT_S after
the first unsaved change, for a drag that never stops), and on exit. The loop
calls :meth:`Autosave.tick` once a frame: it compares a small tuple of numbers
(the settings, the camera, the pad's take generation) and encodes JSON only when
that changed and the delay has passed.

The file is plain data (JSON of numbers, strings, booleans), atomically written
(``engine.atomic``). Reading it trusts nothing: a file that is not valid JSON,
too large, deeper than the JSON limits, not a version >= 1 or from a newer Hitpoint
is renamed aside (``session.corrupt-<time>.json`` or ``session.newer-<time>.json``,
never over an earlier one) with one panel line, and the viewer starts clean; a
field of the wrong type, non-finite or out of its bounds is dropped (one panel
line names them) and the rest restored, ranges clamped by ``ViewerSettings.sanitise``.

A take is stored as its recipe (kind, PC-score points, their times, preset amount,
clean-up options), not as a clip: synthesis is deterministic, so the clip is made
again, identical, when the take is picked (``app.pcpad.show_take``).

``fresh=True`` (``hitpoint view --fresh``) reads nothing; the previous file stays
as it is until the new session first changes, and is then renamed aside to
``session.before-fresh-<time>.json`` rather than overwritten.
"""
from __future__ import annotations

import dataclasses
import json
import os
import time
from pathlib import Path

import numpy as np
import platformdirs

from app.viewer.capture import release, reserve_new
from app.errors import UserError, shorten
from app.jsonfile import read_json
from app.viewer.pcpad import MAX_TAKES_PER_SHOT, PRESET_LABELS, TAKE_KINDS, Take, pad_state
from engine import atomic
from engine.synth import check_scores, check_times   # what synthesis will accept

SESSION_VERSION = 2
# Settings whose default changed at a version: a file older than it saved the old default
# for a user who never chose, so it is not restored (version 2: the lean carried by default,
# engine.carry; a version-1 file says carry_lean false unless the user turned it on).
DEFAULT_CHANGED_AT = {"carry_lean": 2}
SESSION_FILE = "session.json"
DATA_DIR_ENV = "HITPOINT_DATA_DIR"
AUTOSAVE_QUIET_S = 1.0          # saved this long after the last change...
AUTOSAVE_MAX_WAIT_S = 5.0       # ... or this long after the first unsaved one
SAVE_RETRY_S = 30.0             # after a failed save (full disk), try again this much later
MAX_SESSION_BYTES = 32_000_000  # a session file is refused above this (64 takes of 4000 points ~ 10 MB)
MAX_NAME_CHARS = 200            # a shot name, solver or mode
MAX_SHOTS_WITH_TAKES = 1000
MAX_POINTS_PER_TAKE = 20_000    # drawn strokes stop at pcpad.MAX_TAKE_POINTS; presets have a shot's frames
CAMERA_PIVOT_CM = 3000.0        # as OrbitCamera.pan clamps it
CAMERA_DISTANCE_CM = (60.0, 5000.0)
CAMERA_PITCH_DEG = (-5.0, 89.0)
NAMES_IN_MESSAGE = 5            # invalid fields named in the panel line
_PAD_OPTIONS = {"mode": ("pose", "draw"), "loop": bool, "fix_hand": bool, "plant_feet": bool, "detail": bool}


class Invalid(ValueError):
    """One field of a session file that cannot be used."""


def data_dir() -> Path:
    """The folder of the user's session: ``$HITPOINT_DATA_DIR`` (tests, portable installs) or
    the platform's user data folder."""
    override = os.environ.get(DATA_DIR_ENV)
    if override:
        return Path(override)
    return Path(platformdirs.user_data_dir("hitpoint", appauthor=False))


# ------------------------------------------------------------------ writing
def snapshot(settings, state, camera) -> dict:
    """The session as plain data (JSON-ready)."""
    return {"version": SESSION_VERSION, "saved_at": time.time(), "settings": _settings_data(settings),
            "camera": {"pivot": np.asarray(camera.pivot, float).tolist(), "yaw": float(camera.yaw),
                       "pitch": float(camera.pitch), "distance": float(camera.distance)},
            "pc_pad": _pad_data(state.pc_pad)}


def _settings_data(settings) -> dict:
    out = {}
    for f in dataclasses.fields(settings):
        value = getattr(settings, f.name)
        if f.name == "overlays":
            value = dataclasses.asdict(value)
        elif isinstance(value, np.ndarray):
            value = value.astype(float).tolist()
        out[f.name] = value
    return out


def _pad_data(pad) -> dict:
    if pad is None:
        return {}
    takes = {name: [_take_data(t) for t in shot_takes] for name, shot_takes in pad.takes.items() if shot_takes}
    return {"mode": pad.mode, "preset": pad.preset, "amount": float(pad.amount), "loop": bool(pad.loop),
            "fix_hand": bool(pad.fix_hand), "plant_feet": bool(pad.plant_feet), "detail": bool(pad.detail),
            "takes": takes}


def _take_data(take) -> dict:
    return {"kind": take.kind, "points": np.asarray(take.points, float).tolist(),
            "times": None if take.times is None else np.asarray(take.times, float).tolist(),
            "amount": float(take.amount), "fix_hand": bool(take.fix_hand), "plant_feet": bool(take.plant_feet),
            "detail": bool(take.detail)}


def change_key(settings, state, camera) -> tuple:
    """A cheap fingerprint of everything saved (a few dozen numbers, no arrays encoded):
    the frame shown only while paused (playing changes it every frame)."""
    o = settings.overlays
    pad = state.pc_pad
    pad_key = None if pad is None else (pad.generation, pad.mode, pad.preset, pad.amount, pad.loop,
                                        pad.fix_hand, pad.plant_feet, pad.detail)
    return (settings.engine_key(), None if settings.playing else settings.frame, settings.playing,
            settings.speed, settings.slow_motion, settings.loop, settings.render_scale, settings.antialias,
            tuple(vars(o).values()), tuple(np.asarray(camera.pivot, float).tolist()), camera.yaw,
            camera.pitch, camera.distance, pad_key)


# ------------------------------------------------------------------ reading
def read(path: Path) -> dict:
    """The session in ``path`` as checked top-level data; UserError (one line) if the file
    cannot be a session at all; ``Newer`` if a newer Hitpoint wrote it."""
    data = read_json(path, "session file", MAX_SESSION_BYTES)
    if not isinstance(data, dict):
        raise UserError(f"{path}: a session is a JSON object, not {type(data).__name__}")
    version = data.get("version")
    if type(version) is not int or version < 1:
        raise UserError(f"{path}: 'version' must be a whole number >= 1, got {shorten(repr(version))}")
    if version > SESSION_VERSION:
        raise Newer(f"{path} was written by a newer Hitpoint (session version {version}, "
                    f"this one reads {SESSION_VERSION})")
    return data


class Newer(UserError):
    """A session file of a later version than this viewer understands."""


def apply(data: dict, settings, state, camera) -> list[str]:
    """Put the checked session ``data`` into the viewer; the names of the fields dropped."""
    dropped: list[str] = []
    for section, fn, target in (("settings", _apply_settings, settings), ("camera", _apply_camera, camera),
                                ("pc_pad", _apply_pad, state)):
        value = data.get(section, {})
        if isinstance(value, dict):
            if section == "settings":
                value = {k: v for k, v in value.items() if data["version"] >= DEFAULT_CHANGED_AT.get(k, 0)}
            fn(value, target, dropped)
        else:
            dropped.append(section)
    settings.sanitise()
    return dropped


def _like(default, value, name: str):
    """``value`` if it has the type of ``default`` (an int counts as a float; a text field
    takes a short string or null, which ``sanitise`` turns into its default), else Invalid."""
    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, int):
        ok = type(value) is int
    elif isinstance(default, float):
        ok = type(value) in (int, float) and bool(np.isfinite(value))
        value = float(value) if ok else value
    elif default is None or isinstance(default, str):
        ok = value is None or isinstance(value, str) and len(value) <= MAX_NAME_CHARS
    else:
        ok = False
    if not ok:
        raise Invalid(name)
    return value


def _vector(value, n: int, name: str, limit: float) -> np.ndarray:
    """``n`` finite numbers of magnitude <= ``limit`` (bools and strings refused), else Invalid."""
    if not isinstance(value, list) or len(value) != n or not all(type(v) in (int, float) for v in value):
        raise Invalid(name)
    a = np.array(value, float)
    if not (np.isfinite(a).all() and (np.abs(a) <= limit).all()):
        raise Invalid(name)
    return a


def _apply_fields(obj, data: dict, prefix: str, dropped: list, skip=()) -> None:
    """Each known, well-typed field of ``data`` onto the dataclass ``obj``."""
    for f in dataclasses.fields(obj):
        if f.name not in data or f.name in skip:
            continue
        try:
            setattr(obj, f.name, _like(getattr(obj, f.name), data[f.name], prefix + f.name))
        except Invalid as e:
            dropped.append(str(e))


def _apply_settings(data: dict, settings, dropped: list) -> None:
    _apply_fields(settings, data, "", dropped, skip=("overlays", "target"))
    if "target" in data:
        try:
            settings.target = _vector(data["target"], 3, "target", 1e5)
        except Invalid as e:
            dropped.append(str(e))
    overlays = data.get("overlays", {})
    if isinstance(overlays, dict):
        _apply_fields(settings.overlays, overlays, "overlays.", dropped)
    else:
        dropped.append("overlays")


def _apply_camera(data: dict, camera, dropped: list) -> None:
    for name, lo, hi in (("yaw", -1e6, 1e6), ("pitch", *CAMERA_PITCH_DEG), ("distance", *CAMERA_DISTANCE_CM)):
        if name in data:
            try:
                v = _vector([data[name]], 1, f"camera.{name}", 1e6)[0]
                setattr(camera, name, float((v + 180.0) % 360.0 - 180.0 if name == "yaw" else min(max(v, lo), hi)))
            except Invalid as e:
                dropped.append(str(e))
    if "pivot" in data:
        try:
            camera.pivot = np.clip(_vector(data["pivot"], 3, "camera.pivot", 1e6), -CAMERA_PIVOT_CM, CAMERA_PIVOT_CM)
        except Invalid as e:
            dropped.append(str(e))


def _apply_pad(data: dict, state, dropped: list) -> None:
    pad = pad_state(state)
    for name, allowed in (*_PAD_OPTIONS.items(), ("preset", tuple(PRESET_LABELS))):
        if name in data:
            v = data[name]
            ok = isinstance(v, bool) if allowed is bool else v in allowed if isinstance(v, str) else False
            if ok:
                setattr(pad, name, v)
            else:
                dropped.append(f"pc_pad.{name}")
    if "amount" in data:
        try:
            pad.amount = float(np.clip(_vector([data["amount"]], 1, "pc_pad.amount", 1e6)[0], 0.0, 1.0))
        except Invalid as e:
            dropped.append(str(e))
    takes = data.get("takes", {})
    if not isinstance(takes, dict) or len(takes) > MAX_SHOTS_WITH_TAKES:
        dropped.append("pc_pad.takes")
        return
    for shot, items in takes.items():
        kept = _takes(shot, items, dropped)
        if kept:
            pad.takes[shot] = kept
    pad.generation += 1


def _takes(shot: str, items, dropped: list) -> list:
    """The valid takes of one shot (at most pcpad.MAX_TAKES_PER_SHOT, the newest)."""
    where = f"takes[{shorten(repr(shot))}]"
    if len(shot) > MAX_NAME_CHARS or not isinstance(items, list):
        dropped.append(where)
        return []
    if len(items) > MAX_TAKES_PER_SHOT:
        dropped.append(f"{where}[:{len(items) - MAX_TAKES_PER_SHOT}] (over {MAX_TAKES_PER_SHOT} takes)")
        items = items[-MAX_TAKES_PER_SHOT:]
    kept = []
    for i, item in enumerate(items):
        try:
            kept.append(take_from_data(item, f"{where}[{i}]"))
        except Invalid as e:
            dropped.append(str(e))
    return kept


def take_from_data(item, where: str = "take"):
    """A ``pcpad.Take`` from its stored recipe, every number checked; Invalid names the field."""
    if not isinstance(item, dict) or item.get("kind") not in TAKE_KINDS:
        raise Invalid(f"{where}.kind")
    points = item.get("points")
    if not isinstance(points, list) or not 2 <= len(points) <= MAX_POINTS_PER_TAKE:
        raise Invalid(f"{where}.points (2..{MAX_POINTS_PER_TAKE} points)")
    pts = np.stack([_vector(p, 2, f"{where}.points", np.inf) for p in points])
    times = item.get("times")
    if times is not None:
        times = _vector(times, len(pts), f"{where}.times", np.inf)
    try:                          # the engine's own limits: a restored take always re-synthesises
        check_scores(pts)
        if times is not None:
            check_times(times, len(pts))
    except ValueError as e:
        raise Invalid(f"{where}: {e}") from None
    if times is not None and not 0 <= times[0] < times[-1]:
        raise Invalid(f"{where}.times (from >= 0, lasting > 0 s)")
    take = Take(item["kind"], pts, times)
    for name in ("amount", "fix_hand", "plant_feet", "detail"):
        if name in item:
            setattr(take, name, _like(getattr(take, name), item[name], f"{where}.{name}"))
    if not 0.0 <= take.amount <= 1.0:
        raise Invalid(f"{where}.amount (0..1)")
    return take


# ------------------------------------------------------------------ the autosaver
def _notice(state, line: str) -> None:
    """A panel line that is news, not a failure: a session recovered from (its file kept
    aside) does not fail a headless run the way an error does (``app.cli.view._refuse_failures``)."""
    state.report(line)
    state.errors -= 1


class Autosave:
    """Restores the session at start, saves it a moment after each change and on exit."""

    def __init__(self, folder: str | os.PathLike | None = None, fresh: bool = False, clock=time.monotonic):
        self.folder = Path(folder) if folder is not None else data_dir()
        self.path = self.folder / SESSION_FILE
        self.fresh, self.clock = fresh, clock
        self.enabled = True                  # False once the file could not be put aside
        self.line = ""                       # one line for the panel: where the session lives
        self._key = None
        self._first_change = self._last_change = None
        self._retry_at = 0.0
        self._aside_first = fresh            # a fresh session puts the old file aside at its first save

    # -- start
    def restore(self, settings, state, camera) -> bool:
        """Load the saved session into the viewer (unless fresh); True when something was restored."""
        restored = False
        if self.fresh:
            self.line = f"fresh session (the previous one stays until this one changes): {self.path}"
        elif self.path.exists():
            restored = self._restore_file(settings, state, camera)
        if not self.line:
            self.line = f"session autosaves to {self.path}"
        pad_state(state)          # made now, or its first drawing would look like a change
        self._key = change_key(settings, state, camera)
        return restored

    def _restore_file(self, settings, state, camera) -> bool:
        try:
            data = read(self.path)
        except UserError as e:
            kind = "newer" if isinstance(e, Newer) else "corrupt"
            aside = self._put_aside(kind, state)
            if aside is not None:
                _notice(state, f"session: {e}; kept as {aside.name}, starting clean")
            return False
        except OSError as e:       # unreadable (permissions): never overwrite what could not be read
            self.enabled = False
            state.report(f"session: cannot read {self.path} ({e.strerror or e}); autosave is off")
            return False
        dropped = apply(data, settings, state, camera)
        if dropped:
            names = ", ".join(shorten(d, 80) for d in dropped[:NAMES_IN_MESSAGE])
            more = f" and {len(dropped) - NAMES_IN_MESSAGE} more" if len(dropped) > NAMES_IN_MESSAGE else ""
            _notice(state, f"session: {self.path}: ignored invalid {names}{more}")
        self.line = f"session restored from {self.path} (autosaved)"
        return True

    def _put_aside(self, kind: str, state) -> Path | None:
        """Rename the session file to ``session.<kind>-<time>.json`` (a new name); if that fails,
        autosave stops, so that the file is never overwritten."""
        aside = None
        try:
            aside = reserve_new(self.folder, f"session.{kind}-", ".json")
            os.replace(self.path, aside)
        except OSError as e:
            if aside is not None:
                release(aside)
            self.enabled = False
            state.report(f"session: could not rename {self.path} aside ({e.strerror or e}); autosave is off")
            return None
        return aside

    # -- every frame
    def tick(self, settings, state, camera) -> bool:
        """Once a frame: note a change, save when due. True when it saved."""
        if not self.enabled:
            return False
        key = change_key(settings, state, camera)
        now = self.clock()
        if key != self._key:
            self._key, self._last_change = key, now
            self._first_change = self._first_change if self._first_change is not None else now
        if self._first_change is None or now < self._retry_at:
            return False
        if now - self._last_change < AUTOSAVE_QUIET_S and now - self._first_change < AUTOSAVE_MAX_WAIT_S:
            return False
        return self.save(settings, state, camera)

    @property
    def dirty(self) -> bool:
        return self._first_change is not None

    def save(self, settings, state, camera) -> bool:
        """Write the session now (atomically); a failure is one panel line and a later retry."""
        if not self.enabled:
            return False
        text = json.dumps(snapshot(settings, state, camera), separators=(",", ":"), allow_nan=False)
        try:
            if len(text) > MAX_SESSION_BYTES:
                raise OSError(f"{len(text) / 1e6:.0f} MB is over the {MAX_SESSION_BYTES // 1_000_000} MB "
                              "a session may be: forget some PC-pad takes")
            self._make_folder()
            if self._aside_first and self.path.exists() and self._put_aside("before-fresh", state) is None:
                return False
            self._aside_first = False
            atomic.write_text(self.path, text)
        except (OSError, ValueError) as e:
            self._retry_at = self.clock() + SAVE_RETRY_S
            state.report(f"session: not saved to {self.path}: {getattr(e, 'strerror', None) or e}")
            return False
        self._first_change = self._last_change = None
        return True

    def _make_folder(self) -> None:
        """The platform's data folder may need its parents; ``$HITPOINT_DATA_DIR`` only itself."""
        self.folder.mkdir(parents=DATA_DIR_ENV not in os.environ, exist_ok=True)

    def close(self, settings, state, camera) -> None:
        """On exit: save what changed since the last autosave."""
        if self.enabled and self.dirty:
            self.save(settings, state, camera)


def autosave_for(headless: bool, scripted: bool, fresh: bool, wanted: bool | None) -> Autosave | None:
    """The session a ``hitpoint view`` run uses (None: none read, none written). ``wanted``
    (``--session`` / ``--no-session``) decides; without it a window without a script has one,
    while a headless or scripted run (tests, benchmarks: reproducible) has one only when
    ``$HITPOINT_DATA_DIR`` points somewhere."""
    if wanted is None:
        wanted = not (headless or scripted) or bool(os.environ.get(DATA_DIR_ENV))
    return Autosave(fresh=fresh) if wanted else None
