"""The clean-up's compiled kernels (engine.cleanup calls them once per clip): the right hand
put back on its grip frame by frame (:func:`grip_frames`: the right arm alone from the
previous frame's answer, else both arms together, else the bat moved), and a leg chain's
ankle and foot onto their targets (:func:`leg_frames`)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .arms_nb import NO_FACE, both_arms_solve, both_fk
from .end_nb import GRIP_LENGTH, gather_chain, grip_solve, grip_target, orient_finish, scatter_chain
from .frames_nb import GRIP_CM, GRIP_RAD
from .ccd import ccd_frame, turn_joint
from .fk_nb import chain_fk
from .humerus_nb import held, open_window, release, sub_hold
from .step_nb import Chain, Scratch, scratch, with_limits
from .quat_nb import q_at, q_put, v_at, clamp_angle, widen_limits, from_euler_zyx, pick_branch, qconj, to_euler_zyx, q_angle, qmul, vadd, vnorm, vsub

BAT_GIVE_ROUNDS = 4             # times the bat may be moved toward a right hand that cannot reach
BAT_COST = 0.05                 # grip cm a cm of bat movement is worth when choosing between two-arm solutions
TURN_COST = 0.005               # ... and a degree of the bat turning
WARM_ITER = 80                  # Newton steps from the previous frame's right arm
KNEE_STRAIGHT = math.radians(0.5)   # a knee closer than this to straight ...
KNEE_BEND_MIN = math.radians(1.0)   # ... is bent, at least this far, before CCD shortens the leg


@njit(cache=True)
def leg_frames(local, euler, parent_rot, parent_pos, sel, leg, foot, target, target_rot, tol):
    """Each selected frame: the leg chain ``leg`` (hip, knee, ankle; the
    :data:`engine.step_nb.Chain`'s fields as a plain tuple) by CCD so the ankle reaches
    ``target (F,3)``, then the ankle joint turned toward ``target_rot (F,4)``
    (``foot`` = (ankle joint, free (1,3), lo (1,3), hi (1,3))); limits widened only
    to the start pose, locked columns kept. In place on ``local (F,J,4)``
    (``euler`` radians, limit branch)."""
    leg = Chain(*leg)
    lj, off, eoff, lo, hi = leg.joints, leg.offsets, leg.eff_off, leg.lo, leg.hi
    ankle, a_free, a_lo, a_hi = foot
    n = lj.shape[0]
    s = scratch(n)
    g_rot, g_pos = s.g_rot, s.g_pos
    loc = np.empty((n, 4))
    eul = np.empty((n, 3))
    src = np.empty((n, 3))
    lo_w = np.empty((n, 3))
    hi_w = np.empty((n, 3))
    ea = np.empty((1, 3))
    lo_a = np.empty((1, 3))
    hi_a = np.empty((1, 3))
    leg_w = with_limits(leg, lo_w, hi_w)      # (the frame's, filled below)
    for f in range(local.shape[0]):
        if not sel[f]:
            continue
        for k in range(n):
            for c in range(4):
                loc[k, c] = local[f, lj[k], c]
            for c in range(3):
                eul[k, c] = euler[f, lj[k], c]
        widen_limits(lo, hi, eul, lo_w, hi_w)
        src[:] = eul
        prot = (parent_rot[f, 0], parent_rot[f, 1], parent_rot[f, 2], parent_rot[f, 3])
        ppos = (parent_pos[f, 0], parent_pos[f, 1], parent_pos[f, 2])
        t = (target[f, 0], target[f, 1], target[f, 2])
        _unlock_knee(prot, ppos, leg_w, loc, eul, t, tol, s)
        ccd_frame(prot, ppos, leg_w, loc, eul, src, t, tol, 200, s)
        chain_fk(prot, ppos, off, eoff, loc, g_rot, g_pos)
        for k in range(n):
            for c in range(4):
                local[f, lj[k], c] = loc[k, c]
        # the foot: its target orientation in the new shin frame, within its limits
        for c in range(3):
            ea[0, c] = euler[f, ankle, c]
        widen_limits(a_lo, a_hi, ea, lo_a, hi_a)
        want = qmul(qconj(q_at(g_rot, n - 2)), (target_rot[f, 0], target_rot[f, 1], target_rot[f, 2],
                                                  target_rot[f, 3]))
        e = pick_branch(to_euler_zyx(want), ea, ea, a_free, lo_a, hi_a, 0)
        for c in range(3):
            ea[0, c] = clamp_angle(e[c], lo_a[0, c], hi_a[0, c]) if a_free[0, c] else ea[0, c]
        q = from_euler_zyx(ea[0, 0], ea[0, 1], ea[0, 2])
        for c in range(4):
            local[f, ankle, c] = q[c]

@njit(cache=True)
def _unlock_knee(prot, ppos, leg, loc, eul, target, tol, s):
    """A knee held straight (its free angles within KNEE_STRAIGHT of 0) with the target
    nearer the hip than the ankle: bent toward its wider side until the ankle is as far from
    the hip as the target, in place on ``loc`` / ``eul`` (the chain's local rotations and
    Euler angles), and the thigh turned to point the ankle at the target. From straight,
    no turn about the knee brings the ankle toward a target in line with the leg, and CCD
    left such a leg its whole length: a plant 3 cm nearer the hip stayed 3 cm off."""
    knee = 1
    col, room = -1, 0.0
    for c in range(3):
        if leg.free[knee, c]:
            if abs(eul[knee, c]) > KNEE_STRAIGHT:
                return
            wider = max(leg.hi[knee, c], -leg.lo[knee, c])
            if wider > room:
                col, room = c, wider
    if col < 0:
        return
    eff = chain_fk(prot, ppos, leg.offsets, leg.eff_off, loc, s.g_rot, s.g_pos)
    hip, knee_pos = v_at(s.g_pos, 0), v_at(s.g_pos, knee)
    now, want = vnorm(vsub(eff, hip)), vnorm(vsub(target, hip))
    if want > now - tol:
        return
    # the bend that brings the ankle to the target's distance from the hip (the angle at
    # the knee between thigh and shin, by the law of cosines, against the leg's as it is)
    a, b = vnorm(vsub(knee_pos, hip)), vnorm(vsub(eff, knee_pos))
    if a < tol or b < tol:
        return
    want = max(want, abs(a - b) + tol)
    bend = math.acos(max(-1.0, min(1.0, (a * a + b * b - now * now) / (2 * a * b))))
    bend -= math.acos(max(-1.0, min(1.0, (a * a + b * b - want * want) / (2 * a * b))))
    bend = min(max(bend, KNEE_BEND_MIN), room)
    eul[knee, col] = bend if leg.hi[knee, col] >= -leg.lo[knee, col] else -bend
    q_put(loc, knee, from_euler_zyx(eul[knee, 0], eul[knee, 1], eul[knee, 2]))
    # and the thigh turned so the ankle points at the target (CCD turns the knee first, and
    # would straighten it again toward a target still in line with the thigh)
    eff = chain_fk(prot, ppos, leg.offsets, leg.eff_off, loc, s.g_rot, s.g_pos)
    turned, hip_local = turn_joint(prot, q_at(s.g_rot, 0), vsub(eff, hip), vsub(target, hip), eul, eul, leg.free,
                                   leg.lo, leg.hi, 0)
    if turned:
        q_put(loc, 0, hip_local)


@njit(cache=True)
def _grip_error(prot, ppos, arms, loc_l, loc_r, bufs, rel_p, rel_q):
    """FK of both arms (engine.arms_nb.both_fk): (bat, right hand minus its grip target (3,),
    angle error rad)."""
    bat, rh, _, t_pos, t_rot = both_fk(prot, ppos, arms, loc_l, loc_r, bufs, rel_p, rel_q)
    return bat, vsub(rh, t_pos), q_angle(q_at(bufs[2], loc_r.shape[0] - 1), t_rot)

@njit(cache=True)
def _warm_right(loc_r, eul_r, prev_er, src_r, free, lo, hi):
    """The right arm's free angles from the previous frame (within this frame's
    limits), its locked ones this frame's."""
    for k in range(loc_r.shape[0]):
        for c in range(3):
            eul_r[k, c] = clamp_angle(prev_er[k, c], lo[k, c], hi[k, c]) if free[k, c] else src_r[k, c]
        q_put(loc_r, k, from_euler_zyx(eul_r[k, 0], eul_r[k, 1], eul_r[k, 2]))

