"""Fuzzing the viewer's scripted input (app/script.py, ViewerSettings.set):
every script either loads into a player whose expansion is bounded by the
run's frame budget and whose actions never raise, or is one UserError line
naming the event; all checked without opening a viewer (except one run)."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.viewer import script as sc
from app.errors import UserError
from app.viewer.requests import Requests
from app.viewer.settings import (SETTING_CHOICES, SETTING_RANGES, ViewerSettings, check_setting, setting_kinds)
from tests.conftest import ROOT

FUZZ = settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class FakeInteraction:
    """What scripted actions call on ``app.interaction``; records nothing, checks finite input."""

    def mouse_move(self, x, y):
        assert math.isfinite(x) and math.isfinite(y)

    def mouse_button(self, button, down, x=None, y=None):
        assert x is None or math.isfinite(x)

    def scroll(self, dy):
        assert math.isfinite(dy)

    def key(self, code, down):
        pass

    def target_pixel(self):
        return np.array([320.0, 200.0])

    def world_to_pixel(self, p):
        return np.asarray(p, float)[:2] * 2.0


class FakeApp:
    def __init__(self):
        self.settings, self.interaction, self.requests = ViewerSettings(), FakeInteraction(), Requests()

    def scrub(self, frame):
        assert math.isfinite(frame)
        self.settings.frame = float(np.clip(frame, 0, 68))


    def request_screenshot(self, path):
        assert isinstance(path, str)

    def request_export(self, out, formats=None):
        assert isinstance(out, str)


def one_line(err: Exception) -> str:
    text = str(err)
    assert text and "\n" not in text and len(text) < 1000, text
    return text


def run_all(player: sc.ScriptPlayer) -> FakeApp:
    """Every action of a loaded script, in frame order, on a fake app: none may raise."""
    app = FakeApp()
    for frame in sorted(player.actions):
        player.apply(app, frame)
    return app


# ---------------------------------------------------------------- strategies
wild_numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10 ** 25, 10 ** 25),
                         st.sampled_from([1e9, 1e20, 1e308, -1e308, 10 ** 400, -1, 0, 0.5, 2, 60, 1e-300]),
                         st.floats(-200, 200), st.integers(0, 80))
wild = st.recursive(st.one_of(wild_numbers, st.booleans(), st.none(), st.text(max_size=20)),
                    lambda inner: st.one_of(st.lists(inner, max_size=4),
                                            st.dictionaries(st.text(max_size=8), inner, max_size=3)),
                    max_leaves=12)
small_frames = st.integers(0, 40)
vec2 = st.lists(st.one_of(st.floats(-500, 500), wild_numbers), min_size=0, max_size=4)
setting_keys = st.sampled_from(list(setting_kinds()) + ["sanitise", "overlays", "screenshot_requested",
                                                        "_private", "overlays.nope", "set"])
setting_values = st.one_of(wild, st.sampled_from([True, False, None, [], [1, 2, 3], "ccd", "dls", "off",
                                                  "mesh", "skeleton", 0, 2, 90, 0.01, 1.5]))


def event(kind: str, **fields):
    timing = st.one_of(st.fixed_dictionaries({"frame": st.one_of(small_frames, wild_numbers)}),
                       st.fixed_dictionaries({"t": st.one_of(st.floats(0, 1), wild_numbers)}), st.just({}))
    return st.tuples(timing, st.fixed_dictionaries({}, optional=fields)).map(
        lambda tf: {"type": kind, **tf[0], **tf[1]})


frames_field = st.one_of(st.integers(1, 30), wild_numbers)
events = st.one_of(
    event("mouse_move", x=wild_numbers, y=wild_numbers),
    event("mouse_down", x=wild_numbers, y=wild_numbers, button=st.sampled_from(["left", "right", "nope", 3])),
    event("scroll", dy=wild_numbers, x=wild_numbers, y=wild_numbers),
    event("drag", **{"from": vec2, "to": vec2, "frames": frames_field, "button": st.just("left")}),
    event("drag_target", to=st.lists(st.floats(-300, 300), min_size=3, max_size=3) | vec2, to_px=vec2,
          frames=frames_field),
    event("drag_target_path", frames=frames_field, points=st.lists(vec2, max_size=5) | wild,
          circle=st.fixed_dictionaries({"radius": wild_numbers},
                                       optional={"center": st.just("target") | vec2, "turns": wild_numbers})),
    event("set", key=setting_keys, value=setting_values),
    event("scrub", to=wild_numbers, frame_to=wild_numbers),
    event("key", key=st.sampled_from(["space", "h", "left", "nope", "F12"]) | wild),
    event("pcpad_drag", **{"from": vec2, "to": vec2, "frames": frames_field}),
    event("screenshot", path=st.text(max_size=10) | wild),
    event("reload"),
    event("warp"),
    st.dictionaries(st.sampled_from(["type", "frame", "t", "key", "value", "frames"]), wild, max_size=4),
)
budgets = st.one_of(st.none(), st.integers(1, 200), st.sampled_from([10 ** 9, 10 ** 30]))


@FUZZ
@given(evs=st.lists(events, max_size=6), budget=budgets)
def test_any_script_is_bounded_or_one_line_error(evs, budget):
    try:
        player = sc.ScriptPlayer(evs, "fuzz.json", frame_budget=budget)
    except UserError as e:
        text = one_line(e)
        assert text.startswith("fuzz.json")
        return
    limit = min(budget or sc.MAX_SCRIPT_FRAMES, sc.MAX_SCRIPT_FRAMES)
    assert player.last_frame < limit and player.count <= sc.MAX_SCRIPT_ACTIONS
    app = run_all(player)
    assert np.isfinite(app.settings.target).all()


@FUZZ
@given(key=setting_keys, value=setting_values)
def test_set_checks_at_load_and_never_raises_at_run_time(key, value):
    try:
        checked = check_setting(key, value)
    except UserError as e:
        one_line(e)
        with pytest.raises(UserError):          # the same value also refused by set itself
            ViewerSettings().set(key, value)
        return
    s = ViewerSettings()
    s.set(key, checked)
    s.set(key, checked)                         # twice: the checked value survives a first use


# A valid value of every setting, by its type (derived from the dataclass fields).
def valid_values(key: str, kind: str):
    lo, hi = SETTING_RANGES.get(key, (None, None))
    if kind == "bool":
        return st.booleans()
    if key in SETTING_CHOICES:
        return st.sampled_from(SETTING_CHOICES[key])
    if kind == "int":
        return st.integers(int(lo), int(hi))
    if kind == "float":
        return st.floats(lo, hi)
    if kind == "np.ndarray":
        return st.lists(st.floats(-5000, 5000), min_size=3, max_size=3)
    if kind == "str | None":
        return st.none() | st.sampled_from(["cover_drive", "pull"])
    raise AssertionError(f"no valid values for {key} ({kind})")


@FUZZ
@given(data=st.data())
def test_every_setting_applies_valid_values(data):
    for key, kind in setting_kinds().items():
        value = data.draw(valid_values(key, kind), label=key)
        s = ViewerSettings()
        s.set(key, value)                       # JSON-typed input, straight from a script
        obj, name = (s.overlays, key[9:]) if key.startswith("overlays.") else (s, key)
        stored = getattr(obj, name)
        if kind in ("bool", "str", "str | None", "int"):
            assert stored == value
        elif kind == "float":
            assert stored == pytest.approx(value)
        else:
            assert stored.shape == (3,) and np.isfinite(stored).all()


def valid_events():
    """Scripts that must load and run: every field in range."""
    from app.viewer.interaction import KEY_NAMES
    at, n = st.integers(0, 20), st.integers(1, 20)
    xy, score = st.lists(st.floats(-1000, 3000), min_size=2, max_size=2), st.lists(st.floats(-20, 20), min_size=2,
                                                                                   max_size=2)
    world = st.lists(st.floats(-300, 300), min_size=3, max_size=3)
    on_plane = st.tuples(st.floats(-300, 300), st.floats(-300, 300)).map(lambda xy: [*xy, sc.TARGET_PLANE_Z])
    kinds = list(setting_kinds().items())
    setting = st.sampled_from(kinds).flatmap(lambda kk: st.fixed_dictionaries(
        {"type": st.just("set"), "frame": at, "key": st.just(kk[0]), "value": valid_values(*kk)}))
    return st.one_of(
        st.fixed_dictionaries({"type": st.just("mouse_move"), "frame": at, "x": st.floats(-1000, 3000),
                               "y": st.floats(-1000, 3000)}),
        st.fixed_dictionaries({"type": st.just("drag"), "frame": at, "from": xy, "to": xy, "frames": n}),
        st.fixed_dictionaries({"type": st.just("drag_target"), "t": st.floats(0, 0.3), "to": on_plane, "frames": n}),
        st.fixed_dictionaries({"type": st.just("drag_target_path"), "frame": at, "frames": n,
                               "circle": st.fixed_dictionaries({"radius": st.floats(0, 100),
                                                                "turns": st.floats(-3, 3)})}),
        st.fixed_dictionaries({"type": st.just("drag_target_path"), "frame": at, "frames": n,
                               "points": st.lists(world, min_size=1, max_size=5)}),
        st.fixed_dictionaries({"type": st.just("scrub"), "frame": at, "to": st.floats(0, 80)}),
        st.fixed_dictionaries({"type": st.just("key"), "frame": at, "key": st.sampled_from(list(KEY_NAMES))}),
        st.fixed_dictionaries({"type": st.just("pcpad_drag"), "frame": at, "from": score, "to": score,
                               "frames": n}),
        setting)


@FUZZ
@given(evs=st.lists(valid_events(), min_size=1, max_size=8))
def test_valid_scripts_load_and_run(evs):
    """Through JSON and back, as from a file: loads within a budget of 50 frames and every action runs."""
    player = sc.ScriptPlayer(json.loads(json.dumps(evs)), frame_budget=50)
    assert 0 <= player.last_frame < 50 and player.count >= len(evs)
    run_all(player)


def test_setting_kinds_are_real_settings_only():
    kinds = setting_kinds()
    assert "falloff" in kinds and "overlays.flight" in kinds and "target" in kinds
    for absent in ("sanitise", "set", "adapt_settings", "engine_key", "playback_rate", "overlays",
                   "screenshot_requested", "export_requested", "reload_requested"):
        assert absent not in kinds


# ---------------------------------------------------------------- seen today
@pytest.mark.parametrize("ev, needle", [
    ({"type": "set", "frame": 0, "key": "falloff", "value": None}, "falloff must be a number"),
    ({"type": "set", "frame": 0, "key": "falloff", "value": [1, 2]}, "falloff must be a number"),
    ({"type": "set", "frame": 0, "key": "falloff", "value": math.inf}, "finite"),
    ({"type": "set", "frame": 0, "key": "playing", "value": 1}, "true or false"),
    ({"type": "set", "frame": 0, "key": "sanitise", "value": 1}, "unknown setting 'sanitise'"),
    ({"type": "set", "frame": 0, "key": "overlays", "value": {}}, "unknown setting"),
    ({"type": "set", "frame": 0, "key": "target", "value": [0, math.nan, 0]}, "finite"),
    ({"type": "set", "frame": 0, "key": "solver", "value": "newton"}, "ccd or dls"),
    ({"type": "set", "frame": 0, "key": "pinned_shot", "value": 3}, "pinned_shot"),
    ({"type": "key", "t": math.inf, "key": "h"}, "finite"),
    ({"type": "drag", "frame": 0, "from": [0, 0], "to": [9, 9], "frames": 1e9}, "frame budget is 24"),
    ({"type": "drag", "frame": 20, "from": [0, 0], "to": [9, 9], "frames": 10}, "frame budget of 24"),
    ({"type": "key", "frame": 1e20, "key": "h"}, "frame budget is 24"),
    ({"type": "key", "frame": 10 ** 400, "key": "h"}, "frame budget is 24"),
    ({"type": "drag_target_path", "frame": 0, "circle": {"radius": 1e308}, "frames": 5}, "radius"),
    ({"type": "drag_target", "frame": 0, "to": [-85, 40, 210], "frames": 5}, "plane z = -60"),
])
def test_seen_bad_events_are_refused_at_load(ev, needle):
    with pytest.raises(UserError) as e:
        sc.ScriptPlayer([{"type": "key", "frame": 0, "key": "h"}, ev], "bad.json", frame_budget=24)
    text = one_line(e.value)
    assert text.startswith("bad.json: event 1 (") and needle in text, text


def test_expansion_is_bounded_without_frames():
    """No --frames: the budget is MAX_SCRIPT_FRAMES; a 1e9-frame drag is refused before expansion."""
    with pytest.raises(UserError, match="MAX_SCRIPT_FRAMES"):
        sc.ScriptPlayer([{"type": "drag_target_path", "frame": 0, "circle": {"radius": 5}, "frames": 10 ** 9}])
    many = [{"type": "drag", "frame": 0, "from": [0, 0], "to": [1, 1], "frames": sc.MAX_SCRIPT_FRAMES - 3}] * 10
    with pytest.raises(UserError, match="MAX_SCRIPT_ACTIONS"):
        sc.ScriptPlayer(many)


def test_valid_script_expands_within_the_budget():
    evs = [{"type": "set", "frame": 0, "key": "falloff", "value": 100},
           {"type": "drag_target_path", "frame": 1, "circle": {"center": [-20, 70], "radius": 25}, "frames": 12},
           {"type": "scrub", "frame": 16, "to": 5},
           {"type": "key", "frame": 17, "key": "h", "comment": "unknown fields are ignored"}]
    player = sc.ScriptPlayer(evs, frame_budget=24)
    assert player.last_frame == 17
    app = run_all(player)
    assert app.settings.falloff == 100.0


# ---------------------------------------------------------------- the file
script_texts = st.one_of(
    st.text(max_size=200),
    st.sampled_from(['[{"type": "key", "frame": 1, "key": "h", "x": Infinity}]', '[{"type": "key", "t": NaN}]',
                     '[{"type": "key", "frame": 1e400, "key": "h"}]', "[" * 10_000 + "]" * 10_000,
                     '{"type": "key"}', "[1, 2]", "[]", '[{"type": "key", "frame": 1, "key": "h"}]']),
    st.lists(events, max_size=4).map(lambda evs: json.dumps(evs, allow_nan=True)))


@FUZZ
@given(text=script_texts)
def test_any_script_file_loads_or_one_line_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("s") / "script.json"
    path.write_text(text, encoding="utf-8")
    try:
        sc.ScriptPlayer(sc.load_script(path), str(path), frame_budget=100)
    except UserError as e:
        assert str(path) in one_line(e)


def test_script_file_limits(tmp_path):
    big = tmp_path / "big.json"
    big.write_text("[" + " " * sc.MAX_SCRIPT_BYTES + "]")
    with pytest.raises(UserError, match="larger than"):
        sc.load_script(big)
    many = tmp_path / "many.json"
    many.write_text(json.dumps([{"type": "key", "frame": 0, "key": "h"}] * (sc.MAX_SCRIPT_EVENTS + 1)))
    with pytest.raises(UserError, match="MAX_SCRIPT_EVENTS"):
        sc.load_script(many)


def test_headless_view_refuses_a_bad_script_with_one_line(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps([{"type": "set", "frame": 1, "key": "sanitise", "value": None}]))
    r = subprocess.run([sys.executable, "-c", "from app.cli import main; main()", "view", "--headless", "--frames", "5", "--script",
                        str(bad)], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and "event 0" in lines[0] and "sanitise" in lines[0]
