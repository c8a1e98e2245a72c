"""Measurements of authored shots, shared by make_shots (diagnostics) and the tests.

Everything takes FK arrays: global rotations ``(F, J, 4)`` and positions ``(F, J, 3)``.
"""
from __future__ import annotations

import numpy as np

from engine import cleanup, quat
from engine.euler import degrees_outside as outside, other_branch, wrap


def dof_euler(rig, local_rotations: np.ndarray) -> np.ndarray:
    """Euler (z, y, x) degrees ``(F, J, 3)`` in whichever ZYX branch fits the
    rig's DOFs and limits: ``quat.to_euler`` keeps the middle angle within
    +/-90, so an elbow flexed 120 degrees (pure y) comes out as (180, -60, 180)
    while its other branch, (0, -120, 0), is the one the rig means."""
    e1 = quat.to_euler(np.asarray(local_rotations, float), "ZYX")
    e2 = other_branch(e1)
    lim = np.where(rig.dof[..., None], rig.limits, 0.0)
    s1 = outside(e1, lim[..., 0], lim[..., 1]).sum(-1)
    s2 = outside(e2, lim[..., 0], lim[..., 1]).sum(-1)
    return np.where((s2 < s1 - 1e-9)[..., None], e2, e1)


def clamp_into_limits(rig, local_rotations: np.ndarray, joints=None) -> tuple[np.ndarray, float]:
    """(``local_rotations (F, J, 4)`` with the Euler angles of ``joints`` (all but the root by
    default) clamped into the rig's limits, each to its nearer bound; the largest clamp, deg)."""
    e = dof_euler(rig, local_rotations)
    lo, hi = (np.where(rig.dof, rig.limits[..., k], 0.0) for k in (0, 1))
    out = outside(e, lo, hi) > 1e-6      # not the float noise of a locked axis
    chosen = np.zeros(rig.skeleton.num_joints, bool)
    if joints is None:
        chosen[1:] = True
    else:
        chosen[list(joints)] = True
    out &= chosen[None, :, None]
    near_lo = np.abs(wrap(e - lo)) <= np.abs(wrap(e - hi))
    clamped = np.where(out, np.where(near_lo, lo, hi), e)
    local = np.array(local_rotations, float, copy=True)
    moved = out.any(-1)
    local[moved] = quat.from_euler(clamped[moved], "ZYX")
    return local, float(np.abs(wrap(clamped - e)).max())


def euler_zyx(rig, local_rotations: np.ndarray) -> np.ndarray:
    """Euler (z, y, x) degrees ``(F, J, 3)`` as the bundled BVH files store them."""
    return dof_euler(rig, local_rotations)


def limit_violations(rig, local_rotations: np.ndarray, tol: float = 0.5) -> list[str]:
    """Human-readable list of limit / DOF violations beyond ``tol`` degrees."""
    e = dof_euler(rig, local_rotations)
    out = []
    J = rig.skeleton.num_joints
    for j in range(1, J):
        if not rig.skeleton.channel_orders[j]:
            continue
        for a, axis in enumerate("zyx"):
            v = e[:, j, a]
            lo, hi = rig.limits[j, a] if rig.dof[j, a] else (0.0, 0.0)
            over = outside(v, lo, hi)
            bad = over > tol
            if np.any(bad):
                f = int(np.argmax(over))
                out.append(f"{rig.skeleton.names[j]}.{axis} = {v[f]:.1f} at frame {f} "
                           f"(limits {lo:.0f}..{hi:.0f}, {int(bad.sum())} frames)")
    return out


