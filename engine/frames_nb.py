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
from .quat_nb import dot, q_at, v_at, v_put, q_angle, qconj, qrot, vadd, vnorm, vsub, narrow_limits, widen_limits
from .step_nb import Chain, copy_rows, scratch
from .end_nb import FACE_LENGTH, GRIP_LENGTH, face_solve, gather_chain, grip_solve, grip_target, orient_finish, scatter_chain
from .arms_nb import TORSO_WEIGHT, both_arms_solve
from .humerus_nb import held, open_window, release

GRIP_CM = 0.05          # right hand further than this from its grip ...
GRIP_RAD = math.radians(0.5)  # ... or turned more than this: solve both arms together
HELD_ITER = 30          # CCD sweeps (or Newton steps) at most with the humerus held
HELD_FACE = math.radians(0.5)   # a face further than this from its target with the humerus held: let go
HELD_FACE_FAR = math.radians(60.0)  # ... plus this much at blend 0
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
    if held(ch.hold):       # held off its target this long: the frame runs again without the hold
        max_iter = min(max_iter, HELD_ITER)
    if solver == 0:
        return ccd_frame(prot, ppos, ch, local, euler, src_euler, handle, tol, max_iter, s)
    return dls_frame(prot, ppos, ch, local, euler, damping, handle, tol, max_iter, s)


@njit(cache=True, inline='always')
def _left_solve(prot, ppos, ch_l, pose, handle, faces, opts, face, s, work, limits):
    """One solve of the left arm (in :func:`_left_arm`, in place on pose = (local, Euler
    angles, start angles)): the bat joint onto ``handle``, then with the face kept the face
    turned toward faces = (blend, the source's normal turned with the hit point, the normal
    in the hand's frame, whether the face is asked to turn). Returns (steps, the face's
    target normal, the face's error ~rad)."""
    loc_l, eul_l, src_l = pose
    blend, n_src, n_last, turned = faces
    solver, tol, max_iter, damping = opts[1], opts[2], opts[3], opts[4]
    keep_face, face_free, face_w, _, face_turn = face
    nl = loc_l.shape[0]
    l_lo, l_hi, reach = limits
    widen_limits(l_lo, l_hi, src_l, ch_l.lo, ch_l.hi)
    narrow_limits(ch_l.lo, ch_l.hi, src_l, reach)     # the trunk within its reach of the start pose
    # the start's angles unwrapped as src_l's were: the 2-PC cover drive's upper arm, 10 deg
    # past the crossed-arm limit (-235 deg), kept +125, outside the limits taken out to -235:
    # where the bat needed no move the face solve took no step and left the face 60 deg off
    widen_limits(ch_l.lo, ch_l.hi, eul_l, ch_l.lo, ch_l.hi)
    err, its = _solve_chain(solver, prot, ppos, ch_l, loc_l, eul_l, src_l, handle, tol, max_iter, damping, s)
    n_tgt = qrot(_turn_by(face_turn, blend), n_src)
    fe = 0.0
    if keep_face and (its > 0 or turned):    # the bat moved, or the face is asked to turn
        its = max(its, 1)
        # the face the position solve left, moved toward the kept one by the blend (all the
        # way at the hit; over the analyse --style offsets the upper-body style distance
        # 1.84 -> 1.76, position only 1.37)
        chain_fk(prot, ppos, ch_l.offsets, ch_l.eff_off, loc_l, s.g_rot, s.g_pos)
        n_pos = qrot(q_at(s.g_rot, nl - 1), n_last)
        n_b = vadd((n_pos[0] * (1.0 - blend), n_pos[1] * (1.0 - blend), n_pos[2] * (1.0 - blend)),
                   (n_tgt[0] * blend, n_tgt[1] * blend, n_tgt[2] * blend))
        nb = vnorm(n_b)
        if nb > 1e-9:
            n_tgt = (n_b[0] / nb, n_b[1] / nb, n_b[2] / nb)
        pe, fe = face_solve(prot, ppos, ch_l.offsets, ch_l.eff_off, loc_l, eul_l, face_free, face_w, ch_l.lo,
                            ch_l.hi, ch_l.hold, (handle, n_tgt, n_last), tol, FACE_ITER, work)
        if not pe < tol:        # the face held by a limit kept the bat off: the bat first
            _solve_chain(solver, prot, ppos, ch_l, loc_l, eul_l, src_l, handle, tol, max_iter, damping, s)
    return its, n_tgt, fe


