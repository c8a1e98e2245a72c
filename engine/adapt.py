"""Adapt a whole shot so the bat meets the ball at a new hit point (dissertation 2.2).

At the hit frame h the offset from the FK bat joint to the desired point P is
taken into bat-joint space (2.2.4): ``offset_local = R(h)^T (P - b(h))``. Every
frame is fully IK, with the handle ``b(f) + blend(f) R(f) offset_local`` and
``blend(f) = clamp(1 - |b(f) - b(h)| / falloff, 0, 1)`` (2.2.5), so blend 0
gives back the source pose exactly. The left-arm chain (Spine .. LeftHand,
effector Bat) is solved for position; the right hand is put back on its source
grip relative to the new left hand (2.2.2) by solving the right-arm chain for
the wrist position, then turning the trailing joints that do not move the wrist
(forearm twist, hand) for its orientation.

All frames are solved by one compiled call (:func:`_adapt_frames`); a single
frame for scrubbing uses the same call with one frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import njit

from . import quat
from .ccd import ITERATIONS, KIND_MULTI, KIND_NONE, TOLERANCE, ChainArrays, ccd_frame, chain_arrays, limit_euler
from .fk_nb import chain_fk, tree_fk
from .quat_nb import q_at, q_put, v_at, v_put, cross, dot, clamp_angle, from_euler_zyx, pick_branch, q_angle, qconj, qmul, qrot, to_euler_zyx, vadd, vnorm, vsub, widen_limits
from .dls import DAMPING, default_stiffness, dls_frame
from .skeleton import local_translations, relative_pose
from .step_nb import MAX_STEP, NO, Chain, copy_rows, hinge_axis, lm_eval, lm_loop, lm_parts, scratch

ORIENT_TOL = 1e-4       # rad: the right hand's orientation is "there"
GRIP_LENGTH = 10.0      # cm per radian: weighs the right hand's orientation against its position
GRIP_CM = 0.05          # right hand further than this from its grip ...
GRIP_RAD = math.radians(0.5)  # ... or turned more than this: solve both arms together
FACE_LENGTH = 30.0      # cm per unit of face-normal error: weighs the bat face against its position
FACE_TOL = math.radians(0.05)  # the face is "there" (chord of the unit normals ~ angle)
FACE_ITER = 30          # Newton steps at most (crawling along a limit: as near as it gets)
FACES = ("keep", "free")
NO_FACE = (0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # both_arms_solve's face term, off
BAT_WEIGHT = 10.0       # the two-arm solve: the bat on the ball matters most
END_LM = (0.5, 0.05, 1e4, NO)  # the grip, face and two-arm solves' damping: start, least, cap; an undo does not end
END_ROWS = np.int64(6)  # rows of the grip and face solves (an int64, not a literal: one compiled step)
SOLVERS = ("ccd", "dls")
TWISTS = ("follow", "lead")
TWIST_COLUMN = 2        # ZYX Euler columns z, y, x: x is the twist about the bone in the arms


def face_weights(n: int, torso: int) -> np.ndarray:
    """Weights (1 / stiffness) of the chain's joints, root-most first, in the face-keeping
    solve (dissertation 1.10, 4.2): rising toward the hand (squared), so the roll joints
    turn the face first, and a tenth of that for the ``torso`` joints at the chain's root
    (up to the one the right arm hangs from), which turn only where the arm's limits cannot.
    Measured over the 135 offsets of ``analyse --directions``: the spine's largest angle
    change at the hit frame median 4.2 deg (position only 4.1; the torso at the arm's
    weights 5.7, the arm alone then the torso 4.3 at 1.4x the time)."""
    w = np.linspace(0.25, 1.0, n) ** 2
    w[:torso] *= 0.1
    return np.ascontiguousarray(w)


def twist_only(free: np.ndarray) -> np.ndarray:
    """(n,) bool: the chain joints ``free (n, 3)`` whose one free axis is the twist."""
    return (free.sum(axis=1) == 1) & free[:, TWIST_COLUMN]


@dataclass
class AdaptSettings:
    falloff: float = 90.0        # cm
    wrist_dof: int = 0           # 0 (locked, default) or 2
    solver: str = "ccd"          # "ccd" | "dls"
    iterations: int = ITERATIONS
    tolerance: float = TOLERANCE     # cm
    fix_right_hand: bool = True
    # CCD only. "follow": the left arm's twist-only (roll) joints keep the source's twist
    # and the swing joints reach the ball; "lead": CCD turns them too, which spins the bat
    # about its handle (9 shots x 15 offsets, wrist locked: face turned up to 153 deg, p90
    # 30, against 40 and 25 when they follow). DLS spreads the motion by its stiffness
    # weights and keeps the face already (max 34 deg), and needs the twist to reach.
    twist: str = "follow"
    # "keep": after the position solve, damped Newton on the bat's position and face
    # normal turns the face back to the source's at the hit frame (the other adapted frames
    # toward it by the importance blend); "free": position only.
    face: str = "keep"
    # kept face: degrees it turns (about the vertical, carried by the blend) per cm the hit
    # point moves toward the off side, so the ball goes further that way (Fig. 2.6)
    face_turn: float = 0.1
    # kept face: degrees it tilts up (+) or down at the hit (carried by the blend): the
    # ball's elevation (engine.direction)
    face_tilt: float = 0.0
    # kept face: degrees it turns about the vertical at the hit (+ toward the off side,
    # carried by the blend), on top of face_turn: the ball's azimuth (engine.direction)
    face_yaw: float = 0.0


@dataclass
class Adaptation:                # whole adapted shot
    root_positions: np.ndarray   # (F,3)
    local_rotations: np.ndarray  # (F,J,4)
    global_rotations: np.ndarray  # (F,J,4)
    global_positions: np.ndarray  # (F,J,3)
    blend: np.ndarray            # (F,)
    handles: np.ndarray          # (F,3) IK handle per frame
    desired_hit_point: np.ndarray  # (3,)
    bat_error_cm: float          # |bat - desired| at the hit frame
    grip_error_cm: np.ndarray    # (F,) right hand position error vs source grip
    grip_error_deg: np.ndarray   # (F,)


# --------------------------------------------------------------------------
# compiled per-frame pipeline

@njit(cache=True)
def orient_finish(prot, ppos, offsets, eff_off, local, euler, src_euler, free, kind, lo, hi,
                  target_rot, g_rot, g_pos, reps, ori_tol):
    """Turn the trailing chain joints that leave the effector where it is (the
    effector's own joint, a twist about the bone it lies on) so the last
    joint's global rotation approaches target_rot. Returns the angle error (rad)."""
    n = offsets.shape[0]
    eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
    err = q_angle(q_at(g_rot, n - 1), target_rot)
    for _ in range(reps):
        if err < ori_tol:
            break
        for k in range(n - 1, -1, -1):
            kd = kind[k]
            if kd == KIND_NONE:
                continue
            u = vsub(eff, v_at(g_pos, k))
            gp = prot if k == 0 else q_at(g_rot, k - 1)
            last = q_at(g_rot, n - 1)
            if kd == KIND_MULTI:
                if vnorm(u) > 1e-6:
                    break
                # the joint's global rotation that would put the last joint on target
                want = qmul(target_rot, qmul(qconj(last), q_at(g_rot, k)))
                e = pick_branch(to_euler_zyx(qmul(qconj(gp), want)), euler, src_euler, free, lo, hi, k)
                for c in range(3):
                    if free[k, c]:
                        euler[k, c] = clamp_angle(e[c], lo[k, c], hi[k, c])
                    else:
                        euler[k, c] = src_euler[k, c]
            else:
                c = kd - 1
                axis = hinge_axis(prot, g_rot, euler, k, c)
                du = dot(u, axis)
                if vnorm((u[0] - du * axis[0], u[1] - du * axis[1], u[2] - du * axis[2])) > 1e-6:
                    break
                # twist of the remaining error about the hinge axis
                qe = qmul(target_rot, qconj(last))
                if qe[0] < 0.0:
                    qe = (-qe[0], -qe[1], -qe[2], -qe[3])
                theta = 2.0 * math.atan2(qe[1] * axis[0] + qe[2] * axis[1] + qe[3] * axis[2], qe[0])
                euler[k, c] = clamp_angle(euler[k, c] + theta, lo[k, c], hi[k, c])
            q_put(local, k, from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2]))
            eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
        err = q_angle(q_at(g_rot, n - 1), target_rot)
    return err


