"""Clean-up of synthesised animations (dissertation 3.3).

Two independent fixes, both compiled (numba, one call per clip; a whole
70-frame clean-up takes a few ms):

* the right hand is put back on the bat handle: its position and orientation
  relative to the left hand are taken from the source shot (as
  engine.adapt does) and reached with the adaptation's solvers: the right arm
  alone first (from the previous frame's answer, so the arm does not jump
  between poses that all hold the grip; else CCD for the wrist, the joints
  that only turn the hand, damped Newton on both); where the left hand is out
  of the right arm's reach, both arms together (``adapt.both_arms_solve``:
  the torso Spine..Spine2 leans and the left arm gives while the bat holds),
  and where even that cannot reach, the bat is moved by what is still missing;
* planted feet stay planted: where the source's foot is planted (slow and
  low), the leg chain (hip, knee) is solved by CCD so the ankle reaches the
  source's ankle position, and the foot is turned to its orientation, with a
  short blend at the plant's ends so nothing pops.

Both keep locked DOFs and the rig's limits (measured as
engine.ccd.limit_violation does), widened only to take in a pose the new
motion already put outside them, so no joint ends further out than it was.
Each returns the remaining error so the caller can show it.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass, field

import numpy as np

from . import quat
from .adapt import GRIP_CM, GRIP_RAD, ORIENT_TOL, both_arms_solve, grip_solve, orient_finish
from .ccd import ccd_frame, chain_arrays, limit_euler, solve as ccd_solve
from .kinematics_nb import (Pose, chain_fk, euler_to_local, load_pose, new_pose, new_work, store_local, sub_chain,
                            sub_pose)
from .nb import kernel
from .quat_nb import (clamp_angle, from_euler_zyx, pick_branch, q_angle, q_at, qconj, qmul, to_euler_zyx, v_at,
                      vadd, vnorm, vsub)
from .rig import Rig
from .skeleton import Clip, Skeleton, local_translations
from .solve_nb import GRIP_LENGTH, grip_target

PLANT_SPEED = 15.0     # cm/s: slower than this counts as planted ...
PLANT_HEIGHT = 6.0     # cm: ... if also within this of the foot's lowest height
PLANT_BLEND = 4        # frames over which a plant fades in and out



@dataclass
class CleanupResult:
    clip: Clip
    hand_error_cm: np.ndarray | None = None     # (F,) right hand vs its place on the handle
    hand_error_deg: np.ndarray | None = None    # (F,)
    foot_error_cm: dict = field(default_factory=dict)   # side -> (F,) ankle error, 0 where not planted
    planted: dict = field(default_factory=dict)         # side -> (F,) bool

    def summary(self) -> dict:
        out = {}
        if self.hand_error_cm is not None:
            out["hand_error_cm_max"] = float(self.hand_error_cm.max())
            out["hand_error_deg_max"] = float(self.hand_error_deg.max())
        for side, e in self.foot_error_cm.items():
            out[f"{side}_foot_error_cm_max"] = float(e.max()) if e.size else 0.0
            out[f"{side}_foot_planted_frames"] = int(self.planted[side].sum())
        return out


def frame_map(frames: int, source_frames: int) -> np.ndarray:
    """(frames,) source frame for each frame, by stretching time linearly."""
    if frames == 1:
        return np.zeros(1, dtype=np.int64)
    return np.rint(np.arange(frames) * (source_frames - 1) / (frames - 1)).astype(np.int64)


def cleanup(rig: Rig, skeleton: Skeleton, clip: Clip, source: Clip, fix_hand: bool = True,
            plant_feet: bool = True, source_frames: np.ndarray | None = None) -> CleanupResult:
    """Clean ``clip`` (e.g. synthesised from ``source``'s PC space).

    ``source_frames (F,)``: the source frame each frame corresponds to
    (default: linear time stretch).
    """
    out = clip.copy()
    m = frame_map(clip.num_frames, source.num_frames) if source_frames is None else np.asarray(source_frames)
    src_rot, src_pos = _fk(skeleton, source)
    res = CleanupResult(out)
    if plant_feet:
        # feet first: the hand fix does not move the legs, the leg fix moves nothing above the hips
        for side in ("left", "right"):
            err, planted = plant_foot(rig, skeleton, out, src_rot, src_pos, source.fps, side, m)
            res.foot_error_cm[side] = err
            res.planted[side] = planted
    if fix_hand:
        res.hand_error_cm, res.hand_error_deg = reattach_right_hand(rig, skeleton, out, src_rot[m], src_pos[m])
    return res


# ----------------------------------------------------------------- right hand
def right_hand_targets(rig: Rig, clip_global_rot, clip_global_pos, src_global_rot, src_global_pos):
    """Right-hand target position ``(F, 3)`` and orientation ``(F, 4)``: its pose
    relative to the left hand in the source, applied to the clip's left hand."""
    lh = rig.skeleton.parents[rig.bat_joint]        # the bat's parent is the top hand
    rel_pos, rel_rot = _grip_in_left(rig, src_global_rot, src_global_pos)
    pos = clip_global_pos[:, lh] + quat.rotate(clip_global_rot[:, lh], rel_pos)
    rot = quat.mul(clip_global_rot[:, lh], rel_rot)
    return pos, rot



def _grip_in_left(rig: Rig, src_global_rot, src_global_pos):
    """The right hand's source pose in the left hand's frame: ``(F,3)``, ``(F,4)``."""
    lh = rig.skeleton.parents[rig.bat_joint]        # the bat's parent is the top hand
    rh = rig.chains["right_arm"].effector
    inv_src = quat.conjugate(src_global_rot[:, lh])
    return (quat.rotate(inv_src, src_global_pos[:, rh] - src_global_pos[:, lh]),
            quat.mul(inv_src, src_global_rot[:, rh]))


def reattach_right_hand(rig: Rig, skeleton: Skeleton, clip: Clip, src_global_rot, src_global_pos,
                        iterations: int = 60, tolerance: float = 0.01):
    """Solve the arms in place in ``clip`` so the right hand grips the handle
    where the source's does. Returns the remaining (F,) errors in cm and degrees.

    Uses the adaptation's compiled solvers (engine.adapt): the right arm alone
    first; where it cannot reach, both arms together (the torso leans, the left
    arm gives) with the bat held where it is, and where even that cannot reach,
    the bat is let go a little toward the right hand."""
    lh = rig.skeleton.parents[rig.bat_joint]
    rh = rig.chains["right_arm"].effector
    rel_pos, rel_rot = _grip_in_left(rig, src_global_rot, src_global_pos)
    _solve_grips(rig, skeleton, clip, rel_pos, rel_rot, tolerance)
    g_rot, g_pos = _fk(skeleton, clip)
    t_pos = g_pos[:, lh] + quat.rotate(g_rot[:, lh], rel_pos)
    t_rot = quat.mul(g_rot[:, lh], rel_rot)
    return np.linalg.norm(g_pos[:, rh] - t_pos, axis=-1), quat.angle_between(g_rot[:, rh], t_rot)


def solve_chain_position(rig: Rig, skeleton: Skeleton, clip: Clip, joints: list[int], effector: int,
                         target: np.ndarray, g_rot=None, g_pos=None, iterations: int = 60,
                         tolerance: float = 0.01) -> np.ndarray:
    """Position-only CCD (engine.ccd) of the rig chain ``joints`` -> ``effector`` on
    every frame toward ``target (F,3)``, in place. Returns the remaining (F,) error in cm."""
    name = next((n for n, c in rig.chains.items() if list(c.joints) == list(joints) and c.effector == effector),
                None)
    if name is None:
        raise ValueError("solve_chain_position: joints and effector must be one of the rig's chains")
    ch = chain_arrays(rig, name)
    if g_rot is None:
        g_rot, g_pos = _fk(skeleton, clip)
    local, err, _ = ccd_solve(ch, g_rot[:, ch.parent], g_pos[:, ch.parent], clip.local_rotations[:, ch.joints],
                              target, tolerance, iterations)
    clip.local_rotations[:, ch.joints] = local
    return err


# ---------------------------------------------------------------------- feet
def planted_frames(foot_positions: np.ndarray, fps: float, speed: float = PLANT_SPEED,
                   height: float = PLANT_HEIGHT) -> np.ndarray:
    """(F,) bool: the foot joint ``(F, 3)`` is slower than ``speed`` cm/s (central
    differences) and within ``height`` cm of its lowest height in the clip.
    The one planted-foot detector: the clean-up, tools/shots_check and the tests use it."""
    F = len(foot_positions)
    if F < 2:
        return np.ones(F, bool)
    v = np.linalg.norm(np.gradient(foot_positions, axis=0), axis=1) * fps
    y = foot_positions[:, 1]
    return (v < speed) & (y < y.min() + height)


def planted_runs(foot_positions: np.ndarray, fps: float, height: float = 0.5, speed: float = 6.0,
                 min_frames: int = 3) -> list[tuple[int, int]]:
    """Runs ``[a, b)`` of at least ``min_frames`` :func:`planted_frames` (defaults:
    the bundled shots' strict test, down within 0.5 cm and still below 6 cm/s)."""
    down = planted_frames(foot_positions, fps, speed, height)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], down.astype(np.int8), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2]) if b - a >= min_frames]


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


