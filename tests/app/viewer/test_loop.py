"""The viewer, headless (standalone EGL context; same loop, UI and input code
as the window): the default scene's pixels, dragging the target through the
mouse path, scrubbing, keys, capture, errors, and the panel never covering
the 3D view."""
import numpy as np
import pytest


pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

SIZE = (1280, 720)


@pytest.fixture(scope="module")
def app():
    from app.viewer.loop import App
    a = App(SIZE, headless=True)
    for _ in range(3):
        a.frame(dt=1 / 60)
    yield a
    a.close()


def run(app, frames=1, player=None, start=0):
    for i in range(frames):
        if player is not None:
            player.apply(app, start + i)
        app.frame(dt=1 / 60)


def render_view(app, edit=None):
    """Render the current SceneView (optionally edited) offscreen at the viewport's size."""
    from app.viewer.capture import read_rgb
    from app.render.submit import build_scene_view
    size = tuple(app.state.viewport[2:])
    fbo = app.ctx.framebuffer([app.ctx.texture(size, 4)], app.ctx.depth_renderbuffer(size))
    try:
        view = build_scene_view(app.state, app.settings, app.camera, size)
        if edit is not None:
            edit(view)
        app.scene_renderer.render(view, fbo=fbo)
        return read_rgb(fbo).astype(int)
    finally:
        fbo.release()


def changed(a, b, threshold=30):
    return np.abs(a - b).sum(axis=-1) > threshold


def pixel(app, world):
    return app.interaction.world_to_pixel(np.asarray(world, float))


def near(mask, px, radius):
    """Does ``mask`` have changed pixels within ``radius`` of pixel ``px``?"""
    x, y = int(round(px[0])), int(round(px[1]))
    h, w = mask.shape
    return mask[max(y - radius, 0):min(y + radius + 1, h), max(x - radius, 0):min(x + radius + 1, w)].any()


def test_pieces_are_real(app):
    assert app.scene_renderer is not None, app.state.status
    assert app.state.shots and app.state.adaptation is not None, app.state.messages
    assert app.state.status.get("renderer") == "ok"


def test_default_scene_has_batsman_ball_pitch_and_panel(app):
    from app.viewer.loop import layout
    app.settings.overlays.ghost = "off"
    app.scrub(app.state.shot.hit_frame - 1)
    run(app, 2)
    assert app.state.errors == 0, app.state.messages
    base = render_view(app)
    vx, vy, vw, vh = app.state.viewport
    # batsman: moving him far away changes pixels around his chest and hips
    def away(view):
        view.skin_matrices = view.skin_matrices.copy()
        view.skin_matrices[:, 0, 3] += 1e5
    gone = changed(base, render_view(app, away))
    pos = app.state.pose.global_positions
    names = app.state.rig.skeleton.names
    for joint in ("Spine1", "Hips", "Head"):
        assert near(gone, pixel(app, pos[names.index(joint)]), 6), joint
    assert 0.005 < gone.mean() < 0.5
    # ball: hiding it changes pixels where it projects
    ball = app.state.ball_position
    no_ball = changed(base, render_view(app, lambda v: setattr(v, "ball_position", None)))
    assert near(no_ball, pixel(app, ball), 4)
    # pitch: hiding it changes the ground beside the stumps; the strip is
    # lighter than the grass well off it (sampled where nothing stands: at (300, 0, -200) the
    # anatomical grip's back-foot defence holds its blade)
    no_pitch = changed(base, render_view(app, lambda v: setattr(v, "show_pitch", False)))
    strip, grass = pixel(app, (-100.0, 0.0, 0.0)), pixel(app, (600.0, 0.0, -100.0))
    for p in (strip, grass):
        assert vx <= p[0] < vx + vw and vy <= p[1] < vy + vh, p
    assert near(no_pitch, strip, 3)
    sx, sy = np.round(strip).astype(int)
    gx, gy = np.round(grass).astype(int)
    assert base[sy, sx].sum() > base[gy, gx].sum() + 60, (base[sy, sx], base[gy, gx])
    # the composed frame: panel on the right, the scene left of it, the timeline
    # below the scene; neither covers any of it
    shot = app.screenshot()
    rects = layout(SIZE)
    px, py, pw, ph = rects["panel"]
    tx, ty, tw, th = rects["timeline"]
    assert vx + vw <= px and ty == vy + vh and ty + th == SIZE[1] and tw == vw
    panel = shot[:, px + 2:].astype(int)
    assert panel.std() > 10                       # text and widgets drawn
    scene_part = shot[vy:vy + vh, vx:vx + vw].astype(int)
    # the whole scene shows, unscaled, uncovered (drawn 46 px up, the rasteriser's
    # sub-pixel snapping moves a few silhouette pixels: at most 1 in 1000 differ)
    assert (np.abs(scene_part - base).max(-1) > 2).mean() < 1e-3
    assert shot[ty:, tx:tx + tw].std() > 5        # the timeline drawn below it
    app.settings.overlays.ghost = "mesh"