@njit(cache=True)
def _grip_residual(eff, last, target_pos, target_rot, length, r):
    """6-vector residual (position cm, rotation vector * length) into r; returns its norm."""
    qe = qmul(target_rot, qconj(last))
    if qe[0] < 0.0:
        qe = (-qe[0], -qe[1], -qe[2], -qe[3])
    sv = math.sqrt(qe[1] * qe[1] + qe[2] * qe[2] + qe[3] * qe[3])
    scale = 0.0 if sv < 1e-15 else 2.0 * math.atan2(sv, qe[0]) / sv * length
    r[0] = target_pos[0] - eff[0]
    r[1] = target_pos[1] - eff[1]
    r[2] = target_pos[2] - eff[2]
    r[3] = qe[1] * scale
    r[4] = qe[2] * scale
    r[5] = qe[3] * scale
    t = 0.0
    for i in range(6):
        t += r[i] * r[i]
    return math.sqrt(t)


@njit(cache=True)
def lsq_apply(cols, dofs, m, R, r, euler, lo, hi, damping, max_step, A, x):
    """Damped least squares on the first R rows of the m columns ``cols (m, >R)`` of the
    Euler angles ``dofs (m, 2)`` (row of ``euler``, column), applied to ``euler`` in place:
    ``d = W J^T (J W J^T + damping^2 I)^-1 r`` with the Jacobian's columns already scaled
    by sqrt(W) and sqrt(W) in the last column of ``cols`` (per-joint stiffness 1/W); the
    largest change capped at ``max_step``, a column that would cross its limit clamped
    there and frozen and the rest re-solved (up to three rounds). The one step of the
    grip, face and two-arm solves (engine.step_nb.jacobian_step is its 3-row twin, kept
    in registers for the position solves)."""
    wc = cols.shape[1] - 1
    for _round in range(3):
        for i in range(R):
            for j in range(R):
                A[i, j] = damping * damping if i == j else 0.0
        for q in range(m):
            if dofs[q, 0] < 0:
                continue
            for i in range(R):
                ci = cols[q, i]
                if ci != 0.0:
                    for j in range(R):
                        A[i, j] += ci * cols[q, j]
        _solve_spd(A, r, x, R)
        biggest = 0.0
        for q in range(m):
            if dofs[q, 0] >= 0:
                d = 0.0
                for i in range(R):
                    d += cols[q, i] * x[i]
                biggest = max(biggest, abs(d * cols[q, wc]))
        scale = 1.0 if biggest <= max_step else max_step / biggest
        clamped = False
        for q in range(m):
            if dofs[q, 0] < 0:
                continue
            k = dofs[q, 0]
            c = dofs[q, 1]
            d = 0.0
            for i in range(R):
                d += cols[q, i] * x[i]
            want = euler[k, c] + d * cols[q, wc] * scale
            got = clamp_angle(want, lo[k, c], hi[k, c])
            if got != want:
                gd = (got - euler[k, c]) / cols[q, wc]
                euler[k, c] = got
                for i in range(R):
                    r[i] -= cols[q, i] * gd
                dofs[q, 0] = -1
                clamped = True
        if not clamped:
            for q in range(m):
                if dofs[q, 0] < 0:
                    continue
                d = 0.0
                for i in range(R):
                    d += cols[q, i] * x[i]
                euler[dofs[q, 0], dofs[q, 1]] += d * cols[q, wc] * scale
            break


@njit(cache=True, inline='always')
def put_free_locals(local, euler, free):
    """The local rotations of the joints with a free column from their Euler angles."""
    for k in range(local.shape[0]):
        if free[k, 0] or free[k, 1] or free[k, 2]:
            q_put(local, k, from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2]))


@njit(cache=True, inline='always')
def gather_chain(pose, joints, out):
    """The chain joints' rows of one pose ``pose (J, w)`` into ``out (n, w)``."""
    for k in range(joints.shape[0]):
        for c in range(out.shape[1]):
            out[k, c] = pose[joints[k], c]


@njit(cache=True, inline='always')
def scatter_chain(rows, joints, pose):
    """The chain joints' rows ``rows (n, w)`` into one pose ``pose (J, w)``."""
    for k in range(joints.shape[0]):
        for c in range(rows.shape[1]):
            pose[joints[k], c] = rows[k, c]


@njit(cache=True)
def _face_residual(eff, normal, target_pos, target_n, length, r):
    """6-vector residual (position cm, face normal difference * length) into r; returns its norm."""
    t = 0.0
    for i in range(3):
        r[i] = target_pos[i] - eff[i]
        r[3 + i] = length * (target_n[i] - normal[i])
        t += r[i] * r[i] + r[3 + i] * r[3 + i]
    return math.sqrt(t)


@njit(cache=True)
def _end_residual(goal, eff, last, r):
    """The 6-residual of the chain's end against ``goal`` into r: (its norm, position
    error cm, turn error). goal = (face, target_pos, target_rot, target_n, n_last, length):
    the effector's position and the last joint's whole rotation (face False: rotation
    vector * length, error in rad), or its face normal (face True: the normal ``n_last``
    in the last joint's frame onto ``target_n``, difference * length, error its chord)."""
    face, target_pos, target_rot, target_n, n_last, length = goal
    if face:
        nrm = qrot(last, n_last)
        res = _face_residual(eff, nrm, target_pos, target_n, length, r)
        turn = vnorm(vsub(nrm, target_n))
    else:
        res = _grip_residual(eff, last, target_pos, target_rot, length, r)
        turn = q_angle(last, target_rot)
    return res, vnorm(vsub(eff, target_pos)), turn


@njit(cache=True)
def _end_columns(prot, g_rot, g_pos, euler, free, weight, eff, goal, cols, dofs):
    """Jacobian columns (scaled by sqrt(weight), sqrt(weight) in column 6) of the free
    Euler angles with a weight against :func:`_end_residual`'s rows; returns how many."""
    face, _p, _q, _t, n_last, length = goal
    n = euler.shape[0]
    nrm = qrot(q_at(g_rot, n - 1), n_last)
    m = 0
    for k in range(n):
        for c in range(3):
            if free[k, c] and weight[k] > 0.0:
                a = hinge_axis(prot, g_rot, euler, k, c)
                cp = cross(a, vsub(eff, v_at(g_pos, k)))
                turn = cross(a, nrm) if face else a
                sw = math.sqrt(weight[k])
                for i in range(3):
                    cols[m, i] = sw * cp[i]
                    cols[m, 3 + i] = sw * length * turn[i]
                cols[m, 6] = sw
                dofs[m, 0] = k
                dofs[m, 1] = c
                m += 1
    return m