@njit(cache=True, inline='always')
def _left_arm(i, f, handle, shot, start, left, opts, face, out, bufs, s, work, kept, free):
    """Frame f's left arm into out's slot i (from the start pose, the slot holding the
    source; :func:`_left_solve`), the humerus held (engine.humerus_nb); where the hold keeps
    the bat off its handle or its face off its target (HELD_FACE at the hit, more freely
    where the blend is low), or with ``free``, again with it let go, and the held answer
    kept if the free one brings the face no nearer. Into kept's slot i what the second
    pass needs (see :func:`_bat_frames`)."""
    parents, trans, subtree, src_grot, src_gpos, _, _, _, bat, lhand, _ = shot
    lj, l_off, l_eoff, l_free, l_kind, l_lo, l_hi, l_w, l_hold = left
    tol = opts[2]
    face_local, face_turn = face[3], face[4]
    out_local, out_grot, out_gpos, out_blend, _, out_err, _, _ = out
    loc_l, _, src_l, _, eul, lo, hi, held_l, held_e = bufs
    nl = lj.shape[0]
    eul_l, lo_l, hi_l = eul[:nl], lo[:nl], hi[:nl]
    ch_l = Chain(lj, l_off, l_eoff, l_free, l_kind, lo_l, hi_l, l_w, l_hold)
    blend = out_blend[i]
    prot, ppos = q_at(src_grot[f], parents[lj[0]]), v_at(src_gpos[f], parents[lj[0]])
    # the source's face at this frame (turned with the hit point), and in the hand's frame
    n_src = qrot(q_at(src_grot[f], bat), (face_local[0], face_local[1], face_local[2]))
    n_last = qrot(qconj(q_at(src_grot[f], lhand)), n_src)
    turned = blend > 0.0 and (face_turn[0] != 0.0 or face_turn[1] != 0.0 or face_turn[2] != 0.0)
    faces = (blend, n_src, n_last, turned)
    face_slack = HELD_FACE + (1.0 - blend) * HELD_FACE_FAR
    fe_held, its_held, tgt_held = -1.0, 0, n_src
    attempt = 0     # 0: the humerus held, 1: let go, 2 on: the trunk further (the bat first)
    while True:
        gather_chain(start[0][f], lj, loc_l)
        gather_chain(start[1][f], lj, src_l)
        copy_rows(src_l, eul_l)
        open_window(loc_l, l_hold)
        if free or attempt > 0:
            release(l_hold)
        its, n_tgt, fe = _left_solve(prot, ppos, ch_l, (loc_l, eul_l, src_l), handle, faces, opts, face, s, work,
                                     (l_lo, l_hi, opts[6][max(attempt - 1, 0)]))
        if its == 0 or attempt == opts[6].shape[0]:
            break
        bat_ok = vnorm(vsub(chain_fk(prot, ppos, l_off, l_eoff, loc_l, s.g_rot, s.g_pos), handle)) < tol
        if attempt == 0 and held(l_hold):
            if bat_ok and fe <= face_slack:
                break
            if bat_ok:      # the face short of its target: kept, if the free arm gets no nearer
                copy_rows(loc_l, held_l)
                copy_rows(eul_l, held_e)
                fe_held, its_held, tgt_held = fe, its, n_tgt
            attempt = 1
        elif bat_ok or not opts[7]:
            break
        else:
            attempt = max(attempt, 1) + 1
    is_held = held(l_hold)
    if fe_held >= 0.0 and fe_held <= fe + face_slack:
        copy_rows(held_l, loc_l)
        copy_rows(held_e, eul_l)
        its, n_tgt, is_held = its_held, tgt_held, True
    if its > 0:
        scatter_chain(loc_l, lj, out_local[i])
        tree_fk(parents, trans[f], out_local[i], subtree, out_grot[i], out_gpos[i])
    out_err[i] = vnorm(vsub(v_at(out_gpos[i], bat), handle))
    kept[0][i] = its
    kept[3][i] = is_held and its > 0
    for c in range(3):
        kept[1][i, 0, c] = n_tgt[c]
        kept[1][i, 1, c] = n_last[c]
    kept[2][i] = eul_l