def right_palm_on_handle(rig, global_rotations, global_positions) -> tuple[np.ndarray, np.ndarray]:
    """Where the right palm holds the handle: (cm off the handle's axis ``(F,)``, cm slid down
    it from the keyed grip, ``right_grip_below_left`` below the left's ``(F,)``)."""
    sk = rig.skeleton
    lh, rh = sk.index("LeftHand"), sk.index("RightHand")
    grip = np.array(rig.bat["left_grip"], float)
    axis = np.array(rig.bat["axis"], float)
    right_palm = grip * np.array([-1.0, 1.0, 1.0])         # the mirror of the left palm centre
    palm = quat.rotate(quat.conjugate(global_rotations[:, lh]), global_positions[:, rh] - global_positions[:, lh]
                       + quat.rotate(global_rotations[:, rh], right_palm)) - grip
    along = palm @ axis
    return np.linalg.norm(palm - along[:, None] * axis, axis=-1), along - rig.bat["right_grip_below_left"]


def right_in_left(rig, global_rotations, global_positions):
    """Right hand position ``(F, 3)`` and rotation ``(F, 4)`` in the left hand's frame."""
    sk = rig.skeleton
    lh, rh = sk.index("LeftHand"), sk.index("RightHand")
    inv = quat.conjugate(global_rotations[:, lh])
    pos = quat.rotate(inv, global_positions[:, rh] - global_positions[:, lh])
    return pos, quat.mul(inv, global_rotations[:, rh])


def planted_runs(positions: np.ndarray, fps: float, height_tol: float = 0.5,
                 speed_tol: float = 6.0) -> list[tuple[int, int]]:
    """Runs of frames ``[a, b)`` where a foot joint ``(F, 3)`` is down (within ``height_tol``
    cm of its lowest height) and still (below ``speed_tol`` cm/s): the engine's detector
    with the authoring check's tighter tolerances."""
    return cleanup.planted_runs(positions, fps, height_tol, speed_tol)


def foot_drift(positions: np.ndarray, fps: float) -> float:
    """Largest horizontal drift (cm) of a foot joint within any planted run."""
    worst = 0.0
    for a, b in planted_runs(positions, fps):
        p = positions[a:b][:, [0, 2]]
        worst = max(worst, float(np.max(np.linalg.norm(p - p[0], axis=-1))))
    return worst


def centre_of_mass(rig, global_positions: np.ndarray) -> np.ndarray:
    """Approximate whole-body centre of mass ``(F, 3)`` (segment fractions after
    Winter's anthropometric tables: head 8.1 %, trunk 49.7 %, upper arm 2.8 %,
    forearm 1.6 %, hand 0.6 %, thigh 10 %, shank 4.65 %, foot 1.45 %)."""
    sk = rig.skeleton
    P = lambda n: global_positions[:, sk.index(n)]
    segs = [(0.081, P("Head")), (0.497, (P("Hips") + P("Spine2")) / 2)]
    for s in ("Left", "Right"):
        segs += [(0.028, (P(s + "Arm") + P(s + "ForeArm")) / 2),
                 (0.016, (P(s + "ForeArm") + P(s + "Hand")) / 2),
                 (0.006, P(s + "Hand")),
                 (0.100, (P(s + "UpLeg") + P(s + "Leg")) / 2),
                 (0.0465, (P(s + "Leg") + P(s + "Foot")) / 2),
                 (0.0145, (P(s + "Foot") + P(s + "ToeBase")) / 2)]
    m = sum(w for w, _ in segs)
    return sum(w * p for w, p in segs) / m


# ------------------------------------------------------------- the hit (issue 14 item 1)
# Where each bundled shot must send the ball (azimuth deg, DESIGN.md's convention:
# 0 straight back past the bowler, + off side) and how fast the bat may be.
REGIONS = {
    "forward_defence": (-35.0, 35.0), "back_foot_defence": (-35.0, 35.0),
    "straight_drive": (-15.0, 15.0), "cover_drive": (35.0, 85.0), "on_drive": (-50.0, -8.0),
    "square_cut": (65.0, 115.0), "pull": (-120.0, -45.0), "leg_glance": (-170.0, -95.0),
    "sweep": (-160.0, -60.0),
}
DEFENCES = ("forward_defence", "back_foot_defence")
DRIVES = ("straight_drive", "cover_drive", "on_drive")
GLANCES = ("leg_glance",)    # turned off the face with the ball's pace: no swing to time
DEFENCE_MAX_MPS = 3.5        # Stretch et al. 1998: forward defence peak 3.5 m/s
DRIVE_PEAK_MPS = 11.8        # ... drive peak 11.8 m/s, 0.02 s before impact
DEAD_BAT_MPS = 1.5          # a defence's or a glance's bat, 1-4 frames after the ball: near still, and
                            # at most half as fast (2-4 frames) as into it (tests/assets/test_shots)
