"""The viewer's session autosave (app.session): a round trip through a real viewer
(settings, camera, three drawn takes on two shots, re-synthesised identically),
takes surviving shot switches and library reloads, corrupt / newer / oversized
files put aside with a panel line and a clean start, invalid fields dropped (a
fuzz of whole sessions and of single takes), the debounce, --fresh, a viewer
killed with SIGKILL losing nothing autosaved, and captures never overwriting
each other."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings as hsettings, strategies as st

from app.viewer import capture, session as sess
from app.viewer.camera import OrbitCamera
from app.viewer.settings import ViewerSettings
from app.viewer.state import AppState
from engine.synth import MAX_ABS_SCORE

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")
SIZE = (960, 600)


def draws(frame0, *segments, frames=8):
    """A script drawing one PC-pad path per (from, to) segment, 20 frames apart."""
    return [{"type": "pcpad_draw", "frame": frame0 + 20 * i, "from": list(a), "to": list(b), "frames": frames}
            for i, (a, b) in enumerate(segments)]


def run(app, frames, player=None):
    for i in range(frames):
        if player is not None:
            player.apply(app, i)
        app.frame(dt=1 / 60)


def fresh_viewer():
    return ViewerSettings(), AppState(), OrbitCamera()


# ------------------------------------------------------------------ a real viewer, twice
def test_session_round_trip_through_two_viewers(tmp_path):
    """Settings, camera, overlays, pad options and three drawn takes on two shots come back in a
    new viewer; a take picked there re-synthesises the very same clip; shot switches and a
    library reload kept every take on the way."""
    from app.viewer.script import ScriptPlayer
    from app.viewer.loop import App
    app = App(SIZE, headless=True, session=sess.Autosave(tmp_path))
    try:
        run(app, 2)
        s, st_, names = app.settings, app.state, [shot.name for shot in app.state.shots]
        first, second = names[0], names[1]
        s.pinned_shot = first
        run(app, 2)
        run(app, 60, ScriptPlayer(draws(0, ([0, 0], [1.5, -1.0]), ([-1, 1], [1.0, 1.0]))))
        s.pinned_shot = second                   # the ball path switches shot: today's drop
        run(app, 2)
        run(app, 40, ScriptPlayer(draws(0, ([0.5, -1], [-1.0, 0.5]))))
        app.requests.reload = True               # the library reloads
        run(app, 2)
        pad = st_.pc_pad
        assert [len(pad.shot_takes(n)) for n in (first, second)] == [2, 1], pad.takes.keys()
        s.falloff, s.solver, s.overlays.flight, s.overlays.ghost, s.speed = 77.0, "dls", False, "skeleton", 0.5
        app.camera.yaw, app.camera.distance, app.camera.pivot = 25.0, 420.0, np.array([10.0, 80.0, -20.0])
        pad.amount, pad.plant_feet, pad.detail = 0.25, False, False
        pad.shot_takes(first)[0].detail = False
        run(app, 1)
        saved_takes = {n: [(t.kind, t.points.copy(), None if t.times is None else t.times.copy())
                           for t in pad.shot_takes(n)] for n in (first, second)}
        clip = pad.shot_takes(second)[0].anim
        target = s.target.copy()
    finally:
        app.close()                              # saves what changed since the last autosave
    assert (tmp_path / "session.json").is_file()

    app = App(SIZE, headless=True, session=sess.Autosave(tmp_path))
    try:
        s, pad = app.settings, app.state.pc_pad
        assert (s.falloff, s.solver, s.overlays.flight, s.overlays.ghost, s.speed, s.pinned_shot) == \
               (77.0, "dls", False, "skeleton", 0.5, second)
        assert np.array_equal(s.target, target)
        c = app.camera
        assert (c.yaw, c.distance, c.pivot.tolist()) == (25.0, 420.0, [10.0, 80.0, -20.0])
        assert (pad.amount, pad.plant_feet, pad.detail, pad.mode) == (0.25, False, False, "draw")
        assert [t.detail for t in pad.shot_takes(first)] == [False, True]
        for name, takes in saved_takes.items():
            got = pad.shot_takes(name)
            assert len(got) == len(takes)
            for t, (kind, points, times) in zip(got, takes):
                assert t.kind == kind and np.array_equal(t.points, points) and np.array_equal(t.times, times)
        assert app.state.errors == 0, app.state.messages
        run(app, 2)
        from app.viewer.pcpad import show_take
        show_take(app.state, 0)                  # the second shot is pinned: its one take
        again = pad.shot_takes(second)[0].anim
        assert np.array_equal(again.local_rotations, clip.local_rotations)
        assert np.array_equal(again.root_positions, clip.root_positions)
        run(app, 2)
        assert app.state.pose_source == "pc pad"
    finally:
        app.close()


# ------------------------------------------------------------------ bad files
def _restore(folder):
    settings, state, camera = fresh_viewer()
    saver = sess.Autosave(folder)
    saver.restore(settings, state, camera)
    return saver, settings, state, camera


@pytest.mark.parametrize("content, kind, words", [
    (b'{"version": 1, "settings": {"falloff": ', "corrupt", "not valid JSON"),
    (b"\xff\xfe garbage", "corrupt", "UTF-8"),
    (b"[1, 2, 3]", "corrupt", "JSON object"),
    (b'{"settings": {}}', "corrupt", "version"),
    (b'{"version": true}', "corrupt", "version"),
    (b'{"version": 1, "camera": {"yaw": NaN}}', "corrupt", "finite"),
    (b'{"version": 3, "settings": {"falloff": 70}}', "newer", "newer Hitpoint"),
])
def test_a_bad_session_file_is_kept_aside_and_the_viewer_starts_clean(tmp_path, content, kind, words):
    (tmp_path / "session.json").write_bytes(content)
    saver, settings, state, camera = _restore(tmp_path)
    aside = list(tmp_path.glob(f"session.{kind}-*.json"))
    assert len(aside) == 1 and aside[0].read_bytes() == content
    assert not (tmp_path / "session.json").exists()
    assert len(state.messages) == 1 and words in state.messages[0][1] and aside[0].name in state.messages[0][1]
    assert state.errors == 0                     # news, not a failure: headless runs go on
    assert sess.change_key(settings, state, camera)[:-1] == sess.change_key(*fresh_viewer())[:-1]   # defaults
    assert not state.pc_pad.takes
    assert camera.yaw == OrbitCamera().yaw
    assert saver.enabled and not saver.dirty     # nothing changed yet: nothing written
    # a second bad file in the same millisecond gets its own name
    (tmp_path / "session.json").write_bytes(content)
    _restore(tmp_path)
    assert len(list(tmp_path.glob(f"session.{kind}-*.json"))) == 2


def test_an_oversized_session_file_is_refused_without_reading_it_all(tmp_path, monkeypatch):
    monkeypatch.setattr(sess, "MAX_SESSION_BYTES", 1000)
    (tmp_path / "session.json").write_text(json.dumps({"version": 1, "pad": "x" * 5000}))
    _, _, state, _ = _restore(tmp_path)
    assert "larger than" in state.messages[0][1]
    assert len(list(tmp_path.glob("session.corrupt-*.json"))) == 1


def test_invalid_fields_are_dropped_by_name_and_the_rest_restored(tmp_path):
    data = {"version": 1,
            "settings": {"falloff": "far", "iterations": 1e9, "speed": 100, "wrist_dof": 2, "solver": "x" * 500,
                         "target": [1, 2], "overlays": {"flight": False, "ball": "yes"}, "pinned_shot": 5},
            "camera": {"yaw": True, "pitch": 500, "distance": 300, "pivot": [1, "2", 3]},
            "pc_pad": {"mode": "draw", "amount": 7, "takes": {
                "a": [{"kind": "drawn", "points": [[0, 0], [1, 1]], "times": [0, 0.5]},
                      {"kind": "drawn", "points": [[0, 0], [1, 1e9]]},
                      {"kind": "exaggerated", "points": [[0, 0], [1, 1], [2, 2]], "amount": 0.3}]}}}
    (tmp_path / "session.json").write_text(json.dumps(data))
    _, settings, state, camera = _restore(tmp_path)
    line = state.messages[0][1]
    for name in ("falloff", "iterations", "solver", "pinned_shot", "target"):
        assert name in line
    assert "more" in line                       # more than five: the rest counted, not listed
    assert settings.speed == 4.0 and settings.wrist_dof == 2 and settings.overlays.flight is False
    assert settings.falloff == 90.0 and settings.solver == "ccd" and settings.pinned_shot is None
    assert camera.pitch == 89.0 and camera.distance == 300.0 and camera.yaw == OrbitCamera().yaw
    pad = state.pc_pad
    assert pad.mode == "draw" and pad.amount == 1.0
    assert [t.kind for t in pad.shot_takes("a")] == ["drawn", "exaggerated"]
    assert pad.shot_takes("a")[1].amount == 0.3


def test_a_setting_whose_default_changed_is_not_restored_from_an_older_file(tmp_path):
    """Version 1 saved carry_lean false for everyone who never touched it (then the default);
    read after the default became true, that is not the user's choice. From a version-2 file
    the user's false is kept; every other setting of either is restored."""
    for version, lean in ((1, True), (2, False)):
        (tmp_path / "session.json").write_text(json.dumps(
            {"version": version, "settings": {"carry_lean": False, "falloff": 70, "wrist_dof": 2}}))
        _, settings, state, _ = _restore(tmp_path)
        assert settings.carry_lean is lean and settings.falloff == 70.0 and settings.wrist_dof == 2, version
        assert not [m for m in state.messages if "carry_lean" in m[1]]   # not reported as invalid