def plant_targets(foot: np.ndarray, source_foot: np.ndarray, planted: np.ndarray) -> np.ndarray:
    """Ankle targets ``(F, 3)`` for each planted run of ``planted (F,)``.

    Where the new motion plants the foot near the source's plant (the run's mean
    within PLANT_FOLLOW), the source's ankle positions; where it plants it
    elsewhere (an aborted shot never strides), the foot is held still at the
    new motion's mean position for the run, at the source's height, so it
    neither slides nor gets dragged to a stride that no longer happens.
    The hold target also covers the blend frames either side of the run."""
    target = source_foot.copy()
    F = len(planted)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], planted.astype(np.int8), [0]])))
    for a, b in zip(edges[::2], edges[1::2]):          # runs [a, b)
        here, there = foot[a:b].mean(axis=0), source_foot[a:b].mean(axis=0)
        if np.linalg.norm((here - there)[[0, 2]]) <= PLANT_FOLLOW:
            continue
        hold = np.array([here[0], there[1], here[2]])
        lo, hi = max(a - PLANT_BLEND, 0), min(b + PLANT_BLEND, F)
        target[lo:hi] = hold
    return target


def plant_foot(rig: Rig, skeleton: Skeleton, clip: Clip, src_global_rot, src_global_pos, fps: float,
               side: str, source_frames: np.ndarray):
    """Leg IK (hip, knee, foot), in place, toward the source's ankle in its planted frames.

    Returns ``(error (F,), planted (F,))``: the remaining ankle error in cm
    (0 where not planted) and the planted frames."""
    ankle = rig.chains[f"{side}_leg"].effector
    src_planted = planted_frames(src_global_pos[:, ankle], fps)
    planted = src_planted[source_frames]
    w = _plant_weight(planted)
    F = clip.num_frames
    if not w.any():
        return np.zeros(F), planted
    sel = w > 0
    g_rot, g_pos = _fk(skeleton, clip)
    t_pos = plant_targets(g_pos[:, ankle], src_global_pos[source_frames, ankle], planted)
    t_rot = src_global_rot[source_frames, ankle]
    target = g_pos[:, ankle] + (t_pos - g_pos[:, ankle]) * w[:, None]
    target_rot = quat.slerp(g_rot[:, ankle], t_rot, w)
    _solve_leg(rig, skeleton, clip, f"{side}_leg", g_rot, g_pos, target, target_rot, sel)
    g_rot, g_pos = _fk(skeleton, clip)
    err = np.where(planted, np.linalg.norm(g_pos[:, ankle] - t_pos, axis=-1), 0.0)
    return err, planted


