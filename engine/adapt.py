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
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from . import quat
from .ccd import ITERATIONS, TOLERANCE, ChainArrays, ccd_frame, chain_arrays, limit_euler
from .dls import DAMPING, default_stiffness, dls_frame
from .kinematics_nb import (IDENTITY, KIND_MULTI, KIND_NONE, ORIGIN, Chain, chain_fk, fk_into, hinge_axis, load_pose,
                            new_pose, new_work, store_local)
from .nb import kernel
from .quat_nb import (clamp_angle, dot, from_euler_zyx, pick_branch, q_angle, q_at, q_put, qconj, qmul, qrot,
                      to_euler_zyx, v_at, v_put, vnorm, vsub)
from .skeleton import local_translations
from .solve_nb import BOTH, GRIP, Damping, grip_target, lm_solve

ORIENT_TOL = 1e-4       # rad: the right hand's orientation is "there"
GRIP_CM = 0.05          # right hand further than this from its grip ...
GRIP_RAD = math.radians(0.5)  # ... or turned more than this: solve both arms together
SOLVERS = ("ccd", "dls")
FALLOFF = 90.0          # cm: the dissertation's default importance falloff (2.2.5)
# damped Newton on the grip (and on both arms): from 0.5, down to 0.05, give up
# past 1e4; stop when a step gains less than 0.1 % (stalled against a limit)
GRIP_DAMPING = Damping(0.5, 0.05, 1e4, 0.25, 0.0, 0.0, 1e-3)

# the shot's per-frame data and the run's settings, as the compiled pipeline takes them
ShotData = namedtuple("ShotData", "hit parents trans src_local src_grot src_gpos src_euler subtree bat lhand "
                                  "rel_pos rel_rot rp lj rj")
RunSettings = namedtuple("RunSettings", "solver fix_right tol max_iter damping ori_tol")
Outputs = namedtuple("Outputs", "local grot gpos blend handle err gcm gdeg")


@dataclass
class AdaptSettings:
    falloff: float = FALLOFF     # cm
    wrist_dof: int = 0           # 0 (locked, default) or 2
    solver: str = SOLVERS[0]     # "ccd" | "dls"
    iterations: int = ITERATIONS
    tolerance: float = TOLERANCE  # cm
    fix_right_hand: bool = True


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

@kernel
def _orient_joint(prot, kd, free, local, euler, src, lo, hi, g_rot, g_pos, k, eff, target_rot):
    """Turn chain joint k (of kind kd) toward putting the last joint on target_rot,
    if that leaves the effector where it is; False when it would move it."""
    n = free.shape[0]
    u = vsub(eff, v_at(g_pos, k))
    gp = prot if k == 0 else q_at(g_rot, k - 1)
    last = q_at(g_rot, n - 1)
    if kd == KIND_MULTI:
        if vnorm(u) > 1e-6:
            return False
        # the joint's global rotation that would put the last joint on target
        want = qmul(target_rot, qmul(qconj(last), q_at(g_rot, k)))
        e = pick_branch(to_euler_zyx(qmul(qconj(gp), want)), euler, src, free, lo, hi, k)
        for c in range(3):
            if free[k, c]:
                euler[k, c] = clamp_angle(e[c], lo[k, c], hi[k, c])
            else:
                euler[k, c] = src[k, c]
    else:
        c = kd - 1
        axis = hinge_axis(prot, g_rot, euler, k, c)
        du = dot(u, axis)
        if vnorm((u[0] - du * axis[0], u[1] - du * axis[1], u[2] - du * axis[2])) > 1e-6:
            return False
        # twist of the remaining error about the hinge axis
        qe = qmul(target_rot, qconj(last))
        if qe[0] < 0.0:
            qe = (-qe[0], -qe[1], -qe[2], -qe[3])
        theta = 2.0 * math.atan2(qe[1] * axis[0] + qe[2] * axis[1] + qe[3] * axis[2], qe[0])
        euler[k, c] = clamp_angle(euler[k, c] + theta, lo[k, c], hi[k, c])
    q_put(local, k, from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2]))
    return True