def test_scripted_drag_moves_the_adapted_bat(app):
    from app.viewer.script import ScriptPlayer
    from app.viewer.update import choose
    start = np.asarray(app.settings.target, float).copy()
    goal = start + np.array([-25.0, 18.0, 0.0])
    player = ScriptPlayer([{"type": "drag_target", "frame": 0, "to": goal.tolist(), "frames": 12}])
    run(app, player.last_frame + 2, player)
    s = app.state
    assert np.allclose(app.settings.target, goal, atol=0.5), (app.settings.target, goal)
    assert not s.dragging_target
    index, desired = choose(s, app.settings)
    assert index == s.shot_index and np.allclose(desired, s.desired_hit_point)
    bat = s.adaptation.global_positions[s.shot.hit_frame, s.rig.bat_joint]
    assert np.linalg.norm(bat - desired) <= max(s.adaptation.bat_error_cm, 0) + 1e-6
    assert s.adaptation.bat_error_cm < 1.0
    # the desired point moved with the ball path
    app.settings.target = start
    run(app, 1)
    assert not np.allclose(s.desired_hit_point, desired)


def test_drag_starts_only_on_the_target_and_shows_a_hand(app):
    it = app.interaction
    px = it.target_pixel()
    it.mouse_move(*px)
    run(app, 1)
    assert app.state.hover_target and app.state.cursor == "hand"
    it.mouse_move(px[0] + 200, px[1] + 150)       # empty space: orbit, target stays
    run(app, 1)
    assert not app.state.hover_target
    before_t, before_yaw = app.settings.target.copy(), app.camera.yaw
    it.mouse_button(0, True)
    it.mouse_move(px[0] + 260, px[1] + 150)
    it.mouse_button(0, False)
    run(app, 1)
    assert np.allclose(app.settings.target, before_t) and app.camera.yaw != before_yaw
    app.camera.reset()
    run(app, 1)


def click_timeline(app, frame: int, frames: int) -> None:
    """Click the timeline's track at ``frame`` of a track of ``frames`` frames."""
    from app.ui.timeline import track_span, track_x
    from app.viewer.loop import layout
    rect = layout(SIZE)["timeline"]
    x0, x1 = track_span(rect)
    app.interaction.mouse_move(track_x(frame, x0, x1, frames), rect[1] + rect[3] / 2)
    run(app, 1)
    app.interaction.mouse_button(0, True)
    run(app, 1)
    app.interaction.mouse_button(0, False)
    run(app, 1)


def test_scrubbing_changes_the_frame_shown(app):
    app.scrub(0)
    run(app, 2)
    first = app.screenshot().copy()
    pose0 = app.state.pose.global_positions.copy()
    hit = app.state.shot.hit_frame
    click_timeline(app, hit, app.state.num_frames)
    assert app.settings.frame == hit
    assert not np.allclose(app.state.pose.global_positions, pose0)
    assert changed(first.astype(int), app.screenshot().astype(int)).sum() > 200


def test_the_timeline_follows_a_playing_take_and_scrubs_it(app):
    """While a PC-pad take is shown the timeline is the take's: its handle follows the take's
    frame, a click on the track shows that frame of the take (paused) and leaves the adapted
    shot's frame alone; back to the shot, the track is the shot's again."""
    from app.viewer import padrequests, pcpad
    app.requests.pad.append(padrequests.check_request("preset", "exaggerated"))
    run(app, 3)
    take = pcpad.take_timeline(app.state)
    assert take is not None and take.playing and take.frame > 0
    assert take.hit_frame == app.state.pc_pad.impact.hit_frame
    shot_frame = app.settings.frame
    click_timeline(app, take.hit_frame, take.frames)
    take = pcpad.take_timeline(app.state)
    assert not take.playing and take.frame == pytest.approx(take.hit_frame)
    pad = app.state.pc_pad
    assert np.allclose(app.state.pose.global_positions, pad.anim_global[1][take.hit_frame])
    assert app.settings.frame == shot_frame
    app.requests.pad.append(padrequests.check_request("back"))
    run(app, 1)
    assert pcpad.take_timeline(app.state) is None