@njit(cache=True)
def _two_arms(prot, ppos, bat0, lh0, hold, arms, free, pose, limits, rel, tols, bufs, works):
    """Both arms onto bat and grip from the given start (in place); where the
    grip is still out of reach, the bat is moved by what is missing and the
    solve runs again (``rounds`` times at most). With ``hold``, the torso keeps
    that lean and the left arm below it puts the bat back to its place and
    the left hand to its orientation ``lh0`` (the two-arm solve holds the bat
    only by one point, so it may turn it). Then the right arm alone polishes
    the grip on the final left hand. Returns a score: the grip error (cm, with
    10 cm per radian) plus BAT_COST per cm the bat moved and TURN_COST per
    degree it turned. arms, free, pose, limits as engine.arms_nb.both_arms_solve's;
    rel = the grip in the left hand's frame (position, rotation); tols = (tol cm,
    orientation tol rad, rounds); bufs as engine.arms_nb.both_fk's; works = the grip
    solves' work of the left arm below the torso and of the right arm."""
    l_off, l_eoff, r_off, r_eoff, rp = arms[0], arms[1], arms[2], arms[3], arms[4]
    loc_l, loc_r, eul = pose
    lo, hi = limits
    rel_p, rel_q = rel
    tol, ori_tol, rounds = tols
    g_rot, g_pos = bufs[0], bufs[1]
    nl = l_off.shape[0]
    handle = bat0
    for _ in range(rounds):
        both_arms_solve(prot, ppos, arms, free, pose, limits, (handle, NO_FACE, rel_p, rel_q), tol, ori_tol, 40, 1.0)
        bat, d, oe = _grip_error(prot, ppos, arms, loc_l, loc_r, bufs, rel_p, rel_q)
        if vnorm(d) < GRIP_CM and oe < GRIP_RAD:
            break
        handle = vadd(bat, d)
    chain_fk(prot, ppos, l_off, l_eoff, loc_l, g_rot, g_pos)
    if hold:
        a = rp + 1
        grip_solve(q_at(g_rot, rp), v_at(g_pos, rp), l_off[a:], l_eoff, loc_l[a:], eul[a:nl], free[0][a:],
                   lo[a:nl], hi[a:nl], sub_hold(arms[5], a), handle, lh0, tol, ori_tol, 40, works[0])
        chain_fk(prot, ppos, l_off, l_eoff, loc_l, g_rot, g_pos)
    t_pos, t_rot = grip_target(q_at(g_rot, nl - 1), v_at(g_pos, nl - 1), rel_p, rel_q)
    grip_solve(q_at(g_rot, rp), v_at(g_pos, rp), r_off, r_eoff, loc_r, eul[nl:], free[1], lo[nl:], hi[nl:],
               arms[6], t_pos, t_rot, tol, ori_tol, 30, works[1])
    bat, d, oe = _grip_error(prot, ppos, arms, loc_l, loc_r, bufs, rel_p, rel_q)
    turn = math.degrees(q_angle(q_at(g_rot, nl - 1), lh0))
    return vnorm(d) + GRIP_LENGTH * oe + BAT_COST * vnorm(vsub(bat, bat0)) + TURN_COST * turn

