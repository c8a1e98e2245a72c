"""The bundled shots move smoothly: a still stance, and no jerk anywhere.

Every shot opens on the shared stance, held for 0.15 s (tools/shots_defs.compose),
with the bat keyed at the stance until t = -0.80 s, i.e. frame hit_frame - 24,
which is frame 5 or later for all nine shots (hit frames 29-31). So the first
STILL_STEPS frame-to-frame steps are keyed still; all that may move the bat
and hands there is the authoring noise fading in (about 0.5 cm std on the grip,
band-limited to ~9 frames: a few mm a frame).
"""
import numpy as np
import pytest

from engine.library import load_library
from tools.shots_check import (BIG_POP_CM, CONTACT_FRAMES, FACE_TURN_DEG, FAR_PAST_DEG, SWING_FRAMES,
                               bat_acceleration, face_turns_deg)

STILL_STEPS = 5             # frames 0..5: the stance hold and the still bat key
STILL_CM_PER_FRAME = 1.0    # 0.3 m/s; a stance that pops moved 10-14 cm a frame


@pytest.fixture(scope="module")
def shots(rig):
    return load_library(rig=rig)


def test_stance_is_still(shots, rig):
    sk = rig.skeleton
    joints = {"bat": rig.bat_joint, "LeftHand": sk.index("LeftHand"), "RightHand": sk.index("RightHand")}
    for s in shots:
        assert s.hit_frame - 24 >= STILL_STEPS, f"{s.name}: the bat leaves the stance before frame {STILL_STEPS}"
        for name, j in joints.items():
            p = s.fk[1][: STILL_STEPS + 1, j]
            step = np.linalg.norm(np.diff(p, axis=0), axis=-1)
            assert step.max() < STILL_CM_PER_FRAME, (
                f"{s.name}: {name} moves {np.round(step, 1)} cm a frame in the stance")


def test_no_jerk_beyond_the_swing(shots, rig):
    """Nowhere does the bat speed up or slow down harder than in the shot's own
    swing through the ball: a frame-to-frame spike outside it is a pop."""
    for s in shots:
        a = bat_acceleration(s.fk[1], rig.bat_joint)
        window = np.abs(np.arange(len(a)) - s.hit_frame) <= SWING_FRAMES
        swing = a[window].max()
        f = int(np.argmax(np.where(window, 0.0, a)))
        assert a[f] <= swing, (f"{s.name}: bat acceleration {a[f]:.1f} cm/frame^2 at frame {f}, "
                               f"above the swing's {swing:.1f}")




def test_the_face_never_flips_over_between_two_frames(shots, rig):
    """Outside the contact the face turns less than FACE_TURN_DEG from one frame
    to the next: a flip between two frames is a pop the viewer shows (the straight drive's
    face turned 169 degrees between frames 22 and 23 before the bat's keys were
    interpolated as one turn about the axis, the sweep's 174 four frames after the hit)."""
    worst = {}
    for s in shots:
        turn = face_turns_deg(rig, s.fk[0])
        outside = np.abs(np.arange(len(turn)) + 0.5 - s.hit_frame) > CONTACT_FRAMES
        worst[s.name] = round(float(turn[outside].max()), 1)
    assert max(worst.values()) <= FACE_TURN_DEG, worst


def arm_frames(shots, rig, kind):
    """[(shot, side, frame)] of one of tools.shots_check.ARM_FRAMES over the library."""
    from tools.shots_check import arm_frames as frames_of
    return [(s.name, side, f) for s in shots for side, f in frames_of(rig, *s.fk)[0][kind]]


def test_elbows_seldom_swing_round_the_arm(shots, rig):
    """Between two frames an elbow may sit anywhere on its circle round the shoulder-wrist
    line; jumping across it is a pop through the body (up to 45 cm in one frame, 183 arm-frames
    over 5 cm before tools/shots_ik charged the elbow's step). Where the keyed bat turns the
    hands beyond what the arm's limits follow (the drives' downswings) some remain, and
    some more where the upper arm would otherwise lie past the shoulder's ranges
    (test_upper_arms_stay_in_the_shoulders_horizontal_range and
    test_the_humerus_seldom_turns_past_its_axial_range): 80 before those charges, 93 after,
    all but 26 with the wrist moving fast (29 before). With the bat roll's pass charging what
    a continuous elbow costs each arm (tools/shots_viterbi.continuity_charge), the large ones (over
    BIG_POP_CM) fell 46 -> 37, all 95 -> 93, with the wrist slow 21 -> 18; with the humerus's
    axial range charged harder (AXIAL_DEG 14): 38, 81 and 12; with the bottom hand free to
    turn about the handle (BottomHand.TURNS), 31, 80 and 15; with the faces keyed where
    they had been left to the forearms (tools/face_keys), 15, 52 and 10; with the bottom
    hand free to slide down the handle (BottomHand.SLIDES), 10, 45 and 13."""
    pops, slow_pops, big_pops = (arm_frames(shots, rig, k) for k in ("pops", "slow_pops", "big_pops"))
    assert len(pops) <= 55, f"{len(pops)} arm-frames pop (main at eeb3a88: 183): {pops[:12]}"
    assert len(big_pops) <= 14, f"{len(big_pops)} pop over {BIG_POP_CM:.0f} cm (4c83454: 46): {big_pops[:12]}"
    assert len(slow_pops) <= 15, f"{len(slow_pops)} pop while the wrist is slow (eeb3a88: 83): {slow_pops[:12]}"


def test_upper_arms_stay_in_the_shoulders_horizontal_range(shots, rig):
    """Near shoulder height an upper arm crosses the chest at most 135 deg from straight out
    to the side and swings behind it at most 45 (AAOS). Past that by 30 deg or more it lies
    through the neck or the chest: 311 arm-frames over the library before the authoring
    solver charged it (tools/shots_arms.ArmSolver.SHOULDER_DEG), 95 after, 97 with the
    humerus's axial rotation charged too, 82 with the bottom hand free to turn about the
    handle (BottomHand.TURNS), 46 with the faces keyed (tools/face_keys), 40 with the
    bottom hand free to slide down the handle (BottomHand.SLIDES). What is left is
    where the keyed bat holds the hands across the chest (the finishes) and round the hits,
    where the arms are left as they were (ArmSolver.CONTACT_FRAMES)."""
    far = arm_frames(shots, rig, "horizontal")
    assert len(far) <= 50, f"{len(far)} arm-frames {FAR_PAST_DEG:.0f} deg past the horizontal range: {far[:12]}"


def test_the_humerus_seldom_turns_past_its_axial_range(shots, rig):
    """Read as ISB reads it (humerothoracic Y-X-Y, tools/shots_check.humerothoracic), the
    humerus turns at most 70 deg internally and 90 externally (AAOS). 30 deg or more past
    that, the elbow points where no arm can: 386 arm-frames over the library at the start
    of 12-03 late, 285 with the shoulder's horizontal range, 103 since the authoring solver
    charges it too (ArmSolver.AXIAL_DEG), 94 with the forward defence's backlift re-keyed,
    99 with the bat roll charging continuous elbows, 77 with AXIAL_DEG 20 -> 14, 62 with the
    bottom hand free to turn about the handle (BottomHand.TURNS), 43 with the faces keyed
    where they had been left to the forearms (tools/face_keys), 25 with the bottom hand free
    to slide down the handle (BottomHand.SLIDES)."""
    far = arm_frames(shots, rig, "axial")
    assert len(far) <= 35, f"{len(far)} arm-frames {FAR_PAST_DEG:.0f} deg past the humerus's axial range: {far[:12]}"