DEAD_BATS = DEFENCES + GLANCES
FEET_CM = 200.0              # a defended ball first lands within this of the hit point


def bat_speed_mps(rig, global_positions: np.ndarray, fps: float) -> np.ndarray:
    """Horizontal speed (m/s) of the Bat joint per frame ``(F,)``, central differences
    (the speed Stretch et al. measured)."""
    from engine.ballistics import bat_velocities
    v = bat_velocities(global_positions, rig.bat_joint, fps)
    return np.hypot(v[:, 0], v[:, 2]) / 100.0


def first_bounce_cm(path: np.ndarray, hit_point: np.ndarray) -> float:
    """Ground distance (cm) from the hit point to where a flight path ``(K, 3)`` (engine.ballistics.fly)
    first lands: its first sample whose height then rises or stays (a bounce or the roll)."""
    y = path[:, 1]
    up = np.nonzero(y[1:] >= y[:-1])[0]
    p = path[up[0]] if len(up) else path[-1]
    return float(np.hypot(*(p - hit_point)[[0, 2]]))


def hit_measures(rig, shot) -> dict:
    """What a source shot does at its own hit point, from engine.ballistics.shot_flight:
    contact, face_to_ball, the ball's azimuth/elevation (deg), the bat's horizontal speed at
    impact and its peak, and its speed (3D) into the ball (3 frames) and after it (2-4 frames;
    1-4 at most) (m/s), the peak's offset from the hit (frames, + after), and how far
    from the hit point the ball first lands (cm)."""
    from engine.ballistics import bat_velocities, shot_flight
    from engine.choice import BALL_START
    g_rot, g_pos = shot.fk
    fl, _ = shot_flight(rig, shot, g_rot, g_pos, BALL_START, shot.hit_point)
    vel = bat_velocities(g_pos, rig.bat_joint, shot.clip.fps) / 100.0
    v, v3 = np.hypot(vel[:, 0], vel[:, 2]), np.linalg.norm(vel, axis=-1)    # horizontal (bat_speed_mps), 3D
    h = shot.hit_frame
    return {"contact": fl.contact, "face_to_ball": fl.face_to_ball, "azimuth_deg": fl.azimuth_deg,
            "elevation_deg": fl.elevation_deg, "speed_mps": float(v[h]), "peak_mps": float(v.max()),
            "into_mps": float(v3[h - 3:h].mean()), "after_mps": float(v3[h + 2:h + 5].mean()),
            "after_max_mps": float(v3[h + 1:h + 5].max()),
            "peak_offset": int(np.argmax(v)) - h, "first_bounce_cm": first_bounce_cm(fl.path, shot.hit_point)}