def test_keys_drive_playback(app):
    from app.viewer.interaction import KEY_NAMES
    it, s = app.interaction, app.settings

    def press(name):
        it.key(KEY_NAMES[name], True)
        it.key(KEY_NAMES[name], False)
    press("h")
    assert s.frame == app.state.shot.hit_frame and not s.playing
    press("right")
    assert s.frame == app.state.shot.hit_frame + 1
    press("left")
    press("left")
    assert s.frame == app.state.shot.hit_frame - 1
    speed = s.speed
    press("]")
    assert s.speed > speed
    press("[")
    assert abs(s.speed - speed) < 1e-9
    press("s")
    assert s.slow_motion
    press("s")
    press("space")
    assert s.playing
    run(app, 3)
    assert s.frame != app.state.shot.hit_frame - 1
    press("space")


def test_engine_error_keeps_last_good_state(app, monkeypatch):
    s = app.state
    good = s.adaptation
    adapter = s.adapters[s.shot_index]

    def boom(*a, **k):
        raise RuntimeError("solver exploded")
    monkeypatch.setattr(adapter, "adapt", boom)
    app.settings.falloff = 123.0
    run(app, 2)
    assert s.adaptation is good
    assert "solver exploded" in s.messages[-1][1]
    monkeypatch.undo()
    app.settings.falloff = 90.0
    run(app, 1)
    assert s.adaptation is not good


def test_bad_library_file_is_reported_not_fatal(app, tmp_path):
    from app.viewer.update import load_library
    bad = tmp_path / "library.json"
    bad.write_text("[{\"name\": \"x\", \"file\": \"missing.bvh\", \"hit_frame\": 3}]")
    shots = app.state.shots
    assert not load_library(app.state, bad)
    assert app.state.shots is shots
    assert "library" in app.state.messages[-1][1]
    run(app, 1)
    assert app.state.status["library"] == "ok"
    app.requests.reload = True                    # the panel's "Reload shots" button
    run(app, 1)
    assert app.state.shots is not shots and len(app.state.shots) == len(shots)
    assert app.state.adaptation is not None


def test_ball_meets_the_bat_at_the_hit_frame(app):
    s = app.state
    app.scrub(s.shot.hit_frame)
    run(app, 1)
    bat = s.pose.global_positions[s.rig.bat_joint]
    assert np.allclose(s.ball_position, s.desired_hit_point, atol=1e-6)
    assert np.linalg.norm(bat - s.ball_position) <= s.adaptation.bat_error_cm + 1e-6
    before = s.ball_position.copy()
    app.scrub(s.shot.hit_frame - 2)
    run(app, 1)
    incoming = s.ball_position.copy()
    app.scrub(s.shot.hit_frame + 2)
    run(app, 1)
    after = s.ball_position.copy()
    assert not np.allclose(incoming, before) and not np.allclose(after, before)
    # moving toward the batsman from the bowler's end before, away after
    assert incoming[2] > before[2]


def test_watching_the_hit_frame_follows_a_shot_switch(app):
    """At a shot's hit frame, dragging the target onto another shot's ball line moves
    the view to the new shot's hit frame, where bat and ball meet again."""
    from app.viewer.update import default_target
    s = app.state
    names = [shot.name for shot in s.shots]
    a, b = names.index("back_foot_defence"), names.index("square_cut")
    assert s.shots[a].hit_frame != s.shots[b].hit_frame
    app.settings.target = default_target(s, a)
    run(app, 1)
    assert s.shot_index == a
    app.scrub(s.shot.hit_frame)
    run(app, 1)
    app.settings.target = default_target(s, b)
    run(app, 1)
    assert s.shot_index == b and app.settings.frame == s.shots[b].hit_frame
    bat = s.pose.global_positions[s.rig.bat_joint]
    assert np.linalg.norm(bat - s.ball_position) <= s.adaptation.bat_error_cm + 1e-6
    # away from the hit frame the frame shown stays where it was
    app.scrub(5)
    app.settings.target = default_target(s, a)
    run(app, 1)
    assert s.shot_index == a and app.settings.frame == 5


