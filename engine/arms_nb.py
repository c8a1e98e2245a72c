"""Both arm chains solved at once, compiled (engine.adapt's fallback when the right arm alone
cannot get back to its grip): the bat on its handle, the right hand on its grip and, with a
face weight, the bat face (:func:`both_arms_solve`); :func:`both_fk` is their FK."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .fk_nb import chain_fk
from .humerus_nb import hold_axial
from .quat_nb import q_at, v_at, cross, qrot, vadd, vsub
from .step_nb import MAX_STEP, NO, copy_rows, hinge_axis, lm_eval, lm_loop, lm_parts
from .end_nb import END_LM, FACE_TOL, GRIP_LENGTH, grip_residual, grip_target, lsq_apply, put_free_locals

NO_FACE = (0.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # both_arms_solve's face term, off
BAT_WEIGHT = 10.0       # the two-arm solve: the bat on the ball matters most
# the adapter's torso weight (1 / stiffness) against the arms' 1: the arms reach what they
# can and the trunk turns for the rest (the face solve's, engine.adapt.face_weights). At 1
# the trunk, with the longest levers, took most of the least-squares step: the chest turned
# up to 77 deg more at one frame than at the next over the +-30 cm grid, 37 at 0.1. (The
# clean-up's takes keep 1: a take's frames are chosen together, engine.path_nb.)
TORSO_WEIGHT = 0.1


@njit(cache=True, inline='always')
def both_fk(prot, ppos, arms, loc_l, loc_r, bufs, rel_p, rel_q):
    """FK of both arm chains into ``bufs`` = (left g_rot, g_pos, right g_rot, g_pos);
    arms = (left offsets, left effector offset, right offsets, right effector offset, rp:
    the left chain's joint the right arm hangs from, the left and right chains' holds:
    engine.humerus_nb). Returns (bat, right hand, the left
    hand's rotation, the grip's target position, its rotation)."""
    l_off, l_eoff, r_off, r_eoff, rp = arms[0], arms[1], arms[2], arms[3], arms[4]
    gl_rot, gl_pos, gr_rot, gr_pos = bufs
    nl = l_off.shape[0]
    bat = chain_fk(prot, ppos, l_off, l_eoff, loc_l, gl_rot, gl_pos)
    rh = chain_fk(q_at(gl_rot, rp), v_at(gl_pos, rp), r_off, r_eoff, loc_r, gr_rot, gr_pos)
    g_lh = q_at(gl_rot, nl - 1)
    t_pos, t_rot = grip_target(g_lh, v_at(gl_pos, nl - 1), rel_p, rel_q)
    return bat, rh, g_lh, t_pos, t_rot


@njit(cache=True)
def _held_residual(prot, ppos, arms, pose, limits, bufs, goal, r):
    """:func:`_both_residual` of the step's pose after both upper arms are held
    (engine.humerus_nb); pose = (left local, right local, left Euler angles, right's),
    limits = (lo, hi) of both (left first)."""
    loc_l, loc_r, eul_l, eul_r = pose
    lo, hi = limits
    gl_rot, gl_pos, gr_rot, gr_pos = bufs
    nl, nr = loc_l.shape[0], loc_r.shape[0]
    bat, t_pos, res = _both_residual(prot, ppos, arms, loc_l, loc_r, bufs, goal, r)
    rh = vadd(v_at(gr_pos, nr - 1), qrot(q_at(gr_rot, nr - 1), (arms[3][0], arms[3][1], arms[3][2])))
    moved_l = hold_axial(prot, loc_l, eul_l, lo[:nl], hi[:nl], arms[5], gl_rot, gl_pos, bat)
    moved_r = hold_axial(q_at(gl_rot, arms[4]), loc_r, eul_r, lo[nl:], hi[nl:], arms[6], gr_rot, gr_pos, rh)
    if moved_l or moved_r:
        bat, t_pos, res = _both_residual(prot, ppos, arms, loc_l, loc_r, bufs, goal, r)
    return bat, t_pos, res


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
    grip_residual(rh, q_at(bufs[2], nr - 1), t_pos, t_rot, GRIP_LENGTH, tmp)
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
def _both_columns(prot, rp, free, bufs, eul_l, eul_r, bat, t_pos, face, r, cols, dofs, torso_w):
    """Jacobian columns of both arms' free Euler angles against :func:`_both_residual`'s
    rows (``dofs``: rows of the two arms' angles, left first), the torso's (the left chain up
    to ``rp``) scaled by sqrt(``torso_w``), their weight; returns how many."""
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
            sw = math.sqrt(torso_w) if k <= rp else 1.0
            for i in range(3):
                cols[m, i] = sw * BAT_WEIGHT * cb[i]
                cols[m, 3 + i] = sw * cg[i]
                cols[m, 6 + i] = sw * co[i]
                cols[m, 9 + i] = sw * face[0] * cn[i]
            cols[m, 12] = sw
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
            cols[m, 12] = 1.0
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
    torso_w: float      # the torso joints' weight (1 / stiffness) against the arms' 1


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
    m = _both_columns(prot, arms[4], free, bufs, eul_l, eul_r, state[1], state[2], face, r, cols, dofs,
                      problem.torso_w)
    lsq_apply(cols, dofs, m, rows, r, eul, lo, hi, damping, MAX_STEP, A, x)
    put_free_locals(loc_l, eul_l, free[0])
    put_free_locals(loc_r, eul_r, free[1])


def _both_eval(problem):
    prot, ppos, arms, bufs, goal, r = (problem.prot, problem.ppos, problem.arms, problem.bufs, problem.goal,
                                       problem.work[4])
    loc_l, loc_r, _ = problem.pose
    eul_l, eul_r = problem.halves
    lo, hi = problem.limits
    bat, t_pos, res = _held_residual(prot, ppos, arms, (loc_l, loc_r, eul_l, eul_r), (lo, hi), bufs, goal, r)
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
def both_arms_solve(prot, ppos, arms, free, pose, limits, goal, tol, ori_tol, max_iter, torso_w):
    """Damped Newton on both arm chains at once: the bat on its handle AND the
    right hand on its grip (the torso joints shared by both chains can then
    lean to give the right arm its reach), and, with a face weight (goal's ``face``, as
    :func:`_both_residual`), the bat face on its target. Used when the right arm
    alone cannot get back to the grip. arms as :func:`both_fk`'s; free = (left (nl,3),
    right (nr,3)); pose = (left local (nl,4), right local (nr,4), Euler angles of both
    (nl+nr,3), left first), limits = (lo, hi) of those angles; goal = (handle, face,
    rel_p, rel_q); torso_w: the torso joints' weight against the arms' 1 (the adapter's
    TORSO_WEIGHT). Returns the grip's (position cm, angle rad) error."""
    loc_l, loc_r, eul = pose
    nl = loc_l.shape[0]
    nr = loc_r.shape[0]
    bufs = (np.empty((nl, 4)), np.empty((nl, 3)), np.empty((nr, 4)), np.empty((nr, 3)))
    cols = np.zeros((3 * (nl + nr), 13))        # (column 12: each one's sqrt weight)
    work = (cols, np.empty((3 * (nl + nr), 2), np.int64), np.empty((12, 12)), np.empty(12), np.empty(12))
    problem = BothArmsProblem(prot, ppos, arms, free, pose, (eul[:nl], eul[nl:]), limits, goal,
                              12 if goal[1][0] > 0.0 else 9, (tol, ori_tol), bufs, work,
                              (np.empty((nl, 4)), np.empty((nr, 4)), np.empty((nl + nr, 3))), torso_w)
    lm_loop(problem, lm_eval(problem), END_LM, (max_iter, 0.0, 1e-3, NO))
    r = work[4]
    return math.sqrt(r[3] * r[3] + r[4] * r[4] + r[5] * r[5]), math.sqrt(r[6] * r[6] + r[7] * r[7] + r[8] * r[8]) / GRIP_LENGTH

