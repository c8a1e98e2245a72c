"""The PC-score pad: logic without imgui, and the widget through a headless imgui frame."""
import numpy as np
import pytest

from app.ui import padwidget

from app.viewer import padrequests, pcpad
from app.viewer.state import AppState
from engine import quat
from engine.library import Shot
from engine.skeleton import clip_fk
from tests.motion_kit import smooth_random_clip


@pytest.fixture()
def state(rig):
    st = AppState()
    st.rig = rig
    shots = []
    for i in range(2):
        c = smooth_random_clip(rig, 60, seed=60 + i)
        shots.append(Shot(f"syn{i}", f"s{i}.bvh", 35, "", rig.skeleton, c, rig.bat_joint))
    st.shots, st.shot_index = shots, 0
    return st


def test_marker_sets_the_pose_of_those_scores(state, rig):
    """The marker's pose is the two scores' with the source's detail (engine.synth_detail.source_detail),
    or without it the two PCs alone; on the guide, with the detail, it is the shot's own pose."""
    from engine import synth_detail
    from engine.skeleton import Clip
    pcpad.set_scores(state, [1.0, -0.5])
    pad = state.pc_pad
    pose = pcpad.active_pose(state)
    assert pad.live and pose is not None
    s = np.array([1.0, -0.5])
    full = np.concatenate([s, synth_detail.source_detail(pad.pca, s[None], "nearest")[0]])
    for scores in (full, s):
        pose = pcpad.active_pose(state)
        root, local = pad.pca.pose_from_scores(scores)
        g_rot, g_pos = clip_fk(rig.skeleton, Clip(root[None], local[None]))
        assert np.allclose(pose.global_positions, g_pos[0], atol=1e-9)
        assert np.all(quat.angle_between(pose.global_rotations, g_rot[0]) < 1e-5)
        pad.detail = False
        pcpad.set_scores(state, s)
    pad.detail = True
    pcpad.set_scores(state, pad.guide[20])
    shot_pos = state.shot.fk[1][20]
    assert np.linalg.norm(pcpad.active_pose(state).global_positions - shot_pos, axis=-1).max() < 1.0
    pcpad.release(state)
    assert pcpad.active_pose(state) is None


def test_the_source_detail_box_remakes_the_take_shown(state, rig):
    """Unticking "source detail" with a take shown makes it again with the first two PCs alone
    (another take: both stay, to compare); ticking it again shows the first one."""
    pcpad.apply_preset(state, "exaggerated", 0.4)
    pad = state.pc_pad
    first = pcpad.shown_take(state)
    assert first.detail
    padrequests.step(state, [padrequests.check_request("detail", False)], 0.0)
    second = pcpad.shown_take(state)
    assert second is not first and not second.detail and second.kind == first.kind
    assert not np.allclose(second.anim.local_rotations, first.anim.local_rotations)
    padrequests.step(state, [padrequests.check_request("detail", True)], 0.0)
    assert pcpad.shown_take(state) is first and len(pad.shot_takes(state.shot.name)) == 2


def test_the_panel_reads_the_take_s_errors_while_it_is_shown(state, rig):
    """The readouts' bat and grip errors, and the time, are the take's while it is shown (the
    adapted shot's solve is not what the viewport shows), the adapted shot's again after."""
    from app.ui.panel import _error_rows, _solver_row
    from app.viewer.settings import ViewerSettings
    settings = ViewerSettings()
    pcpad.apply_preset(state, "exaggerated", 0.4)
    rows = dict(_error_rows(state))
    assert float(rows["take's bat error"].split()[0]) < 0.01
    assert "take's grip (max)" in rows and "bat error at hit frame" not in rows
    label, value = _solver_row(settings, state)
    assert label == "take made in" and float(value.split()[0]) > 0.0
    pcpad.release(state)
    state.pc_pad.anim = None
    assert "bat error at hit frame" in dict(_error_rows(state))
    assert _solver_row(settings, state)[0] == settings.solver


def test_an_aborted_take_leaves_the_ball(state, rig):
    """An aborted take (leaving the path before the hit, dissertation 3.2.3) plays no ball: the
    ball passes the shot's hit point untouched and goes on toward the keeper; the panel says the
    shot is left and names no face, edge or back."""
    from app.ui.panel import _impact_rows
    pcpad.apply_preset(state, "aborted", 0.5)
    pad = state.pc_pad
    imp = pad.impact
    assert imp.readouts.contact == "none" and "leaves the ball" in pad.info
    assert np.allclose(imp.hit_point, state.shot.hit_point)
    assert abs(imp.readouts.ball_azimuth_deg) > 150.0                 # on past the stumps
    g_pos = pad.anim_global[1]
    assert np.linalg.norm(g_pos[imp.hit_frame, rig.bat_joint] - state.shot.hit_point) > 5.0  # the bat is not there
    rows = dict(_impact_rows(imp.readouts))
    assert rows["ball meets bat"].startswith("none") and "face vs source" not in rows


