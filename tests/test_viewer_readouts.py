"""The panel's hit readouts (what the ball meets, the face against the source's, where the
ball goes) come from the update, in DESIGN.md's conventions."""
import numpy as np
import pytest

from app.ui.panel import field_region
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


def test_field_regions_follow_the_azimuth_convention():
    """0 straight back past the bowler, positive toward the off side (DESIGN.md)."""
    assert field_region(0.0) == "straight"
    assert field_region(60.0) == "cover" and field_region(90.0) == "point"
    assert field_region(-70.0) == "mid-wicket" and field_region(-140.0) == "fine leg"
    assert field_region(179.0) == field_region(-181.0 + 360.0)
    assert field_region(540.0) == field_region(180.0)


def test_the_panel_twist_choice_reaches_the_engine(state):
    """The viewer's 'arm rolls' choice is a real engine setting: it changes the engine key
    (a re-solve), and with the rolls leading the README's cover-drive example turns the
    face away from the ball (cosine 0.51 since the re-keyed shots, issue 14 item 1), with
    them following it meets the ball squarer (0.88), with the face."""
    from engine import face
    from engine.adapt import Adapter
    from engine.choice import BALL_START
    rig = state.rig
    shot = next(s for s in state.shots if s.name == "cover_drive")
    adapter = Adapter(rig, shot)
    contacts = {}
    for twist in ("follow", "lead"):
        settings = ViewerSettings(pinned_shot="cover_drive", twist=twist)
        a = adapter.adapt((-70.0, 45.0, 215.0), settings.adapt_settings())
        n = face.face_normal(a.global_rotations[shot.hit_frame], rig.bat_joint, rig.bat["face_normal"])
        contacts[twist] = float(face.face_to_ball(n, BALL_START, a.desired_hit_point))
    assert face.contact(contacts["follow"]) == "face" and contacts["lead"] < contacts["follow"] - 0.2
    assert ViewerSettings(twist="follow").engine_key() != ViewerSettings(twist="lead").engine_key()
