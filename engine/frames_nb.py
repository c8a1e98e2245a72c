"""The shot adapter's per-frame pipeline, compiled (engine.adapt.Adapter calls
:func:`adapt_frames` once for any set of frames): the bat's chain to its handle with the
face kept, the torso's help where the right arm cannot reach, then the right hand back on
its grip."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .ccd import ccd_frame
from .dls import dls_frame
from .fk_nb import chain_fk, tree_fk
from .quat_nb import q_at, v_at, v_put, q_angle, qconj, qrot, vadd, vnorm, vsub, widen_limits
from .step_nb import Chain, copy_rows, scratch
from .end_nb import FACE_LENGTH, face_solve, gather_chain, grip_solve, grip_target, orient_finish, scatter_chain
from .arms_nb import both_arms_solve

GRIP_CM = 0.05          # right hand further than this from its grip ...
GRIP_RAD = math.radians(0.5)  # ... or turned more than this: solve both arms together
FACE_ITER = 30          # Newton steps at most (crawling along a limit: as near as it gets)


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
    """Every frame's left arm (the first pass of :func:`adapt_frames`, arguments as
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
        gather_chain(src_local[f], lj, loc_l)
        gather_chain(src_euler[f], lj, src_l)
        copy_rows(src_l, eul_l)
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
    second pass of :func:`adapt_frames`, after :func:`_bat_frames`): where the left arm
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
            gather_chain(out_local[i], rj, loc_r)
            gather_chain(src_euler[f], rj, src_r)
            copy_rows(src_r, eul_r)
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
def adapt_frames(frames, desired, blends, shot, start, left, right, opts, face, out):
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