# ------------------------------------------------------------- compiled part
BAT_GIVE_ROUNDS = 4             # times the bat may be moved toward a right hand that cannot reach
BAT_COST = 0.05                 # grip cm a cm of bat movement is worth when choosing between two-arm solutions
TURN_COST = 0.005               # ... and a degree of the bat turning
WARM_ITER = 80                  # Newton steps from the previous frame's right arm

# one frame of the grip fix: the left chain's parent pose, the grip in the left
# hand's frame, the bat and left hand where the new motion has them, tolerances
GripFrame = namedtuple("GripFrame", "prot ppos rel_p rel_q bat0 lh0 tol ori_tol rp rounds")
# the right arm's candidate poses, kept between the tries of one frame and across frames
Keep = namedtuple("Keep", "start_l start_el best_l best_r best_er prev_er ccd_r ccd_er")


@kernel
def _start_limits(chain, pose):
    """The chain's limits widened to take in the start angles ``pose.euler``
    (radians; a pose the new motion put outside its limits may stay there or
    move back in, never further out), into pose.lo / pose.hi; pose.src gets the
    start angles. An angle outside is first unwrapped to the side of the limits
    it is nearer on the circle (as engine.ccd.limit_violation measures it), so
    the widening does not take in the long way round."""
    _start_limits_rows(chain.lo, chain.hi, pose)


