"""Clean-up of synthesised animations (dissertation 3.3).

Three fixes, the first two compiled (engine/cleanup_nb.py, one call per clip; a whole
70-frame clean-up takes a few ms):

* the right hand is put back on the bat handle: its position and orientation
  relative to the left hand are taken from the source shot (as
  engine.adapt does) and reached with the adaptation's solvers: the right arm
  alone first (from the previous frame's answer, so the arm does not jump
  between poses that all hold the grip; else CCD for the wrist, the joints
  that only turn the hand, damped Newton on both); where the left hand is out
  of the right arm's reach, both arms together (``arms_nb.both_arms_solve``:
  the torso Spine..Spine2 leans and the left arm gives while the bat holds),
  and where even that cannot reach, the bat is moved by what is still missing; solved
  forward and backward in time, each frame keeping the answer that swings the elbows
  least between frames;
* planted feet stay planted: where the source's foot is planted (slow and
  low for at least 3 frames), the leg chain (hip, knee) is solved by CCD so the
  ankle reaches the source's ankle position (or, where the new motion strides
  elsewhere, holds where it lands), and the foot is turned to its orientation,
  with a short blend at the plant's ends so nothing pops; where the new hips go
  further from the plant than the leg reaches, the heel lifts and the ball of the
  foot stays (:mod:`engine.heel`); where the legs' limits keep an ankle off its
  plant, the hips follow the feet (the root moves by what they miss, smoothed over a
  few frames);
* the hit: at the take's hit frame the bat is brought to the source's hit point and its face
  turned to the source's there (:mod:`engine.cleanup_hit`), after the other two.

All keep locked DOFs and the rig's limits (measured as
engine.ccd.limit_violation does), widened only to take in a pose the new
motion already put outside them, so no joint ends further out than it was.
Each returns the remaining error so the caller can show it.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.ndimage import gaussian_filter1d

from . import heel, quat
from .rig import Rig
from .adapt import ORIENT_TOL, twist_only
from .ccd import chain_arrays, limit_euler
from .cleanup_hit import meet_ball
from .cleanup_nb import BAT_COST, BAT_GIVE_ROUNDS, grip_frames, leg_frames
from .fk_nb import frames_fk
from .path_nb import cheapest_path
from .skeleton import Clip, Skeleton, carried_pose, clip_fk, local_translations, relative_pose
from .synth_detail import frame_map

PLANT_SPEED = 15.0     # cm/s: slower than this counts as planted ...
PLANT_HEIGHT = 6.0     # cm: ... if also within this of the foot's lowest height
PLANT_BLEND = 4        # frames over which a plant fades in and out
REACH = 0.995          # a plant further from the hip than this share of the leg lifts the heel
BALL_ROUNDS = 4        # re-aims of a lifted ankle whose foot the ankle's limits stop short
FOOT_TOL = 0.05        # cm: a planted ankle further than this off its plant moves the hips ...
PELVIS_ROUNDS = 12     # ... at most this many times ...
PELVIS_SMOOTH = 2.0    # ... by what the feet miss, smoothed over this many frames (Gaussian sigma)
FACE_REDO_DEG = 1.0    # deg: a face further than this from the source's at the hit: the hand fixed again, forward only


@dataclass
class CleanupResult:
    clip: Clip
    hand_error_cm: np.ndarray | None = None     # (F,) right hand vs its place on the handle
    hand_error_deg: np.ndarray | None = None    # (F,)
    foot_error_cm: dict = field(default_factory=dict)   # side -> (F,) ankle error, 0 where not planted
    planted: dict = field(default_factory=dict)         # side -> (F,) bool
    heel_deg: dict = field(default_factory=dict)        # side -> (F,) the heel's lift, planted frames
    face_angle_deg: float | None = None                 # the face at the take's hit vs the source's, after
    hit_frame: int | None = None                        # the take's hit frame, where it meets the ball
    bat_error_cm: float | None = None                   # the bat there vs the source's hit point, after
    bat_moved_cm: float | None = None                   # how far the bat was brought there

    def summary(self) -> dict:
        out = {}
        if self.hand_error_cm is not None:
            out["hand_error_cm_max"] = float(self.hand_error_cm.max())
            out["hand_error_deg_max"] = float(self.hand_error_deg.max())
        for side, e in self.foot_error_cm.items():
            out[f"{side}_foot_error_cm_max"] = float(e.max()) if e.size else 0.0
            out[f"{side}_foot_planted_frames"] = int(self.planted[side].sum())
            if side in self.heel_deg:
                lift = self.heel_deg[side]
                out[f"{side}_heel_lifted_frames"] = int((lift > 0).sum())
                out[f"{side}_heel_lift_deg_max"] = float(lift.max()) if lift.size else 0.0
        if self.face_angle_deg is not None:
            out["face_angle_deg"] = self.face_angle_deg
            out["hit_frame"] = self.hit_frame
        if self.bat_error_cm is not None:
            out["bat_error_cm"] = self.bat_error_cm
            out["bat_moved_cm"] = self.bat_moved_cm
        return out


def cleanup(rig: Rig, skeleton: Skeleton, clip: Clip, source: Clip, fix_hand: bool = True,
            plant_feet: bool = True, source_frames: np.ndarray | None = None,
            source_hit_frame: int | None = None, hit_frame: int | None = None,
            meet_hit_point: bool = True) -> CleanupResult:
    """Clean ``clip`` (e.g. synthesised from ``source``'s PC space).

    ``source_frames (F,)``: the source frame each frame corresponds to
    (default: linear time stretch). With ``source_hit_frame``, the hit too: at
    ``hit_frame`` (default: the frame that corresponds to the source's hit) the bat's
    face is turned to the source's at its hit and, with ``meet_hit_point``, the bat
    brought to the source's hit point (else it stays where the clip has it).
    """
    out = clip.copy()
    m = frame_map(clip.num_frames, source.num_frames) if source_frames is None else np.asarray(source_frames)
    src_rot, src_pos = _fk(skeleton, source)
    res = CleanupResult(out)
    if plant_feet:
        # feet first: the hand fix does not move the legs, the leg fix moves nothing above the hips
        for side, (err, planted, lift) in feet_on_plants(rig, skeleton, out, src_rot, src_pos, source.fps, m).items():
            res.foot_error_cm[side] = err
            res.planted[side] = planted
            res.heel_deg[side] = np.where(planted, lift, 0.0)
    feet_done = out.copy() if fix_hand and source_hit_frame is not None else None   # (the hit's redo below)
    if fix_hand:
        res.hand_error_cm, res.hand_error_deg = reattach_right_hand(rig, skeleton, out, src_rot[m], src_pos[m])
    if source_hit_frame is not None:
        h = int(np.argmin(np.abs(m - source_hit_frame))) if hit_frame is None else int(hit_frame)
        face = quat.rotate(src_rot[source_hit_frame, rig.bat_joint], np.asarray(rig.bat["face_normal"], float))
        point = src_pos[source_hit_frame, rig.bat_joint] if meet_hit_point else None
        res.hit_frame = h
        res.face_angle_deg, error, moved = meet_ball(rig, skeleton, out, face, h, point)
        if fix_hand and res.face_angle_deg > FACE_REDO_DEG:
            # the hit comes first: where the arms the two grip passes chose keep the face from
            # the source's, the hand fixed forward in time alone (as before them), if it does better
            again = feet_done
            errors = reattach_right_hand(rig, skeleton, again, src_rot[m], src_pos[m], passes=(1,))
            hit = meet_ball(rig, skeleton, again, face, h, point)
            if hit[0] < res.face_angle_deg:
                out.local_rotations[:] = again.local_rotations
                (res.hand_error_cm, res.hand_error_deg), (res.face_angle_deg, error, moved) = errors, hit
        if meet_hit_point:
            res.bat_error_cm, res.bat_moved_cm = error, moved
    return res


# ----------------------------------------------------------------- right hand
def right_hand_targets(rig: Rig, clip_global_rot, clip_global_pos, src_global_rot, src_global_pos):
    """Right-hand target position ``(F, 3)`` and orientation ``(F, 4)``: its pose
    relative to the left hand in the source, applied to the clip's left hand."""
    lh = rig.skeleton.parents[rig.bat_joint]        # the bat's parent is the top hand
    rh = rig.chains["right_arm"].effector
    rel_pos, rel_rot = relative_pose(src_global_rot[:, lh], src_global_pos[:, lh],
                                     src_global_rot[:, rh], src_global_pos[:, rh])
    return carried_pose(clip_global_rot[:, lh], clip_global_pos[:, lh], rel_pos, rel_rot)


def reattach_right_hand(rig: Rig, skeleton: Skeleton, clip: Clip, src_global_rot, src_global_pos,
                        iterations: int = 60, tolerance: float = 0.01, passes: tuple = (1, -1)):
    """Solve the arms in place in ``clip`` so the right hand grips the handle
    where the source's does. Returns the remaining (F,) errors in cm and degrees.
    ``passes``: the grip solve's passes over the frames, 1 forward and -1 backward in time
    (:func:`_solve_grips`).

    Uses the adaptation's compiled solvers (engine.adapt): the right arm alone
    first; where it cannot reach, both arms together (the torso leans, the left
    arm gives) with the bat held where it is, and where even that cannot reach,
    the bat is let go a little toward the right hand."""
    lh = rig.skeleton.parents[rig.bat_joint]
    rh = rig.chains["right_arm"].effector
    rel_pos, rel_rot = relative_pose(src_global_rot[:, lh], src_global_pos[:, lh],
                                     src_global_rot[:, rh], src_global_pos[:, rh])
    _solve_grips(rig, skeleton, clip, rel_pos, rel_rot, tolerance, passes)
    g_rot, g_pos = _fk(skeleton, clip)
    t_pos, t_rot = carried_pose(g_rot[:, lh], g_pos[:, lh], rel_pos, rel_rot)
    return np.linalg.norm(g_pos[:, rh] - t_pos, axis=-1), quat.angle_between(g_rot[:, rh], t_rot)


# ---------------------------------------------------------------------- feet
def planted_frames(foot_positions: np.ndarray, fps: float, height_tol: float = PLANT_HEIGHT,
                   speed_tol: float = PLANT_SPEED) -> np.ndarray:
    """(F,) bool: the foot joint ``(F, 3)`` is still (speed by central differences below
    ``speed_tol`` cm/s) and down (within ``height_tol`` cm of its lowest height). The one
    planted-foot detector: the clean-up, the shot authoring checks and the tests use it."""
    F = len(foot_positions)
    if F < 2:
        return np.ones(F, bool)
    speed = np.linalg.norm(np.gradient(foot_positions, axis=0), axis=1) * fps
    low = foot_positions[:, 1] < foot_positions[:, 1].min() + height_tol
    return (speed < speed_tol) & low


def planted_runs(foot_positions: np.ndarray, fps: float, height_tol: float = PLANT_HEIGHT,
                 speed_tol: float = PLANT_SPEED, min_frames: int = 3) -> list[tuple[int, int]]:
    """Runs ``[a, b)`` of at least ``min_frames`` frames of :func:`planted_frames`."""
    down = np.concatenate([[False], planted_frames(foot_positions, fps, height_tol, speed_tol), [False]])
    edges = np.flatnonzero(np.diff(down.astype(np.int8)))
    starts, ends = edges[::2], edges[1::2]
    return [(int(a), int(b)) for a, b in zip(starts, ends) if b - a >= min_frames]


def _plant_weight(planted: np.ndarray, blend: int = PLANT_BLEND) -> np.ndarray:
    """(F,) 1 inside plants, easing to 0 over ``blend`` frames outside them."""
    F = len(planted)
    idx = np.flatnonzero(planted)
    if idx.size == 0:
        return np.zeros(F)
    f = np.arange(F)
    # distance in frames to the nearest planted frame
    pos = np.searchsorted(idx, f)
    left = np.abs(f - idx[np.clip(pos - 1, 0, idx.size - 1)])
    right = np.abs(idx[np.clip(pos, 0, idx.size - 1)] - f)
    dist = np.minimum(left, right)
    x = np.clip(1 - dist / (blend + 1), 0, 1)
    return x * x * (3 - 2 * x)


PLANT_FOLLOW = 15.0   # cm: a plant further than this from the source's stays where the new motion put it
PLANT_ROLL = 5.0      # cm: runs whose blends meet are one plant if the source's ankle moves less between


def plant_targets(foot: np.ndarray, source_foot: np.ndarray, planted: np.ndarray) -> np.ndarray:
    """Ankle targets ``(F, 3)`` for each plant of ``planted (F,)``: a planted run, or runs
    whose blends meet (gaps of at most 2 PLANT_BLEND frames) with the source's ankle moved
    less than PLANT_ROLL between them (a foot rolling on the ground, as the CMU golfer's
    lead foot does, is still for a few frames at a time).

    Where the new motion plants the foot near the source's plant (the plant's mean
    within PLANT_FOLLOW), the source's ankle positions; where it plants it
    elsewhere (an aborted shot never strides), the foot is held still at the
    new motion's position where the plant starts (it lands there: the hips
    are then behind it, so the leg reaches it), at the source's height, so it
    neither slides nor gets dragged to a stride that no longer happens.
    The hold target also covers the blend frames either side of the plant. Runs of one
    plant are decided together: decided apart, a hold could take over the blend frames
    at the end of a run that follows the source, and the foot slid there, planted."""
    target = source_foot.copy()
    F = len(planted)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], planted.astype(np.int8), [0]])))
    starts, ends = edges[::2], edges[1::2]
    rolled = np.linalg.norm((source_foot[starts[1:]] - source_foot[ends[:-1] - 1])[:, [0, 2]], axis=-1)
    apart = np.flatnonzero((starts[1:] - ends[:-1] > 2 * PLANT_BLEND) | (rolled > PLANT_ROLL))  # between plants
    firsts, lasts = (starts[np.r_[0, apart + 1]], ends[np.r_[apart, -1]]) if starts.size else ([], [])
    for i, (a, b) in enumerate(zip(firsts, lasts)):
        sel = planted[a:b]
        here, there = foot[a:b][sel].mean(axis=0), source_foot[a:b][sel].mean(axis=0)
        if np.linalg.norm((here - there)[[0, 2]]) <= PLANT_FOLLOW:
            continue
        hold = np.array([foot[a, 0], there[1], foot[a, 2]])
        # the blends, but not into the next or the last plant
        lo = max(a - PLANT_BLEND, lasts[i - 1] if i else 0)
        hi = min(b + PLANT_BLEND, firsts[i + 1] if i + 1 < len(firsts) else F)
        target[lo:hi] = hold
    return target


