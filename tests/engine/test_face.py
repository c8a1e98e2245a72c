"""The bat face and the ball's direction (engine/face.py, engine/ballistics.py's
contact), `hitpoint adapt`'s face/direction JSON fields and `hitpoint analyse
--directions` (issue 14, items 4-6)."""
import json
import numpy as np
import pytest

from engine import ballistics, bvh, choice, face, quat
from engine.library import load_library

FACE_KEYS = ("face_angle_deg", "face_to_ball", "contact", "ball_azimuth_deg", "ball_elevation_deg")


@pytest.fixture(scope="module")
def library(rig):
    return load_library(rig=rig)


# ------------------------------------------------------------ conventions

@pytest.mark.parametrize("direction, azimuth", [
    ((0, 0, 1), 0.0),                                               # straight back past the bowler
    ((-1, 0, 0), 90.0),                                             # point (off side, -X)
    ((1, 0, 0), -90.0),                                             # square leg
    ((-np.sin(np.radians(60)), 0, np.cos(np.radians(60))), 60.0),   # cover
    ((np.sin(np.radians(140)), 0, np.cos(np.radians(140))), -140.0),  # fine leg
])
def test_azimuth_follows_design_md(direction, azimuth):
    assert face.azimuth_deg(np.array(direction, float)) == pytest.approx(azimuth, abs=1e-9)


def test_azimuth_and_elevation_are_vectorised():
    v = np.array([[[-1.0, 1.0, 0.0], [0.0, -1.0, 1.0]]])
    assert np.allclose(face.azimuth_deg(v), [[90.0, 0.0]])
    assert np.allclose(face.elevation_deg(v), [[45.0, -45.0]])
    assert np.allclose(face.wrap_deg([190.0, -190.0, 180.0, 10.0]), [-170.0, 170.0, 180.0, 10.0])


def test_face_angle_between_two_rotations(rig):
    J, bat = rig.skeleton.num_joints, rig.bat_joint
    a = quat.identity((4, J))
    b = a.copy()
    twist = quat.from_axis_angle(np.array(rig.bat["axis"], float), np.radians([0.0, 30.0, 90.0, 180.0]))
    b[:, bat] = twist
    assert np.allclose(face.face_angle_deg(a, b, bat, rig.bat["face_normal"]), [0.0, 30.0, 90.0, 180.0], atol=1e-6)
    n = face.face_normal(b, bat, rig.bat["face_normal"])
    assert n.shape == (4, 3) and np.allclose(np.linalg.norm(n, axis=-1), 1.0)


def test_contact_from_the_cosine():
    assert face.contact(1.0) == "face" and face.contact(-0.9) == "back" and face.contact(0.05) == "edge"
    assert face.contact(face.EDGE_COS) == "face" and face.contact(-face.EDGE_COS) == "back"
    assert list(face.contact([0.5, 0.0, -0.5])) == ["face", "edge", "back"]


# ------------------------------------------------------------ the impact

def test_bat_velocity_is_the_central_difference_at_every_frame():
    """ballistics.bat_velocities: a joint moving at constant velocity reads it at every frame
    (the ends one-sided), an accelerating one the central difference; bat_velocity agrees
    frame by frame; a single frame reads zero."""
    from engine import ballistics
    t = np.arange(6)[:, None, None] / 30.0
    steady = np.concatenate([np.zeros((6, 1, 3)), t * [100.0, -50.0, 20.0]], 1)      # (F, 2, 3) cm
    assert np.allclose(ballistics.bat_velocities(steady, 1, 30.0), [100.0, -50.0, 20.0])
    accel = np.concatenate([np.zeros((6, 1, 3)), t ** 2 * [300.0, 0.0, 0.0]], 1)
    v = ballistics.bat_velocities(accel, 1, 30.0)
    assert np.allclose(v[1:-1, 0], 600.0 * t[1:-1, 0, 0]) and v[0, 0] > 0.0      # 2 a t between the ends
    for f in range(6):
        assert np.allclose(ballistics.bat_velocity(accel, 1, f, 30.0), v[f])
    assert np.allclose(ballistics.bat_velocities(accel[:1], 1, 30.0), 0.0)