@kernel
def _foot_turn(ankle_euler, a_free, a_lo, a_hi, shin_rot, target_rot):
    """The foot's Euler angles turned toward target_rot in the shin's frame, within
    its limits widened to the start; ``ankle_euler (1,3)`` in place."""
    lo_a = np.empty((1, 3))
    hi_a = np.empty((1, 3))
    pose = Pose(np.empty((1, 4)), ankle_euler, np.empty((1, 3)), lo_a, hi_a)
    _start_limits_rows(a_lo, a_hi, pose)
    e = pick_branch(to_euler_zyx(qmul(qconj(shin_rot), target_rot)), ankle_euler, ankle_euler, a_free,
                    lo_a, hi_a, 0)
    for c in range(3):
        ankle_euler[0, c] = clamp_angle(e[c], lo_a[0, c], hi_a[0, c]) if a_free[0, c] else ankle_euler[0, c]
    return from_euler_zyx(ankle_euler[0, 0], ankle_euler[0, 1], ankle_euler[0, 2])


@kernel
def _start_limits_rows(lo, hi, pose):
    """:func:`_start_limits` for limits ``lo``/``hi (n,3)`` given as arrays."""
    for k in range(lo.shape[0]):
        for c in range(3):
            a = pose.euler[k, c]
            if a > hi[k, c]:
                d = (lo[k, c] - a) % (2.0 * math.pi)
                if d < a - hi[k, c]:
                    a = lo[k, c] - d
            elif a < lo[k, c]:
                d = (a - hi[k, c]) % (2.0 * math.pi)
                if d < lo[k, c] - a:
                    a = hi[k, c] + d
            pose.euler[k, c] = a
            pose.src[k, c] = a
            pose.lo[k, c] = min(lo[k, c], a)
            pose.hi[k, c] = max(hi[k, c], a)


@kernel
def _leg_frames(local, euler, parent_rot, parent_pos, sel, chain, lj, ankle, foot, target, target_rot, tol):
    """Each selected frame: the leg chain ``lj`` (hip, knee, ankle) by CCD so the
    ankle reaches ``target (F,3)``, then the ankle joint turned toward
    ``target_rot (F,4)``; limits widened only to the start pose, locked columns
    kept. ``foot``: (free (1,3), lo (1,3), hi (1,3)) of the ankle joint. In place
    on ``local (F,J,4)`` (``euler`` radians, limit branch)."""
    n = lj.shape[0]
    w = new_work(n)
    pose = new_pose(n)
    ea = np.empty((1, 3))
    for f in range(local.shape[0]):
        if not sel[f]:
            continue
        load_pose(pose, local[f], euler[f], lj)
        _start_limits(chain, pose)
        prot = q_at(parent_rot, f)
        ppos = v_at(parent_pos, f)
        ccd_frame(prot, ppos, chain, pose, v_at(target, f), tol, 200, w)
        chain_fk(prot, ppos, chain, pose.local, w.g_rot, w.g_pos)
        store_local(pose, lj, local[f])
        for c in range(3):
            ea[0, c] = euler[f, ankle, c]
        q = _foot_turn(ea, foot[0], foot[1], foot[2], q_at(w.g_rot, n - 2), q_at(target_rot, f))
        for c in range(4):
            local[f, ankle, c] = q[c]