class Plant(NamedTuple):
    """One foot's plant over a clip's frames (:func:`foot_plant`)."""
    planted: np.ndarray      # (F,) bool
    ankle: np.ndarray        # (F, 3) cm: the ankle's target
    foot: np.ndarray         # (F, 4): the foot's target rotation, heel lifted
    heel_deg: np.ndarray     # (F,) the heel's lift (engine.heel), 0 within the leg's reach
    flat_foot: np.ndarray    # (F, 4): the foot's rotation before the lift
    ball: np.ndarray         # (F, 3) cm: the ball of the foot's place, which a lift keeps
    ball_joint: int | None = None   # the joint the foot turns about (heel.ball_joint; None: no toe)


def foot_plant(rig: Rig, skeleton: Skeleton, clip: Clip, src_global_rot, src_global_pos, fps: float,
               side: str, source_frames: np.ndarray) -> Plant:
    """One foot's plant in ``clip``, where the source's foot is planted (:func:`plant_targets`)."""
    chain = rig.chains[f"{side}_leg"]
    ankle = chain.effector
    # runs only: a foot slow and low for a frame or two is passing the ground, not planted
    # (a one-frame "plant" at the cover drive's frame 34 pulled the synthesised back foot
    # 9 cm toward where the source had it, over the blend's 9 frames)
    src_planted = np.zeros(len(src_global_pos), bool)
    for a, b in planted_runs(src_global_pos[:, ankle], fps):
        src_planted[a:b] = True
    planted = src_planted[source_frames]
    g_rot, g_pos = _fk(skeleton, clip)
    t_pos = plant_targets(g_pos[:, ankle], src_global_pos[source_frames, ankle], planted)
    t_rot = src_global_rot[source_frames, ankle]
    # where the new motion takes the hip further from the plant than the leg reaches (an
    # exaggerated drive's lunge), the heel lifts and the ball of the foot stays
    reach = REACH * np.linalg.norm(skeleton.offsets[chain.joints[1:]], axis=-1).sum()
    hip = g_pos[:, chain.joints[0]]
    ball = heel.ball_joint(rig, skeleton, side)
    if ball is None:        # no toe to stand on: the foot leaves the plant
        planted = planted & (np.linalg.norm(t_pos - hip, axis=-1) < reach)
        return Plant(planted, t_pos, t_rot, np.zeros(len(planted)), t_rot, t_pos)
    ball_offset = src_global_pos[source_frames, ball] - src_global_pos[source_frames, ankle]
    lifted_pos, lifted_rot, heel_deg, reached = heel.lift_heels(t_pos, t_rot, ball_offset, hip, reach,
                                                                _plant_weight(planted) > 0)
    # beyond what the lift brings back, the foot leaves the plant
    return Plant(planted & reached, lifted_pos, lifted_rot, heel_deg, t_rot, t_pos + ball_offset, ball)


