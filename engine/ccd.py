"""Cyclic-coordinate-descent IK (dissertation 1.7.1 and its CCDSolverNode), compiled.

Position-only CCD on a chain of joints taken from the rig. Each iteration visits
the chain from the joint nearest the effector up to the chain root; a joint is
turned by the shortest-arc rotation taking ``effector - joint`` onto
``handle - joint``, then its locked Euler columns get their source values back
and the free ones are clamped to the rig's limits (the same Euler convention as
``quat.to_euler(q, "ZYX")``: columns z, y, x, R = Rz Ry Rx). A joint with a
single free axis is turned by the shortest rotation about that axis, which is
what "shortest arc, then put the locked columns back" is aiming at, without the
detour through a rotation the joint cannot make.

Every frame is independent: the hot loop runs in numba on flat float64 arrays,
quaternions are (w, x, y, z) tuples, and a whole shot is solved in one call.
The start pose is the frame's FK pose; when the effector is already within the
tolerance the frame is left untouched, so a handle on the FK effector gives back
exactly the source floats.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numba import njit

from .fk_nb import chain_fk
from .quat_nb import (TINY, qmul, qconj, cross, dot, vsub, vadd, vnorm, qrot, between, from_euler_zyx, to_euler_zyx,
                      clamp_angle, into_range, other_branch, outside, pick_branch, q_at, v_at, q_put, wrap)
from .step_nb import YES, Chain, PositionProblem, hinge_axis, lm_loop, scratch
from .euler import degrees_outside
from .humerus_nb import hold_fk, no_hold, open_window


KIND_NONE = 0          # no free DOF: never turned
# 1, 2, 3: a single free Euler column (kind - 1 = column z, y, x)
KIND_MULTI = 4         # two or three free columns

TOLERANCE = 0.001      # cm
ITERATIONS = 200
_STALL = 1e-7          # cm per sweep: slower progress than this means "as close as it gets"
_STALL_REL = 0.0       # share of the error a sweep must gain (0: only _STALL; CCD may crawl near limits yet arrive)
POLISH_STEPS = np.int64(8)     # Newton steps at most when a CCD sweep stalls near the handle
HOLD_ROUNDS = 3        # sweeps, then the humerus held, at most this many times (ccd_frame)


@njit(cache=True, inline='always')
def turn_joint(parent_rot, joint_rot, u, v, euler, src_euler, free, lo, hi, k):
    """Joint ``k`` (global rotation ``joint_rot``, its parent's ``parent_rot``) turned by the
    shortest arc taking direction ``u`` onto ``v`` (world), on its limits' Euler branch: the
    free columns clamped to ``lo``/``hi``, the locked ones ``src_euler``'s, into ``euler[k]``.
    Returns (whether it turned, its new local rotation). Inlined: the CCD sweep turns a
    joint with it every step (called, one frame cost ~3 us more)."""
    qd = between(u, v)
    if qd[0] == 1.0:
        return False, qd
    lc = qmul(qconj(parent_rot), qmul(qd, joint_rot))
    e = pick_branch(to_euler_zyx(lc), euler, src_euler, free, lo, hi, k)
    for c in range(3):
        if free[k, c]:
            euler[k, c] = clamp_angle(e[c], lo[k, c], hi[k, c])
        else:
            euler[k, c] = src_euler[k, c]
    return True, from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2])


@njit(cache=True)
def ccd_sweep(prot, offsets, local, euler, src_euler, free, kind, lo, hi, handle, tol, eff, g_rot, g_pos):
    """One CCD pass from the joint nearest the effector up to the chain root.
    Globals of joints below a turned one go stale (the caller recomputes them)."""
    n = offsets.shape[0]
    for k in range(n - 1, -1, -1):
        kd = kind[k]
        if kd == KIND_NONE:
            continue
        p = v_at(g_pos, k)
        gp = prot if k == 0 else q_at(g_rot, k - 1)
        u = vsub(eff, p)
        v = vsub(handle, p)
        if kd < KIND_MULTI:
            c = kd - 1
            axis = hinge_axis(prot, g_rot, euler, k, c)
            du = dot(u, axis)
            dv = dot(v, axis)
            up = (u[0] - du * axis[0], u[1] - du * axis[1], u[2] - du * axis[2])
            vp = (v[0] - dv * axis[0], v[1] - dv * axis[1], v[2] - dv * axis[2])
            if vnorm(up) < TINY or vnorm(vp) < TINY:
                continue
            delta = math.atan2(dot(axis, cross(up, vp)), dot(up, vp))
            old = euler[k, c]
            new = clamp_angle(old + delta, lo[k, c], hi[k, c])
            if new == old:
                continue
            euler[k, c] = new
            lq = from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2])
        else:
            turned, lq = turn_joint(gp, q_at(g_rot, k), u, v, euler, src_euler, free, lo, hi, k)
            if not turned:
                continue
        old_g = q_at(g_rot, k)
        new_g = qmul(gp, lq)
        q_put(local, k, lq)
        q_put(g_rot, k, new_g)
        # the subtree turns rigidly about the joint by new_g * old_g^-1
        eff = vadd(p, qrot(qmul(new_g, qconj(old_g)), u))
        if vnorm(vsub(eff, handle)) < tol:
            break
    return eff


@njit(cache=True)
def _sweeps(prot, ppos, ch, local, euler, src_euler, handle, tol, max_iter, s, eff, err, do_polish):
    """:func:`ccd_frame`'s sweeps (and Newton polish) from the pose whose effector ``eff``
    is ``err`` cm off: returns (error, effector, sweeps)."""
    offsets, eff_off, g_rot, g_pos = ch.offsets, ch.eff_off, s.g_rot, s.g_pos
    it = 0
    while it < max_iter:
        it += 1
        start_err = err
        eff = ccd_sweep(prot, offsets, local, euler, src_euler, ch.free, ch.kind, ch.lo, ch.hi, handle, tol, eff,
                        g_rot, g_pos)
        eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
        err = vnorm(vsub(eff, handle))
        if err < tol:
            break
        if do_polish and err > 0.5 * start_err:
            # Newton (lightly damped) steps from a CCD pose that stalled near the handle
            (err, eff), _ = lm_loop(PositionProblem(prot, ppos, ch, local, euler, handle, s, tol), (err, eff),
                                    (0.01, 0.01, 0.0, YES), (POLISH_STEPS, 0.0, 0.0, YES))
            if err < tol:
                break
        if start_err - err < max(_STALL, _STALL_REL * err):
            break       # as close as this pose gets (unreachable, or held by limits)
    return err, eff, it


@njit(cache=True)
def ccd_frame(prot, ppos, ch, local, euler, src_euler, handle, tol, max_iter, s):
    """Solve one frame in place. local (n,4) and euler (n,3, radians) hold the
    start pose and receive the result. Returns (error cm, iterations).

    CCD converges fast far from the handle and slowly near it (each joint only
    swings the effector onto its own joint-handle line, so the reach distance
    is fixed up a little per sweep). When a sweep gains less than half, Newton
    steps weighted by ``ch.weight (n,)`` finish the last centimetres
    (all-zero weights: pure CCD). The humerus is held (``ch.hold``, engine.humerus_nb)
    on the pose the sweeps converge to; its swing keeps the effector unless the arm's
    limits clamp it, and then the sweeps go on from the held pose (HOLD_ROUNDS)."""
    g_rot, g_pos = s.g_rot, s.g_pos
    eff = chain_fk(prot, ppos, ch.offsets, ch.eff_off, local, g_rot, g_pos)
    err = vnorm(vsub(eff, handle))
    if not err >= tol:          # also stops on a NaN handle (pose stays the source)
        return err, 0
    do_polish = False
    for k in range(local.shape[0]):
        if ch.weight[k] > 0.0:
            do_polish = True
    it = 0
    for _ in range(HOLD_ROUNDS):
        err, eff, k = _sweeps(prot, ppos, ch, local, euler, src_euler, handle, tol, max_iter - it, s, eff, err,
                              do_polish)
        it += k
        before = err
        # (the sweeps leave the FK of their last pose in g_rot/g_pos: the hold reads it)
        eff = hold_fk(prot, ppos, ch.offsets, ch.eff_off, local, euler, ch.lo, ch.hi, ch.hold, g_rot, g_pos, eff)
        err = vnorm(vsub(eff, handle))
        if err < tol or abs(err - before) < _STALL or it >= max_iter:
            break
    return err, it


@njit(cache=True)
def ccd_batch(prot, ppos, ch, local, euler, src_euler, handles, tol, max_iter, out_err, out_iter):
    """Every frame f of local (F,n,4) / euler (F,n,3) solved in place. ``ch``: the
    Chain's fields as a plain tuple (numba types a named tuple from Python slowly)."""
    ch = Chain(*ch)
    s = scratch(local.shape[1])
    for f in range(local.shape[0]):
        pr = (prot[f, 0], prot[f, 1], prot[f, 2], prot[f, 3])
        pp = (ppos[f, 0], ppos[f, 1], ppos[f, 2])
        h = (handles[f, 0], handles[f, 1], handles[f, 2])
        open_window(local[f], ch.hold)
        e, i = ccd_frame(pr, pp, ch, local[f], euler[f], src_euler[f], h, tol, max_iter, s)
        out_err[f] = e
        out_iter[f] = i


# --------------------------------------------------------------------------
# Python side: chain data from the rig, and a batched solve

@dataclass
class ChainArrays:
    """A rig chain as flat arrays for the compiled solvers (angles in radians)."""
    joints: np.ndarray      # (n,) int64 joint indices, root-most first
    effector: int
    offsets: np.ndarray     # (n,3) local translations of the chain joints
    eff_off: np.ndarray     # (3,) effector offset in the last chain joint's frame
    free: np.ndarray        # (n,3) bool, Euler columns (z, y, x) the solver may move
    kind: np.ndarray        # (n,) int64: 0 none, 1..3 single column (z, y, x), 4 several
    lo: np.ndarray          # (n,3) radians
    hi: np.ndarray          # (n,3) radians
    parent: int             # parent joint of the chain root
    polish_weight: np.ndarray = None  # (n,) weights of the Newton finish (0: pure CCD)
    hold: tuple = field(default_factory=no_hold)  # the upper arm's axial rotation (engine.humerus_nb)
    # the packed tuples, made once: never copied by dataclasses.replace (a changed chain packs its own)
    _tuples: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def packed(self, weight=None, free=None, kind=None) -> Chain:
        """The compiled kernels' :data:`engine.step_nb.Chain` (Newton weights ``weight``,
        default the polish weights; ``free``/``kind`` to lock more columns)."""
        free = self.free if free is None else free
        kind = self.kind if kind is None else kind
        weight = self.polish_weight if weight is None else weight
        return Chain(self.joints, self.offsets, self.eff_off, np.ascontiguousarray(free, np.bool_),
                     np.ascontiguousarray(kind, np.int64), self.lo, self.hi, np.ascontiguousarray(weight, float),
                     self.hold)

    def kernel_tuple(self, key: str, weight=None) -> tuple:
        """:meth:`packed` with Newton weights ``weight`` as the plain tuple the batch
        kernels take, made once per ``key`` (a single-frame solve would spend more on
        packing than on solving)."""
        if key not in self._tuples:
            self._tuples[key] = tuple(self.packed(weight))
        return self._tuples[key]


def chain_arrays(rig, name: str, wrist_dof: int | None = None) -> ChainArrays:
    """Flat arrays of ``rig.chains[name]`` with the wrist set to ``wrist_dof``."""
    ch = rig.chains[name]
    return joint_chain(rig, ch.joints, ch.effector, wrist_dof, name)


def joint_chain(rig, joints, effector: int, wrist_dof: int | None = None, name: str = "") -> ChainArrays:
    """Flat arrays of the chain of ``joints`` (root-most first, each the parent of the next)
    ending at ``effector`` (the last joint or its child), the wrist set to ``wrist_dof``."""
    skel = rig.skeleton
    joints = np.asarray(joints, np.int64)
    eff = int(effector)
    if np.any(skel.parents[joints[1:]] != joints[:-1]):
        raise ValueError(f"chain {name!r}: each joint must be the parent of the next")
    if eff == joints[-1]:
        eff_off = np.zeros(3)
    elif skel.parents[eff] == joints[-1]:
        eff_off = skel.offsets[eff].astype(float)
    else:
        raise ValueError(f"chain {name!r}: effector must be the last joint or its child")
    free = rig.dof_mask(wrist_dof)[joints].copy()
    lim = np.radians(rig.limits[joints])
    return ChainArrays(joints, eff, skel.offsets[joints].astype(float), eff_off, free, kinds(free),
                       np.ascontiguousarray(lim[..., 0]), np.ascontiguousarray(lim[..., 1]),
                       int(skel.parents[joints[0]]), polish_weights(len(joints)), chain_hold(rig, joints))


def chain_hold(rig, joints: np.ndarray) -> tuple:
    """The hold (engine.humerus_nb) of the chain of ``joints``: the rig's humerus where the
    chain holds an upper arm and its roll joint, from below the chest (or from the joint
    under it); else nothing held."""
    h = getattr(rig, "humerus", None)
    js = [int(j) for j in joints]
    for roll, side in (h or {}).get("rolls", {}).items():
        if roll not in js or js.index(roll) == 0:
            continue
        k = js.index(roll)
        chest = h["chest"]
        if chest in js:
            kc = js.index(chest)
        elif int(rig.skeleton.parents[js[0]]) == chest:
            kc = -1
        else:
            continue
        if kc >= k - 1:
            continue
        rng = np.radians(np.asarray(h["range"], float))
        return (np.array([kc, k - 1, side], np.int64), rng, rng.copy())
    return no_hold()


def kinds(free: np.ndarray) -> np.ndarray:
    """Each joint's kind ``(n,) int64`` from its free Euler columns ``free (n, 3)``."""
    nfree = free.sum(axis=1)
    return np.where(nfree == 0, KIND_NONE, np.where(nfree == 1, np.argmax(free, axis=1) + 1,
                                                    KIND_MULTI)).astype(np.int64)


def with_locked(chain: ChainArrays, lock: np.ndarray) -> ChainArrays:
    """``chain`` with the joints where ``lock (n,)`` is true never turned."""
    free = chain.free & ~np.asarray(lock, bool)[:, None]
    return replace(chain, free=free, kind=kinds(free))


def polish_weights(n: int) -> np.ndarray:
    """Newton-finish weights rising towards the effector, like CCD's own bias
    towards the joints nearest the effector."""
    return np.linspace(0.25, 1.0, n)


@njit(cache=True)
def _gimbal_split(e, lo, hi):
    """At the ZYX gimbal (y = +-90) only z + x (y = -90) or z - x (y = +90) is the
    rotation: the split of it that lies best inside [lo, hi] (3,), so a pose on the
    gimbal is not read as outside limits an equal rotation keeps."""
    if abs(abs(e[1]) - 0.5 * math.pi) > 1e-5:      # asin near +-1: a clamp onto -90 reads ~1e-6 off
        return e
    sg = 1.0 if e[1] < 0.0 else -1.0             # the rotation is Rz(z + sg x) Ry(y)
    total = e[0] + sg * e[2]
    best = e
    best_out = outside(e[0], lo[0], hi[0]) + outside(e[2], lo[2], hi[2])
    for z in (clamp_angle(e[0], lo[0], hi[0]), wrap(total - sg * clamp_angle(e[2], lo[2], hi[2]))):
        x = wrap(sg * (total - z))
        o = outside(z, lo[0], hi[0]) + outside(x, lo[2], hi[2])
        if o < best_out - 1e-12:
            best, best_out = (z, e[1], x), o
    return best


@njit(cache=True)
def limit_euler_one(q, lo, hi):
    """One local rotation ``q`` (tuple) -> its (z, y, x) radians in the ZYX branch that fits
    ``lo``/``hi`` (3,) radians better, read in the limits' own window (a range past +-180
    reads 190, not -170): the solvers step and clamp from these numbers."""
    e1 = to_euler_zyx(q)
    e2 = other_branch(e1)
    s1 = 0.0
    s2 = 0.0
    for c in range(3):
        s1 += outside(e1[c], lo[c], hi[c])
        s2 += outside(e2[c], lo[c], hi[c])
    e = _gimbal_split(e2 if s2 < s1 - 1e-11 else e1, lo, hi)
    return (into_range(e[0], lo[0], hi[0]), into_range(e[1], lo[1], hi[1]), into_range(e[2], lo[2], hi[2]))


@njit(cache=True)
def _limit_euler_nb(local, lo, hi, out):
    """local (M,J,4), lo/hi (J,3) radians -> out (M,J,3) radians, best branch."""
    for i in range(local.shape[0]):
        for j in range(local.shape[1]):
            e = limit_euler_one((local[i, j, 0], local[i, j, 1], local[i, j, 2], local[i, j, 3]), lo[j], hi[j])
            for c in range(3):
                out[i, j, c] = e[c]


def limit_euler(local_rotations, limits) -> np.ndarray:
    """Euler angles ``(..., J, 3)`` degrees (columns z, y, x) of local rotations
    ``(..., J, 4)`` in whichever of the two ZYX branches fits ``limits (J,3,2)``
    (degrees) better; columns without a DOF have limits [0, 0].

    ``quat.to_euler`` keeps the middle angle in [-90, 90], so an elbow flexed
    by 120 degrees comes out as (180, -60, 180); its other branch (0, -120, 0)
    is the one the rig's limits are written in.
    """
    q = np.asarray(local_rotations, float)
    lim = np.radians(np.asarray(limits, float))
    J = q.shape[-2]
    flat = np.ascontiguousarray(q.reshape(-1, J, 4))
    out = np.empty(flat.shape[:-1] + (3,))
    _limit_euler_nb(flat, np.ascontiguousarray(lim[..., 0]), np.ascontiguousarray(lim[..., 1]), out)
    return np.degrees(out).reshape(q.shape[:-1] + (3,))


def limit_violation(local_rotations, limits) -> np.ndarray:
    """Largest excess (degrees) over ``limits (J,3,2)`` per joint ``(..., J)``,
    taking the Euler branch that fits best (0 when inside)."""
    e = limit_euler(local_rotations, limits)
    return degrees_outside(e, limits[..., 0], limits[..., 1]).max(-1)


def _check_handles(handles: np.ndarray) -> None:
    if not np.all(np.isfinite(handles)):
        raise ValueError("IK target must be finite numbers (got NaN or infinity)")


def solve(chain: ChainArrays, parent_rotations, parent_positions, local_rotations, handles,
          tolerance: float = TOLERANCE, iterations: int = ITERATIONS, source_euler=None,
          pure: bool = False):
    """CCD for a batch of independent frames.

    parent_rotations (F,4), parent_positions (F,3): global transform of the
    chain root's parent; local_rotations (F,n,4): start pose of the chain joints;
    handles (F,3). source_euler (F,n,3) degrees gives the locked columns'
    values (default: the start pose). ``pure``: CCD sweeps only, no Newton
    finish. Returns (local (F,n,4), error cm (F,),
    iterations (F,)).
    """
    handles = np.ascontiguousarray(np.atleast_2d(handles), float)
    _check_handles(handles)
    local = np.array(local_rotations, float, copy=True, order="C")
    F = local.shape[0]
    if source_euler is None:
        src = limit_euler(local, np.degrees(np.stack([chain.lo, chain.hi], -1)))
    else:
        src = np.asarray(source_euler, float)
    src = np.ascontiguousarray(np.radians(src))
    euler = src.copy()
    err = np.empty(F)
    its = np.empty(F, np.int64)
    ccd_batch(np.ascontiguousarray(parent_rotations, float), np.ascontiguousarray(parent_positions, float),
              chain.kernel_tuple("pure", np.zeros(len(chain.joints))) if pure else chain.kernel_tuple("polish"),
              local, euler, src, handles,
              float(tolerance), int(iterations), err, its)
    return local, err, its