@kernel
def _grip_error(g, L, pose_l, R, pose_r, w):
    """FK of both arms: (bat, right hand minus its grip target (3,), angle error rad)."""
    bat = chain_fk(g.prot, g.ppos, L, pose_l.local, w.g_rot, w.g_pos)
    rh = chain_fk(q_at(w.g_rot, g.rp), v_at(w.g_pos, g.rp), R, pose_r.local, w.g2_rot, w.g2_pos)
    t_pos, t_rot = grip_target(w.g_rot, w.g_pos, L.order.shape[0], g.rel_p, g.rel_q)
    return bat, vsub(rh, t_pos), q_angle(q_at(w.g2_rot, R.order.shape[0] - 1), t_rot)


@kernel
def _warm_right(R, pose_r, prev_er):
    """The right arm's free angles from the previous frame (within this frame's
    limits), its locked ones this frame's."""
    for k in range(pose_r.local.shape[0]):
        for c in range(3):
            pose_r.euler[k, c] = (min(max(prev_er[k, c], pose_r.lo[k, c]), pose_r.hi[k, c]) if R.free[k, c]
                                  else pose_r.src[k, c])
        euler_to_local(pose_r, k)


@kernel
def _right_on_left(g, L, pose_l, R, pose_r, iters, w):
    """The right arm alone onto its grip on the left hand as pose_l has it."""
    chain_fk(g.prot, g.ppos, L, pose_l.local, w.g_rot, w.g_pos)
    t_pos, t_rot = grip_target(w.g_rot, w.g_pos, L.order.shape[0], g.rel_p, g.rel_q)
    return grip_solve(q_at(w.g_rot, g.rp), v_at(w.g_pos, g.rp), R, pose_r, t_pos, t_rot, g.tol, g.ori_tol,
                      iters, w)


@kernel
def _two_arms(g, L, pose_l, R, pose_r, hold, w):
    """Both arms onto bat and grip from the given start (in place); where the
    grip is still out of reach, the bat is moved by what is missing and the
    solve runs again (``g.rounds`` times at most). With ``hold``, the torso keeps
    that lean and the left arm below it puts the bat back to its place and
    the left hand to its orientation ``g.lh0`` (the two-arm solve holds the bat
    only by one point, so it may turn it). Then the right arm alone polishes
    the grip on the final left hand. Returns a score: the grip error (cm, with
    10 cm per radian) plus BAT_COST per cm the bat moved and TURN_COST per
    degree it turned."""
    handle = g.bat0
    for _ in range(g.rounds):
        both_arms_solve(g.prot, g.ppos, L, pose_l, g.rp, R, pose_r, handle, g.rel_p, g.rel_q, g.tol, g.ori_tol,
                        40, w)
        bat, d, oe = _grip_error(g, L, pose_l, R, pose_r, w)
        if vnorm(d) < GRIP_CM and oe < GRIP_RAD:
            break
        handle = vadd(bat, d)
    chain_fk(g.prot, g.ppos, L, pose_l.local, w.g_rot, w.g_pos)
    if hold:
        a = g.rp + 1
        grip_solve(q_at(w.g_rot, g.rp), v_at(w.g_pos, g.rp), sub_chain(L, a), sub_pose(pose_l, a), handle, g.lh0,
                   g.tol, g.ori_tol, 40, w)
    _right_on_left(g, L, pose_l, R, pose_r, 30, w)
    bat, d, oe = _grip_error(g, L, pose_l, R, pose_r, w)
    turn = math.degrees(q_angle(q_at(w.g_rot, L.order.shape[0] - 1), g.lh0))
    return vnorm(d) + GRIP_LENGTH * oe + BAT_COST * vnorm(vsub(bat, g.bat0)) + TURN_COST * turn