def reach_plant(rig: Rig, skeleton: Skeleton, clip: Clip, side: str, plant: Plant, g_rot, g_pos) -> None:
    """The leg of ``side`` solved toward its ``plant`` (:func:`foot_plant`), in place, with
    a short blend at the plant's ends. ``g_rot``/``g_pos``: the clip's FK (the other leg
    may have been solved since: the legs hang apart from the hips)."""
    w = _plant_weight(plant.planted)
    if not w.any():
        return
    ankle = rig.chains[f"{side}_leg"].effector
    target = g_pos[:, ankle] + (plant.ankle - g_pos[:, ankle]) * w[:, None]
    target_rot = quat.slerp(g_rot[:, ankle], plant.foot, w)
    _solve_leg(rig, skeleton, clip, f"{side}_leg", g_rot, g_pos, target, target_rot, w > 0)
    _keep_ball(rig, skeleton, clip, side, plant, g_rot, g_pos, target_rot)


def _keep_ball(rig: Rig, skeleton: Skeleton, clip: Clip, side: str, plant: Plant, g_rot, g_pos,
               target_rot) -> None:
    """Where the ankle's limits stop a lifted foot short of its turn (so the ball of the foot
    leaves its place), the ankle's target moved to where the foot as it turned puts the ball
    back, in ``plant`` (in place), and the leg solved again, in place. ``g_rot``/``g_pos``:
    the FK :func:`reach_plant` solved from (the hips have not moved since)."""
    ball = plant.ball_joint
    lifted = plant.planted & (plant.heel_deg > 0)
    if ball is None or not lifted.any():
        return
    ankle = rig.chains[f"{side}_leg"].effector
    for _ in range(BALL_ROUNDS):      # (the foot turns a little differently on the moved shin)
        now = _fk(skeleton, clip)[1]
        off = lifted & (np.linalg.norm(now[:, ball] - plant.ball, axis=-1) > 0.2 * FOOT_TOL)
        if not off.any():
            return
        plant.ankle[off] = plant.ball[off] - (now[off, ball] - now[off, ankle])
        _solve_leg(rig, skeleton, clip, f"{side}_leg", g_rot, g_pos, plant.ankle, target_rot, off)