def test_draw_mode_records_a_timed_animation(state):
    pad = pcpad.sync(state)
    pad.mode = "draw"
    pad.fix_hand = pad.plant_feet = False
    for i in range(16):
        pcpad.advance(pad, 1 / 30)
        pcpad.set_scores(state, [np.cos(i / 5), np.sin(i / 5)], final=(i == 15))
    assert pad.anim is not None and pad.playing and pad.path_kind == "drawn"
    assert pad.anim.num_frames == 16                  # 15 frame intervals of drawing at 30 fps
    assert np.allclose(pad.path[0], [1, 0]) and pcpad.active_pose(state) is not None


def test_a_stroke_longer_than_a_take_is_stretched_not_lost(state):
    """A stroke held past the engine's take length is kept (stretched over the shot),
    with a message, instead of failing inside the panel."""
    from engine import synth
    pad = pcpad.sync(state)
    pad.mode = "draw"
    pad.fix_hand = pad.plant_feet = False
    for i in range(5):
        pcpad.advance(pad, synth.MAX_PATH_SECONDS / 3)
        pcpad.set_scores(state, [np.cos(i), np.sin(i)], final=(i == 4))
    assert pad.anim is not None and pad.anim.num_frames == state.shot.num_frames
    assert any("stretched" in m for _, m in state.messages)


def test_presets_and_shot_change(state):
    pcpad.apply_preset(state, "toned_down", 0.5)
    pad = state.pc_pad
    assert pad.anim.num_frames == 60 and pad.path_kind == "toned_down"
    pcpad.advance(pad, 0.5)
    assert pad.pose is not None and np.allclose(pad.marker, pad.path[15])
    state.shot_index = 1
    assert pcpad.active_pose(state) is None          # the pose belonged to the other shot
    pcpad.sync(state)
    assert pad.anim is None and pad.shot_key[1] == "syn1"
    with pytest.raises(ValueError):
        pcpad.set_scores(state, [np.nan, 0])


def test_widget_draws_headless_and_drags(state):
    from imgui_bundle import imgui, implot
    ctx = imgui.create_context()
    pctx = implot.create_context()
    try:
        io = imgui.get_io()
        io.set_ini_filename("")
        io.display_size = imgui.ImVec2(800, 900)
        io.delta_time = 1 / 30
        io.backend_flags |= imgui.BackendFlags_.renderer_has_textures

        def frame(pos, down):
            io.add_mouse_pos_event(*pos)
            io.add_mouse_button_event(0, down)
            imgui.new_frame()
            imgui.set_next_window_pos(imgui.ImVec2(0, 0))
            imgui.set_next_window_size(imgui.ImVec2(360, 880))
            imgui.begin("panel")
            requests = []
            padwidget.draw_pc_pad(state, requests)
            imgui.end()
            imgui.render()
            padrequests.step(state, requests, io.delta_time)     # what the update does with them
            return requests

        for _ in range(3):
            frame((5, 5), False)
        asked = [frame((150 + 3 * i, 200 + 2 * i), True) for i in range(4)]
        frame((160, 210), False)
        assert any(r.action == "marker" for frame_asked in asked for r in frame_asked)
        assert state.pc_pad.live and pcpad.active_pose(state) is not None
        assert state.errors == 0
    finally:
        implot.destroy_context(pctx)
        imgui.destroy_context(ctx)


def test_a_playing_take_shows_the_ball_its_own_bat_meets(state, rig):
    """While a take plays, the viewport's ball, flight and impact readouts are the take's
    (app.takeball): the ball reaches the take's bat at the take's hit frame and leaves along
    its flight; the live marker's still pose shows no ball; back to the shot, the adapted
    shot's come back."""
    from app.viewer import update
    pcpad.apply_preset(state, "exaggerated", 0.4)
    pad = state.pc_pad
    imp = pad.impact
    assert imp is not None and imp.hit_frame == state.shot.hit_frame
    g_rot, g_pos = pad.anim_global
    assert np.allclose(imp.hit_point, g_pos[imp.hit_frame, rig.bat_joint])
    assert np.linalg.norm(imp.hit_point - state.shot.hit_point) < 0.01   # where the shot meets it
    assert imp.readouts.face_angle_deg < 5.0                          # with the source's face (a random clip's:
    assert np.isfinite(imp.readouts.ball_azimuth_deg)                  # the bundled shots' meet with the face)
    assert "bat brought" in pad.info
    pad.play_time = (imp.hit_frame - 0.2) / pad.anim.fps
    pcpad.advance(pad, 0.0)
    assert np.allclose(pad.ball, imp.hit_point, atol=1e-6)             # the ball at the bat at the hit
    ball, flight, readouts = pcpad.active_ball(state)
    assert ball is pad.ball and flight is imp.flight.path and readouts is imp.readouts
    pcpad.advance(pad, 5.0 / pad.anim.fps)                            # five frames on: in flight
    assert np.linalg.norm(pad.ball - imp.hit_point) > 1.0
    state.readouts.contact = "adapted"
    update.pad_pose(state)
    assert state.pose_source == "pc pad" and state.shown_impact is imp.readouts
    assert np.array_equal(state.ball_position, pad.ball) and state.shown_flight is imp.flight.path
    pcpad.set_scores(state, [0.5, 0.5])                               # the live marker: a pose, no ball
    assert pcpad.active_ball(state) == (None, None, None)
    pcpad.release(state)
    assert pcpad.active_pose(state) is None
