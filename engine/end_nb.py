"""The chain end's pose solves of the shot adapter (engine.adapt), compiled: the trailing
joints turned for the last joint's orientation (:func:`orient_finish`), and damped Newton on
the effector's position with the last joint's whole rotation (:func:`grip_solve`, the right
hand onto its grip) or with the bat face (:func:`face_solve`); the least-squares step
(:func:`lsq_apply`) they share with the two-arm solve (engine.arms_nb)."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .ccd import KIND_MULTI, KIND_NONE
from .fk_nb import chain_fk
from .humerus_nb import held_fk
from .quat_nb import q_at, q_put, v_at, cross, dot, clamp_angle, from_euler_zyx, pick_branch, q_angle, qconj, qmul, qrot, to_euler_zyx, vadd, vnorm, vsub
from .step_nb import MAX_STEP, NO, copy_rows, hinge_axis, lm_eval, lm_loop, lm_parts

GRIP_LENGTH = 10.0      # cm per radian: weighs the right hand's orientation against its position
FACE_LENGTH = 30.0      # cm per unit of face-normal error: weighs the bat face against its position
FACE_TOL = math.radians(0.05)  # the face is "there" (chord of the unit normals ~ angle)
END_LM = (0.5, 0.05, 1e4, NO)  # the grip, face and two-arm solves' damping: start, least, cap; an undo does not end
END_ROWS = np.int64(6)  # rows of the grip and face solves (an int64, not a literal: one compiled step)


@njit(cache=True)
def orient_finish(prot, ppos, offsets, eff_off, local, euler, src_euler, free, kind, lo, hi, hold,
                  target_rot, fk_bufs, reps, ori_tol):
    """Turn the trailing chain joints that leave the effector where it is (the
    effector's own joint, a twist about the bone it lies on) so the last
    joint's global rotation approaches target_rot; the upper arm held once at the end
    (``hold``, engine.humerus_nb). fk_bufs = (g_rot (n,4), g_pos (n,3)) the chain's FK.
    Returns the angle error (rad)."""
    g_rot, g_pos = fk_bufs
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
    # held once at the end: its turns keep the effector, the hold's swing turns the hand back
    held_fk(prot, ppos, offsets, eff_off, local, euler, lo, hi, hold, g_rot, g_pos)
    return q_angle(q_at(g_rot, n - 1), target_rot)


@njit(cache=True)
def grip_residual(eff, last, target_pos, target_rot, length, r):
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
        res = grip_residual(eff, last, target_pos, target_rot, length, r)
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
    hold: tuple         # the upper arm's axial rotation held after every step (engine.humerus_nb)
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
    euler, lo, hi, hold = problem.euler, problem.lo, problem.hi, problem.hold
    g_rot, g_pos, r = problem.work[0], problem.work[1], problem.work[6]
    eff = held_fk(prot, ppos, offsets, eff_off, local, euler, lo, hi, hold, g_rot, g_pos)   # the step's pose, held
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
def grip_solve(prot, ppos, offsets, eff_off, local, euler, free, lo, hi, hold, target_pos, target_rot,
               tol, ori_tol, max_iter, work):
    """Damped Newton on position and orientation of the chain's last joint
    from the current pose (after the position solve and the twist/hand finish
    could not get the orientation); work as :class:`EndProblem`'s. Returns
    (position error, angle error)."""
    goal = (False, (target_pos[0], target_pos[1], target_pos[2]),
            (target_rot[0], target_rot[1], target_rot[2], target_rot[3]), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0),
            GRIP_LENGTH)
    return _end_solve(EndProblem(prot, ppos, offsets, eff_off, local, euler, free, np.ones(offsets.shape[0]), lo, hi,
                                 hold, goal, tol, ori_tol, work), max_iter, 1e-3)


@njit(cache=True)
def face_solve(prot, ppos, offsets, eff_off, local, euler, free, weight, lo, hi, hold, target, tol, max_iter,
               work):
    """Damped Newton on the effector's position AND the bat face: the normal
    ``n_last`` (in the last chain joint's frame) turned onto the world ``target_n``,
    from the current (position-solved) pose, by the free joints with a weight
    (1 / stiffness; 0: held); the roll joints, which position-only CCD leaves alone,
    turn the face back; ``hold`` holds the upper arm after every step (engine.humerus_nb).
    target = (target_pos, target_n, n_last); work as :class:`EndProblem`'s. Returns
    (position error cm, face error: the chord between the unit normals, ~rad)."""
    target_pos, target_n, n_last = target
    goal = (True, (target_pos[0], target_pos[1], target_pos[2]), (1.0, 0.0, 0.0, 0.0),
            (target_n[0], target_n[1], target_n[2]), (n_last[0], n_last[1], n_last[2]), FACE_LENGTH)
    return _end_solve(EndProblem(prot, ppos, offsets, eff_off, local, euler, free, weight, lo, hi, hold, goal, tol,
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