class EndProblem(NamedTuple):
    """The chain's end onto ``goal`` (:func:`_end_residual`): the grip and face solves'
    problem of :func:`engine.step_nb.lm_loop`, stepped by :func:`lsq_apply` on
    :func:`_end_columns`. State (residual norm, effector (3,), position error cm, turn
    error)."""
    prot: tuple         # (4,) the chain root's parent's global rotation
    ppos: tuple         # (3,) and position, cm
    offsets: np.ndarray  # (n,3) the chain joints' local translations, cm
    eff_off: np.ndarray  # (3,) the effector in the last joint's frame, cm
    local: np.ndarray   # (n,4) the chain's local rotations, in place
    euler: np.ndarray   # (n,3) their Euler angles, radians, in place
    free: np.ndarray    # (n,3) bool: the Euler columns a step may move
    weight: np.ndarray  # (n,) 1 / stiffness (0: held)
    lo: np.ndarray      # (n,3) radians
    hi: np.ndarray      # (n,3) radians
    goal: tuple         # as _end_residual's
    tol: float          # cm
    ori_tol: float      # the turn error's tolerance
    work: tuple         # (g_rot, g_pos, cols (3n,7), dofs, A (6,6), x, r, bak_l, bak_e)


# (the parts read the problem's fields before calling anything: see engine.step_nb)

def _end_save(problem):
    local, euler, bak_l, bak_e = problem.local, problem.euler, problem.work[7], problem.work[8]
    copy_rows(local, bak_l)
    copy_rows(euler, bak_e)


def _end_restore(problem):
    local, euler, bak_l, bak_e = problem.local, problem.euler, problem.work[7], problem.work[8]
    copy_rows(bak_l, local)
    copy_rows(bak_e, euler)


def _end_step(problem, state, damping):
    prot, local, euler, free, weight, goal = (problem.prot, problem.local, problem.euler, problem.free,
                                              problem.weight, problem.goal)
    lo, hi = problem.lo, problem.hi
    g_rot, g_pos, cols, dofs, A, x, r, _, _ = problem.work
    m = _end_columns(prot, g_rot, g_pos, euler, free, weight, state[1], goal, cols, dofs)
    lsq_apply(cols, dofs, m, END_ROWS, r, euler, lo, hi, damping, MAX_STEP, A, x)
    put_free_locals(local, euler, free)


def _end_eval(problem):
    prot, ppos, offsets, eff_off, local, goal = (problem.prot, problem.ppos, problem.offsets, problem.eff_off,
                                                 problem.local, problem.goal)
    g_rot, g_pos, r = problem.work[0], problem.work[1], problem.work[6]
    eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
    res, pe, oe = _end_residual(goal, eff, q_at(g_rot, local.shape[0] - 1), r)
    return res, eff, pe, oe


def _end_done(problem, state):
    # & not `and`: a short circuit in an inlined part warns (NumbaIRAssumptionWarning)
    return (state[2] < problem.tol) & (state[3] < problem.ori_tol)


lm_parts(EndProblem, _end_save, _end_restore, _end_step, _end_eval, _end_done)


@njit(cache=True, inline='always')
def _end_solve(problem, max_iter, stall):
    """Damped Newton (Levenberg-Marquardt, :func:`engine.step_nb.lm_loop`) on
    :func:`_end_residual` from the current pose; a step that does not help is undone and
    damped harder; stops when both errors are in tolerance or a step gains less than
    ``stall`` of the residual (held by a limit). Returns (position error cm, turn error)."""
    (_, _, pe, oe), _ = lm_loop(problem, lm_eval(problem), END_LM, (max_iter, 0.0, stall, NO))
    return pe, oe


@njit(cache=True)
def grip_solve(prot, ppos, offsets, eff_off, local, euler, free, lo, hi, target_pos, target_rot,
               tol, ori_tol, max_iter, work):
    """Damped Newton on position and orientation of the chain's last joint
    from the current pose (after the position solve and the twist/hand finish
    could not get the orientation); work as :class:`EndProblem`'s. Returns
    (position error, angle error)."""
    goal = (False, (target_pos[0], target_pos[1], target_pos[2]),
            (target_rot[0], target_rot[1], target_rot[2], target_rot[3]), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
            GRIP_LENGTH)
    return _end_solve(EndProblem(prot, ppos, offsets, eff_off, local, euler, free, np.ones(offsets.shape[0]), lo, hi,
                                 goal, tol, ori_tol, work), max_iter, 1e-3)


@njit(cache=True)
def face_solve(prot, ppos, offsets, eff_off, local, euler, free, weight, lo, hi, target_pos, target_n,
               n_last, tol, max_iter, work):
    """Damped Newton on the effector's position AND the bat face: the normal
    ``n_last`` (in the last chain joint's frame) turned onto the world ``target_n``,
    from the current (position-solved) pose, by the free joints with a weight
    (1 / stiffness; 0: held); the roll joints, which position-only CCD leaves alone,
    turn the face back. work as :class:`EndProblem`'s. Returns (position error cm,
    face error: the chord between the unit normals, ~rad)."""
    goal = (True, (target_pos[0], target_pos[1], target_pos[2]), (1.0, 0.0, 0.0, 0.0),
            (target_n[0], target_n[1], target_n[2]), (n_last[0], n_last[1], n_last[2]), FACE_LENGTH)
    return _end_solve(EndProblem(prot, ppos, offsets, eff_off, local, euler, free, weight, lo, hi, goal, tol,
                                 FACE_TOL, work), max_iter, 1e-4)


@njit(cache=True)
def _solve_spd(A, r, x, R):
    """Solve A x = r for a symmetric positive definite R x R matrix (A is overwritten)."""
    for i in range(R):
        for j in range(i + 1):
            t = A[i, j]
            for k in range(j):
                t -= A[i, k] * A[j, k]
            if i == j:
                A[i, i] = math.sqrt(max(t, 1e-300))
            else:
                A[i, j] = t / A[j, j]
    for i in range(R):
        t = r[i]
        for k in range(i):
            t -= A[i, k] * x[k]
        x[i] = t / A[i, i]
    for i in range(R - 1, -1, -1):
        t = x[i]
        for k in range(i + 1, R):
            t -= A[k, i] * x[k]
        x[i] = t / A[i, i]


@njit(cache=True, inline='always')
def grip_target(g_lh, p_lh, rel_p, rel_q):
    """The right hand's grip (position, rotation) carried by the left hand's global
    rotation ``g_lh`` and position ``p_lh``: engine.skeleton.carried_pose, compiled."""
    return vadd(p_lh, qrot(g_lh, rel_p)), qmul(g_lh, rel_q)


@njit(cache=True, inline='always')
def both_fk(prot, ppos, arms, loc_l, loc_r, bufs, rel_p, rel_q):
    """FK of both arm chains into ``bufs`` = (left g_rot, g_pos, right g_rot, g_pos);
    arms = (left offsets, left effector offset, right offsets, right effector offset, rp:
    the left chain's joint the right arm hangs from). Returns (bat, right hand, the left
    hand's rotation, the grip's target position, its rotation)."""
    l_off, l_eoff, r_off, r_eoff, rp = arms
    gl_rot, gl_pos, gr_rot, gr_pos = bufs
    nl = l_off.shape[0]
    bat = chain_fk(prot, ppos, l_off, l_eoff, loc_l, gl_rot, gl_pos)
    rh = chain_fk(q_at(gl_rot, rp), v_at(gl_pos, rp), r_off, r_eoff, loc_r, gr_rot, gr_pos)
    g_lh = q_at(gl_rot, nl - 1)
    t_pos, t_rot = grip_target(g_lh, v_at(gl_pos, nl - 1), rel_p, rel_q)
    return bat, rh, g_lh, t_pos, t_rot