@njit(cache=True, inline='always')
def _bat_frames(frames, desired, blends, shot, start, left, opts, face, out, bufs, s, work, kept):
    """Every frame's left arm (the first pass of :func:`adapt_frames`, arguments as
    there; :func:`_left_arm`); the pose into ``out`` (FK of the left chain's subtree);
    into kept = (steps (K,) (0: untouched), the face's target normal and its normal in
    the left hand's frame (K,2,3), the left arm's Euler angles (K,nl,3), whether its
    humerus was held (K,)) what the second pass needs. Inlined (called once): a call
    passing some fifty arrays cost a one-frame adaptation ~1 us."""
    _, _, _, src_grot, src_gpos, _, _, hit, bat, _, _ = shot
    out_local, out_grot, out_gpos, out_blend, out_handle = out[0], out[1], out[2], out[3], out[4]
    src_local = start[0]
    b_h = v_at(src_gpos[hit], bat)
    offset = qrot(qconj(q_at(src_grot[hit], bat)), vsub((desired[0], desired[1], desired[2]), b_h))
    for i in range(frames.shape[0]):
        f = frames[i]
        out_local[i] = src_local[f]
        out_grot[i] = src_grot[f]
        out_gpos[i] = src_gpos[f]
        b_f = v_at(src_gpos[f], bat)
        blend = blends[f]
        o = qrot(q_at(src_grot[f], bat), offset)
        handle = (b_f[0] + blend * o[0], b_f[1] + blend * o[1], b_f[2] + blend * o[2])
        out_blend[i] = blend
        v_put(out_handle, i, handle)
        _left_arm(i, f, handle, shot, start, left, opts, face, out, bufs, s, work, kept, False)


@njit(cache=True, inline='always')
def _torso_helps(i, f, shot, start, left, right, opts, face, out, bufs, s, work, kept):
    """Frame f's right hand out of the right arm's reach (in :func:`_hand_frames`): both
    arms together from the first pass's left arm (the torso leans, and with the face kept
    the roll joints turn too), the grip before the face (without the face if they clash);
    where the bat gave way to the grip, the bat back on its handle and the right arm
    again. The left arm into out's local rotations of slot i; the right arm in bufs."""
    parents, _, _, src_grot, src_gpos, rel_pos, rel_rot, _, _, _, rp = shot
    lj, l_off, l_eoff, l_free, l_kind, l_lo, l_hi, l_w, l_hold = left
    _, solver, tol, max_iter, damping, ori_tol, reach, _ = opts
    keep_face, face_free = face[0], face[1]
    loc_l, loc_r, src_l, _, eul, lo, hi, _, _ = bufs
    nl = lj.shape[0]
    eul_l, eul_r = eul[:nl], eul[nl:]
    gather_chain(out[0][i], lj, loc_l)
    gather_chain(start[1][f], lj, src_l)
    eul_l[:] = kept[2][i]
    widen_limits(l_lo, l_hi, src_l, lo[:nl], hi[:nl])
    narrow_limits(lo[:nl], hi[:nl], src_l, reach[0])      # the trunk within its reach, or where the bat took it
    widen_limits(lo[:nl], hi[:nl], eul_l, lo[:nl], hi[:nl])
    handle = v_at(out[4], i)
    rel_p, rel_q = v_at(rel_pos, f), q_at(rel_rot, f)
    pj = parents[lj[0]]
    prl = q_at(src_grot[f], pj)
    ppl = v_at(src_gpos[f], pj)
    arms = (l_off, l_eoff, right[1], right[2], rp, l_hold, right[8])
    both_free = face_free if keep_face else l_free
    fw = FACE_LENGTH if keep_face else 0.0
    n_face = kept[1]
    n_tgt = (n_face[i, 0, 0], n_face[i, 0, 1], n_face[i, 0, 2])
    n_last = (n_face[i, 1, 0], n_face[i, 1, 1], n_face[i, 1, 2])
    for _try in range(2):   # the grip before the face: without it if they clash
        pe, oe = both_arms_solve(prl, ppl, arms, (both_free, right[3]), (loc_l, loc_r, eul), (lo, hi),
                                 (handle, (fw, n_tgt, n_last), rel_p, rel_q), tol, ori_tol, 80, TORSO_WEIGHT)
        if fw == 0.0 or (pe <= GRIP_CM and oe <= GRIP_RAD):
            break
        fw = 0.0
    b2 = chain_fk(prl, ppl, l_off, l_eoff, loc_l, s.g_rot, s.g_pos)
    if vnorm(vsub(b2, handle)) >= tol:
        # the bat gave way to the grip: put it back, then the right arm again
        ch_l = Chain(lj, l_off, l_eoff, l_free, l_kind, lo[:nl], hi[:nl], l_w, l_hold)
        _solve_chain(solver, prl, ppl, ch_l, loc_l, eul_l, src_l, handle, tol, max_iter, damping, s)
        if opts[7] and vnorm(vsub(chain_fk(prl, ppl, l_off, l_eoff, loc_l, s.g_rot, s.g_pos), handle)) >= tol:
            # held, short of it from there (crawling along the trunk's bounds: the cover drive
            # 30 cm off, low and forward, held within 10 deg, 0.046 cm at its hit after 200
            # sweeps): the left arm as the first pass left it, on its handle
            gather_chain(out[0][i], lj, loc_l)
            eul_l[:] = kept[2][i]
        chain_fk(prl, ppl, l_off, l_eoff, loc_l, s.g_rot, s.g_pos)
        t_pos, t_rot = grip_target(q_at(s.g_rot, nl - 1), v_at(s.g_pos, nl - 1), rel_p, rel_q)
        grip_solve(q_at(s.g_rot, rp), v_at(s.g_pos, rp), right[1], right[2], loc_r, eul_r, right[3], lo[nl:],
                   hi[nl:], right[8], t_pos, t_rot, tol, ori_tol, 30, work)
    scatter_chain(loc_l, lj, out[0][i])