def test_a_face_pointing_to_the_off_side_sends_the_ball_to_point():
    """A still bat whose face points -X, the ball coming from the off side: it goes
    back to the off side, azimuth +90, level; contact face."""
    hit = np.array([0.0, 80.0, 100.0])
    start = hit + np.array([-1500.0, 0.0, 0.0])
    v, kind, cos = ballistics.impact([-1.0, 0.0, 0.0], start, hit, np.zeros(3))
    assert kind == "face" and cos == pytest.approx(1.0)
    assert face.azimuth_deg(v) == pytest.approx(90.0) and face.elevation_deg(v) == pytest.approx(0.0)


def test_the_back_of_the_bat_is_reported_not_flipped():
    hit = np.array([0.0, 80.0, 100.0])
    start = hit + np.array([-1500.0, 0.0, 0.0])
    v, kind, cos = ballistics.impact([1.0, 0.0, 0.0], start, hit, np.zeros(3))   # face turned away
    assert kind == "back" and cos == pytest.approx(-1.0)
    assert face.azimuth_deg(v) == pytest.approx(90.0)          # off the back, still a real collision
    # the plain collision does not flip a normal the ball does not approach
    assert np.allclose(ballistics.outgoing_velocity([0, 0, -1], [0, 0, -1000], [0, 0, 0]), [0, 0, -1000])


def test_an_edge_deflects_off_the_rounded_edge():
    hit = np.array([0.0, 80.0, 100.0])
    start = hit + np.array([0.0, 0.0, 1500.0])                 # ball along the face plane
    v, kind, cos = ballistics.impact([-1.0, 0.0, 0.0], start, hit, np.zeros(3), bat_axis=[0.0, -1.0, 0.0])
    assert kind == "edge" and abs(cos) < 1e-9
    assert v[2] > 0 and np.isfinite(v).all()                    # back toward the bowler off the edge


def test_flight_reports_what_the_ball_meets(rig, library):
    for s in library:
        grot, gpos = s.fk
        fl = ballistics.flight(grot, gpos, rig.bat_joint, rig.bat["face_normal"], s.hit_frame, s.clip.fps,
                               choice.BALL_START, s.hit_point, rig.bat["axis"])
        assert fl.contact == face.contact(fl.face_to_ball)
        assert np.allclose(fl.path[0], s.hit_point) and np.all(fl.path[:, 1] >= 3.6 - 1e-9)
        old = ballistics.ball_after_impact(grot, gpos, rig.bat_joint, rig.wrist, rig.bat["face_normal"],
                                           s.hit_frame, s.clip.fps, choice.BALL_START, s.hit_point,
                                           bat_axis_local=rig.bat["axis"])
        assert np.allclose(old, fl.path)


# ------------------------------------------------------------ adapt's JSON

def _cli(*args):
    from typer.testing import CliRunner
    from app.cli import cli
    r = CliRunner().invoke(cli, [str(a) for a in args])
    assert r.exit_code == 0, r.stderr
    return r.stdout


def _adapt_json(*args):
    return json.loads(_cli("adapt", *args))


def test_source_at_its_own_hit_point_has_face_angle_zero(library):
    from app.cli.adapt import run_adapt
    for s in library[:3]:
        d = run_adapt(shot_name=s.name, hit=list(s.hit_point))
        assert d["face_angle_deg"] < 1e-3
        assert d["contact"] in face.CONTACTS and -1.0 <= d["face_to_ball"] <= 1.0
        assert -180.0 <= d["ball_azimuth_deg"] <= 180.0 and -90.0 <= d["ball_elevation_deg"] <= 90.0


