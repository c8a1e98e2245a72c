"""The panel's hit readouts (what the ball meets, the face against the source's, where the
ball goes) come from the update, in DESIGN.md's conventions."""
import numpy as np
import pytest

from app.ui.panel import _elevation_row
from app.viewer.settings import ViewerSettings
from app.viewer.state import AppState
from app.viewer.update import default_target, load_library, solve


@pytest.fixture(scope="module")
def state():
    st = AppState()
    assert load_library(st, None)
    return st


@pytest.mark.parametrize("name", ["cover_drive", "forward_defence", "square_cut"])
def test_each_shot_at_its_own_hit_point_keeps_its_face(state, name):
    """Pinned to a shot with the ball through its own FK hit point, the face is the
    source's (0 degrees), and the readouts agree with the flight the scene draws."""
    index = [s.name for s in state.shots].index(name)
    settings = ViewerSettings(pinned_shot=name, target=default_target(state, index))
    assert solve(state, settings)
    r = state.readouts
    assert r.face_angle_deg == pytest.approx(0.0, abs=1e-3)
    assert r.contact in ("face", "edge", "back") and -1.0 <= r.face_to_ball <= 1.0
    assert (r.contact == "face") == (r.face_to_ball >= 0.2)
    first_step = state.flight[1] - state.flight[0]
    azimuth = np.degrees(np.arctan2(-first_step[0], first_step[2]))
    assert abs((azimuth - r.ball_azimuth_deg + 180) % 360 - 180) < 1.0


def test_the_balls_climb_reads_as_a_word_and_a_size():
    """A ball going down off the bat "falls", never "rises -18"."""
    assert _elevation_row(7.1) == ("ball rises", "7 deg")
    assert _elevation_row(-18.4) == ("ball falls", "18 deg")
    assert _elevation_row(0.0) == ("ball rises", "0 deg")


def test_the_panel_twist_choice_reaches_the_engine(state):
    """The viewer's 'arm rolls' choice is a real engine setting: it changes the engine key
    (a re-solve), and with the rolls leading (the face free) the straight drive's hit point
    moved 30 cm to the leg side and 15 up turns the face further from the ball; with them
    following it meets the ball squarer, with the face (the anatomical grip's shots: cosine
    0.67 against 0.99, the face 50 and 8 deg from the source's; leading turned it further
    in all 24 cells of a +-30 cm grid of the straight drive, median 17.5 deg)."""
    from engine import face
    from engine.adapt import Adapter
    from engine.choice import BALL_START
    rig = state.rig
    shot = next(s for s in state.shots if s.name == "straight_drive")
    adapter = Adapter(rig, shot)
    contacts = {}
    for twist in ("follow", "lead"):
        settings = ViewerSettings(pinned_shot="straight_drive", twist=twist, face="free")
        a = adapter.adapt(shot.hit_point + (30.0, 15.0, 0.0), settings.adapt_settings())
        n = face.face_normal(a.global_rotations[shot.hit_frame], rig.bat_joint, rig.bat["face_normal"])
        contacts[twist] = float(face.face_to_ball(n, BALL_START, a.desired_hit_point))
    assert face.contact(contacts["follow"]) == "face" and contacts["lead"] < contacts["follow"] - 0.15
    assert ViewerSettings(twist="follow").engine_key() != ViewerSettings(twist="lead").engine_key()


def test_the_panel_face_choice_reaches_the_engine(state):
    """The viewer's 'bat face' choice is the engine's: kept (the default), the README's
    cover-drive example (30 cm to the off side) meets the ball with the face within 8 degrees
    of the source's; free (position only), it turns further (3.2 and 8.9 deg on the anatomical
    grip's cover drive); the choice changes the engine key."""
    from engine import face
    from engine.adapt import Adapter
    rig = state.rig
    shot = next(s for s in state.shots if s.name == "cover_drive")
    adapter = Adapter(rig, shot)
    angle = {}
    for choice in ("keep", "free"):
        settings = ViewerSettings(pinned_shot="cover_drive", face=choice)
        a = adapter.adapt((-85.0, 36.0, 196.0), settings.adapt_settings())
        angle[choice] = float(face.face_angle_deg(a.global_rotations[shot.hit_frame], shot.fk[0][shot.hit_frame],
                                                  rig.bat_joint, rig.bat["face_normal"]))
    assert ViewerSettings().face == "keep" and angle["keep"] < 8.0 and angle["free"] > angle["keep"] + 4.0
    assert ViewerSettings(face="keep").engine_key() != ViewerSettings(face="free").engine_key()