@njit(cache=True, inline='always')
def _arm_alone(pr, pp, target, arm_r, pose_r, warm, tols, s_r, work_r):
    """The right arm alone onto its grip ``target`` (position, rotation) from the frame's
    pose, in place on pose_r = (local (nr,4), Euler (nr,3), the frame's Euler angles and
    local rotations). Frames follow each other: first from the previous frame's answer
    (warm = (there is one, its Euler angles)), so the arm moves smoothly instead of
    jumping between the several poses that hold the grip; else wrist position, the
    joints that only turn the hand, both. Returns the grip's (position, angle) error.
    Inlined (one call a frame): a call passing its twenty arrays costs."""
    loc_r, eul_r, src_r, frame_r = pose_r
    prev_ok, prev_er = warm
    t_pos, t_rot = target
    tol, ori_tol, _ = tols
    off, eoff, free, lo, hi, hold = arm_r.offsets, arm_r.eff_off, arm_r.free, arm_r.lo, arm_r.hi, arm_r.hold
    pe = 1e300
    oe = 1e300
    if prev_ok:
        _warm_right(loc_r, eul_r, prev_er, src_r, free, lo, hi)
        pe, oe = grip_solve(pr, pp, off, eoff, loc_r, eul_r, free, lo, hi, hold, t_pos, t_rot, tol, ori_tol,
                            WARM_ITER, work_r)
    if pe > GRIP_CM or oe > GRIP_RAD:
        loc_r[:] = frame_r
        eul_r[:] = src_r
        ccd_frame(pr, pp, arm_r, loc_r, eul_r, src_r, t_pos, tol, 200, s_r)
        orient_finish(pr, pp, off, eoff, loc_r, eul_r, src_r, free, arm_r.kind, lo, hi, hold, t_rot,
                      (work_r[0], work_r[1]), 8, ori_tol)
        pe, oe = grip_solve(pr, pp, off, eoff, loc_r, eul_r, free, lo, hi, hold, t_pos, t_rot, tol, ori_tol, 30,
                            work_r)
    return pe, oe

