"""The one damped-least-squares step and the one Levenberg–Marquardt loop of
the compiled solvers (ccd's Newton finish, dls, the right hand's grip, both
arms at once).

A problem is one of three kinds, each a residual and its Jacobian columns
over the free Euler columns of one chain or two:

* POSITION (3 rows): the chain's effector onto ``goal[0]``, columns weighted
  by ``chain.weight`` (``d_theta = W J^T (J W J^T + lambda^2 I)^-1 r``);
* GRIP (6 rows): the last joint's position ``goal[0]`` and rotation
  ``goal[1]``, the rotation error as a rotation vector times GRIP_LENGTH;
* BOTH (9 rows): chain a's effector (the bat) on ``goal[0]`` (weight
  BAT_WEIGHT) and chain b's last joint (the right hand, hanging off chain a's
  joint ``rp``) on its grip ``goal[2]`` / ``goal[1]`` in chain a's last joint's
  frame, so the joints both chains share lean to give chain b its reach.

Limits hold by clamping a column that would cross one and re-solving the
others for what is left (up to three rounds).
"""
from __future__ import annotations

import math
from collections import namedtuple

from .kinematics_nb import chain_fk, euler_to_local, hinge_axis, restore_pose, save_pose
from .nb import kernel
from .quat_nb import clamp_angle, cross, q_angle, q_at, qconj, qmul, qrot, v_at, vadd, vnorm, vsub

POSITION, GRIP, BOTH = 0, 1, 2
GRIP_LENGTH = 10.0      # cm per radian: weighs the right hand's orientation against its position
BAT_WEIGHT = 10.0       # the bat on the ball matters most when both arms move

# Levenberg–Marquardt schedule: start, floor and give-up damping (cm), largest
# turn per step (rad), stop when a step keeps more than ``progress`` of the
# residual (0: never) or gains less than max(stall, stall_rel * residual)
Damping = namedtuple("Damping", "lam0 lam_min lam_max max_step progress stall stall_rel")


@kernel
def solve_small(A, r, x, R):
    """x = A^-1 r for the symmetric positive definite R x R matrix A (overwritten):
    closed-form cofactors for 3 x 3 (False when singular), Cholesky otherwise."""
    if R == 3:
        a00, a11, a22, a01, a02, a12 = A[0, 0], A[1, 1], A[2, 2], A[0, 1], A[0, 2], A[1, 2]
        c00 = a11 * a22 - a12 * a12
        c01 = a02 * a12 - a01 * a22
        c02 = a01 * a12 - a02 * a11
        det = a00 * c00 + a01 * c01 + a02 * c02
        if not abs(det) > 1e-300:
            return False
        c11 = a00 * a22 - a02 * a02
        c12 = a01 * a02 - a00 * a12
        c22 = a00 * a11 - a01 * a01
        x[0] = (c00 * r[0] + c01 * r[1] + c02 * r[2]) / det
        x[1] = (c01 * r[0] + c11 * r[1] + c12 * r[2]) / det
        x[2] = (c02 * r[0] + c12 * r[1] + c22 * r[2]) / det
        return True
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
    return True


@kernel
def _normal_matrix(w, m, R, lam):
    A = w.A
    for i in range(R):
        for j in range(R):
            A[i, j] = lam * lam if i == j else 0.0
    for q in range(m):
        if w.dofs[q, 3]:
            continue
        for i in range(R):
            ci = w.cols[q, i]
            if ci != 0.0:
                for j in range(R):
                    A[i, j] += ci * w.cols[q, j]


@kernel
def _turn(w, q, R):
    """Joint-angle change of column q for the current solution x (before scaling)."""
    d = 0.0
    for i in range(R):
        d += w.cols[q, i] * w.x[i]
    return d * w.colw[q]


@kernel
def dls_step(w, m, R, lam, max_step, pa, pb):
    """One damped least-squares step on the ``m`` columns in ``w.cols`` (rows 0..R-1,
    ``w.dofs[q] = (chain 0|1, joint, Euler column, frozen)``) for the residual
    ``w.r``, in place on the poses pa / pb. False when the system is singular."""
    for _round in range(3):
        _normal_matrix(w, m, R, lam)
        if not solve_small(w.A, w.r, w.x, R):
            return False
        biggest = 0.0
        for q in range(m):
            if not w.dofs[q, 3]:
                biggest = max(biggest, abs(_turn(w, q, R)))
        scale = 1.0 if biggest <= max_step else max_step / biggest
        clamped = False
        for q in range(m):
            if w.dofs[q, 3]:
                continue
            pose = pa if w.dofs[q, 0] == 0 else pb
            k, c = w.dofs[q, 1], w.dofs[q, 2]
            want = pose.euler[k, c] + _turn(w, q, R) * scale
            got = clamp_angle(want, pose.lo[k, c], pose.hi[k, c])
            if got != want:
                # take what the limit allows, freeze it, and leave the rest to the others
                gd = got - pose.euler[k, c]
                pose.euler[k, c] = got
                sw = 1.0 / w.colw[q]
                for i in range(R):
                    w.r[i] -= w.cols[q, i] * sw * gd
                w.dofs[q, 3] = 1
                clamped = True
        if not clamped:
            for q in range(m):
                if not w.dofs[q, 3]:
                    pose = pa if w.dofs[q, 0] == 0 else pb
                    pose.euler[w.dofs[q, 1], w.dofs[q, 2]] += _turn(w, q, R) * scale
            break
    for q in range(m):
        if q == 0 or w.dofs[q, 0] != w.dofs[q - 1, 0] or w.dofs[q, 1] != w.dofs[q - 1, 1]:
            euler_to_local(pa if w.dofs[q, 0] == 0 else pb, w.dofs[q, 1])
    return True