@kernel
def orient_finish(prot, ppos, chain, pose, target_rot, reps, ori_tol, w):
    """Turn the trailing chain joints that leave the effector where it is (the
    effector's own joint, a twist about the bone it lies on) so the last
    joint's global rotation approaches target_rot. Returns the angle error (rad)."""
    kind, free, local, g_rot, g_pos = chain.kind, chain.free, pose.local, w.g_rot, w.g_pos
    euler, src, lo, hi = pose.euler, pose.src, pose.lo, pose.hi
    n = kind.shape[0]
    eff = chain_fk(prot, ppos, chain, local, g_rot, g_pos)
    err = q_angle(q_at(g_rot, n - 1), target_rot)
    for _ in range(reps):
        if err < ori_tol:
            break
        for k in range(n - 1, -1, -1):
            if kind[k] == KIND_NONE:
                continue
            if not _orient_joint(prot, kind[k], free, local, euler, src, lo, hi, g_rot, g_pos, k, eff, target_rot):
                break
            eff = chain_fk(prot, ppos, chain, local, g_rot, g_pos)
        err = q_angle(q_at(g_rot, n - 1), target_rot)
    return err


@kernel
def grip_solve(prot, ppos, chain, pose, target_pos, target_rot, tol, ori_tol, max_iter, w):
    """Damped Newton on position and orientation of the chain's last joint
    from the current pose (after the position solve and the twist/hand finish
    could not get the orientation). Returns (position error, angle error)."""
    eff, _, _ = lm_solve(GRIP, prot, ppos, chain, pose, chain, pose, 0, (target_pos, target_rot, ORIGIN),
                         tol, ori_tol, GRIP_DAMPING, max_iter, w)
    return vnorm(vsub(eff, target_pos)), q_angle(q_at(w.g_rot, chain.order.shape[0] - 1), target_rot)


@kernel
def both_arms_solve(prot, ppos, left, pose_l, rp, right, pose_r, handle, rel_p, rel_q, tol, ori_tol,
                    max_iter, w):
    """Damped Newton on both arm chains at once: the bat on its handle AND the
    right hand on its grip ``rel_p``/``rel_q`` in the left hand's frame (the torso
    joints shared by both chains, up to left-chain joint ``rp``, can then lean to
    give the right arm its reach). Used when the right arm alone cannot get
    back to the grip."""
    lm_solve(BOTH, prot, ppos, left, pose_l, right, pose_r, rp, (handle, rel_q, rel_p), tol, ori_tol,
             GRIP_DAMPING, max_iter, w)


@kernel
def _effective_limits(chain, pose):
    """The rig's limits widened to take in the source angle: a source frame
    outside its limits may stay where it is or move back in, never further out
    (and never jump to the far limit)."""
    lo, hi, src, out_lo, out_hi = chain.lo, chain.hi, pose.src, pose.lo, pose.hi
    for k in range(lo.shape[0]):
        for c in range(3):
            out_lo[k, c] = min(lo[k, c], src[k, c])
            out_hi[k, c] = max(hi[k, c], src[k, c])


@kernel
def _solve_chain(cfg, prot, ppos, chain, pose, handle, w):
    if cfg.solver == 0:
        return ccd_frame(prot, ppos, chain, pose, handle, cfg.tol, cfg.max_iter, w)
    return dls_frame(prot, ppos, chain, pose, handle, cfg.tol, cfg.max_iter, cfg.damping, w)


@kernel
def _row_q(a, f, j):
    return (a[f, j, 0], a[f, j, 1], a[f, j, 2], a[f, j, 3])


@kernel
def _row_v(a, f, j):
    return (a[f, j, 0], a[f, j, 1], a[f, j, 2])


@kernel
def _grip_of(S, out, i, f):
    """The right hand's grip target (position, rotation) on slot i's left hand."""
    return grip_target(out.grot[i], out.gpos[i], S.lhand + 1, _row_v3(S.rel_pos, f), _row_q4(S.rel_rot, f))


@kernel
def _row_v3(a, f):
    return (a[f, 0], a[f, 1], a[f, 2])


@kernel
def _row_q4(a, f):
    return (a[f, 0], a[f, 1], a[f, 2], a[f, 3])