@kernel
def _right_alone(g, L, pose_l, R, pose_r, start_r, keep, prev_ok, w):
    """Step 1: the right arm alone. Frames follow each other: first from the
    previous frame's answer (so the arm moves smoothly instead of jumping between
    the several poses that hold the grip), else wrist position, the joints that
    only turn the hand, both. Returns (position, angle) error."""
    pr = q_at(w.g_rot, g.rp)
    pp = v_at(w.g_pos, g.rp)
    t_pos, t_rot = grip_target(w.g_rot, w.g_pos, L.order.shape[0], g.rel_p, g.rel_q)
    pe = 1e300
    oe = 1e300
    if prev_ok:
        _warm_right(R, pose_r, keep.prev_er)
        pe, oe = grip_solve(pr, pp, R, pose_r, t_pos, t_rot, g.tol, g.ori_tol, WARM_ITER, w)
    if pe > GRIP_CM or oe > GRIP_RAD:
        pose_r.local[:] = start_r
        pose_r.euler[:] = pose_r.src
        ccd_frame(pr, pp, R, pose_r, t_pos, g.tol, 200, w)
        orient_finish(pr, pp, R, pose_r, t_rot, 8, g.ori_tol, w)
        pe, oe = grip_solve(pr, pp, R, pose_r, t_pos, t_rot, g.tol, g.ori_tol, 30, w)
    return pe, oe


@kernel
def _both_best(g, L, pose_l, R, pose_r, start_r, keep, prev_ok, w):
    """Step 2, out of reach: both arms together (the torso leans, the left arm
    gives), from a few starts for the right arm: where the arm-alone solve left
    it, the new motion's pose, the previous frame's answer, each with and
    without holding the bat; the closest grip wins. Returns the bat's move (cm)."""
    keep.start_l[:] = pose_l.local
    keep.start_el[:] = pose_l.euler
    keep.ccd_r[:] = pose_r.local
    keep.ccd_er[:] = pose_r.euler
    best = 1e300
    for attempt in range(6):
        trial = attempt // 2
        pose_l.local[:] = keep.start_l
        pose_l.euler[:] = keep.start_el
        if trial == 0:
            if not prev_ok:
                continue
            _warm_right(R, pose_r, keep.prev_er)
        elif trial == 1:
            pose_r.local[:] = keep.ccd_r
            pose_r.euler[:] = keep.ccd_er
        else:
            pose_r.local[:] = start_r
            pose_r.euler[:] = pose_r.src
        score = _two_arms(g, L, pose_l, R, pose_r, attempt % 2 == 0, w)
        if score < best:
            best = score
            keep.best_l[:] = pose_l.local
            keep.best_r[:] = pose_r.local
            keep.best_er[:] = pose_r.euler
        if score < GRIP_CM + GRIP_LENGTH * GRIP_RAD:
            break
    pose_l.local[:] = keep.best_l
    pose_r.local[:] = keep.best_r
    pose_r.euler[:] = keep.best_er
    bat = chain_fk(g.prot, g.ppos, L, pose_l.local, w.g_rot, w.g_pos)
    return vnorm(vsub(bat, g.bat0))


@kernel
def _new_keep(nl, nr):
    return Keep(np.empty((nl, 4)), np.empty((nl, 3)), np.empty((nl, 4)), np.empty((nr, 4)), np.empty((nr, 3)),
                np.empty((nr, 3)), np.empty((nr, 4)), np.empty((nr, 3)))