def test_f12_screenshot_and_frame_export(app, tmp_path, monkeypatch):
    from app.viewer.interaction import KEY_NAMES
    monkeypatch.chdir(tmp_path)
    app.interaction.key(KEY_NAMES["f12"], True)
    app.interaction.key(KEY_NAMES["f12"], False)
    run(app, 1)
    pngs = list(tmp_path.glob("hitpoint_*.png"))
    assert len(pngs) == 1
    from PIL import Image
    assert Image.open(pngs[0]).size == SIZE
    out = tmp_path / "export"
    frame, errors = app.settings.frame, app.state.errors
    app.request_export(out)
    run(app, 1)
    assert app.state.export_progress is not None       # spread over frames: the window stays live
    app.finish_exports()
    assert app.state.export_progress is None
    frames = sorted(out.glob("frame_*.png"))
    assert len(frames) == app.state.num_frames
    first, hit = (np.asarray(Image.open(frames[i]), int) for i in (0, app.state.shot.hit_frame))
    assert first.shape[:2] == (app.state.viewport[3], app.state.viewport[2])
    assert changed(first, hit).sum() > 200
    assert app.settings.frame == frame and app.state.errors == errors, app.state.messages


def test_scripted_pc_pad_drag_drives_the_pose(app):
    from app.viewer.script import ScriptPlayer
    run(app, 1)
    adapted = app.state.pose.global_positions.copy()
    player = ScriptPlayer([{"type": "pcpad_drag", "frame": 0, "from": [0, 0], "to": [1.5, -1.0], "frames": 5}])
    run(app, player.last_frame + 1, player)
    assert app.state.pose_source == "pc pad"
    assert not np.allclose(app.state.pose.global_positions, adapted)
    assert np.isfinite(app.state.pose.global_positions).all()
    back = ScriptPlayer([{"type": "pcpad", "frame": 0, "action": "back"}])
    run(app, 1, back)
    assert app.state.pose_source == "adapted"


def test_every_pc_pad_action_can_be_scripted(app, tmp_path, monkeypatch):
    """What the pad's widget does, a script does through the same requests: presets, the
    amount, a drawn take, the take list, play/pause, the BVH export, back to the shot."""
    from app.viewer.script import ScriptPlayer
    from app.viewer.update import default_target
    monkeypatch.chdir(tmp_path)
    app.settings.target = default_target(app.state)
    run(app, 2)
    pad, name, errors = app.state.pc_pad, app.state.shot.name, app.state.errors
    pad.takes.pop(name, None)

    def script(*events):
        player = ScriptPlayer([{"frame": i, **e} for i, e in enumerate(events)])
        run(app, player.last_frame + 1, player)
    script({"type": "pcpad", "action": "fix_hand", "value": False},
           {"type": "pcpad", "action": "plant_feet", "value": False},
           {"type": "pcpad", "action": "preset", "value": "aborted"})
    assert [t.kind for t in pad.takes[name]] == ["aborted"] and pad.playing
    assert app.state.pose_source == "pc pad"
    script({"type": "pcpad", "action": "amount", "value": 0.7}, {"type": "pcpad", "action": "remake_preset"})
    assert [(t.kind, t.amount) for t in pad.takes[name]] == [("aborted", 0.7)]
    script({"type": "pcpad_draw", "from": [0, 0], "to": [1.0, 0.5], "frames": 6})
    assert pad.mode == "draw" and [t.kind for t in pad.takes[name]] == ["aborted", "drawn"]
    script({"type": "pcpad", "action": "take", "value": 0}, {"type": "pcpad", "action": "play"})
    assert pad.take == 0 and pad.path_kind == "aborted" and not pad.playing
    script({"type": "pcpad", "action": "export"})
    assert len(list(tmp_path.glob("hitpoint_synth_*.bvh"))) == 1 and pad.info.startswith("wrote")
    script({"type": "pcpad", "action": "forget"}, {"type": "pcpad", "action": "mode", "value": "pose"})
    assert [t.kind for t in pad.takes[name]] == ["drawn"] and pad.mode == "pose"
    script({"type": "pcpad", "action": "back"})
    assert app.state.pose_source == "adapted" and app.state.errors == errors, app.state.messages
    pad.fix_hand = pad.plant_feet = True


@pytest.mark.parametrize("event", [{"action": "warp"}, {"action": "preset", "value": "huge"},
                                   {"action": "take", "value": -1}, {"action": "amount", "value": 2},
                                   {"action": "loop", "value": "yes"}, {"action": "mode", "value": "paint"}])