@njit(cache=True, inline='always')
def _right_hand(i, f, target, shot, start, left, right, opts, face, out, bufs, s, work, kept, torso):
    """Frame f's right hand onto its grip ``target`` = (position, rotation) from out's slot
    i (in :func:`_hand_frames`): wrist position first (as the dissertation), then the
    joints that turn the hand without moving the wrist; if limits keep the hand off its
    grip and ``torso``, both arms together (:func:`_torso_helps`). Slot i gets the pose, its FK and the
    bat's error. Returns the grip target of the new left hand."""
    parents, trans, subtree, _, _, rel_pos, rel_rot, _, bat, lhand, rp = shot
    rj, r_off, r_eoff, r_free, r_kind, r_lo, r_hi, r_w, r_hold = right
    _, solver, tol, max_iter, damping, ori_tol, _, _ = opts
    out_local, out_grot, out_gpos, _, out_handle, out_err, _, _ = out
    _, loc_r, _, src_r, eul, lo, hi, _, _ = bufs
    g_rot, g_pos = s.g_rot, s.g_pos
    nr = rj.shape[0]
    nl = eul.shape[0] - nr
    eul_r, lo_r, hi_r = eul[nl:], lo[nl:], hi[nl:]
    t_pos, t_rot = target
    gather_chain(out_local[i], rj, loc_r)
    gather_chain(start[1][f], rj, src_r)
    copy_rows(src_r, eul_r)
    widen_limits(r_lo, r_hi, src_r, lo_r, hi_r)
    pj = parents[rj[0]]
    prot = (out_grot[i, pj, 0], out_grot[i, pj, 1], out_grot[i, pj, 2], out_grot[i, pj, 3])
    ppos = (out_gpos[i, pj, 0], out_gpos[i, pj, 1], out_gpos[i, pj, 2])
    eff = chain_fk(prot, ppos, r_off, r_eoff, loc_r, g_rot, g_pos)
    if vnorm(vsub(eff, t_pos)) < tol and q_angle(q_at(g_rot, nr - 1), t_rot) < ori_tol:
        return t_pos, t_rot
    ch_r = Chain(rj, r_off, r_eoff, r_free, r_kind, lo_r, hi_r, r_w, r_hold)
    _solve_chain(solver, prot, ppos, ch_r, loc_r, eul_r, src_r, t_pos, tol, max_iter, damping, s)
    oe = orient_finish(prot, ppos, r_off, r_eoff, loc_r, eul_r, src_r, r_free, r_kind, lo_r, hi_r, r_hold, t_rot,
                       (g_rot, g_pos), 8, ori_tol)
    eff = chain_fk(prot, ppos, r_off, r_eoff, loc_r, g_rot, g_pos)
    pe = vnorm(vsub(eff, t_pos))
    if pe >= tol or oe >= ori_tol:
        before = math.hypot(pe, GRIP_LENGTH * oe)
        pe, oe = grip_solve(prot, ppos, r_off, r_eoff, loc_r, eul_r, r_free, lo_r, hi_r, r_hold, t_pos, t_rot,
                            tol, ori_tol, 30, work)
        if (pe > GRIP_CM or oe > GRIP_RAD) and rp >= 0 and (torso or math.hypot(pe, GRIP_LENGTH * oe) < before):
            # out of the right arm's reach: let the torso help
            _torso_helps(i, f, shot, start, left, right, opts, face, out, bufs, s, work, kept)
    scatter_chain(loc_r, rj, out_local[i])
    tree_fk(parents, trans[f], out_local[i], subtree, out_grot[i], out_gpos[i])
    out_err[i] = vnorm(vsub(v_at(out_gpos[i], bat), v_at(out_handle, i)))
    return grip_target(q_at(out_grot[i], lhand), v_at(out_gpos[i], lhand), v_at(rel_pos, f), q_at(rel_rot, f))