def _numpy_fk(skel, clip):
    """Global rotation matrices (F,J,3,3) and positions (F,J,3): plain numpy, not the engine's FK."""
    q = clip.local_rotations
    w, x, y, z = np.moveaxis(q, -1, 0)
    m = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                  2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                  2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1).reshape(q.shape[:-1] + (3, 3))
    F, J = q.shape[:2]
    R, P = np.empty((F, J, 3, 3)), np.empty((F, J, 3))
    for j in range(J):
        p = skel.parents[j]
        t = clip.root_positions if j == 0 else np.broadcast_to(skel.offsets[j], (F, 3))
        if p < 0:
            R[:, j], P[:, j] = m[:, j], t
        else:
            R[:, j] = R[:, p] @ m[:, j]
            P[:, j] = P[:, p] + np.einsum("fab,fb->fa", R[:, p], t)
    return R, P


def test_json_agrees_with_the_exported_bvh(rig, library, tmp_path):
    """The README's example shot, read back from the BVH it writes: the face
    fields recomputed with engine.bvh + numpy (own FK, own collision)."""
    shot = next(s for s in library if s.name == "cover_drive")
    hit = np.array([-85.0, 36.0, 196.0])
    out = tmp_path / "a.bvh"
    d = _adapt_json("--shot", "cover_drive", "--hit", *map(str, hit), "--out", str(out))
    assert set(FACE_KEYS) <= set(d)
    skel, clip = bvh.read(out)
    src_skel, src_clip = shot.skeleton, shot.clip
    bat, h, fps = skel.names.index("Bat"), d["hit_frame"], clip.fps
    R, P = _numpy_fk(skel, clip)
    Rs, _ = _numpy_fk(src_skel, src_clip)
    n_local = np.asarray(rig.bat["face_normal"], float)
    n, ns = R[h, bat] @ n_local, Rs[h, src_skel.names.index("Bat")] @ n_local
    assert np.degrees(np.arccos(np.clip(n @ ns, -1, 1))) == pytest.approx(d["face_angle_deg"], abs=0.05)
    toward = (choice.BALL_START - hit) / np.linalg.norm(choice.BALL_START - hit)
    assert n @ toward == pytest.approx(d["face_to_ball"], abs=1e-3)
    assert d["contact"] == ("face" if n @ toward >= 0.2 else "back" if n @ toward <= -0.2 else "edge")
    # the collision off the surface met (face n or back -n), in the bat's rest frame
    bat_v = (P[h + 1, bat] - P[h - 1, bat]) * fps / 2
    m = n if n @ toward > 0 else -n
    rel = -ballistics.BALL_SPEED * toward - bat_v
    vn = rel @ m
    v = bat_v + ballistics.TANGENT_KEEP * (rel - vn * m) - ballistics.RESTITUTION_BAT * vn * m
    assert np.degrees(np.arctan2(-v[0], v[2])) == pytest.approx(d["ball_azimuth_deg"], abs=0.2)
    assert np.degrees(np.arctan2(v[1], np.hypot(v[0], v[2]))) == pytest.approx(d["ball_elevation_deg"], abs=0.2)


# ------------------------------------------------------------ analyse --directions

def test_spearman():
    from app.cli.analyse import spearman
    assert spearman([1, 2, 3, 4], [10, 20, 25, 100]) == pytest.approx(1.0)
    assert spearman([1, 2, 3, 4], [4, 3, 2, 1]) == pytest.approx(-1.0)
    assert spearman([1, 1, 2, 2], [1, 2, 3, 4]) == pytest.approx(np.corrcoef([1.5, 1.5, 3.5, 3.5], [1, 2, 3, 4])[0, 1])