@njit(cache=True)
def _both_residual(prot, ppos, arms, loc_l, loc_r, bufs, goal, r):
    """FK of both arms (:func:`both_fk`) and the 12-residual (bat, grip position, grip
    rotation, bat face) into r against goal = (handle, face, rel_p, rel_q), ``face`` =
    (weight, target normal, normal in the left hand's frame), weight 0: no face;
    returns (bat, grip target position, the residual's norm)."""
    handle, face, rel_p, rel_q = goal
    nr = loc_r.shape[0]
    bat, rh, g_lh, t_pos, t_rot = both_fk(prot, ppos, arms, loc_l, loc_r, bufs, rel_p, rel_q)
    for i in range(3):
        r[i] = BAT_WEIGHT * (handle[i] - bat[i])
    tmp = np.empty(6)
    _grip_residual(rh, q_at(bufs[2], nr - 1), t_pos, t_rot, GRIP_LENGTH, tmp)
    for i in range(6):
        r[3 + i] = tmp[i]
    fw, n_tgt, n_last = face
    nrm = qrot(g_lh, n_last)
    for i in range(3):
        r[9 + i] = fw * (n_tgt[i] - nrm[i])
    t = 0.0
    for i in range(12):
        t += r[i] * r[i]
    return bat, t_pos, math.sqrt(t)


@njit(cache=True)
def _both_columns(prot, rp, free, bufs, eul_l, eul_r, bat, t_pos, face, r, cols, dofs):
    """Jacobian columns of both arms' free Euler angles against :func:`_both_residual`'s
    rows (``dofs``: rows of the two arms' angles, left first); returns how many."""
    l_free, r_free = free
    gl_rot, gl_pos, gr_rot, gr_pos = bufs
    nl = eul_l.shape[0]
    nr = eul_r.shape[0]
    L = GRIP_LENGTH
    rh = v_at(gr_pos, nr - 1)
    rv = (r[6] / L, r[7] / L, r[8] / L)
    rpos = (r[3], r[4], r[5])
    nrm = qrot(q_at(gl_rot, nl - 1), face[2])
    m = 0
    for k in range(nl):
        for c in range(3):
            if not l_free[k, c]:
                continue
            a = hinge_axis(prot, gl_rot, eul_l, k, c)
            pk = v_at(gl_pos, k)
            cb = cross(a, vsub(bat, pk))
            if k <= rp:     # turns the right arm and its target together
                cg = cross(a, rpos)
                co = cross(a, rv)
                cg = (-cg[0], -cg[1], -cg[2])
                co = (-L * co[0], -L * co[1], -L * co[2])
            else:           # turns the left hand (the target) only
                cg = cross(a, vsub(t_pos, pk))
                cg = (-cg[0], -cg[1], -cg[2])
                co = (-L * a[0], -L * a[1], -L * a[2])
            cn = cross(a, nrm)
            for i in range(3):
                cols[m, i] = BAT_WEIGHT * cb[i]
                cols[m, 3 + i] = cg[i]
                cols[m, 6 + i] = co[i]
                cols[m, 9 + i] = face[0] * cn[i]
            dofs[m, 0] = k
            dofs[m, 1] = c
            m += 1
    pr = q_at(gl_rot, rp)
    for k in range(nr):
        for c in range(3):
            if not r_free[k, c]:
                continue
            a = hinge_axis(pr, gr_rot, eul_r, k, c)
            cg = cross(a, vsub(rh, v_at(gr_pos, k)))
            for i in range(3):
                cols[m, i] = 0.0
                cols[m, 3 + i] = cg[i]
                cols[m, 6 + i] = L * a[i]
            dofs[m, 0] = nl + k
            dofs[m, 1] = c
            m += 1
    return m


class BothArmsProblem(NamedTuple):
    """Both arm chains onto the bat's handle and the right hand's grip (and the face):
    :func:`both_arms_solve`'s problem of :func:`engine.step_nb.lm_loop`, stepped by
    :func:`lsq_apply` on :func:`_both_columns`. State (residual norm, bat (3,), grip
    target position (3,))."""
    prot: tuple         # (4,) the left chain root's parent's global rotation
    ppos: tuple         # (3,) and position, cm
    arms: tuple         # as both_fk's
    free: tuple         # (left (nl,3), right (nr,3)) bool
    pose: tuple         # (left local (nl,4), right local (nr,4), Euler angles of both (nl+nr,3)), in place
    halves: tuple       # the Euler angles' rows of the left arm, of the right (views of pose's)
    limits: tuple       # (lo, hi) (nl+nr,3) radians
    goal: tuple         # as _both_residual's
    rows: int           # rows solved: 12 with the face, else 9
    tols: tuple         # (tol cm, orientation tol rad)
    bufs: tuple         # both_fk's
    work: tuple         # (cols (3(nl+nr),13), dofs, A (12,12), x (12,), r (12,))
    backup: tuple       # copies of pose's arrays


@njit(cache=True, inline='always')
def _copy_pose(src, dst):
    """Both arms' pose ``(left local, right local, Euler angles)`` into another such tuple."""
    copy_rows(src[0], dst[0])
    copy_rows(src[1], dst[1])
    copy_rows(src[2], dst[2])


def _both_save(problem):
    pose, backup = problem.pose, problem.backup
    _copy_pose(pose, backup)


def _both_restore(problem):
    pose, backup = problem.pose, problem.backup
    _copy_pose(backup, pose)


def _both_step(problem, state, damping):
    prot, arms, free, bufs, face, rows = (problem.prot, problem.arms, problem.free, problem.bufs, problem.goal[1],
                                          problem.rows)
    loc_l, loc_r, eul = problem.pose
    eul_l, eul_r = problem.halves
    lo, hi = problem.limits
    cols, dofs, A, x, r = problem.work
    m = _both_columns(prot, arms[4], free, bufs, eul_l, eul_r, state[1], state[2], face, r, cols, dofs)
    lsq_apply(cols, dofs, m, rows, r, eul, lo, hi, damping, MAX_STEP, A, x)
    put_free_locals(loc_l, eul_l, free[0])
    put_free_locals(loc_r, eul_r, free[1])


def _both_eval(problem):
    prot, ppos, arms, bufs, goal, r = (problem.prot, problem.ppos, problem.arms, problem.bufs, problem.goal,
                                       problem.work[4])
    loc_l, loc_r, _ = problem.pose
    bat, t_pos, res = _both_residual(prot, ppos, arms, loc_l, loc_r, bufs, goal, r)
    return res, bat, t_pos


def _both_done(problem, state):
    """Bat, grip position and rotation (and with 12 rows the face) within tolerance."""
    r, fw, rows = problem.work[4], problem.goal[1][0], problem.rows
    tol, ori_tol = problem.tols
    bat_e = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / BAT_WEIGHT
    pos_e = math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5])
    ori_e = math.sqrt(r[6] * r[6] + r[7] * r[7] + r[8] * r[8]) / GRIP_LENGTH
    face_e = math.sqrt(r[9] * r[9] + r[10] * r[10] + r[11] * r[11]) / max(fw, 1e-300)
    return (bat_e < tol) & (pos_e < tol) & (ori_e < ori_tol) & ((rows == 9) | (face_e < FACE_TOL))


lm_parts(BothArmsProblem, _both_save, _both_restore, _both_step, _both_eval, _both_done)