def hit_problems(name: str, m: dict) -> list[str]:
    """What keeps a shot's hit ``m`` (from :func:`hit_measures`) from issue 14's targets."""
    out = []
    if m["contact"] != "face":
        out.append(f"meets the ball with the {m['contact']} (face_to_ball {m['face_to_ball']:.2f})")
    lo, hi = REGIONS[name]
    if not lo <= m["azimuth_deg"] <= hi:
        out.append(f"azimuth {m['azimuth_deg']:.1f} outside {lo:.0f}..{hi:.0f}")
    if name in DEAD_BATS and (m["after_max_mps"] >= DEAD_BAT_MPS or m["into_mps"] <= 2.0 * m["after_mps"]):
        out.append(f"the bat still moves after the ball ({m['after_max_mps']:.1f} m/s; into it {m['into_mps']:.1f})")
    if name in DEFENCES:
        if m["peak_mps"] > DEFENCE_MAX_MPS:
            out.append(f"bat peaks at {m['peak_mps']:.1f} m/s (> {DEFENCE_MAX_MPS})")
        if m["first_bounce_cm"] > FEET_CM:
            out.append(f"ball first lands {m['first_bounce_cm']:.0f} cm away (> {FEET_CM:.0f})")
    elif name not in GLANCES:
        if abs(m["peak_offset"]) > 1:
            out.append(f"bat speed peaks {m['peak_offset']:+d} frames from the hit")
        if name in DRIVES and m["speed_mps"] < 0.8 * DRIVE_PEAK_MPS:
            out.append(f"bat at {m['speed_mps']:.1f} m/s at impact (drive ~{DRIVE_PEAK_MPS})")
    return out



# ------------------------------------------------------------- the shoulder (issue 14 item 1)
# The rig's Arm limits are a box in ZYX Euler angles, which cannot say how far the
# humerus may cross the body at shoulder height (its frontal-plane angle wraps at
# +-180 there). The authoring check measures that on the arm's direction in the
# chest frame instead: near shoulder height (elevation 45-135 deg from hanging), its
# horizontal angle from straight out to the side stays within horizontal flexion
# 135 (across the front) and horizontal extension 45 (behind the frontal plane)
# (AAOS, Joint Motion: Method of Measuring and Recording, 1965).
HORIZONTAL_FLEXION = 135.0
HORIZONTAL_EXTENSION = 45.0
SHOULDER_BAND = (45.0, 135.0)     # elevation (deg from hanging) where the horizontal range applies
SHOULDER_FADE = 10.0              # deg over which the band fades in about its edges
_MIRROR = np.array([-1.0, 1.0, 1.0])