def test_analyse_directions_json_and_table():
    d = json.loads(_cli("analyse", "--directions", "--shot", "straight_drive", "--json"))
    (s,) = d["shots"]
    assert len(s["grid"]) == 2 * len(d["grid_x_cm"]) * len(d["grid_y_cm"])
    for e in s["grid"]:
        assert set(FACE_KEYS) <= set(e) and e["wrist_dof"] in (0, 2)
    zero = [e for e in s["grid"] if e["offset_cm"] == [0.0, 0.0, 0.0]]
    assert len(zero) == 2 and all(e["face_angle_deg"] < 1e-3 for e in zero)
    # the trunk's turn from the source's: none where the shot is its own source, some elsewhere
    assert all(e["trunk_turn_deg"] < 1e-3 for e in zero)
    assert all(0.0 <= e["trunk_turn_deg"] <= 180.0 for e in s["grid"]) and max(e["trunk_turn_deg"] for e in s["grid"]) > 1.0
    # its jumps between frames: none at the shot's own hit point, never more than its turn can make
    assert all(e["trunk_jump_deg"] < 1e-3 for e in zero)
    assert all(0.0 <= e["trunk_jump_deg"] <= 2.0 * e["trunk_turn_deg"] + 1e-3 for e in s["grid"])
    src = s["source"]
    assert all(e["ball_azimuth_deg"] == pytest.approx(src["ball_azimuth_deg"], abs=0.01) for e in zero)
    for dof in ("dof0", "dof2"):
        assert {"face_angle_median_deg", "face_angle_max_deg", "face_share", "spearman_azimuth_vs_off_offset",
                "azimuth_moves_with_hit_point", "turned_from_ball"} <= set(s[dof])
        assert {"face_angle_p90_deg", "turned_from_ball", "trunk_turn_p90_deg"} <= set(d["overall"][dof])
        assert s[dof]["trunk_turn_max_deg"] == max(e["trunk_turn_deg"] for e in s["grid"]
                                                   if e["wrist_dof"] == int(dof[-1]) and e["bat_error_cm"] < 0.01)
        assert s[dof]["trunk_jump_max_deg"] == max(e["trunk_jump_deg"] for e in s["grid"]
                                                   if e["wrist_dof"] == int(dof[-1]) and e["bat_error_cm"] < 0.01)
        assert d["overall"][dof]["trunk_jump_max_deg"] == s[dof]["trunk_jump_max_deg"]     # one shot
    assert src["bat_speed_mps"] > 0
    t = _cli("analyse", "--directions", "--shot", "straight_drive")
    assert "straight_drive" in t and "rho(az, off)" in t and "all shots, 0 DOF" in t and "trunk turned" in t and "jumped a frame" in t
    assert d["settings"]["trunk_reach_deg"] is None and "the trunk free" in t
    # the trunk held: said in the JSON and the table, and no more trunk turned than free
    held = json.loads(_cli("analyse", "--directions", "--shot", "straight_drive", "--trunk-reach", "5", "--json"))
    assert held["settings"]["trunk_reach_deg"] == 5.0
    for dof in ("dof0", "dof2"):
        assert held["overall"][dof]["trunk_turn_max_deg"] <= d["overall"][dof]["trunk_turn_max_deg"] + 0.5
    assert "held within 5 deg" in _cli("analyse", "--directions", "--shot", "straight_drive", "--trunk-reach", "5")