@njit(cache=True)
def _slot(out, i, dst):
    """Copy out's slot i (local rotations, global rotations, positions, bat error) into
    ``dst``; :func:`_put_slot` is the way back."""
    dst[0][:] = out[0][i]
    dst[1][:] = out[1][i]
    dst[2][:] = out[2][i]
    dst[3][0] = out[5][i]


@njit(cache=True)
def _put_slot(src, out, i):
    out[0][i] = src[0]
    out[1][i] = src[1]
    out[2][i] = src[2]
    out[5][i] = src[3][0]


@njit(cache=True)
def _off_grip(out, i, rh, target):
    """Whether the right hand in out's slot i is further than GRIP_CM or GRIP_RAD from its
    grip ``target``."""
    return vnorm(vsub(v_at(out[2][i], rh), target[0])) > GRIP_CM or q_angle(q_at(out[1][i], rh), target[1]) > GRIP_RAD


@njit(cache=True)
def _face_error(out, i, lhand, kept):
    """Radians between the bat face in out's slot i and the first pass's target for it."""
    n = qrot(q_at(out[1][i], lhand), v_at(kept[1][i], 1))
    return math.acos(min(1.0, max(-1.0, dot(n, v_at(kept[1][i], 0)))))


@njit(cache=True, inline='always')
def _hand_frames(frames, shot, start, left, right, opts, face, out, bufs, s, work, kept):
    """Every frame's right hand back on its source grip relative to the left hand (the
    second pass of :func:`adapt_frames`, after :func:`_bat_frames`) where the left arm
    moved (:func:`_right_hand`), both humeri held (engine.humerus_nb). Where that leaves
    the hand off its grip, the bat off its handle or turns its face, again with them let
    go; if the left arm's held pose is what keeps the grip out of reach, both arms again
    from the start, free (as before the hold). Then the grip's errors. Inlined, as
    :func:`_bat_frames`."""
    _, _, _, _, _, rel_pos, rel_rot, _, _, lhand, _ = shot
    rj, r_hold, l_hold, lj = right[0], right[8], left[8], left[0]
    fix_right, tol = opts[0], opts[2]
    out_grot, out_gpos, out_err, out_gcm, out_gdeg = out[1], out[2], out[5], out[6], out[7]
    rh = rj[rj.shape[0] - 1]
    J = out[0].shape[1]
    saved = (np.empty((J, 4)), np.empty((J, 4)), np.empty((J, 3)), np.empty(1))
    for i in range(frames.shape[0]):
        f = frames[i]
        target = grip_target(q_at(out_grot[i], lhand), v_at(out_gpos[i], lhand), v_at(rel_pos, f), q_at(rel_rot, f))
        if fix_right and kept[0][i] > 0:
            _slot(out, i, saved)
            err0, face0 = out_err[i], _face_error(out, i, lhand, kept)
            gather_chain(out[0][i], rj, bufs[1])
            open_window(bufs[1], r_hold)
            gather_chain(start[0][f], lj, bufs[0])
            open_window(bufs[0], l_hold)        # (the first pass left the last frame's)
            t = _right_hand(i, f, target, shot, start, left, right, opts, face, out, bufs, s, work, kept,
                            not (held(r_hold) or held(l_hold)))
            if (held(r_hold) or held(l_hold)) and (_off_grip(out, i, rh, t) or out_err[i] > max(tol, err0)
                                                  or _face_error(out, i, lhand, kept) > face0 + HELD_FACE):
                _put_slot(saved, out, i)
                release(r_hold)
                release(l_hold)
                t = _right_hand(i, f, target, shot, start, left, right, opts, face, out, bufs, s, work, kept, True)
                if kept[3][i] and (_off_grip(out, i, rh, t) or _face_error(out, i, lhand, kept) > face0 + HELD_FACE):
                    # the left arm's held pose keeps the grip out of reach, or turns the face
                    # to reach it (the leg glance 30 cm to leg, low and forward: 2.9 -> 8.5
                    # deg at the hit): both arms free
                    _put_slot(saved, out, i)
                    out[0][i] = start[0][f]
                    out[1][i] = shot[3][f]
                    out[2][i] = shot[4][f]
                    _left_arm(i, f, v_at(out[4], i), shot, start, left, opts, face, out, bufs, s, work, kept, True)
                    t = grip_target(q_at(out_grot[i], lhand), v_at(out_gpos[i], lhand), v_at(rel_pos, f),
                                    q_at(rel_rot, f))
                    t = _right_hand(i, f, t, shot, start, left, right, opts, face, out, bufs, s, work, kept, True)
            target = t
        out_gcm[i] = vnorm(vsub(v_at(out_gpos[i], rh), target[0]))
        out_gdeg[i] = math.degrees(q_angle(q_at(out_grot[i], rh), target[1]))