@njit(cache=True)
def both_arms_solve(prot, ppos, arms, free, pose, limits, goal, tol, ori_tol, max_iter):
    """Damped Newton on both arm chains at once: the bat on its handle AND the
    right hand on its grip (the torso joints shared by both chains can then
    lean to give the right arm its reach), and, with a face weight (goal's ``face``, as
    :func:`_both_residual`), the bat face on its target. Used when the right arm
    alone cannot get back to the grip. arms as :func:`both_fk`'s; free = (left (nl,3),
    right (nr,3)); pose = (left local (nl,4), right local (nr,4), Euler angles of both
    (nl+nr,3), left first), limits = (lo, hi) of those angles; goal = (handle, face,
    rel_p, rel_q). Returns the grip's (position cm, angle rad) error."""
    loc_l, loc_r, eul = pose
    nl = loc_l.shape[0]
    nr = loc_r.shape[0]
    bufs = (np.empty((nl, 4)), np.empty((nl, 3)), np.empty((nr, 4)), np.empty((nr, 3)))
    cols = np.zeros((3 * (nl + nr), 13))
    cols[:, 12] = 1.0                  # no stiffness weights
    work = (cols, np.empty((3 * (nl + nr), 2), np.int64), np.empty((12, 12)), np.empty(12), np.empty(12))
    problem = BothArmsProblem(prot, ppos, arms, free, pose, (eul[:nl], eul[nl:]), limits, goal,
                              12 if goal[1][0] > 0.0 else 9, (tol, ori_tol), bufs, work,
                              (np.empty((nl, 4)), np.empty((nr, 4)), np.empty((nl + nr, 3))))
    lm_loop(problem, lm_eval(problem), END_LM, (max_iter, 0.0, 1e-3, NO))
    r = work[4]
    return math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5]), math.sqrt(r[6] * r[6] + r[7] * r[7] + r[8] * r[8]) / GRIP_LENGTH


@njit(cache=True)
def _turn_by(turn, share):
    """Quaternion of the rotation vector ``turn (3,)`` times ``share``."""
    a = math.sqrt(turn[0] * turn[0] + turn[1] * turn[1] + turn[2] * turn[2])
    if a < 1e-15:
        return (1.0, 0.0, 0.0, 0.0)
    s = math.sin(0.5 * a * share) / a
    return (math.cos(0.5 * a * share), turn[0] * s, turn[1] * s, turn[2] * s)


@njit(cache=True)
def _solve_chain(solver, prot, ppos, ch, local, euler, src_euler, handle, tol, max_iter, damping, s):
    if solver == 0:
        return ccd_frame(prot, ppos, ch, local, euler, src_euler, handle, tol, max_iter, s)
    return dls_frame(prot, ppos, ch, local, euler, damping, handle, tol, max_iter, s)


@njit(cache=True, inline='always')
def _bat_frames(frames, desired, blends, shot, start, left, opts, face, out, bufs, s, work, kept):
    """Every frame's left arm (the first pass of :func:`_adapt_frames`, arguments as
    there): the bat joint onto its handle from the start pose, then with the face kept
    the face turned to the source's (turned by ``turn`` times the blend); the pose into
    ``out`` (FK of the left chain's subtree); into kept = (steps (K,) (0: untouched),
    the face's target normal and its normal in the left hand's frame (K,2,3), the left
    arm's Euler angles (K,nl,3)) what the second pass needs. Inlined (called once): a
    call passing some fifty arrays cost a one-frame adaptation ~1 us."""
    parents, trans, subtree, src_grot, src_gpos, _, _, hit, bat, lhand, _ = shot
    src_local, src_euler = start
    lj, l_off, l_eoff, l_free, l_kind, l_lo, l_hi, l_w = left
    _, solver, tol, max_iter, damping, _ = opts
    keep_face, face_free, face_w, face_local, face_turn = face
    out_local, out_grot, out_gpos, out_blend, out_handle, out_err, _, _ = out
    loc_l, _, src_l, _, eul, lo, hi = bufs
    steps, n_face, eul_kept = kept
    nl = lj.shape[0]
    eul_l, lo_l, hi_l = eul[:nl], lo[:nl], hi[:nl]
    g_rot, g_pos = s.g_rot, s.g_pos
    ch_l = Chain(lj, l_off, l_eoff, l_free, l_kind, lo_l, hi_l, l_w)    # (lo/hi: the frame's, filled below)
    b_h = (src_gpos[hit, bat, 0], src_gpos[hit, bat, 1], src_gpos[hit, bat, 2])
    r_h = (src_grot[hit, bat, 0], src_grot[hit, bat, 1], src_grot[hit, bat, 2], src_grot[hit, bat, 3])
    offset = qrot(qconj(r_h), vsub((desired[0], desired[1], desired[2]), b_h))
    n_bat = (face_local[0], face_local[1], face_local[2])
    for i in range(frames.shape[0]):
        f = frames[i]
        out_local[i] = src_local[f]
        out_grot[i] = src_grot[f]
        out_gpos[i] = src_gpos[f]
        b_f = (src_gpos[f, bat, 0], src_gpos[f, bat, 1], src_gpos[f, bat, 2])
        r_f = (src_grot[f, bat, 0], src_grot[f, bat, 1], src_grot[f, bat, 2], src_grot[f, bat, 3])
        blend = blends[f]
        o = qrot(r_f, offset)
        handle = (b_f[0] + blend * o[0], b_f[1] + blend * o[1], b_f[2] + blend * o[2])
        out_blend[i] = blend
        v_put(out_handle, i, handle)
        for k in range(nl):
            for c in range(4):
                loc_l[k, c] = src_local[f, lj[k], c]
            for c in range(3):
                src_l[k, c] = src_euler[f, lj[k], c]
                eul_l[k, c] = src_l[k, c]
        widen_limits(l_lo, l_hi, src_l, lo_l, hi_l)
        pj = parents[lj[0]]
        prot = (src_grot[f, pj, 0], src_grot[f, pj, 1], src_grot[f, pj, 2], src_grot[f, pj, 3])
        ppos = (src_gpos[f, pj, 0], src_gpos[f, pj, 1], src_gpos[f, pj, 2])
        err, its = _solve_chain(solver, prot, ppos, ch_l, loc_l, eul_l, src_l, handle, tol, max_iter, damping, s)
        # the source's face at this frame (turned with the hit point), and in the hand's frame
        n_src = qrot(r_f, n_bat)
        n_last = qrot(qconj(q_at(src_grot[f], lhand)), n_src)
        n_tgt = qrot(_turn_by(face_turn, blend), n_src)
        turned = blend > 0.0 and (face_turn[0] != 0.0 or face_turn[1] != 0.0 or face_turn[2] != 0.0)
        if keep_face and (its > 0 or turned):    # the bat moved, or the face is asked to turn
            its = max(its, 1)
            # the face the position solve left, moved toward the kept one by the blend (all
            # the way at the hit; over the analyse --style offsets the upper-body style
            # distance 1.84 -> 1.76, position only 1.37)
            chain_fk(prot, ppos, l_off, l_eoff, loc_l, g_rot, g_pos)
            n_pos = qrot(q_at(g_rot, nl - 1), n_last)
            n_b = vadd((n_pos[0] * (1.0 - blend), n_pos[1] * (1.0 - blend), n_pos[2] * (1.0 - blend)),
                       (n_tgt[0] * blend, n_tgt[1] * blend, n_tgt[2] * blend))
            nb = vnorm(n_b)
            if nb > 1e-9:
                n_tgt = (n_b[0] / nb, n_b[1] / nb, n_b[2] / nb)
            pe, _ = face_solve(prot, ppos, l_off, l_eoff, loc_l, eul_l, face_free, face_w, lo_l, hi_l, handle,
                               n_tgt, n_last, tol, FACE_ITER, work)
            if not pe < tol:        # the face held by a limit kept the bat off: the bat first
                _solve_chain(solver, prot, ppos, ch_l, loc_l, eul_l, src_l, handle, tol, max_iter, damping, s)
        if its > 0:
            for k in range(nl):
                for c in range(4):
                    out_local[i, lj[k], c] = loc_l[k, c]
            tree_fk(parents, trans[f], out_local[i], subtree, out_grot[i], out_gpos[i])
        bpos = (out_gpos[i, bat, 0], out_gpos[i, bat, 1], out_gpos[i, bat, 2])
        out_err[i] = vnorm(vsub(bpos, handle))
        steps[i] = its
        for c in range(3):
            n_face[i, 0, c] = n_tgt[c]
            n_face[i, 1, c] = n_last[c]
        eul_kept[i] = eul_l