def test_position_only_ccd_keeps_the_face_better_when_the_roll_joints_follow(rig, library):
    """Wrist locked, position-only CCD (face "free"): over hit points moved up to 30 cm
    across and 15 cm up or down, every shot whose source meets the ball with the face still
    does but at one cell, where it meets it with the edge, never the back; the face within 55
    degrees of the source's (position-only CCD starts from the source's arms and drifts from
    there: the library grip's back-foot defence turned 51.5 at 30 cm to the leg side and 15
    down; the anatomical grip's leg glance, whose source meets the ball at cosine 0.53, the
    nearest to the edge, meets it at 0.19 there, the edge). With the roll joints leading (the
    dissertation's CCD) the face turns much further: the straight drive 30 cm to the leg side
    and 15 up, 50 deg against 8 (cosine 0.67 against 0.99; the library grip's cover drive at
    the README's example, 45 against 16)."""
    from engine import face
    from engine.adapt import AdaptSettings, Adapter
    from engine.choice import BALL_START
    n_local = rig.bat["face_normal"]
    contacts = []
    for shot in library:
        src_n = face.face_normal(shot.fk[0][shot.hit_frame], rig.bat_joint, n_local)
        if face.contact(face.face_to_ball(src_n, BALL_START, shot.hit_point)) != "face":
            continue                     # a source that does not meet the ball with the face
        adapter = Adapter(rig, shot)
        for dx in (-30.0, -15.0, 15.0, 30.0):
            for dy in (-15.0, 15.0):
                p = shot.hit_point + (dx, dy, 0.0)
                a = adapter.adapt(p, AdaptSettings(face="free"))
                g = a.global_rotations[shot.hit_frame]
                cos = face.face_to_ball(face.face_normal(g, rig.bat_joint, n_local), BALL_START, a.desired_hit_point)
                contacts.append((face.contact(cos), shot.name, dx, dy, round(float(cos), 3)))
                assert face.face_angle_deg(g, shot.fk[0][shot.hit_frame], rig.bat_joint, n_local) < 55.0
    assert len(contacts) >= 60 and all(c[0] != "back" for c in contacts), contacts
    assert sum(c[0] == "edge" for c in contacts) <= 1, [c for c in contacts if c[0] != "face"]
    drive = next(s for s in library if s.name == "straight_drive")
    turned = {}
    for twist in ("follow", "lead"):
        a = Adapter(rig, drive).adapt(drive.hit_point + (30.0, 15.0, 0.0), AdaptSettings(twist=twist, face="free"))
        g = a.global_rotations[drive.hit_frame]
        cos = face.face_to_ball(face.face_normal(g, rig.bat_joint, n_local), BALL_START, a.desired_hit_point)
        turned[twist] = (face.face_angle_deg(g, drive.fk[0][drive.hit_frame], rig.bat_joint, n_local), cos)
    assert turned["lead"][0] > turned["follow"][0] + 10.0 and turned["lead"][1] < turned["follow"][1]


GRID_X = (-30.0, -15.0, 0.0, 15.0, 30.0)        # cm across the pitch (-x: the off side)
GRID_Y = (-15.0, 0.0, 15.0)                     # cm up


@pytest.fixture(scope="module")
def kept_face_grid(rig, library):
    """Every shot adapted over GRID_X x GRID_Y with the defaults (face kept), wrist 0 and
    2 DOF: {(dof, shot, dx, dy): (adaptation, flight, face angle deg, deg off the face aimed
    for: the source's turned with the hit point, Adapter.face_turn)}."""
    from engine import ballistics
    from engine.adapt import AdaptSettings, Adapter
    from engine.choice import BALL_START
    out = {}
    for shot in library:
        adapter = Adapter(rig, shot)
        for dof in (0, 2):
            for dy in GRID_Y:
                for dx in GRID_X:
                    settings = AdaptSettings(wrist_dof=dof)
                    a = adapter.adapt(shot.hit_point + (dx, dy, 0.0), settings)
                    fl, angle = ballistics.shot_flight(rig, shot, a.global_rotations, a.global_positions,
                                                       BALL_START, a.desired_hit_point, duration=0.0)
                    aim = quat.rotate(quat.exp(adapter.face_turn(a.desired_hit_point, settings)),
                                      adapter.source_face())
                    n = face.face_normal(a.global_rotations[shot.hit_frame], rig.bat_joint, rig.bat["face_normal"])
                    miss = float(np.degrees(np.arccos(np.clip(n @ aim, -1.0, 1.0))))
                    out[(dof, shot.name, dx, dy)] = (a, fl, angle, miss)
    return out


OUT_OF_REACH_DEG = 0.5   # a kept face this far off its aim: out of the arm's reach
                         # (test_the_ball_goes_the_way_the_hit_point_moves)