@njit(cache=True)
def _arms_together(prot, ppos, start, arms, free, pose, limits, rel, tols, bufs, works, keep, warm):
    """Out of the right arm's reach: both arms together (:func:`_two_arms`: the torso
    leans, the left arm gives), from a few starts for the right arm: the previous frame's
    answer (warm as :func:`_arm_alone`'s), where the arm-alone solve left it, the frame's
    pose; the closest grip wins, in place on ``pose``. start = (the bat, the left hand's
    rotation) the frame began with; keep: work buffers (start_l, start_el, ccd_r, ccd_er,
    best_l, best_r, best_er, the frame's right local rotations and Euler angles)."""
    loc_l, loc_r, eul = pose
    lo, hi = limits
    nl = loc_l.shape[0]
    eul_l, eul_r = eul[:nl], eul[nl:]
    start_l, start_el, ccd_r, ccd_er, best_l, best_r, best_er, frame_r, src_r = keep
    prev_ok, prev_er = warm
    start_l[:] = loc_l
    start_el[:] = eul_l
    best = 1e300
    ccd_r[:] = loc_r
    ccd_er[:] = eul_r
    for attempt in range(6):
        trial = attempt // 2
        loc_l[:] = start_l
        eul_l[:] = start_el
        if trial == 0:
            if not prev_ok:
                continue
            _warm_right(loc_r, eul_r, prev_er, src_r, free[1], lo[nl:], hi[nl:])
        elif trial == 1:
            loc_r[:] = ccd_r
            eul_r[:] = ccd_er
        else:
            loc_r[:] = frame_r
            eul_r[:] = src_r
        score = _two_arms(prot, ppos, start[0], start[1], attempt % 2 == 0, arms, free, pose, limits, rel, tols,
                          bufs, works)
        if score < best:
            best = score
            best_l[:] = loc_l
            best_r[:] = loc_r
            best_er[:] = eul_r
        if score < GRIP_CM + GRIP_LENGTH * GRIP_RAD:
            break
    loc_l[:] = best_l
    loc_r[:] = best_r
    eul_r[:] = best_er

