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

from .kinematics_nb import hinge_axis, path_fk
from .nb import inline_kernel, kernel
from .quat_nb import (clamp_angle, cross, from_euler_zyx, q_angle, q_at, q_put, qconj, qmul, qrot, v_at, vadd,
                      vnorm, vsub)

POSITION, GRIP, BOTH = 0, 1, 2
GRIP_LENGTH = 10.0      # cm per radian: weighs the right hand's orientation against its position
BAT_WEIGHT = 10.0       # the bat on the ball matters most when both arms move

# Levenberg–Marquardt schedule: start, floor and give-up damping (cm), largest
# turn per step (rad), stop when a step keeps more than ``progress`` of the
# residual (0: never) or gains less than max(stall, stall_rel * residual)
Damping = namedtuple("Damping", "lam0 lam_min lam_max max_step progress stall stall_rel")


@inline_kernel
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


@inline_kernel
def _normal_matrix(A, cols, dofs, m, R, lam):
    """A = J J^T + lam^2 I over the columns not frozen."""
    for i in range(R):
        for j in range(R):
            A[i, j] = lam * lam if i == j else 0.0
    for q in range(m):
        if dofs[q, 2]:
            continue
        for i in range(R):
            ci = cols[q, i]
            if ci != 0.0:
                for j in range(R):
                    A[i, j] += ci * cols[q, j]


@kernel
def dls_step(step, ma, m, R, lam, max_step, ea, la, ha, eb, lb, hb):
    """One damped least-squares step on the ``m`` columns of ``step.cols`` (rows
    0..R-1; columns 0..ma-1 move the angles ``ea`` within ``la``/``ha``, the rest
    ``eb`` within ``lb``/``hb``) for the residual ``step.r``, in place. False
    when the system is singular (nothing moved). One flat loop nest: numba
    counts references on every array a call receives, which a helper per
    column would pay many times per step."""
    cols, colw, dofs, A, x, r = step.cols, step.colw, step.dofs, step.A, step.x, step.r
    for _round in range(3):
        _normal_matrix(A, cols, dofs, m, R, lam)
        if not solve_small(A, r, x, R):
            return False
        # cap the largest angle change: the linearisation holds for small turns
        biggest = 0.0
        for q in range(m):
            if not dofs[q, 2]:
                d = 0.0
                for i in range(R):
                    d += cols[q, i] * x[i]
                biggest = max(biggest, abs(d * colw[q]))
        scale = 1.0 if biggest <= max_step else max_step / biggest
        clamped = False
        for q in range(m):
            if dofs[q, 2]:
                continue
            euler, lo, hi = (ea, la, ha) if q < ma else (eb, lb, hb)
            k, c = dofs[q, 0], dofs[q, 1]
            d = 0.0
            for i in range(R):
                d += cols[q, i] * x[i]
            want = euler[k, c] + d * colw[q] * scale
            got = clamp_angle(want, lo[k, c], hi[k, c])
            if got != want:
                # take what the limit allows, freeze it, and leave the rest to the others
                gd = got - euler[k, c]
                euler[k, c] = got
                sw = 1.0 / colw[q]
                for i in range(R):
                    r[i] -= cols[q, i] * sw * gd
                dofs[q, 2] = 1
                clamped = True
        if not clamped:
            for q in range(m):
                if not dofs[q, 2]:
                    euler = ea if q < ma else eb
                    d = 0.0
                    for i in range(R):
                        d += cols[q, i] * x[i]
                    euler[dofs[q, 0], dofs[q, 1]] += d * colw[q] * scale
            break
    return True


@inline_kernel
def _write_locals(dofs, q0, q1, local, euler):
    """Local rotations of the joints that had columns q0..q1-1, from their angles."""
    last = -1
    for q in range(q0, q1):
        k = dofs[q, 0]
        if k != last:
            last = k
            q_put(local, k, from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2]))


@kernel
def _column(colw, dofs, m, k, c, scale):
    colw[m] = scale
    dofs[m, 0] = k
    dofs[m, 1] = c
    dofs[m, 2] = 0