@pytest.mark.parametrize("dof", [0, 2])
def test_the_kept_face_stays_near_the_source_and_on_the_ball(kept_face_grid, dof):
    """Issue 14 item 2: over hit points moved up to 30 cm across and 15 cm up or down, every
    target is reached, the face stays within a few degrees of the source's (median <= 3, p90
    and all but a corner or two no more than the 3 deg the turn with the hit point asks at 30
    cm plus 1), the ball meets the face, and the right hand keeps its grip (within 0.5 cm but
    at a corner or two the right arm cannot reach, as with the position-only solve). The
    corners past: with the wrist locked, the anatomical grip's back-foot defence 30 cm to the
    leg side and 15 up (13.4 deg; the best any pose of the chain inside its limits and the
    humerus's range reaches, by SLSQP, 12.7 off its aim) and the cover drive 30 cm to the off
    side and 15 down or up (5.8 and 4.1; best 3.6 and 4.8 off)."""
    from engine.adapt import AdaptSettings
    turn_max = AdaptSettings().face_turn * max(abs(x) for x in GRID_X)
    cells = [v for k, v in kept_face_grid.items() if k[0] == dof]
    angles = np.array([c[2] for c in cells])
    assert all(c[0].bat_error_cm <= 0.001 for c in cells)
    assert np.median(angles) <= 3.0 and np.percentile(angles, 90) <= turn_max + 1.0, np.sort(angles)[-8:]
    assert np.sum(angles > turn_max + 1.0) <= 3 and angles.max() < 15.0, np.sort(angles)[-8:]
    assert all(c[1].contact == "face" and c[1].face_to_ball > 0 for c in cells)
    grip = np.array([float(c[0].grip_error_cm.max()) for c in cells])
    assert np.sum(grip >= 0.5) <= 2 and grip.max() < 1.0      # a corner or two out of the right arm's reach


def test_the_face_meets_the_ball_as_far_as_the_arms_reach(rig, library):
    """Beyond the grid: every shot's hit point moved 45 and 60 cm along each axis (up, down,
    either side, toward and away from the bowler) is reached, and the ball meets the face,
    not its back or edge (measured 2026-12-04: the worst cosine 0.24, the cover drive 60 cm
    toward the bowler; at 75 cm six targets are out of reach, and the face still meets the ball)."""
    from engine import ballistics
    from engine.adapt import AdaptSettings, Adapter
    from engine.choice import BALL_START
    for shot in library:
        adapter = Adapter(rig, shot)
        for distance in (45.0, 60.0):
            for axis in np.vstack([np.eye(3), -np.eye(3)]):
                a = adapter.adapt(shot.hit_point + distance * axis, AdaptSettings())
                fl, _ = ballistics.shot_flight(rig, shot, a.global_rotations, a.global_positions, BALL_START,
                                               a.desired_hit_point, duration=0.0)
                where = (shot.name, distance, axis.tolist())
                assert a.bat_error_cm <= 0.001, where
                assert fl.contact == "face" and fl.face_to_ball > 0.0, where + (fl.face_to_ball,)


@pytest.mark.parametrize("dof", [0, 2])
def test_the_ball_goes_the_way_the_hit_point_moves(kept_face_grid, library, dof):
    """Fig. 2.6 with the face kept: along every row of the grid, for every shot (the cover
    drive and the square cut too), moving the hit point toward the off side sends the ball
    further toward the off side, and toward the leg side further to the leg side, wherever
    the face is kept as aimed (the turn with the hit point is 1.5 deg per 15 cm, so a face
    OUT_OF_REACH_DEG off its aim may already send the ball back). With the anatomical grip's
    shots and the wrist locked, 9 of the 135 cells' faces are further off: the cover drive's
    and the square cut's 30 cm to the off side (4.7-6.3 and 0.9-2.2 deg; the cover drive's at
    15 up from 15 cm, 1.4), the on drive's 30 cm to the leg side and 15 up (1.7) and the
    back-foot defence's (13.6): out of a locked wrist's reach (by SLSQP, see above); with 2 DOF,
    the leg glance's 30 cm to the off side and 15 up (0.8). Those keep no such promise."""
    skipped = 0
    for shot in library:
        for dy in GRID_Y:
            cells = [kept_face_grid[(dof, shot.name, dx, dy)] for dx in GRID_X]
            kept = [i for i, c in enumerate(cells) if c[3] < OUT_OF_REACH_DEG]
            skipped += len(cells) - len(kept)
            assert GRID_X.index(0.0) in kept, (shot.name, dy)
            az = np.array([cells[i][1].azimuth_deg for i in kept])
            dx = np.array([GRID_X[i] for i in kept])
            turn = face.wrap_deg(az - cells[GRID_X.index(0.0)][1].azimuth_deg)
            assert np.all(np.sign(turn[dx != 0.0]) == np.sign(-dx[dx != 0.0])), (shot.name, dy, dx, turn)
            assert np.all(np.diff(az) < 0), (shot.name, dy, dx, az)
    assert skipped <= (10 if dof == 0 else 2), skipped