def test_the_panel_trunk_hold_reaches_the_engine():
    """'hold the trunk' off (the default) leaves the engine's trunk free whatever the slider says;
    on, the slider's reach is the engine's; either changes the engine key; a script's absurd
    reach is clamped into the slider's range."""
    import math
    from app.viewer.settings import TRUNK_REACH_RANGE
    assert ViewerSettings().adapt_settings().trunk_reach == math.inf
    assert ViewerSettings(trunk_reach=5.0).adapt_settings().trunk_reach == math.inf
    held = ViewerSettings(hold_trunk=True, trunk_reach=5.0)
    assert held.adapt_settings().trunk_reach == 5.0
    assert held.engine_key() != ViewerSettings().engine_key()
    assert held.engine_key() != ViewerSettings(hold_trunk=True, trunk_reach=6.0).engine_key()
    wild = ViewerSettings(hold_trunk=True, trunk_reach=float("nan"))
    wild.sanitise()
    assert TRUNK_REACH_RANGE[0] <= wild.trunk_reach <= TRUNK_REACH_RANGE[1]


def test_the_lean_carried_is_the_engine_s_and_re_solves():
    """'lean into the hit' (on by default, as the engine) reaches AdaptSettings.carry_lean and
    changes the engine key."""
    assert ViewerSettings().adapt_settings().carry_lean is True
    off = ViewerSettings(carry_lean=False)
    assert off.adapt_settings().carry_lean is False
    assert off.engine_key() != ViewerSettings().engine_key()


def test_a_direction_asked_on_the_wagon_wheel_is_hit_once_the_target_holds_still(state):
    """Issue 14 item 3 in the viewer: ``aim_direction``/``direction`` (what the wagon wheel
    writes) turn the face only after the target has held still (AIM_SETTLE_S), land within
    a few degrees inside the shot's reach, and dropping the request gives the plain solve."""
    from app.viewer.update import AIM_SETTLE_S, update
    index = [s.name for s in state.shots].index("cover_drive")
    settings = ViewerSettings(pinned_shot="cover_drive", target=default_target(state, index))
    state.solved_key = None
    update(state, settings, 1 / 60)
    plain = state.readouts.ball_azimuth_deg
    source = state.readouts.source_azimuth_deg
    assert plain == pytest.approx(source, abs=0.5) and state.readouts.aim_reached is None
    settings.set("aim_direction", True)
    settings.set("direction", plain + 15.0)
    update(state, settings, AIM_SETTLE_S / 4)          # still settling: nothing aimed yet
    assert state.readouts.aim_reached is None
    for _ in range(5):
        update(state, settings, AIM_SETTLE_S / 2)
    r = state.readouts
    assert r.aim_reached is not None and r.contact == "face"
    lo, hi = r.aim_range_deg
    if lo <= plain + 15.0 <= hi:
        assert r.aim_reached and abs(r.ball_azimuth_deg - (plain + 15.0)) < 3.0
    assert np.linalg.norm(state.adaptation.global_positions[state.shot.hit_frame, state.rig.bat_joint]
                          - state.desired_hit_point) < 0.01
    settings.set("aim_direction", False)
    update(state, settings, 1 / 60)
    assert state.readouts.aim_reached is None and state.readouts.ball_azimuth_deg == pytest.approx(plain, abs=1e-6)
    assert len(state.azimuth_trail) >= 3               # what the wagon wheel draws as the trail