@kernel
def _position_columns(prot, free, weight, euler, eff, g_rot, g_pos, cols, colw, dofs):
    """Weighted position columns of a chain's effector."""
    m = 0
    for k in range(free.shape[0]):
        for c in range(3):
            if free[k, c] and weight[k] > 0.0:
                col = cross(hinge_axis(prot, g_rot, euler, k, c), vsub(eff, v_at(g_pos, k)))
                sw = math.sqrt(weight[k])
                for i in range(3):
                    cols[m, i] = col[i] * sw
                _column(colw, dofs, m, k, c, sw)
                m += 1
    return m


@kernel
def _grip_columns(prot, free, euler, eff, g_rot, g_pos, cols, colw, dofs, o, m):
    """Columns of a chain's free angles on a hand at ``eff``: 3 position rows from
    row o, 3 rotation rows (GRIP_LENGTH cm per radian) after them, rows before o zero."""
    for k in range(free.shape[0]):
        for c in range(3):
            if free[k, c]:
                a = hinge_axis(prot, g_rot, euler, k, c)
                cg = cross(a, vsub(eff, v_at(g_pos, k)))
                for i in range(3):
                    if o:
                        cols[m, i] = 0.0
                    cols[m, o + i] = cg[i]
                    cols[m, o + 3 + i] = a[i] * GRIP_LENGTH
                _column(colw, dofs, m, k, c, 1.0)
                m += 1
    return m


@kernel
def _both_columns(prot, rp, free, euler, bat, t_pos, g_rot, g_pos, r, cols, colw, dofs):
    """Bat rows 0..2 and grip rows 3..8 of chain a's free angles (FK in g_rot/g_pos,
    bat effector at ``bat``, grip target ``t_pos``, residual ``r``)."""
    L = GRIP_LENGTH
    rv = (r[6] / L, r[7] / L, r[8] / L)
    rpos = (r[3], r[4], r[5])
    m = 0
    for k in range(free.shape[0]):
        for c in range(3):
            if not free[k, c]:
                continue
            a = hinge_axis(prot, g_rot, euler, k, c)
            pk = v_at(g_pos, k)
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
                cols[m, i] = BAT_WEIGHT * cb_[i]
                cols[m, 3 + i] = cg[i]
                cols[m, 6 + i] = co[i]
            _column(colw, dofs, m, k, c, 1.0)
            m += 1
    return m


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


@inline_kernel
def copy_rows(dst, src, n):
    """dst[:n] = src[:n] without making views (each view costs a reference count)."""
    for k in range(n):
        for c in range(src.shape[1]):
            dst[k, c] = src[k, c]


@kernel
def residual(kind, prot, ppos, ga, la, gb, lb, rp, goal, G):
    """FK and the residual of the problem into G's r. ``ga``/``gb``: (link, offsets,
    order, eff_off) of chain a / b, ``la``/``lb`` their local rotations, ``G``:
    (g_rot, g_pos, g2_rot, g2_pos, r). Returns (point, norm): the effector
    (POSITION, GRIP) or the grip target (BOTH)."""
    g_rot, g_pos, g2_rot, g2_pos, r = G
    eff = path_fk(prot, ppos, ga[0], ga[1], ga[2], ga[3], la, g_rot, g_pos)
    n = la.shape[0]
    if kind == POSITION:
        return eff, vnorm(vsub(eff, goal[0]))
    if kind == GRIP:
        return eff, grip_residual(eff, q_at(g_rot, n - 1), goal[0], goal[1], GRIP_LENGTH, r, 0)
    rh = path_fk(q_at(g_rot, rp), v_at(g_pos, rp), gb[0], gb[1], gb[2], gb[3], lb, g2_rot, g2_pos)
    t_pos, t_rot = grip_target(g_rot, g_pos, n, goal[2], goal[1])
    handle = goal[0]
    for i in range(3):
        r[i] = BAT_WEIGHT * (handle[i] - eff[i])
    grip_residual(rh, q_at(g2_rot, lb.shape[0] - 1), t_pos, t_rot, GRIP_LENGTH, r, 3)
    t = 0.0
    for i in range(9):
        t += r[i] * r[i]
    return t_pos, math.sqrt(t)


@kernel
def converged(kind, n, point, res, goal, tol, ori_tol, g_rot, r):
    if kind == POSITION:
        return not res >= tol
    if kind == GRIP:
        return vnorm(vsub(point, goal[0])) < tol and q_angle(q_at(g_rot, n - 1), goal[1]) < ori_tol
    bat_e = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / BAT_WEIGHT
    pos_e = math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5])
    ori_e = math.sqrt(r[6] * r[6] + r[7] * r[7] + r[8] * r[8]) / GRIP_LENGTH
    return bat_e < tol and pos_e < tol and ori_e < ori_tol