@njit(cache=True, nogil=True)
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
    damping, orientation tol rad, the left chain's reach from its start pose (R, nl) rad
    (engine.adapt.trunk_reach: row 0 first, each next one where the bat is not reached
    within the last), whether row 0 bounds anything); face = (keep, free (nl,3), weights (nl,), normal in the
    bat's frame (3,), turn (3,)): when kept, after the position solve the left arm's
    ``free`` joints turn the bat face to the source's, turned by the rotation vector
    ``turn`` times the frame's blend."""
    nl, nr = left[0].shape[0], right[0].shape[0]
    K = frames.shape[0]
    s = scratch(max(nl, nr))
    work = (s.g_rot, s.g_pos, np.empty((3 * max(nl, nr), 7)), s.dofs, np.empty((6, 6)), np.empty(6), np.empty(6),
            s.bak_l, s.bak_e)
    # loc_l, loc_r, src_l, src_r, both arms' Euler angles and the frame's limits (left first),
    # the left arm's held answer (local rotations, Euler angles) while the free one is tried
    bufs = (np.empty((nl, 4)), np.empty((nr, 4)), np.empty((nl, 3)), np.empty((nr, 3)), np.empty((nl + nr, 3)),
            np.empty((nl + nr, 3)), np.empty((nl + nr, 3)), np.empty((nl, 4)), np.empty((nl, 3)))
    kept = (np.empty(K, np.int64), np.empty((K, 2, 3)), np.empty((K, nl, 3)), np.zeros(K, np.bool_))
    _bat_frames(frames, desired, blends, shot, start, left, opts, face, out, bufs, s, work, kept)
    _hand_frames(frames, shot, start, left, right, opts, face, out, bufs, s, work, kept)