@njit(cache=True)
def grip_frames(local, euler, hips, left, right, rp, rel_pos, rel_rot, tols):
    """Every frame of ``local (F,J,4)`` (in place; ``euler (F,J,3)`` radians
    on the limits' branch) gets its right hand onto its grip
    ``rel_pos (F,3)`` / ``rel_rot (F,4)`` in the left hand's frame.
    ``hips`` = (rotations (F,4), positions (F,3)): the global pose of the left chain's
    parent per frame; left, right: the arm chains (the :data:`engine.step_nb.Chain`'s
    fields as plain tuples); tols = (tol cm, orientation tol rad, rounds)."""
    left = Chain(*left)
    right = Chain(*right)
    lj, rj = left.joints, right.joints
    nl, nr = lj.shape[0], rj.shape[0]
    nmax = max(nl, nr)
    tol, ori_tol = tols[0], tols[1]
    bufs = (np.empty((nmax, 4)), np.empty((nmax, 3)), np.empty((nr, 4)), np.empty((nr, 3)))
    s_r = Scratch(bufs[2], bufs[3], np.empty((3 * nmax, 3)), np.empty((3 * nmax, 2), np.int64),
                  np.empty((nmax, 4)), np.empty((nmax, 3)))
    step6 = (np.empty((3 * nmax, 7)), s_r.dofs, np.empty((6, 6)), np.empty(6), np.empty(6), s_r.bak_l, s_r.bak_e)
    works = ((np.empty((nl, 4)), np.empty((nl, 3))) + step6, (bufs[2], bufs[3]) + step6)
    loc_l, loc_r = np.empty((nl, 4)), np.empty((nr, 4))
    eul, lo, hi = np.empty((nl + nr, 3)), np.empty((nl + nr, 3)), np.empty((nl + nr, 3))
    eul_l, eul_r = eul[:nl], eul[nl:]
    src_r, frame_r, prev_er = np.empty((nr, 3)), np.empty((nr, 4)), np.empty((nr, 3))
    keep = (np.empty((nl, 4)), np.empty((nl, 3)), np.empty((nr, 4)), np.empty((nr, 3)), np.empty((nl, 4)),
            np.empty((nr, 4)), np.empty((nr, 3)), frame_r, src_r)
    release(left.hold)          # the left arm moves here only with the torso's help, free
    arms = (left.offsets, left.eff_off, right.offsets, right.eff_off, rp, left.hold, right.hold)
    arm_r = with_limits(right, lo[nl:], hi[nl:])    # (the frame's limits, filled below)
    bat_moved = np.zeros(local.shape[0])
    prev_ok = 0
    for f in range(local.shape[0]):
        gather_chain(local[f], lj, loc_l)
        gather_chain(euler[f], lj, eul_l)
        gather_chain(local[f], rj, loc_r)
        gather_chain(euler[f], rj, eul_r)
        widen_limits(left.lo, left.hi, eul_l, lo[:nl], hi[:nl])
        widen_limits(right.lo, right.hi, eul_r, lo[nl:], hi[nl:])
        open_window(loc_r, right.hold)
        src_r[:] = eul_r
        frame_r[:] = loc_r
        prot, ppos = q_at(hips[0], f), v_at(hips[1], f)
        rel = (v_at(rel_pos, f), q_at(rel_rot, f))
        bat0, d, oe = _grip_error(prot, ppos, arms, loc_l, loc_r, bufs, rel[0], rel[1])
        lh0 = q_at(bufs[0], nl - 1)      # the left hand (and so the bat) as the new motion turns it
        if not (vnorm(d) < tol and oe < ori_tol):
            target = grip_target(lh0, v_at(bufs[1], nl - 1), rel[0], rel[1])
            pe, oe = _arm_alone(q_at(bufs[0], rp), v_at(bufs[1], rp), target, arm_r, (loc_r, eul_r, src_r, frame_r),
                                (prev_ok, prev_er), tols, s_r, works[1])
            if (pe > GRIP_CM or oe > GRIP_RAD) and held(right.hold):
                # the humerus held keeps the hand off its grip: let it go (and the torso's help runs free)
                release(right.hold)
                loc_r[:] = frame_r
                eul_r[:] = src_r
                pe, oe = _arm_alone(q_at(bufs[0], rp), v_at(bufs[1], rp), target, arm_r,
                                    (loc_r, eul_r, src_r, frame_r), (prev_ok, prev_er), tols, s_r, works[1])
            if pe > GRIP_CM or oe > GRIP_RAD:
                _arms_together(prot, ppos, (bat0, lh0), arms, (left.free, right.free), (loc_l, loc_r, eul),
                               (lo, hi), rel, tols, bufs, works, keep, (prev_ok, prev_er))
                bat = chain_fk(prot, ppos, left.offsets, left.eff_off, loc_l, bufs[0], bufs[1])
                bat_moved[f] = vnorm(vsub(bat, bat0))
                scatter_chain(loc_l, lj, local[f])
            scatter_chain(loc_r, rj, local[f])
        prev_er[:] = eul_r
        prev_ok = 1
    return bat_moved