@kernel
def _columns(kind, prot, rp, point, goal, fa, wa, eoa, ea, fb, eb, G, cols, colw, dofs):
    """The problem's Jacobian columns (chain a: free columns ``fa``, weights ``wa``,
    effector offset ``eoa``, angles ``ea``; chain b: ``fb``, ``eb``) at the FK in
    G: (columns of chain a, all columns, rows)."""
    g_rot, g_pos, g2_rot, g2_pos, r = G
    if kind == POSITION:
        d = vsub(goal[0], point)
        r[0], r[1], r[2] = d[0], d[1], d[2]
        m = _position_columns(prot, fa, wa, ea, point, g_rot, g_pos, cols, colw, dofs)
        return m, m, 3
    if kind == GRIP:
        m = _grip_columns(prot, fa, ea, point, g_rot, g_pos, cols, colw, dofs, 0, 0)
        return m, m, 6
    n = ea.shape[0]
    bat = vadd(v_at(g_pos, n - 1), qrot(q_at(g_rot, n - 1), (eoa[0], eoa[1], eoa[2])))
    ma = _both_columns(prot, rp, fa, ea, bat, point, g_rot, g_pos, r, cols, colw, dofs)
    rh = v_at(g2_pos, eb.shape[0] - 1)
    return ma, _grip_columns(q_at(g_rot, rp), fb, eb, rh, g2_rot, g2_pos, cols, colw, dofs, 3, ma), 9


@kernel
def lm_solve(kind, prot, ppos, ca, pa, cb, pb, rp, goal, tol, ori_tol, damp, max_iter, w):
    """Levenberg–Marquardt from the current pose(s), in place: a step that does not
    lower the residual is undone and the damping raised. Returns (point, residual,
    steps taken) with point as :func:`residual`'s. (The loop hands its callees
    arrays, not records: see engine.kinematics_nb on reference counts.)"""
    la, ea, lb, eb = pa.local, pa.euler, pb.local, pb.euler
    bak_l, bak_e, bak2_l, bak2_e, step = w.bak_l, w.bak_e, w.bak2_l, w.bak2_e, w.step
    cols, colw, dofs, r = step.cols, step.colw, step.dofs, step.r
    G = (w.g_rot, w.g_pos, w.g2_rot, w.g2_pos, r)
    ga = (ca.link, ca.offsets, ca.order, ca.eff_off)
    gb = (cb.link, cb.offsets, cb.order, cb.eff_off)
    fa, wa, fb = ca.free, ca.weight, cb.free
    lo_a, hi_a, lo_b, hi_b = pa.lo, pa.hi, pb.lo, pb.hi
    n, nb, max_step = la.shape[0], lb.shape[0], damp.max_step
    two = kind == BOTH
    point, res = residual(kind, prot, ppos, ga, la, gb, lb, rp, goal, G)
    lam = damp.lam0
    it = 0
    while it < max_iter:
        if converged(kind, n, point, res, goal, tol, ori_tol, G[0], r):
            break
        it += 1
        copy_rows(bak_l, la, n)
        copy_rows(bak_e, ea, n)
        if two:
            copy_rows(bak2_l, lb, nb)
            copy_rows(bak2_e, eb, nb)
        # the columns are taken at the residual's FK (still in G)
        ma, m, R = _columns(kind, prot, rp, point, goal, fa, wa, ga[3], ea, fb, eb, G, cols, colw, dofs)
        if dls_step(step, ma, m, R, lam, max_step, ea, lo_a, hi_a, eb, lo_b, hi_b):
            _write_locals(dofs, 0, ma, la, ea)
            _write_locals(dofs, ma, m, lb, eb)
        point2, res2 = residual(kind, prot, ppos, ga, la, gb, lb, rp, goal, G)
        if not res2 < res:
            # overshoot (or a limit in the way): undo and damp harder
            copy_rows(la, bak_l, n)
            copy_rows(ea, bak_e, n)
            if two:
                copy_rows(lb, bak2_l, nb)
                copy_rows(eb, bak2_e, nb)
            point, res = residual(kind, prot, ppos, ga, la, gb, lb, rp, goal, G)
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