def test_a_kept_face_with_no_turn_is_the_source_face(rig, library):
    """face_turn 0: the face at the hit frame is the source's (to the solver's 0.05 deg)
    where the hit point moves within the arm's reach; "free" (position only) turns it further."""
    from engine.adapt import AdaptSettings, Adapter
    cover = next(s for s in library if s.name == "cover_drive")
    g_src = cover.fk[0][cover.hit_frame]
    n_local = rig.bat["face_normal"]
    for p in (cover.hit_point + (-15.0, 10.0, 0.0), cover.hit_point + (20.0, -10.0, 0.0)):
        kept = Adapter(rig, cover).adapt(p, AdaptSettings(face_turn=0.0))
        free = Adapter(rig, cover).adapt(p, AdaptSettings(face="free"))
        k = face.face_angle_deg(kept.global_rotations[cover.hit_frame], g_src, rig.bat_joint, n_local)
        f = face.face_angle_deg(free.global_rotations[cover.hit_frame], g_src, rig.bat_joint, n_local)
        assert kept.bat_error_cm <= 0.001 and k < 0.06 and f > k + 2.0, (k, f)


@pytest.mark.parametrize("name", ["straight_drive", "cover_drive", "on_drive", "pull"])
def test_a_requested_direction_is_met_with_the_face(rig, library, name):
    """``engine.direction.aim`` sends the ball within REACHED_DEG of any direction inside
    the shot's range, with the face, the bat on the hit point and the shot's first and
    last frames as captured; a request beyond the range gets its nearest end, flagged."""
    from engine import direction
    from engine.choice import BALL_START
    shot = next(s for s in library if s.name == name)
    lo, hi = direction.aim(rig, shot, shot.hit_point, 0.0).range_deg
    for request in (lo + 0.3 * (hi - lo), lo + 0.7 * (hi - lo)):
        r = direction.aim(rig, shot, shot.hit_point, request)
        a = r.adaptation
        g = a.global_rotations[shot.hit_frame]
        cos = face.face_to_ball(face.face_normal(g, rig.bat_joint, rig.bat["face_normal"]), BALL_START,
                                a.desired_hit_point)
        assert r.reached and abs(face.wrap_deg(r.azimuth_deg - request)) <= direction.REACHED_DEG
        assert face.contact(cos) == "face" and a.bat_error_cm < 0.01
        src = shot.clip.local_rotations
        assert np.allclose(a.local_rotations[[0, -1]], src[[0, -1]], atol=1e-9)
        assert r.twist_deg == 0.0 and abs(r.yaw_deg) <= direction.MAX_YAW_DEG + 1e-6
    beyond = direction.aim(rig, shot, shot.hit_point, float(face.wrap_deg(lo - 40.0)))
    if lo - 40.0 > -180.0 and hi - lo < 320.0:       # a range that does not wrap round
        # the range is sampled every 5 deg of turn; the refined answer is its nearest end,
        # which the answer's own range reports, at most one sample's step past the sampled
        # end (measured 2026-12-08 with the anatomical grip: a step moves the ball 8-11.7 deg
        # of azimuth, the largest the cover drive's; the pull's face range ends at -130.2
        # sampled and its refined end -138.3, 8.1 past, between that sample and the edge;
        # 8 deg a step before the grip)
        assert not beyond.reached and beyond.azimuth_deg == min(beyond.range_deg)
        assert abs(beyond.azimuth_deg - lo) < 12.0