def _missed(rig: Rig, side: str, plant: Plant, g_pos) -> np.ndarray:
    """``(F, 3)`` what the ankle still misses of its plant, cm (target - ankle; 0 where not
    planted), from the clip's FK ``g_pos``."""
    return np.where(plant.planted[:, None], plant.ankle - g_pos[:, rig.chains[f"{side}_leg"].effector], 0.0)


def plant_foot(rig: Rig, skeleton: Skeleton, clip: Clip, src_global_rot, src_global_pos, fps: float,
               side: str, source_frames: np.ndarray):
    """Two-bone IK of one leg, in place, toward the source's ankle in its planted frames.

    Returns ``(error (F,), planted (F,))``: the remaining ankle error in cm
    (0 where not planted) and the planted frames."""
    plant = foot_plant(rig, skeleton, clip, src_global_rot, src_global_pos, fps, side, source_frames)
    reach_plant(rig, skeleton, clip, side, plant, *_fk(skeleton, clip))
    g_rot, g_pos = _fk(skeleton, clip)
    _flatten_toes(rig, skeleton, clip, side, plant, g_rot)
    return np.linalg.norm(_missed(rig, side, plant, g_pos), axis=-1), plant.planted


def _flatten_toes(rig: Rig, skeleton: Skeleton, clip: Clip, side: str, plant: Plant, g_rot) -> None:
    """Where ``plant`` lifted the heel, the toes turned back flat on the ground (engine.heel),
    in place; ``g_rot``: the clip's global rotations with the leg solved."""
    ball = plant.ball_joint
    if ball is not None and plant.heel_deg.any():
        weight = _plant_weight(plant.planted) * (plant.heel_deg > 0)
        heel.flatten_toes(rig, skeleton, clip.local_rotations, g_rot, ball, plant.flat_foot, weight)