# ------------------------------------------------------------------ fuzz: nothing crashes, nothing invalid is kept
json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-10**12, 10**12) | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=30),
    lambda inner: st.lists(inner, max_size=5) | st.dictionaries(st.text(max_size=12), inner, max_size=5),
    max_leaves=30)
setting_names = st.sampled_from(["falloff", "wrist_dof", "solver", "iterations", "tolerance", "target", "frame",
                                 "pinned_shot", "speed", "playing", "overlays", "render_scale", "antialias",
                                 "screenshot_requested"])


@hsettings(max_examples=400, deadline=None)
@given(st.dictionaries(setting_names, json_values, max_size=8),
       st.dictionaries(st.sampled_from(["yaw", "pitch", "distance", "pivot"]), json_values, max_size=4),
       st.dictionaries(st.sampled_from(["mode", "preset", "amount", "loop", "takes"]), json_values, max_size=5))
def test_fuzzed_sessions_restore_or_drop_never_crash(settings_data, camera_data, pad_data):
    settings, state, camera = fresh_viewer()
    dropped = sess.apply({"version": 1, "settings": settings_data, "camera": camera_data, "pc_pad": pad_data},
                         settings, state, camera)
    assert all(isinstance(d, str) for d in dropped)
    assert np.isfinite(settings.target).all() and np.isfinite(camera.pivot).all()
    assert all(np.isfinite(v) for v in (settings.falloff, settings.frame, camera.yaw, camera.pitch, camera.distance))
    assert type(settings.iterations) is int and isinstance(settings.playing, bool)
    assert not hasattr(settings, "screenshot_requested")  # a request is no setting: never restored
    for takes in state.pc_pad.takes.values():
        for t in takes:
            assert np.isfinite(t.points).all() and t.points.shape[1] == 2