def test_a_bad_pc_pad_action_fails_when_the_script_loads(event):
    from app.errors import UserError
    from app.viewer.script import ScriptPlayer
    with pytest.raises(UserError, match="pcpad"):
        ScriptPlayer([{"type": "pcpad", "frame": 0, **event}])


def test_idle_frames_draw_the_scene_exactly_where_it_was_drawn(app):
    """The scene is drawn above the timeline (at an offset in the frame); idle frames
    draw it again in the same place, ghost included, pixel for pixel."""
    app.settings.overlays.ghost = "mesh"
    app.scrub(app.state.shot.hit_frame)
    run(app, 2)
    app.finish_frame()
    drawn = app.screenshot().copy()
    run(app, 3)                       # unchanged
    app.finish_frame()
    assert app.compositor.scene_origin[1] > 0              # and the view does sit above the timeline
    vx, vy, vw, vh = app.state.viewport
    scene = app.screenshot()[vy:vy + vh, vx:vx + vw].astype(int)
    np.testing.assert_array_equal(scene, drawn[vy:vy + vh, vx:vx + vw])   # (the panel's readouts tick)
    assert (np.abs(scene - render_view(app)).max(-1) > 2).mean() < 1e-3   # ghost composited in place


def test_without_region_copies_the_scene_still_lands_above_the_timeline(app, monkeypatch):
    """Where GL cannot copy framebuffer regions, the scene goes through its own
    framebuffer and is stretched into place: the same picture."""
    import app.render.compose as compose
    monkeypatch.setattr(compose, "can_copy_regions", lambda: False)
    app.settings.overlays.ghost = "mesh"
    run(app, 2)
    app.finish_frame()
    assert not app.compositor.direct
    vx, vy, vw, vh = app.state.viewport
    scene = app.screenshot()[vy:vy + vh, vx:vx + vw].astype(int)
    assert (np.abs(scene - render_view(app)).max(-1) > 2).mean() < 1e-3
    monkeypatch.undo()
    run(app, 1)
    assert app.compositor.direct


def test_timing_readouts_are_quarter_second_means():
    from app.viewer.state import TIMING_PERIOD_S, TimingDisplay
    t = TimingDisplay()
    t.add(0.0, frame=10.0)
    assert t.shown == {"frame": 10.0}            # something to show from the first frame
    for k in range(1, 10):                        # within one period the shown value holds still
        t.add(k * TIMING_PERIOD_S / 10, frame=20.0 + k)
        assert t.shown == {"frame": 10.0}
    t.add(TIMING_PERIOD_S, frame=30.0)           # then it is the mean of the period's frames
    assert t.shown["frame"] == pytest.approx(np.mean([20.0 + k for k in range(1, 10)] + [30.0]))


def test_startup_objects_are_frozen_out_of_full_collections(app):
    """The objects made while starting live as long as the window: a full garbage
    collection (a ~120 ms stall mid-drag) must not walk them."""
    import gc
    assert gc.get_freeze_count() > 10_000


def test_the_first_solve_is_solved_again_for_the_readout():
    """The first solve (building the shot's adapter) is solved once more: the panel's solve
    readout is a re-solve's, and the next frame does not solve again."""
    from app.viewer.settings import ViewerSettings
    from app.viewer.state import AppState
    from app.viewer.update import default_target, load_library, update
    state, settings = AppState(), ViewerSettings()
    assert load_library(state, None)
    settings.target = default_target(state)
    update(state, settings, 1 / 60)
    assert state.solve_count == 2 and state.adaptation is not None
    update(state, settings, 1 / 60)
    assert state.solve_count == 2 and state.errors == 0


def test_f12_is_a_request_taken_once_not_a_setting(app, tmp_path, monkeypatch):
    """F12 asks for one screenshot: the loop takes the request in that frame (one new PNG in
    the working folder), nothing of it is left in the settings or for the next frame."""
    import dataclasses
    import glfw
    monkeypatch.chdir(tmp_path)
    app.interaction.key(glfw.KEY_F12, True, 0)
    assert app.requests.screenshot
    run(app, 2)
    assert len(list(tmp_path.glob("*.png"))) == 1 and not app.requests.screenshot
    assert all("request" not in f.name for f in dataclasses.fields(app.settings))


def test_a_script_reloads_the_library_like_the_panel_button(app):
    from app.viewer.script import ScriptPlayer
    shots = app.state.shots
    run(app, 2, ScriptPlayer([{"type": "reload", "frame": 0}]))
    assert app.state.shots is not shots and [s.name for s in app.state.shots] == [s.name for s in shots]