def feet_on_plants(rig: Rig, skeleton: Skeleton, clip: Clip, src_global_rot, src_global_pos, fps: float,
                   source_frames: np.ndarray) -> dict:
    """Both feet onto their plants (:func:`plant_foot`), in place; where a leg's limits keep
    its ankle off its plant (an exaggerated golf swing turns the hips past what the trail
    hip's adduction follows), the hips follow the feet: the root moves by what the feet
    still miss, smoothed over a few frames so the pelvis does not jerk, and the legs are
    solved again. Returns ``{side: (error (F,) cm, planted (F,), heel lift (F,) deg)}``."""
    sides = ("left", "right")
    plants = {s: foot_plant(rig, skeleton, clip, src_global_rot, src_global_pos, fps, s, source_frames)
              for s in sides}
    for _round in range(PELVIS_ROUNDS + 1):
        g_rot, g_pos = _fk(skeleton, clip)
        for s in sides:
            reach_plant(rig, skeleton, clip, s, plants[s], g_rot, g_pos)
        g_rot, g_pos = _fk(skeleton, clip)
        miss = {s: _missed(rig, s, plants[s], g_pos) for s in sides}
        off = np.stack([np.linalg.norm(miss[s], axis=-1) > FOOT_TOL for s in sides])       # (2, F)
        if _round == PELVIS_ROUNDS or not off.any():
            break
        # each frame, the mean of what the feet that miss still miss
        shift = (miss["left"] * off[0, :, None] + miss["right"] * off[1, :, None]) / np.maximum(off.sum(0), 1)[:, None]
        clip.root_positions[:] += gaussian_filter1d(shift, PELVIS_SMOOTH, axis=0, mode="nearest")
    for s in sides:         # the toes come after the legs: a toe moves nothing the legs reach for
        _flatten_toes(rig, skeleton, clip, s, plants[s], g_rot)
    return {s: (np.linalg.norm(miss[s], axis=-1), plants[s].planted, plants[s].heel_deg) for s in sides}