@njit(cache=True, inline='always')
def _torso_helps(i, f, shot, start, left, right, opts, face, out, bufs, s, work, kept):
    """Frame f's right hand out of the right arm's reach (in :func:`_hand_frames`): both
    arms together from the first pass's left arm (the torso leans, and with the face kept
    the roll joints turn too), the grip before the face (without the face if they clash);
    where the bat gave way to the grip, the bat back on its handle and the right arm
    again. The left arm into out's local rotations of slot i; the right arm in bufs."""
    parents, _, _, src_grot, src_gpos, rel_pos, rel_rot, _, _, _, rp = shot
    lj, l_off, l_eoff, l_free, l_kind, l_lo, l_hi, l_w = left
    _, solver, tol, max_iter, damping, ori_tol = opts
    keep_face, face_free = face[0], face[1]
    loc_l, loc_r, src_l, _, eul, lo, hi = bufs
    nl = lj.shape[0]
    eul_l, eul_r = eul[:nl], eul[nl:]
    gather_chain(out[0][i], lj, loc_l)
    gather_chain(start[1][f], lj, src_l)
    eul_l[:] = kept[2][i]
    widen_limits(l_lo, l_hi, src_l, lo[:nl], hi[:nl])
    handle = v_at(out[4], i)
    rel_p, rel_q = v_at(rel_pos, f), q_at(rel_rot, f)
    pj = parents[lj[0]]
    prl = q_at(src_grot[f], pj)
    ppl = v_at(src_gpos[f], pj)
    arms = (l_off, l_eoff, right[1], right[2], rp)
    both_free = face_free if keep_face else l_free
    fw = FACE_LENGTH if keep_face else 0.0
    n_face = kept[1]
    n_tgt = (n_face[i, 0, 0], n_face[i, 0, 1], n_face[i, 0, 2])
    n_last = (n_face[i, 1, 0], n_face[i, 1, 1], n_face[i, 1, 2])
    for _try in range(2):   # the grip before the face: without it if they clash
        pe, oe = both_arms_solve(prl, ppl, arms, (both_free, right[3]), (loc_l, loc_r, eul), (lo, hi),
                                 (handle, (fw, n_tgt, n_last), rel_p, rel_q), tol, ori_tol, 40)
        if fw == 0.0 or (pe <= GRIP_CM and oe <= GRIP_RAD):
            break
        fw = 0.0
    b2 = chain_fk(prl, ppl, l_off, l_eoff, loc_l, s.g_rot, s.g_pos)
    if vnorm(vsub(b2, handle)) >= tol:
        # the bat gave way to the grip: put it back, then the right arm again
        ch_l = Chain(lj, l_off, l_eoff, l_free, l_kind, lo[:nl], hi[:nl], l_w)
        _solve_chain(solver, prl, ppl, ch_l, loc_l, eul_l, src_l, handle, tol, max_iter, damping, s)
        chain_fk(prl, ppl, l_off, l_eoff, loc_l, s.g_rot, s.g_pos)
        t_pos, t_rot = grip_target(q_at(s.g_rot, nl - 1), v_at(s.g_pos, nl - 1), rel_p, rel_q)
        grip_solve(q_at(s.g_rot, rp), v_at(s.g_pos, rp), right[1], right[2], loc_r, eul_r, right[3], lo[nl:],
                   hi[nl:], t_pos, t_rot, tol, ori_tol, 30, work)
    scatter_chain(loc_l, lj, out[0][i])


@njit(cache=True, inline='always')
def _hand_frames(frames, shot, start, left, right, opts, face, out, bufs, s, work, kept):
    """Every frame's right hand back on its source grip relative to the left hand (the
    second pass of :func:`_adapt_frames`, after :func:`_bat_frames`): where the left arm
    moved, wrist position first (as the dissertation), then the joints that turn the hand
    without moving the wrist; if limits keep the hand off its grip, both together by
    damped Newton (:func:`_torso_helps`). Then the grip's errors. Inlined, as
    :func:`_bat_frames`."""
    parents, trans, subtree, _, _, rel_pos, rel_rot, _, bat, lhand, rp = shot
    src_euler = start[1]
    rj, r_off, r_eoff, r_free, r_kind, r_lo, r_hi, r_w = right
    fix_right, solver, tol, max_iter, damping, ori_tol = opts
    out_local, out_grot, out_gpos, _, out_handle, out_err, out_gcm, out_gdeg = out
    _, loc_r, _, src_r, eul, lo, hi = bufs
    g_rot, g_pos = s.g_rot, s.g_pos
    nr = rj.shape[0]
    nl = eul.shape[0] - nr
    eul_r, lo_r, hi_r = eul[nl:], lo[nl:], hi[nl:]
    ch_r = Chain(rj, r_off, r_eoff, r_free, r_kind, lo_r, hi_r, r_w)    # (lo/hi: the frame's, filled below)
    rh = rj[nr - 1]
    for i in range(frames.shape[0]):
        f = frames[i]
        g_lh = (out_grot[i, lhand, 0], out_grot[i, lhand, 1], out_grot[i, lhand, 2], out_grot[i, lhand, 3])
        p_lh = (out_gpos[i, lhand, 0], out_gpos[i, lhand, 1], out_gpos[i, lhand, 2])
        rel_p = (rel_pos[f, 0], rel_pos[f, 1], rel_pos[f, 2])
        rel_q = (rel_rot[f, 0], rel_rot[f, 1], rel_rot[f, 2], rel_rot[f, 3])
        t_pos, t_rot = grip_target(g_lh, p_lh, rel_p, rel_q)
        if fix_right and kept[0][i] > 0:
            for k in range(nr):
                for c in range(4):
                    loc_r[k, c] = out_local[i, rj[k], c]
                for c in range(3):
                    src_r[k, c] = src_euler[f, rj[k], c]
                    eul_r[k, c] = src_r[k, c]
            widen_limits(r_lo, r_hi, src_r, lo_r, hi_r)
            pj = parents[rj[0]]
            prot = (out_grot[i, pj, 0], out_grot[i, pj, 1], out_grot[i, pj, 2], out_grot[i, pj, 3])
            ppos = (out_gpos[i, pj, 0], out_gpos[i, pj, 1], out_gpos[i, pj, 2])
            eff = chain_fk(prot, ppos, r_off, r_eoff, loc_r, g_rot, g_pos)
            if vnorm(vsub(eff, t_pos)) >= tol or q_angle(q_at(g_rot, nr - 1), t_rot) >= ori_tol:
                _solve_chain(solver, prot, ppos, ch_r, loc_r, eul_r, src_r, t_pos, tol, max_iter, damping, s)
                oe = orient_finish(prot, ppos, r_off, r_eoff, loc_r, eul_r, src_r, r_free, r_kind,
                                   lo_r, hi_r, t_rot, g_rot, g_pos, 8, ori_tol)
                eff = chain_fk(prot, ppos, r_off, r_eoff, loc_r, g_rot, g_pos)
                if vnorm(vsub(eff, t_pos)) >= tol or oe >= ori_tol:
                    pe, oe = grip_solve(prot, ppos, r_off, r_eoff, loc_r, eul_r, r_free, lo_r, hi_r, t_pos,
                                        t_rot, tol, ori_tol, 30, work)
                    if (pe > GRIP_CM or oe > GRIP_RAD) and rp >= 0:
                        # out of the right arm's reach: let the torso help
                        _torso_helps(i, f, shot, start, left, right, opts, face, out, bufs, s, work, kept)
                for k in range(nr):
                    for c in range(4):
                        out_local[i, rj[k], c] = loc_r[k, c]
                tree_fk(parents, trans[f], out_local[i], subtree, out_grot[i], out_gpos[i])
                bpos = (out_gpos[i, bat, 0], out_gpos[i, bat, 1], out_gpos[i, bat, 2])
                out_err[i] = vnorm(vsub(bpos, (out_handle[i, 0], out_handle[i, 1], out_handle[i, 2])))
                g_lh = (out_grot[i, lhand, 0], out_grot[i, lhand, 1], out_grot[i, lhand, 2], out_grot[i, lhand, 3])
                p_lh = (out_gpos[i, lhand, 0], out_gpos[i, lhand, 1], out_gpos[i, lhand, 2])
                t_pos, t_rot = grip_target(g_lh, p_lh, rel_p, rel_q)
        g_rh = (out_grot[i, rh, 0], out_grot[i, rh, 1], out_grot[i, rh, 2], out_grot[i, rh, 3])
        p_rh = (out_gpos[i, rh, 0], out_gpos[i, rh, 1], out_gpos[i, rh, 2])
        out_gcm[i] = vnorm(vsub(p_rh, t_pos))
        out_gdeg[i] = math.degrees(q_angle(g_rh, t_rot))