take_fields = st.fixed_dictionaries({}, optional={
    "kind": st.sampled_from(["drawn", "aborted", "source (2 PCs)", "other"]) | json_values,
    "points": st.lists(st.lists(st.floats(-2e4, 2e4) | st.integers(-5, 5) | json_values, min_size=1, max_size=3),
                       max_size=6) | json_values,
    "times": st.lists(st.floats(-1, 5), max_size=6) | json_values,
    "amount": json_values | st.floats(-1, 2), "fix_hand": json_values})


@hsettings(max_examples=600, deadline=None)
@given(take_fields)
def test_fuzzed_takes_are_exactly_valid_or_invalid(item):
    try:
        take = sess.take_from_data(item)
    except sess.Invalid as e:
        assert "\n" not in str(e)
        return
    assert take.points.ndim == 2 and take.points.shape[1] == 2 and len(take.points) >= 2
    assert (np.abs(take.points) <= MAX_ABS_SCORE).all() and 0 <= take.amount <= 1
    if take.times is not None:
        assert take.times[0] >= 0 and (np.diff(take.times) >= 0).all() and len(take.times) == len(take.points)
    again = sess.take_from_data(sess._take_data(take))        # a valid take round-trips
    assert again.kind == take.kind and np.array_equal(again.points, take.points)


# ------------------------------------------------------------------ when it saves
class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def test_autosave_waits_for_a_quiet_second_and_at_most_five(tmp_path):
    clock, (settings, state, camera) = Clock(), fresh_viewer()
    saver = sess.Autosave(tmp_path, clock=clock)
    saver.restore(settings, state, camera)
    path = tmp_path / "session.json"
    for _ in range(100):                          # nothing changes: nothing written
        clock.t += 0.1
        assert not saver.tick(settings, state, camera)
    settings.falloff = 80.0
    assert not saver.tick(settings, state, camera)
    clock.t += 0.9
    assert not saver.tick(settings, state, camera) and not path.exists()
    clock.t += 0.2
    assert saver.tick(settings, state, camera) and json.loads(path.read_text())["settings"]["falloff"] == 80.0
    saves = 0
    for i in range(80):                           # a drag that never stops: saved every 5 s
        camera.yaw = float(i % 90)
        clock.t += 0.1
        saves += saver.tick(settings, state, camera)
    assert saves == 1
    settings.playing = True                       # playback moves the frame each frame: no saves
    saver.tick(settings, state, camera)
    clock.t += 2
    saver.tick(settings, state, camera)
    for _ in range(50):
        settings.frame += 0.5
        clock.t += 0.1
        assert not saver.tick(settings, state, camera)