def _solve_grips(rig: Rig, skeleton: Skeleton, clip: Clip, rel_pos: np.ndarray, rel_rot: np.ndarray,
                 tolerance: float, passes: tuple = (1, -1)) -> np.ndarray:
    """Right hand onto ``rel_pos (F,3)`` / ``rel_rot (F,4)`` (its grip in the left
    hand's frame) on every frame of ``clip``, in place. Returns the (F,) distance
    in cm the bat had to move.

    A pass (:func:`_grip_pass`) solves the frames one after another, each from the previous
    frame's answer, so an arm keeps its side of the elbow's circle; where that warm solve
    fails, a colder one may land on the other side, and the elbow swings round the arm
    between two frames. So the frames are solved forward and backward in time, and each
    frame keeps one of the two answers: the path through them whose elbows swing least
    beyond their hands, with the grip's error and the bat's move charged too
    (engine.path_nb). Measured over 45 takes (9 shots x 5 presets, the source's detail):
    takes with a right elbow swing over 10 cm 23 -> 13, frame pairs 50 -> 23, the
    right humerus past its range 7% less; a take 1.2-1.35x as long. ``passes``: 1 forward,
    -1 backward."""
    left, right = chain_arrays(rig, "left_arm"), chain_arrays(rig, "right_arm")
    g_rot, g_pos = _fk(skeleton, clip)
    frames = (clip.local_rotations, np.radians(limit_euler(clip.local_rotations, rig.limits)),
              g_rot[:, left.parent], g_pos[:, left.parent])
    chains = (left, right, list(left.joints).index(right.parent))
    answers = [_grip_pass(frames, chains, rel_pos, rel_rot, tolerance, step) for step in passes]
    cost, points = [], []
    lh, rh = rig.skeleton.parents[rig.bat_joint], rig.chains["right_arm"].effector
    arms = [_elbow_and_hand(ch) for ch in (left, right)]
    for local, moved in answers:
        g_rot, g_pos = _fk(skeleton, Clip(clip.root_positions, local, clip.fps, clip.local_positions))
        t_pos, _ = carried_pose(g_rot[:, lh], g_pos[:, lh], rel_pos, rel_rot)
        cost.append(np.linalg.norm(g_pos[:, rh] - t_pos, axis=-1) + BAT_COST * moved)
        points.append([g_pos[:, js] for js in arms])
    path = cheapest_path(np.ascontiguousarray(np.stack(cost, 1)), _swing_charges(points))
    for k, (local, _) in enumerate(answers):
        clip.local_rotations[path == k] = local[path == k]
    return np.choose(path, [moved for _, moved in answers])