@kernel
def _column(w, m, chain_id, k, c, scale):
    w.colw[m] = scale
    w.dofs[m, 0] = chain_id
    w.dofs[m, 1] = k
    w.dofs[m, 2] = c
    w.dofs[m, 3] = 0


@kernel
def _position_columns(prot, chain, pose, eff, goal, w):
    m = 0
    for k in range(chain.order.shape[0]):
        for c in range(3):
            if chain.free[k, c] and chain.weight[k] > 0.0:
                col = cross(hinge_axis(prot, w.g_rot, pose.euler, k, c), vsub(eff, v_at(w.g_pos, k)))
                sw = math.sqrt(chain.weight[k])
                for i in range(3):
                    w.cols[m, i] = col[i] * sw
                _column(w, m, 0, k, c, sw)
                m += 1
    r = vsub(goal[0], eff)
    for i in range(3):
        w.r[i] = r[i]
    return m


@kernel
def _grip_columns(prot, chain, pose, eff, w, g_rot, g_pos, chain_id, m, L):
    """Columns of chain_id's free angles on a hand at ``eff``: 3 position rows at
    rows 0..2 of the hand block, 3 rotation rows after them."""
    o = 3 if chain_id == 1 else 0
    for k in range(chain.order.shape[0]):
        for c in range(3):
            if chain.free[k, c]:
                a = hinge_axis(prot, g_rot, pose.euler, k, c)
                cg = cross(a, vsub(eff, v_at(g_pos, k)))
                for i in range(3):
                    if o:
                        w.cols[m, i] = 0.0
                    w.cols[m, o + i] = cg[i]
                    w.cols[m, o + 3 + i] = a[i] * L
                _column(w, m, chain_id, k, c, 1.0)
                m += 1
    return m


@kernel
def _both_columns(prot, ppos, ca, pa, cb, pb, rp, t_pos, w):
    """Bat rows 0..2 and grip rows 3..8 for both chains' free angles."""
    L = GRIP_LENGTH
    bat = chain_fk(prot, ppos, ca, pa.local, w.g_rot, w.g_pos)
    rv = (w.r[6] / L, w.r[7] / L, w.r[8] / L)
    rpos = (w.r[3], w.r[4], w.r[5])
    m = 0
    for k in range(ca.order.shape[0]):
        for c in range(3):
            if not ca.free[k, c]:
                continue
            a = hinge_axis(prot, w.g_rot, pa.euler, k, c)
            pk = v_at(w.g_pos, k)
            cb_ = cross(a, vsub(bat, pk))
            if k <= rp:     # turns the right arm and its target together
                cg = cross(a, rpos)
                co = cross(a, rv)
                cg = (-cg[0], -cg[1], -cg[2])
                co = (-L * co[0], -L * co[1], -L * co[2])
            else:           # turns the left hand (the target) only
                cg = cross(a, vsub(t_pos, pk))
                cg = (-cg[0], -cg[1], -cg[2])
                co = (-L * a[0], -L * a[1], -L * a[2])
            for i in range(3):
                w.cols[m, i] = BAT_WEIGHT * cb_[i]
                w.cols[m, 3 + i] = cg[i]
                w.cols[m, 6 + i] = co[i]
            _column(w, m, 0, k, c, 1.0)
            m += 1
    rh = v_at(w.g2_pos, cb.order.shape[0] - 1)
    return _grip_columns(q_at(w.g_rot, rp), cb, pb, rh, w, w.g2_rot, w.g2_pos, 1, m, L)


@kernel
def grip_residual(eff, last, target_pos, target_rot, length, r, o):
    """6-vector residual (position cm, rotation vector * length) into r[o:o+6]; returns its norm."""
    qe = qmul(target_rot, qconj(last))
    if qe[0] < 0.0:
        qe = (-qe[0], -qe[1], -qe[2], -qe[3])
    sv = math.sqrt(qe[1] * qe[1] + qe[2] * qe[2] + qe[3] * qe[3])
    scale = 0.0 if sv < 1e-15 else 2.0 * math.atan2(sv, qe[0]) / sv * length
    r[o + 0] = target_pos[0] - eff[0]
    r[o + 1] = target_pos[1] - eff[1]
    r[o + 2] = target_pos[2] - eff[2]
    r[o + 3] = qe[1] * scale
    r[o + 4] = qe[2] * scale
    r[o + 5] = qe[3] * scale
    t = 0.0
    for i in range(6):
        t += r[o + i] * r[o + i]
    return math.sqrt(t)