def test_fresh_keeps_the_previous_session_until_something_changes(tmp_path):
    path = tmp_path / "session.json"
    path.write_text('{"version": 1, "settings": {"falloff": 70}}')
    settings, state, camera = fresh_viewer()
    saver = sess.Autosave(tmp_path, fresh=True)
    saver.restore(settings, state, camera)
    assert settings.falloff == 90.0
    saver.close(settings, state, camera)          # unchanged: the old file is untouched
    assert json.loads(path.read_text())["settings"]["falloff"] == 70
    settings.falloff = 100.0
    saver.tick(settings, state, camera)
    saver.close(settings, state, camera)
    kept = list(tmp_path.glob("session.before-fresh-*.json"))
    assert len(kept) == 1 and json.loads(kept[0].read_text())["settings"]["falloff"] == 70
    assert json.loads(path.read_text())["settings"]["falloff"] == 100.0


def test_which_runs_have_a_session(monkeypatch, tmp_path):
    monkeypatch.delenv(sess.DATA_DIR_ENV, raising=False)
    assert sess.autosave_for(False, False, False, None) is not None      # a window
    assert sess.autosave_for(True, False, False, None) is None           # headless
    assert sess.autosave_for(False, True, False, None) is None           # scripted benchmark
    assert sess.autosave_for(True, True, False, True) is not None        # --session
    assert sess.autosave_for(False, False, False, False) is None         # --no-session
    monkeypatch.setenv(sess.DATA_DIR_ENV, str(tmp_path))
    saver = sess.autosave_for(True, True, True, None)
    assert saver.path == tmp_path / "session.json" and saver.fresh


# ------------------------------------------------------------------ kill -9
def test_a_killed_viewer_loses_no_autosaved_take(tmp_path):
    """A headless viewer draws three PC-pad paths and keeps running; once the autosave has them,
    SIGKILL; a new viewer restores the three."""
    script = tmp_path / "draw.json"
    script.write_text(json.dumps(draws(5, ([0, 0], [1.5, -1.0]), ([-1, 1], [1.0, 1.0]), ([0.5, -1], [-1.0, 0.5]))))
    env = dict(os.environ, HITPOINT_DATA_DIR=str(tmp_path), PYOPENGL_PLATFORM="egl")
    exe = Path(sys.executable).with_name("hitpoint")
    proc = subprocess.Popen([str(exe), "view", "--headless", "--size", "640", "400", "--script", str(script),
                             "--frames", "30000"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    path, takes = tmp_path / "session.json", []
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if path.exists():
                takes = [t for shot in json.loads(path.read_text())["pc_pad"]["takes"].values() for t in shot]
                if len(takes) == 3:
                    break
            time.sleep(0.2)
        assert proc.poll() is None, proc.stderr.read().decode()[-2000:]
        assert len(takes) == 3
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    from app.viewer.loop import App
    app = App((640, 400), headless=True, session=sess.Autosave(tmp_path))
    try:
        restored = [t for shot in app.state.pc_pad.takes.values() for t in shot]
        assert len(restored) == 3 and all(t.kind == "drawn" for t in restored)
        assert [t.points.tolist() for t in restored] == [t["points"] for t in takes]
        assert app.state.errors == 0 and not app.state.messages, app.state.messages
    finally:
        app.close()


# ------------------------------------------------------------------ captures never overwrite
def test_captures_in_one_second_get_their_own_names(tmp_path):
    image = np.zeros((4, 6, 3), np.uint8)
    pngs = {capture.write_new_png(image, tmp_path) for _ in range(5)}
    bvhs = {capture.write_new(tmp_path, "hitpoint_synth_x_", ".bvh", lambda p: p.write_text("x")) for _ in range(3)}
    dirs = {capture.new_export_dir(tmp_path) for _ in range(3)}
    assert len(pngs) == 5 and len(bvhs) == 3 and len(dirs) == 3
    assert all(p.stat().st_size > 0 for p in pngs | bvhs) and all(d.is_dir() for d in dirs)

    def fail(path):
        raise OSError(28, "No space left on device")
    before = set(tmp_path.iterdir())
    with pytest.raises(OSError):
        capture.write_new(tmp_path, "hitpoint_", ".png", fail)
    for d in dirs:
        capture.release(d)
    assert set(tmp_path.iterdir()) == before - dirs       # the claimed names were given back
    assert capture.safe_stem("a/b c..d") == "a_b_c__d"


def test_an_unreadable_session_is_left_alone_and_never_overwritten(tmp_path, monkeypatch):
    path = tmp_path / "session.json"
    path.write_text('{"version": 1}')

    def unreadable(_path):
        raise PermissionError(13, "Permission denied", str(_path))
    monkeypatch.setattr(sess, "read", unreadable)
    saver, settings, state, camera = _restore(tmp_path)
    assert "cannot read" in state.messages[0][1] and not saver.enabled
    settings.falloff = 100.0
    saver.tick(settings, state, camera)
    saver.close(settings, state, camera)
    assert path.read_text() == '{"version": 1}' and len(list(tmp_path.iterdir())) == 1