def _elbow_and_hand(ch) -> list[int]:
    """An arm chain's (ChainArrays) elbow and hand joints: its last joint, and the last before
    it that is no roll (twist-only) joint. (Charging every joint of the chains instead: 17
    takes with a swing over 10 cm, against 13.)"""
    roll = twist_only(ch.free)
    elbow = max(k for k in range(len(ch.joints) - 1) if not roll[k])
    return [int(ch.joints[elbow]), int(ch.joints[-1])]


def _swing_charges(points: list) -> np.ndarray:
    """Charges ``(F-1, K, K)`` between candidate poses: ``points[k]`` the arm chains' joint
    positions ``(F, n, 3)`` of candidate k, one array a chain (its hand last); going from
    candidate i at frame f to j at f + 1 costs the cm each joint moves beyond its hand (an
    elbow that swings round the arm moves much further than the hand)."""
    K = len(points)
    out = np.zeros((points[0][0].shape[0] - 1, K, K))
    for i in range(K):
        for j in range(K):
            for a, b in zip(points[i], points[j]):
                step = np.linalg.norm(b[1:] - a[:-1], axis=-1)        # (F-1, n)
                out[:, i, j] += np.maximum(0.0, step - step[:, -1:]).sum(axis=1)
    return out


def _grip_pass(frames: tuple, chains: tuple, rel_pos: np.ndarray, rel_rot: np.ndarray, tolerance: float,
               step: int) -> tuple[np.ndarray, np.ndarray]:
    """One pass of the compiled grip solve (engine.cleanup_nb.grip_frames) over the frames
    in time order (``step`` 1) or reversed (-1): the local rotations ``(F, J, 4)`` it leaves
    and the bat's move ``(F,)`` cm, in time order. ``frames`` = (local rotations, their limit
    Euler angles rad, the left chain's parent's global rotations and positions), left
    unchanged; ``chains`` = (left, right ChainArrays, the left joint the right arm hangs from)."""
    left, right, rp = chains
    local, euler, parent_rot, parent_pos = (np.array(a[::step], float) for a in frames)   # copies: solved in place
    moved = grip_frames(local, euler, (parent_rot, parent_pos), left.kernel_tuple("polish"),
                        right.kernel_tuple("polish"), rp, np.ascontiguousarray(rel_pos[::step], float),
                        np.ascontiguousarray(rel_rot[::step], float), (float(tolerance), ORIENT_TOL, BAT_GIVE_ROUNDS))
    return local[::step], moved[::step]


def _fk(skeleton: Skeleton, clip: Clip) -> tuple[np.ndarray, np.ndarray]:
    """:func:`engine.skeleton.clip_fk`, compiled (the clean-up runs FK a dozen times)."""
    parents = np.asarray(skeleton.parents, np.int64)
    if np.any(parents >= np.arange(len(parents))):
        return clip_fk(skeleton, clip)
    F, J = clip.num_frames, len(parents)
    g_rot, g_pos = np.empty((F, J, 4)), np.empty((F, J, 3))
    frames_fk(parents, np.ascontiguousarray(local_translations(skeleton, clip), float),
              np.ascontiguousarray(clip.local_rotations, float), np.ones(J, np.bool_), g_rot, g_pos)
    return g_rot, g_pos


def _solve_leg(rig: Rig, skeleton: Skeleton, clip: Clip, chain_name: str, g_rot, g_pos, target, target_rot,
               sel) -> None:
    """Leg chain IK (compiled CCD, the rig's limits and DOFs) of the ``sel (F,)``
    frames toward ankle ``target (F,3)`` and foot orientation ``target_rot (F,4)``, in place."""
    ch = chain_arrays(rig, chain_name)
    local = np.ascontiguousarray(clip.local_rotations, float)
    euler = np.ascontiguousarray(np.radians(limit_euler(local, rig.limits)))
    a = int(ch.effector)
    lim = np.radians(rig.limits[a])
    leg_frames(local, euler, np.ascontiguousarray(g_rot[:, ch.parent]), np.ascontiguousarray(g_pos[:, ch.parent]),
                np.ascontiguousarray(sel), ch.kernel_tuple("polish"),
                (a, rig.dof[a][None].copy(), np.ascontiguousarray(lim[None, :, 0]), np.ascontiguousarray(lim[None, :, 1])),
                np.ascontiguousarray(target, float), np.ascontiguousarray(target_rot, float), 1e-3)
    clip.local_rotations[:] = local