@njit(cache=True)
def _adapt_frames(frames, desired, blends, shot, start, left, right, opts, face, out):
    """Adapt the frames listed in ``frames`` into output slots 0..len(frames)-1 of ``out`` =
    (local rotations, global rotations, global positions, blend, handle, bat error, grip
    error cm, grip error deg): the left arms (:func:`_bat_frames`), then the right hands
    (:func:`_hand_frames`); frames are independent. shot = (parents, trans, subtree of the
    left chain, source global rotations, positions, the grip in the left hand's frame:
    positions, rotations, hit frame, bat joint, left hand joint, rp: the left chain's joint
    the right arm hangs from); start = (local rotations, their limit-branch Euler angles)
    the chains start from; left, right: the arm chains (:data:`engine.step_nb.Chain`'s
    fields as plain tuples); opts = (fix the right hand, solver index, tol cm, iterations,
    damping, orientation tol rad); face = (keep, free (nl,3), weights (nl,), normal in the
    bat's frame (3,), turn (3,)): when kept, after the position solve the left arm's
    ``free`` joints turn the bat face to the source's, turned by the rotation vector
    ``turn`` times the frame's blend."""
    nl, nr = left[0].shape[0], right[0].shape[0]
    K = frames.shape[0]
    s = scratch(max(nl, nr))
    work = (s.g_rot, s.g_pos, np.empty((3 * max(nl, nr), 7)), s.dofs, np.empty((6, 6)), np.empty(6), np.empty(6),
            s.bak_l, s.bak_e)
    # loc_l, loc_r, src_l, src_r, both arms' Euler angles and the frame's limits (left first)
    bufs = (np.empty((nl, 4)), np.empty((nr, 4)), np.empty((nl, 3)), np.empty((nr, 3)), np.empty((nl + nr, 3)),
            np.empty((nl + nr, 3)), np.empty((nl + nr, 3)))
    kept = (np.empty(K, np.int64), np.empty((K, 2, 3)), np.empty((K, nl, 3)))
    _bat_frames(frames, desired, blends, shot, start, left, opts, face, out, bufs, s, work, kept)
    _hand_frames(frames, shot, start, left, right, opts, face, out, bufs, s, work, kept)


# --------------------------------------------------------------------------

def _subtree(parents: np.ndarray, root: int) -> np.ndarray:
    """(J,) bool: root and every joint below it."""
    m = np.zeros(len(parents), bool)
    m[root] = True
    for j in range(root + 1, len(parents)):
        if parents[j] >= 0 and m[parents[j]]:
            m[j] = True
    return m