@kernel
def _grip_frames(local, euler, hips_rot, hips_pos, L, R, lj, rj, rp, rel_pos, rel_rot, tol, ori_tol, rounds):
    """Every frame of ``local (F,J,4)`` (in place; ``euler (F,J,3)`` radians
    on the limits' branch) gets its right hand onto its grip
    ``rel_pos (F,3)`` / ``rel_rot (F,4)`` in the left hand's frame.
    ``hips_*``: the global pose of the left chain's parent per frame."""
    F = local.shape[0]
    nl, nr = lj.shape[0], rj.shape[0]
    w = new_work(max(nl, nr))
    pose_l = new_pose(nl)
    pose_r = new_pose(nr)
    start_r = np.empty((nr, 4))
    keep = _new_keep(nl, nr)
    bat_moved = np.zeros(F)
    prev_ok = False
    for f in range(F):
        load_pose(pose_l, local[f], euler[f], lj)
        load_pose(pose_r, local[f], euler[f], rj)
        start_r[:] = pose_r.local
        _start_limits(L, pose_l)
        _start_limits(R, pose_r)
        g = GripFrame(q_at(hips_rot, f), v_at(hips_pos, f), v_at(rel_pos, f), q_at(rel_rot, f),
                      (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), tol, ori_tol, rp, rounds)
        bat0, d, oe = _grip_error(g, L, pose_l, R, pose_r, w)
        # the left hand (and so the bat) as the new motion turns it
        g = GripFrame(g.prot, g.ppos, g.rel_p, g.rel_q, bat0, q_at(w.g_rot, nl - 1), tol, ori_tol, rp, rounds)
        if not (vnorm(d) < tol and oe < ori_tol):
            pe, oe = _right_alone(g, L, pose_l, R, pose_r, start_r, keep, prev_ok, w)
            if pe > GRIP_CM or oe > GRIP_RAD:
                bat_moved[f] = _both_best(g, L, pose_l, R, pose_r, start_r, keep, prev_ok, w)
                store_local(pose_l, lj, local[f])
            store_local(pose_r, rj, local[f])
        keep.prev_er[:] = pose_r.euler
        prev_ok = True
    return bat_moved


def _solve_grips(rig: Rig, skeleton: Skeleton, clip: Clip, rel_pos: np.ndarray, rel_rot: np.ndarray,
                 tolerance: float) -> np.ndarray:
    """Right hand onto ``rel_pos (F,3)`` / ``rel_rot (F,4)`` (its grip in the left
    hand's frame) on every frame of ``clip``, in place. Returns the (F,) distance
    in cm the bat had to move."""
    left = chain_arrays(rig, "left_arm")
    right = chain_arrays(rig, "right_arm")
    rp = list(left.joints).index(right.parent)
    g_rot, g_pos = _fk(skeleton, clip)
    local = np.ascontiguousarray(clip.local_rotations, float)
    euler = np.ascontiguousarray(np.radians(limit_euler(local, rig.limits)))
    moved = _grip_frames(local, euler, np.ascontiguousarray(g_rot[:, left.parent]),
                         np.ascontiguousarray(g_pos[:, left.parent]), left.packed(), right.packed(),
                         np.ascontiguousarray(left.joints, np.int64), np.ascontiguousarray(right.joints, np.int64),
                         rp, np.ascontiguousarray(rel_pos, float), np.ascontiguousarray(rel_rot, float),
                         float(tolerance), ORIENT_TOL, BAT_GIVE_ROUNDS)
    clip.local_rotations[:] = local
    return moved


def _fk(skeleton: Skeleton, clip: Clip) -> tuple[np.ndarray, np.ndarray]:
    """:func:`engine.skeleton.clip_fk` by the compiled twin (the clean-up runs FK a dozen times)."""
    from .skeleton import compiled_fk
    return compiled_fk(skeleton.parents, local_translations(skeleton, clip), clip.local_rotations)


def _solve_leg(rig: Rig, skeleton: Skeleton, clip: Clip, chain_name: str, g_rot, g_pos, target, target_rot,
               sel) -> None:
    """Leg chain IK (compiled CCD, the rig's limits and DOFs) of the ``sel (F,)``
    frames toward ankle ``target (F,3)`` and foot orientation ``target_rot (F,4)``, in place."""
    ch = chain_arrays(rig, chain_name)
    local = np.ascontiguousarray(clip.local_rotations, float)
    euler = np.ascontiguousarray(np.radians(limit_euler(local, rig.limits)))
    a = int(ch.effector)
    lim = np.radians(rig.limits[a])
    foot = (rig.dof[a][None].copy(), np.ascontiguousarray(lim[None, :, 0]), np.ascontiguousarray(lim[None, :, 1]))
    _leg_frames(local, euler, np.ascontiguousarray(g_rot[:, ch.parent]), np.ascontiguousarray(g_pos[:, ch.parent]),
                np.ascontiguousarray(sel), ch.packed(), np.ascontiguousarray(ch.joints, np.int64), a, foot,
                np.ascontiguousarray(target, float), np.ascontiguousarray(target_rot, float), 1e-3)
    clip.local_rotations[:] = local