def test_an_elevation_asked_with_the_direction_is_hit_by_the_face_tilt(state):
    """The wagon wheel's 'elevation' (``aim_elevation``/``elevation``, scriptable by ``set``):
    with a direction asked, the ball leaves within a few degrees of both inside the reach
    (the face tilted), the readouts give the elevation's reach; dropping it gives the
    direction alone back (no elevation readout)."""
    from app.viewer.update import AIM_SETTLE_S, update
    index = [s.name for s in state.shots].index("straight_drive")
    settings = ViewerSettings(pinned_shot="straight_drive", target=default_target(state, index))
    state.solved_key = None
    update(state, settings, 1 / 60)
    settings.set("aim_direction", True)
    settings.set("direction", 10.0)
    settings.set("aim_elevation", True)
    settings.set("elevation", 5.0)
    for _ in range(5):
        update(state, settings, AIM_SETTLE_S / 2)
    r = state.readouts
    lo, hi = r.aim_elevation_range_deg
    assert lo < 5.0 < hi and r.aim_elevation_reached and r.aim_reached and r.contact == "face"
    assert abs(r.ball_elevation_deg - 5.0) < 3.0 and abs(r.ball_azimuth_deg - 10.0) < 3.0
    settings.set("aim_elevation", False)
    for _ in range(2):
        update(state, settings, AIM_SETTLE_S / 2)
    assert state.readouts.aim_elevation_reached is None and state.readouts.aim_reached


def test_a_fielding_position_asks_for_its_direction(state):
    """"Cover drive, hit it to mid-off": a script's ``set direction "mid-off"`` (or the
    wagon wheel's picker) asks for the position's azimuth and the ball goes there, with no
    ``aim_direction`` needed first (as the CLI's --direction); ``aim_direction`` false drops
    it; a name that is no position is refused with the names, before the run."""
    from app.errors import UserError
    from app.ui.wagonwheel import position_named
    from app.viewer.update import AIM_SETTLE_S, update
    from engine import field
    index = [s.name for s in state.shots].index("cover_drive")
    settings = ViewerSettings(pinned_shot="cover_drive", target=default_target(state, index))
    assert position_named(settings) == "as the shot goes"
    settings.set("direction", "Mid Off")
    assert settings.aim_direction and not settings.aim_elevation
    assert settings.direction == field.POSITIONS["mid-off"] and position_named(settings) == "mid-off"
    state.solved_key = None
    for _ in range(5):
        update(state, settings, AIM_SETTLE_S / 2)
    r = state.readouts
    assert r.aim_reached and r.contact == "face" and abs(r.ball_azimuth_deg - field.POSITIONS["mid-off"]) < 3.0
    assert field.region(r.ball_azimuth_deg) == "mid-off"
    settings.set("direction", 23.0)
    assert position_named(settings) == "+23 deg"
    settings.set("aim_direction", False)
    assert position_named(settings) == "as the shot goes" and settings.aim_key() is None
    settings.set("elevation", 10.0)                     # an elevation goes with a direction
    assert settings.aim_elevation and settings.asked_elevation() is None
    settings.set("direction", "cover")
    assert settings.asked_elevation() == 10.0 and settings.aim_key() is not None
    with pytest.raises(UserError, match="mid-off"):
        settings.set("direction", "car park")


def test_the_trunk_readout_says_what_the_adaptation_costs_the_posture(state):
    """"trunk vs source (max)": 0 at the shot's own hit point; off it, the chest's largest turn
    from the source's (engine.adapt.trunk_turn_deg of the pose drawn), the trunk held or free
    (held, each spine joint is bounded, not the chest's sum: here 49 deg held against 47 free)."""
    from engine.adapt import trunk_jump_deg, trunk_turn_deg
    index = [s.name for s in state.shots].index("back_foot_defence")
    own = default_target(state, index)
    assert solve(state, ViewerSettings(pinned_shot="back_foot_defence", target=own))
    assert state.readouts.trunk_turn_deg == pytest.approx(0.0, abs=1e-6)
    assert state.readouts.trunk_jump_deg == pytest.approx(0.0, abs=1e-6)
    turned = {}
    for hold in (False, True):
        settings = ViewerSettings(pinned_shot="back_foot_defence", target=own + np.array([-40.0, -30.0, 0.0]),
                                  hold_trunk=hold, trunk_reach=10.0)
        assert solve(state, settings)
        turned[hold] = state.readouts.trunk_turn_deg
        assert turned[hold] == pytest.approx(trunk_turn_deg(state.rig, state.shots[index].fk[0],
                                                            state.adaptation.global_rotations))
        # and its largest jump between two frames, the pop the eye sees ("trunk jump a frame")
        assert state.readouts.trunk_jump_deg == pytest.approx(trunk_jump_deg(
            state.rig, state.shots[index].fk[0], state.adaptation.global_rotations))
        assert 0.0 <= state.readouts.trunk_jump_deg <= 2.0 * turned[hold] + 1e-6
    assert min(turned.values()) > 1.0, turned