@kernel
def _right_hand(S, L, R, cfg, pose_l, pose_r, i, f, handle, t_pos, t_rot, out, w):
    """Slot i's right hand back on its grip (t_pos, t_rot) after the left arm
    moved: wrist position first (as the dissertation), then the joints that
    turn the hand without moving the wrist; if limits keep the hand off its
    grip, both together by damped Newton, then both arms (and if the bat gave
    way to the grip, the bat back, then the right arm again). Returns the grip.
    (One function, not three: each call level costs numba seconds of compile.)"""
    load_pose(pose_r, out.local[i], S.src_euler[f], S.rj)
    _effective_limits(R, pose_r)
    pj = S.parents[S.rj[0]]
    prot = _row_q(out.grot, i, pj)
    ppos = _row_v(out.gpos, i, pj)
    nr = R.order.shape[0]
    eff = chain_fk(prot, ppos, R, pose_r.local, w.g_rot, w.g_pos)
    if not (vnorm(vsub(eff, t_pos)) >= cfg.tol or q_angle(q_at(w.g_rot, nr - 1), t_rot) >= cfg.ori_tol):
        return t_pos, t_rot     # the left arm's move left the grip where it was
    _solve_chain(cfg, prot, ppos, R, pose_r, t_pos, w)
    oe = orient_finish(prot, ppos, R, pose_r, t_rot, 8, cfg.ori_tol, w)
    eff = chain_fk(prot, ppos, R, pose_r.local, w.g_rot, w.g_pos)
    if vnorm(vsub(eff, t_pos)) >= cfg.tol or oe >= cfg.ori_tol:
        pe, oe = grip_solve(prot, ppos, R, pose_r, t_pos, t_rot, cfg.tol, cfg.ori_tol, 30, w)
        if (pe > GRIP_CM or oe > GRIP_RAD) and S.rp >= 0:
            # out of the right arm's reach: both arms together (the torso leans)
            pj = S.parents[S.lj[0]]
            prl = _row_q(S.src_grot, f, pj)
            ppl = _row_v(S.src_gpos, f, pj)
            rel_p = _row_v3(S.rel_pos, f)
            rel_q = _row_q4(S.rel_rot, f)
            both_arms_solve(prl, ppl, L, pose_l, S.rp, R, pose_r, handle, rel_p, rel_q, cfg.tol, cfg.ori_tol, 40, w)
            b2 = chain_fk(prl, ppl, L, pose_l.local, w.g_rot, w.g_pos)
            if vnorm(vsub(b2, handle)) >= cfg.tol:
                # the bat gave way to the grip: put it back, then the right arm again
                _solve_chain(cfg, prl, ppl, L, pose_l, handle, w)
                chain_fk(prl, ppl, L, pose_l.local, w.g_rot, w.g_pos)
                tp2, tr2 = grip_target(w.g_rot, w.g_pos, L.order.shape[0], rel_p, rel_q)
                grip_solve(q_at(w.g_rot, S.rp), v_at(w.g_pos, S.rp), R, pose_r, tp2, tr2, cfg.tol, cfg.ori_tol, 30, w)
            store_local(pose_l, S.lj, out.local[i])
    store_local(pose_r, S.rj, out.local[i])
    fk_into(IDENTITY, ORIGIN, S.parents, S.trans[f], out.local[i], S.subtree, out.grot[i], out.gpos[i])
    out.err[i] = vnorm(vsub(_row_v(out.gpos, i, S.bat), handle))
    return _grip_of(S, out, i, f)