@kernel
def grip_target(g_rot, g_pos, n, rel_p, rel_q):
    """The grip (position, rotation) in the frame of joint n-1 of g_rot/g_pos."""
    g = q_at(g_rot, n - 1)
    return vadd(v_at(g_pos, n - 1), qrot(g, rel_p)), qmul(g, rel_q)


@kernel
def residual(kind, prot, ppos, ca, pa, cb, pb, rp, goal, w):
    """FK and the residual of the problem into w.r. Returns (point, norm): the
    effector (POSITION, GRIP) or the grip target (BOTH)."""
    eff = chain_fk(prot, ppos, ca, pa.local, w.g_rot, w.g_pos)
    n = ca.order.shape[0]
    if kind == POSITION:
        return eff, vnorm(vsub(eff, goal[0]))
    if kind == GRIP:
        return eff, grip_residual(eff, q_at(w.g_rot, n - 1), goal[0], goal[1], GRIP_LENGTH, w.r, 0)
    rh = chain_fk(q_at(w.g_rot, rp), v_at(w.g_pos, rp), cb, pb.local, w.g2_rot, w.g2_pos)
    t_pos, t_rot = grip_target(w.g_rot, w.g_pos, n, goal[2], goal[1])
    for i in range(3):
        w.r[i] = BAT_WEIGHT * (goal[0][i] - eff[i])
    grip_residual(rh, q_at(w.g2_rot, cb.order.shape[0] - 1), t_pos, t_rot, GRIP_LENGTH, w.r, 3)
    t = 0.0
    for i in range(9):
        t += w.r[i] * w.r[i]
    return t_pos, math.sqrt(t)


@kernel
def converged(kind, ca, point, res, goal, tol, ori_tol, w):
    if kind == POSITION:
        return not res >= tol
    if kind == GRIP:
        n = ca.order.shape[0]
        return vnorm(vsub(point, goal[0])) < tol and q_angle(q_at(w.g_rot, n - 1), goal[1]) < ori_tol
    r = w.r
    bat_e = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / BAT_WEIGHT
    pos_e = math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5])
    ori_e = math.sqrt(r[6] * r[6] + r[7] * r[7] + r[8] * r[8]) / GRIP_LENGTH
    return bat_e < tol and pos_e < tol and ori_e < ori_tol


@kernel
def _step(kind, prot, ppos, ca, pa, cb, pb, rp, point, goal, lam, max_step, w):
    if kind == POSITION:
        return dls_step(w, _position_columns(prot, ca, pa, point, goal, w), 3, lam, max_step, pa, pa)
    if kind == GRIP:
        m = _grip_columns(prot, ca, pa, point, w, w.g_rot, w.g_pos, 0, 0, GRIP_LENGTH)
        return dls_step(w, m, 6, lam, max_step, pa, pa)
    return dls_step(w, _both_columns(prot, ppos, ca, pa, cb, pb, rp, point, w), 9, lam, max_step, pa, pb)


@kernel
def lm_solve(kind, prot, ppos, ca, pa, cb, pb, rp, goal, tol, ori_tol, damp, max_iter, w):
    """Levenberg–Marquardt from the current pose(s), in place: a step that does not
    lower the residual is undone and the damping raised. Returns (point, residual,
    steps taken) with point as :func:`residual`'s."""
    point, res = residual(kind, prot, ppos, ca, pa, cb, pb, rp, goal, w)
    lam = damp.lam0
    it = 0
    while it < max_iter:
        if converged(kind, ca, point, res, goal, tol, ori_tol, w):
            break
        it += 1
        save_pose(pa, w.bak_l, w.bak_e)
        save_pose(pb, w.bak2_l, w.bak2_e)
        _step(kind, prot, ppos, ca, pa, cb, pb, rp, point, goal, lam, damp.max_step, w)
        point2, res2 = residual(kind, prot, ppos, ca, pa, cb, pb, rp, goal, w)
        if not res2 < res:
            # overshoot (or a limit in the way): undo and damp harder
            restore_pose(pa, w.bak_l, w.bak_e)
            restore_pose(pb, w.bak2_l, w.bak2_e)
            point, res = residual(kind, prot, ppos, ca, pa, cb, pb, rp, goal, w)
            lam *= 4.0
            if lam > damp.lam_max:
                break
            continue
        gain = res - res2
        kept = damp.progress > 0.0 and not res2 < damp.progress * res
        point = point2
        res = res2
        lam = max(damp.lam_min, lam * 0.5)
        if kept or gain < max(damp.stall, damp.stall_rel * res):
            break
    return point, res, it