def check_point(p, what: str = "target") -> np.ndarray:
    """A finite (3,) point, or ValueError with one clear line."""
    if isinstance(p, np.ndarray) and p.shape == (3,) and p.dtype == np.float64:
        x, y, z = p
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
            return p        # fast path (scrubbing calls this every frame)
    try:
        a = np.asarray(p, float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be three numbers (x, y, z) in cm") from None
    if a.shape != (3,):
        raise ValueError(f"{what} must be three numbers (x, y, z) in cm, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be finite numbers, got {a.tolist()}")
    return a


def check_settings(s: AdaptSettings) -> None:
    """ValueError with one clear line for settings the solvers cannot use."""
    if s.solver not in SOLVERS:
        raise ValueError(f"solver must be one of {', '.join(SOLVERS)}, got {s.solver!r}")
    if s.wrist_dof not in (0, 2):
        raise ValueError(f"wrist DOF must be 0 or 2, got {s.wrist_dof}")
    if s.face not in FACES:
        raise ValueError(f"face must be one of {', '.join(FACES)}, got {s.face!r}")
    if s.twist not in TWISTS:
        raise ValueError(f"twist must be one of {', '.join(TWISTS)}, got {s.twist!r}")
    if not (math.isfinite(s.falloff) and s.falloff > 0):
        raise ValueError(f"falloff must be a positive number of cm, got {s.falloff}")
    if not (math.isfinite(s.tolerance) and s.tolerance > 0):
        raise ValueError(f"tolerance must be a positive number of cm, got {s.tolerance}")
    if int(s.iterations) < 1:
        raise ValueError(f"iterations must be at least 1, got {s.iterations}")


END_GUARD_FRAMES = 8   # frames over which the blend fades to 0 at a shot's ends, where needed


class Adapter:
    """Per-shot precomputation (done once); :meth:`adapt` and :meth:`adapt_frame`
    then cost one compiled call each."""

    def __init__(self, rig, shot):
        skel, clip = shot.skeleton, shot.clip
        if list(skel.names) != list(rig.skeleton.names):
            raise ValueError(f"shot {shot.name!r}: joints are not in the rig's order "
                             "(load it with engine.library.conform_to_rig)")
        self.rig = rig
        self.shot = shot
        self.hit_frame = int(shot.hit_frame)
        self.num_frames = clip.num_frames
        self.parents = np.ascontiguousarray(skel.parents, np.int64)
        self.trans = np.ascontiguousarray(local_translations(skel, clip), float)
        self.src_local = np.ascontiguousarray(clip.local_rotations, float)
        grot, gpos = shot.fk
        self.src_grot = np.ascontiguousarray(grot, float)
        self.src_gpos = np.ascontiguousarray(gpos, float)
        self.src_euler = np.ascontiguousarray(np.radians(limit_euler(self.src_local, rig.limits)))
        self.bat = int(rig.bat_joint)
        left = rig.chains["left_arm"]
        right = rig.chains["right_arm"]
        self.lhand = int(left.joints[-1])
        self.rhand = int(right.joints[-1])
        self.subtree_l = _subtree(self.parents, int(left.joints[0]))
        # the right hand's source grip in the left hand's frame, per frame
        rel_pos, rel_rot = relative_pose(self.src_grot[:, self.lhand], self.src_gpos[:, self.lhand],
                                         self.src_grot[:, self.rhand], self.src_gpos[:, self.rhand])
        self.rel_pos, self.rel_rot = np.ascontiguousarray(rel_pos), np.ascontiguousarray(rel_rot)
        self._chains: dict[tuple, tuple] = {}
        self._blend_cache: tuple[float, np.ndarray] = (float("nan"), np.empty(0))
        # where the right arm hangs off the left-arm chain (Spine2), for the two-arm solve
        rpar = int(self.parents[right.joints[0]])
        self.right_parent_in_left = list(left.joints).index(rpar) if rpar in list(left.joints) else -1
        self.face_w = face_weights(len(left.joints), self.right_parent_in_left + 1)
        self.hit_point = self.src_gpos[self.hit_frame, self.bat].copy()
        self.bat_positions = self.src_gpos[:, self.bat]
        n = np.asarray(rig.bat["face_normal"], float)
        self.face_local = n / np.linalg.norm(n)
        self._shot_args = (self.parents, self.trans, self.subtree_l, self.src_grot, self.src_gpos, self.rel_pos,
                           self.rel_rot, self.hit_frame, self.bat, self.lhand, self.right_parent_in_left)

    @property
    def max_falloff(self) -> float:
        """Largest falloff (cm) that keeps the first and last frames fully FK
        (dissertation 2.2.5: the bat's distance from the hit point there)."""
        d = np.linalg.norm(self.bat_positions[[0, -1]] - self.hit_point, axis=-1)
        return float(d.min())

    def blend(self, falloff: float) -> np.ndarray:
        """Importance blend (F,) for a falloff in cm (2.2.5), with an end guard.

        The dissertation requires every shot to start and end fully FK (the
        shared stance and rest poses). Where the bat already lies within
        ``falloff`` of the hit point at the first or last frame (defensive
        shots whose hit point is near the stance), the blend is faded to 0 over
        the END_GUARD_FRAMES frames at that end; otherwise it is exactly
        ``clamp(1 - d / falloff, 0, 1)``.
        """
        d = np.linalg.norm(self.bat_positions - self.hit_point, axis=-1)
        blend = np.clip(1.0 - d / falloff, 0.0, 1.0)
        F = len(blend)
        frames = np.arange(F)
        for end, steps in ((0, frames), (F - 1, F - 1 - frames)):
            if blend[end] > 0.0:
                t = np.clip(steps / END_GUARD_FRAMES, 0.0, 1.0)
                blend = blend * (t * t * (3.0 - 2.0 * t))
        return blend

    def face_turn(self, desired: np.ndarray, settings: AdaptSettings) -> np.ndarray:
        """Rotation vector (3,) of the kept face at the hit frame against the source's:
        ``face_turn`` deg per cm of the hit point's move toward the off side (-x) plus
        ``face_yaw`` deg about the vertical, then ``face_tilt`` deg up about the horizontal
        across the face."""
        off_cm = -(float(desired[0]) - float(self.hit_point[0]))
        yaw = -math.radians(settings.face_turn * off_cm + settings.face_yaw)
        if settings.face_tilt == 0.0:
            return np.array([0.0, yaw, 0.0])        # the fast path: scrubbing calls this every frame
        across = np.cross(self.source_face(), [0.0, 1.0, 0.0])
        if np.linalg.norm(across) < 1e-9:
            return np.array([0.0, yaw, 0.0])
        tilt = quat.from_axis_angle(across / np.linalg.norm(across), math.radians(settings.face_tilt))
        q = quat.mul(tilt, quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), yaw))
        q = q if q[0] >= 0 else -q
        s = float(np.linalg.norm(q[1:]))
        return np.zeros(3) if s < 1e-15 else q[1:] / s * 2.0 * math.atan2(s, q[0])

    def source_face(self) -> np.ndarray:
        """The source's world face normal (3,) at the hit frame."""
        return quat.rotate(self.src_grot[self.hit_frame, self.bat], self.face_local)

    def _blend_for(self, falloff: float) -> np.ndarray:
        # cached: scrubbing calls adapt_frame every frame with the same falloff
        if self._blend_cache[0] != falloff:
            self._blend_cache = (falloff, np.ascontiguousarray(self.blend(falloff)))
        return self._blend_cache[1]

    def _chain_args(self, settings: AdaptSettings) -> tuple:
        key = (settings.wrist_dof, settings.solver, settings.twist)
        if key not in self._chains:
            out = []
            for name, wd in (("left_arm", settings.wrist_dof), ("right_arm", None)):
                ch: ChainArrays = chain_arrays(self.rig, name, wd)
                n = len(ch.joints)
                w = ch.polish_weight if settings.solver == "ccd" else 1.0 / default_stiffness(n)
                free, kind = ch.free, ch.kind
                if name == "left_arm" and settings.solver == "ccd" and settings.twist == "follow":
                    # locked, the source's twist is put back after every step
                    roll = twist_only(free)
                    free, kind = free & ~roll[:, None], np.where(roll, KIND_NONE, kind)
                out.append((ch.joints, ch.offsets, ch.eff_off, np.ascontiguousarray(free),
                            np.ascontiguousarray(kind), ch.lo, ch.hi, np.ascontiguousarray(w, float)))
                if name == "left_arm":
                    face_free = np.ascontiguousarray(ch.free)     # the roll joints too
            self._chains[key] = (tuple(out), face_free)
        return self._chains[key]

    def _start_pose(self, start) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(F, J, 4)`` and their limit-branch Euler angles (rad) the
        chains start from: the source, or ``start`` (engine.learnt_solver's learnt pose,
        equal to the source wherever the blend is 0). The handles, the grip and the
        chain roots' transforms stay the source's."""
        if start is None:
            return self.src_local, self.src_euler
        start = np.ascontiguousarray(start, float)
        if start.shape != self.src_local.shape or not np.isfinite(start).all():
            raise ValueError(f"start pose must be finite local rotations {self.src_local.shape}")
        return start, np.ascontiguousarray(np.radians(limit_euler(start, self.rig.limits)))

    def _run(self, frames: np.ndarray, desired, settings: AdaptSettings, start=None):
        check_settings(settings)
        p = check_point(desired, "desired hit point")
        K, J = len(frames), self.parents.shape[0]
        out = (np.empty((K, J, 4)), np.empty((K, J, 4)), np.empty((K, J, 3)), np.empty(K),
               np.empty((K, 3)), np.empty(K), np.empty(K), np.empty(K))
        start_local, start_euler = self._start_pose(start)
        chains, face_free = self._chain_args(settings)
        _adapt_frames(frames, p, self._blend_for(float(settings.falloff)), self._shot_args, (start_local, start_euler),
                      *chains, (bool(settings.fix_right_hand), SOLVERS.index(settings.solver),
                                float(settings.tolerance), int(settings.iterations), DAMPING, ORIENT_TOL),
                      (settings.face == "keep", face_free, self.face_w, self.face_local, self.face_turn(p, settings)),
                      out)
        return out, p

    def adapt(self, desired_hit_point, settings: AdaptSettings | None = None, start=None) -> Adaptation:
        """The whole shot adapted so the bat joint is at ``desired_hit_point`` at the hit frame;
        ``start``: the chains' start pose ``(F, J, 4)`` instead of the source's (learnt+ccd)."""
        settings = settings or AdaptSettings()
        frames = np.arange(self.num_frames, dtype=np.int64)
        (loc, grot, gpos, blend, handles, err, gcm, gdeg), p = self._run(frames, desired_hit_point, settings, start)
        h = self.hit_frame
        return Adaptation(self.trans[:, 0].copy(), loc, grot, gpos, blend, handles, p,
                          float(np.linalg.norm(gpos[h, self.bat] - p)), gcm, gdeg)

    def adapt_frame(self, frame: int, desired_hit_point, settings: AdaptSettings | None = None):
        """(local_rotations (J,4), global_rotations (J,4), global_positions (J,3)) of one frame."""
        settings = settings or AdaptSettings()
        if not 0 <= int(frame) < self.num_frames:
            raise ValueError(f"frame {frame} outside 0..{self.num_frames - 1}")
        (loc, grot, gpos, *_), _ = self._run(np.array([int(frame)], np.int64), desired_hit_point, settings)
        return loc[0], grot[0], gpos[0]