def _in_band(elevation: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """Weight ``(...)`` of a reading at ``elevation``: 1 inside ``band``, 0 outside, faded over
    SHOULDER_FADE about its edges (an arm dropped just out of it does not read as fixed)."""
    return np.clip(np.minimum(elevation - band[0], band[1] - elevation) / SHOULDER_FADE + 0.5, 0.0, 1.0)


def horizontal_excess(elevation: np.ndarray, horizontal: np.ndarray) -> np.ndarray:
    """Degrees ``(...)`` an upper arm near shoulder height (inside SHOULDER_BAND) lies beyond
    horizontal flexion or extension, the nearer way round the circle (an arm pointing
    straight across the chest is 45 past flexion, not 135 past extension); 0 elsewhere."""
    past = np.minimum(np.abs(wrap(horizontal - HORIZONTAL_FLEXION)), np.abs(wrap(-HORIZONTAL_EXTENSION - horizontal)))
    inside = (horizontal >= -HORIZONTAL_EXTENSION) & (horizontal <= HORIZONTAL_FLEXION)
    return np.where(inside, 0.0, past * _in_band(elevation, SHOULDER_BAND))


def humerus_angles(rig, global_rotations, side: str) -> tuple[np.ndarray, np.ndarray]:
    """Elevation from hanging and horizontal angle (deg, 0 straight out to the side, + forward
    and across) of one upper arm ``(F,)`` each, in the chest (Spine2) frame: ISB's elevation
    and plane of elevation (``humeral_rotations``)."""
    plane, elevation, _ = humeral_rotations(rig, global_rotations, side)
    return elevation, plane


def shoulder_problems(rig, global_rotations) -> list[str]:
    """Frames where an upper arm near shoulder height crosses the body further than the
    documented horizontal flexion, or swings behind it further than horizontal extension,
    and where the humerus is turned past its documented axial rotation (``axial_excess``)."""
    out = []
    for side in ("Left", "Right"):
        horiz, elev, axial = humeral_rotations(rig, global_rotations, side)
        out += _flagged(f"{side} upper arm at {{:.0f}} deg horizontally", horizontal_excess(elev, horiz), horiz, elev,
                        f"range {-HORIZONTAL_EXTENSION:.0f}..{HORIZONTAL_FLEXION:.0f}")
        out += _flagged(f"{side} humerus turned {{:.0f}} deg (+ internal)", axial_excess(elev, axial), axial, elev,
                        f"range {-EXTERNAL_ROTATION:.0f}..{INTERNAL_ROTATION:.0f}")
    return out


def _flagged(what: str, excess: np.ndarray, reading: np.ndarray, elevation: np.ndarray, allowed: str) -> list[str]:
    """One report line for the frames where ``excess`` (F,) passes 0.5 deg, at the worst one."""
    bad = excess > 0.5
    if not np.any(bad):
        return []
    f = int(np.argmax(excess))
    return [f"{what.format(reading[f])} (elevation {elevation[f]:.0f}) at frame {f} ({allowed}, {int(bad.sum())} frames)"]


# ------------------------------------------------------------- the humerus's axial rotation
# The rig's Arm x + ArmRoll x is the twist of a ZYX Euler decomposition from the T-pose: it is
# the humerus's axial rotation only near the T-pose (Codman's paradox), so its limits cannot
# hold the documented range. The check reads it as ISB does (Wu et al. 2005, humerothoracic
# Y-X-Y: plane of elevation, elevation, axial rotation) and holds it to AAOS's internal 70 /
# external 90, away from the hanging arm where the plane and the axial rotation are one.
INTERNAL_ROTATION = 70.0
EXTERNAL_ROTATION = 90.0
AXIAL_BAND = (20.0, 160.0)        # elevation (deg) where the axial rotation is read


def humerothoracic(chest: np.ndarray, humerus: np.ndarray, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ISB Y-X-Y angles (deg, each ``(...)``) of an upper arm in the chest: plane of elevation
    (0 abduction, 90 forward flexion), elevation (0 hanging, as a positive angle) and axial
    rotation (+ internal). ``chest``, ``humerus``: global rotation matrices ``(..., 3, 3)`` of
    Spine2 and of the arm's roll joint (columns: the joint's axes in world; the bone along
    +x on the left arm and -x on the right, the elbow's flexion axis y). The left arm is
    mirrored onto the right, ISB's side."""
    m = _MIRROR if side == "Left" else np.ones(3)
    s = 1.0 if side == "Left" else -1.0
    tx, ty = chest[..., :, 2] * m, chest[..., :, 1] * m                 # thorax: x forward, y up
    hy = -s * humerus[..., :, 0] * m                                     # elbow -> shoulder
    hz = humerus[..., :, 1] * m                                          # the flexion axis, lateral
    hz = hz - np.sum(hz * hy, -1, keepdims=True) * hy
    hz = hz / np.maximum(np.linalg.norm(hz, axis=-1, keepdims=True), 1e-12)
    T = np.stack([tx, ty, np.cross(tx, ty)], -1)
    H = np.stack([np.cross(hy, hz), hy, hz], -1)
    R = np.einsum("...ji,...jk->...ik", T, H)
    # ISB takes the elevation negative (a rotation about x taking y down), hence the signs
    elevation = np.degrees(np.arccos(np.clip(R[..., 1, 1], -1.0, 1.0)))
    plane = np.degrees(np.arctan2(-R[..., 0, 1], -R[..., 2, 1]))
    axial = np.degrees(np.arctan2(-R[..., 1, 0], R[..., 1, 2]))
    return plane, elevation, axial


def axial_excess(elevation: np.ndarray, axial: np.ndarray) -> np.ndarray:
    """Degrees ``(...)`` an upper arm is turned past AAOS's internal or external rotation,
    read inside AXIAL_BAND; 0 elsewhere."""
    past = np.maximum(axial - INTERNAL_ROTATION, -EXTERNAL_ROTATION - axial).clip(0.0)
    return past * _in_band(elevation, AXIAL_BAND)


def humeral_rotations(rig, global_rotations, side: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``humerothoracic`` of one arm over a clip's global rotations ``(F, J, 4)``."""
    sk = rig.skeleton
    return humerothoracic(quat.to_matrix(global_rotations[:, sk.index("Spine2")]),
                          quat.to_matrix(global_rotations[:, sk.index(side + "ArmRoll")]), side)


# ------------------------------------------------------------- the arms outside the trunk
# An elbow nearer the spine line (hips to neck) than TRUNK_CM touches the chest or belly (the
# rig's chest is ~20 cm deep, its shoulder joints 18 cm either side of the spine); nearer than
# TRUNK_INSIDE_CM it is inside: the authoring IK keeps elbows beyond the first where it can, the
# check flags the second. (Before the IK kept them out, 145 source frames had an elbow within
# 9 cm of the spine, down to 0.4 cm: arms through the chest; now the nearest is the bottom
# hand's elbow tucked in at the back-foot defence's and the leg glance's hit, 9.1-9.4 cm.)
TRUNK_CM = 12.0
TRUNK_INSIDE_CM = 9.0
TRUNK_JOINTS = ("Hips", "Spine", "Spine1", "Spine2", "Neck")   # the spine line, hips to neck


def elbow_to_spine(rig, global_positions, side: str) -> np.ndarray:
    """Distance (cm) ``(F,)`` of the ``side`` ("Left"/"Right") elbow from the spine line."""
    sk = rig.skeleton
    spine = global_positions[:, [sk.index(n) for n in TRUNK_JOINTS]]
    return distance_to_polyline(global_positions[:, sk.index(side + "ForeArm")], spine)


def distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance (cm) of ``points (..., 3)`` to the polyline ``line (..., N, 3)`` (broadcast)."""
    a, b = line[..., :-1, :], line[..., 1:, :]
    p = points[..., None, :]
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, -1) / np.maximum(np.sum(ab * ab, -1), 1e-12), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[..., None] * ab), axis=-1).min(-1)


def trunk_problems(rig, global_positions) -> list[str]:
    """Frames where an elbow lies inside the trunk (nearer the spine than TRUNK_INSIDE_CM)."""
    out = []
    for side in ("Left", "Right"):
        d = elbow_to_spine(rig, global_positions, side)
        bad = d < TRUNK_INSIDE_CM
        if np.any(bad):
            f = int(np.argmin(d))
            out.append(f"{side} elbow {d[f]:.1f} cm from the spine at frame {f} ({int(bad.sum())} frames)")
    return out


# An elbow outpacing its wrist and its shoulder by more than POP_CM in a frame has swung
# round the shoulder-wrist line: a pop through the body (tools/shots_arms charges it; where the
# keyed bat turns a hand beyond what the arm's limits follow, some remain).
POP_CM = 5.0


def elbow_excess(rig, global_positions, side: str) -> tuple[np.ndarray, np.ndarray]:
    """(cm the ``side`` elbow moves in each frame beyond its wrist and its shoulder ``(F-1,)``,
    the wrist's step ``(F-1,)``)."""
    sk = rig.skeleton
    step = lambda j: np.linalg.norm(np.diff(global_positions[:, sk.index(side + j)], axis=0), axis=-1)
    wrist = step("Hand")
    return step("ForeArm") - np.maximum(wrist, step("Arm")), wrist


def elbow_problems(rig, global_positions) -> list[str]:
    """Frames where an elbow pops round its arm (moves POP_CM further than its wrist and shoulder)."""
    excess = {side: elbow_excess(rig, global_positions, side)[0] for side in ("Left", "Right")}
    return [f"{side} elbow {e.max():.1f} cm beyond its wrist and shoulder between frames {int(e.argmax())} "
            f"and {int(e.argmax()) + 1} ({int((e > POP_CM).sum())} frames over {POP_CM:.0f})"
            for side, e in excess.items() if e.max() > POP_CM]


# ----------------------------------------------------------------- the shot's motion, in counts
FAR_PAST_DEG = 30.0     # past a shoulder range by this much the arm lies through the body
BIG_POP_CM = 20.0       # an elbow 20 cm past its wrist in one frame: the whole arm flips
FOLD_CM = 20.0          # a wrist this near its shoulder folds the arm shut
SWING_FRAMES = 6        # frames either side of the hit: the swing and the contact
CONTACT_FRAMES = 2      # frames either side of the hit where the swing itself turns the face
FACE_TURN_DEG = 45.0    # a frame outside the contact (1350 deg/s): faster than wrists roll a bat


SLOW_WRIST_CM = 5.0     # a wrist slower than 1.5 m/s a frame: no swing to hide a pop in
ARM_FRAMES = ("pops", "big_pops", "slow_pops", "horizontal", "axial", "folds")


def arm_frames(rig, global_rotations, global_positions) -> tuple[dict, float]:
    """({kind: [(side, frame), ...]} for each of ARM_FRAMES, the cm summed beyond POP_CM):
    ``pops`` (an elbow POP_CM past its wrist and shoulder in a frame), ``big_pops``
    (BIG_POP_CM), ``slow_pops`` (a pop with the wrist under SLOW_WRIST_CM), ``horizontal`` and
    ``axial`` (FAR_PAST_DEG past the shoulder's horizontal or the humerus's axial range) and
    ``folds`` (the wrist within FOLD_CM of its shoulder)."""
    sk = rig.skeleton
    out = {k: [] for k in ARM_FRAMES}
    pop_excess_cm = 0.0
    for side in ("Left", "Right"):
        e, wrist = elbow_excess(rig, global_positions, side)
        _, elevation, axial = humeral_rotations(rig, global_rotations, side)
        reach = global_positions[:, sk.index(side + "Hand")] - global_positions[:, sk.index(side + "Arm")]
        where = {"pops": e > POP_CM, "big_pops": e > BIG_POP_CM, "slow_pops": (e > POP_CM) & (wrist < SLOW_WRIST_CM),
                 "horizontal": horizontal_excess(*humerus_angles(rig, global_rotations, side)) > FAR_PAST_DEG,
                 "axial": axial_excess(elevation, axial) > FAR_PAST_DEG,
                 "folds": np.linalg.norm(reach, axis=-1) < FOLD_CM}
        for kind, mask in where.items():
            out[kind] += [(side, int(f)) for f in np.nonzero(mask)[0]]
        pop_excess_cm += float(np.maximum(e - POP_CM, 0.0).sum())
    return out, pop_excess_cm


def arm_figures(rig, global_rotations, global_positions) -> dict:
    """``arm_frames`` counted: {kind: arm-frames} and ``pop_excess_cm``."""
    frames, pop_excess_cm = arm_frames(rig, global_rotations, global_positions)
    return {**{k: len(v) for k, v in frames.items()}, "pop_excess_cm": pop_excess_cm}


def face_turns_deg(rig, global_rotations) -> np.ndarray:
    """How far the bat's face turns between frames ``(F-1,)`` degrees."""
    from engine.face import face_normal
    n = face_normal(global_rotations, rig.bat_joint, rig.bat["face_normal"])
    return np.degrees(np.arccos(np.clip((n[1:] * n[:-1]).sum(-1), -1.0, 1.0)))


def bat_acceleration(global_positions, bat_joint: int) -> np.ndarray:
    """|second difference| of the Bat joint ``(F,)`` cm per frame^2; the shot starts from rest."""
    p = global_positions[:, bat_joint]
    p = np.concatenate([p[:1], p])
    return np.linalg.norm(np.diff(p, 2, axis=0), axis=-1)