def test_a_requested_elevation_is_met_by_the_face_tilt(rig, library):
    """``aim(..., elevation_deg=EL)`` (issue 14 item 3): inside the tilt's range the ball
    leaves within REACHED_DEG of the asked elevation and azimuth, with the face and the bat
    on the point; beyond it, the closest elevation the shot gives, flagged, at an end of the
    reported range; the first and last frames stay the source's."""
    from engine import direction
    shot = next(s for s in library if s.name == "straight_drive")
    p = shot.hit_point + (-10.0, 5.0, 0.0)
    for request in (-20.0, 5.0):
        r = direction.aim(rig, shot, p, 15.0, elevation_deg=request)
        a = r.adaptation
        assert r.reached and r.elevation_reached, (request, r.azimuth_deg, r.elevation_deg)
        assert abs(r.elevation_deg - request) <= direction.REACHED_DEG
        assert abs(face.wrap_deg(r.azimuth_deg - 15.0)) <= direction.REACHED_DEG
        assert r.elevation_range_deg[0] <= request <= r.elevation_range_deg[1]
        assert a.bat_error_cm <= 0.001 and abs(r.tilt_deg) <= direction.MAX_TILT_DEG + 1e-6
        assert np.allclose(a.local_rotations[[0, -1]], shot.clip.local_rotations[[0, -1]], atol=1e-9)
        fl, _ = ballistics.shot_flight(rig, shot, a.global_rotations, a.global_positions, choice.BALL_START,
                                       a.desired_hit_point, duration=0.0)
        assert fl.contact == "face" and fl.elevation_deg == pytest.approx(r.elevation_deg, abs=1e-6)
    high = direction.aim(rig, shot, p, 15.0, elevation_deg=85.0)
    assert not high.elevation_reached and high.elevation_deg < 85.0 - direction.REACHED_DEG
    assert high.elevation_deg == pytest.approx(high.elevation_range_deg[1], abs=3.0)


def test_adapt_cli_takes_a_fielding_position():
    """"cover drive, hit it to mid-off": the ball goes to mid-off with the face."""
    from engine import field
    d = json.loads(_cli("adapt", "--shot", "cover_drive", "--hit", "-40.6", "29.6", "205", "--direction", "mid-off"))
    assert d["direction_requested_deg"] == field.POSITIONS["mid-off"] and d["direction_reached"]
    assert d["ball_region"] == d["direction_requested_region"] == "mid-off" and d["contact"] == "face"


def test_adapt_cli_elevation_json_and_bad_input():
    d = json.loads(_cli("adapt", "--shot", "straight_drive", "--hit", "-12", "35", "212", "--direction", "15",
                        "--elevation", "0"))
    assert d["elevation_reached"] and abs(d["ball_elevation_deg"]) <= 3.0
    assert d["elevation_range_deg"][0] <= 0.0 <= d["elevation_range_deg"][1] and "face_tilt_deg" in d
    from typer.testing import CliRunner
    from app.cli import cli
    for bad in (["--elevation", "10"], ["--direction", "10", "--elevation", "91"],
                ["--direction", "10", "--elevation", "nan"], ["--direction", "car park"],
                ["--direction", "181"]):
        r = CliRunner().invoke(cli, ["adapt", "--shot", "straight_drive", "--hit", "0", "30", "210", *bad])
        assert r.exit_code == 2 and r.stderr.startswith("error:") and "Traceback" not in r.stderr, r.stderr


def test_with_the_face_free_the_direction_comes_from_the_forearm_twist(rig, library):
    """face "free" (position only): ``aim`` turns the face by the left forearm's twist
    instead, within MAX_TWIST_DEG, and still lands inside its range with the face."""
    from engine import direction
    from engine.adapt import AdaptSettings
    shot = next(s for s in library if s.name == "cover_drive")
    free = AdaptSettings(face="free")
    lo, hi = direction.aim(rig, shot, shot.hit_point, 0.0, free).range_deg
    r = direction.aim(rig, shot, shot.hit_point, lo + 0.6 * (hi - lo), free)
    assert r.reached and r.yaw_deg == 0.0 and 0.0 < abs(r.twist_deg) <= direction.MAX_TWIST_DEG + 1e-6
    assert r.adaptation.bat_error_cm < 0.01