@kernel
def _adapt_frames(frames, desired, blends, s, left, right, c, outs):
    """Adapt the frames listed in ``frames`` into output slots 0..len(frames)-1.

    ``s``, ``left``, ``right``, ``c``, ``outs``: the fields of ShotData, the two
    Chains, RunSettings and Outputs as plain tuples (numba types a namedtuple
    argument in Python, some microseconds a call, a plain tuple in C; scrubbing
    calls this every frame). Kept one level deep on purpose: numba re-optimises
    a kernel's whole call tree at every level, so each wrapper costs seconds of
    cold compile."""
    S, L, R, cfg, out = ShotData(*s), Chain(*left), Chain(*right), RunSettings(*c), Outputs(*outs)
    nl = L.order.shape[0]
    nr = R.order.shape[0]
    w = new_work(max(nl, nr))
    pose_l = new_pose(nl)
    pose_r = new_pose(nr)
    rh = S.rj[nr - 1]
    b_h = _row_v(S.src_gpos, S.hit, S.bat)
    r_h = _row_q(S.src_grot, S.hit, S.bat)
    offset = qrot(qconj(r_h), vsub((desired[0], desired[1], desired[2]), b_h))
    for i in range(frames.shape[0]):
        f = frames[i]
        b_f = _row_v(S.src_gpos, f, S.bat)
        blend = blends[f]
        o = qrot(_row_q(S.src_grot, f, S.bat), offset)
        out.blend[i] = blend
        handle = (b_f[0] + blend * o[0], b_f[1] + blend * o[1], b_f[2] + blend * o[2])
        # the left arm puts the bat on the handle, the right hand goes back on its grip
        out.local[i] = S.src_local[f]
        out.grot[i] = S.src_grot[f]
        out.gpos[i] = S.src_gpos[f]
        v_put(out.handle, i, handle)
        load_pose(pose_l, S.src_local[f], S.src_euler[f], S.lj)
        _effective_limits(L, pose_l)
        pj = S.parents[S.lj[0]]
        _, its = _solve_chain(cfg, _row_q(S.src_grot, f, pj), _row_v(S.src_gpos, f, pj), L, pose_l, handle, w)
        if its > 0:
            store_local(pose_l, S.lj, out.local[i])
            fk_into(IDENTITY, ORIGIN, S.parents, S.trans[f], out.local[i], S.subtree, out.grot[i], out.gpos[i])
        out.err[i] = vnorm(vsub(_row_v(out.gpos, i, S.bat), handle))
        t_pos, t_rot = _grip_of(S, out, i, f)
        if cfg.fix_right and its > 0:
            t_pos, t_rot = _right_hand(S, L, R, cfg, pose_l, pose_r, i, f, handle, t_pos, t_rot, out, w)
        out.gcm[i] = vnorm(vsub(_row_v(out.gpos, i, rh), t_pos))
        out.gdeg[i] = math.degrees(q_angle(_row_q(out.grot, i, rh), t_rot))


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
        self.subtree_r = _subtree(self.parents, int(right.joints[0]))
        # the right hand's source grip in the left hand's frame, per frame
        g_lh, g_rh = self.src_grot[:, self.lhand], self.src_grot[:, self.rhand]
        inv = quat.conjugate(g_lh)
        self.rel_rot = np.ascontiguousarray(quat.mul(inv, g_rh))
        self.rel_pos = np.ascontiguousarray(quat.rotate(inv, self.src_gpos[:, self.rhand] - self.src_gpos[:, self.lhand]))
        self._chains: dict[tuple, tuple] = {}
        self._blend_cache: tuple[float, np.ndarray] = (float("nan"), np.empty(0))
        # where the right arm hangs off the left-arm chain (Spine2), for the two-arm solve
        rpar = int(self.parents[right.joints[0]])
        self.right_parent_in_left = list(left.joints).index(rpar) if rpar in list(left.joints) else -1
        self.hit_point = self.src_gpos[self.hit_frame, self.bat].copy()
        self.bat_positions = self.src_gpos[:, self.bat]
        self._shot_data = ShotData(self.hit_frame, self.parents, self.trans, self.src_local, self.src_grot,
                                   self.src_gpos, self.src_euler, np.flatnonzero(self.subtree_l).astype(np.int64),
                                   self.bat, self.lhand, self.rel_pos, self.rel_rot, self.right_parent_in_left,
                                   np.ascontiguousarray(left.joints, np.int64),
                                   np.ascontiguousarray(right.joints, np.int64))
        self._shot_tuple = tuple(self._shot_data)

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

    def _blend_for(self, falloff: float) -> np.ndarray:
        # cached: scrubbing calls adapt_frame every frame with the same falloff
        if self._blend_cache[0] != falloff:
            self._blend_cache = (falloff, np.ascontiguousarray(self.blend(falloff)))
        return self._blend_cache[1]

    def _chain_args(self, settings: AdaptSettings) -> tuple:
        """The left and right arm chains for the compiled solvers (cached per wrist and solver)."""
        key = (settings.wrist_dof, settings.solver)
        if key not in self._chains:
            out = []
            for name, wd in (("left_arm", settings.wrist_dof), ("right_arm", None)):
                ch: ChainArrays = chain_arrays(self.rig, name, wd)
                n = len(ch.joints)
                out.append(ch.packed(None if settings.solver == "ccd" else 1.0 / default_stiffness(n)))
            self._chains[key] = tuple(out)
        return self._chains[key]

    def _run(self, frames: np.ndarray, desired, settings: AdaptSettings):
        check_settings(settings)
        p = check_point(desired, "desired hit point")
        K, J = len(frames), self.parents.shape[0]
        out = Outputs(np.empty((K, J, 4)), np.empty((K, J, 4)), np.empty((K, J, 3)), np.empty(K),
                      np.empty((K, 3)), np.empty(K), np.empty(K), np.empty(K))
        cfg = RunSettings(SOLVERS.index(settings.solver), bool(settings.fix_right_hand), float(settings.tolerance),
                          int(settings.iterations), DAMPING, ORIENT_TOL)
        left, right = self._chain_args(settings)
        _adapt_frames(frames, p, self._blend_for(float(settings.falloff)), self._shot_tuple, tuple(left),
                      tuple(right), tuple(cfg), tuple(out))
        return tuple(out), p

    def adapt(self, desired_hit_point, settings: AdaptSettings | None = None) -> Adaptation:
        """The whole shot adapted so the bat joint is at ``desired_hit_point`` at the hit frame."""
        settings = settings or AdaptSettings()
        frames = np.arange(self.num_frames, dtype=np.int64)
        (loc, grot, gpos, blend, handles, err, gcm, gdeg), p = self._run(frames, desired_hit_point, settings)
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
