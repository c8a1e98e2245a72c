"""The damped least-squares step the compiled solvers take (dissertation 1.7.2), the
Levenberg-Marquardt loop around it, and the chain and work-buffer bundles they pass.

A chain is a :data:`Chain` named tuple of flat arrays (numba takes named tuples, so a
kernel takes one argument for the chain instead of eight); :data:`Scratch` holds the
work buffers of one solve, allocated once per batch by :func:`scratch`.

:func:`lm_loop` is the one Levenberg-Marquardt loop: steps from the current pose, a
step that does not lower the cost undone and damped harder. Its problems:
:class:`PositionProblem` (the CCD finish in ``engine.ccd`` and the DLS solver in
``engine.dls``), and in ``engine.adapt`` the chain's end (grip and face) and the two arms.

Named tuples from Python are typed slowly (~1.3 us for 8 arrays): batch kernels take the
chain as a plain tuple and rebuild it (``Chain(*t)``); a field read inside a loop costs
a reference count, so loops read the fields into locals first.
"""
from __future__ import annotations

import inspect
import math
from collections import namedtuple
from typing import NamedTuple

import numpy as np
from numba import njit, types
from numba.extending import overload

from .humerus_nb import held_fk
from .quat_nb import clamp_angle, cross, from_euler_zyx, q_at, q_put, qmul, qrot, v_at, vnorm, vsub

MAX_STEP = 0.25         # rad: the largest angle change of one step (the linearisation holds for small turns)

# Flags handed to kernels as numpy scalars: numba compiles a callee again for every
# literal constant it is called with
YES = np.bool_(True)
NO = np.bool_(False)

Chain = namedtuple("Chain", "joints offsets eff_off free kind lo hi weight hold")
"""A solver chain: joints (n,) int64 skeleton indices, offsets (n,3), eff_off (3,) the
effector in the last joint's frame, free (n,3) bool Euler columns (z, y, x) the solver may
move, kind (n,) int64 (see engine.ccd), lo/hi (n,3) radians, weight (n,) of the Newton
steps, hold: the upper arm's axial rotation held after every step (engine.humerus_nb)."""

Scratch = namedtuple("Scratch", "g_rot g_pos cols dofs bak_l bak_e")
"""Work buffers: chain globals g_rot (n,4) / g_pos (n,3); the step's columns cols (3n,3)
and their (joint, column) dofs (3n,2) int64; a backup of a pose bak_l (n,4) / bak_e (n,3)."""


@njit(cache=True)
def scratch(n):
    """Work buffers for solving one chain of up to ``n`` joints, allocated once per batch."""
    return Scratch(np.empty((n, 4)), np.empty((n, 3)), np.empty((3 * n, 3)), np.empty((3 * n, 2), np.int64),
                   np.empty((n, 4)), np.empty((n, 3)))


@njit(cache=True)
def with_limits(ch, lo, hi):
    """``ch`` with other limits (a frame's, widened to take in its start pose)."""
    return Chain(ch.joints, ch.offsets, ch.eff_off, ch.free, ch.kind, lo, hi, ch.weight, ch.hold)


@njit(cache=True)
def hinge_axis(prot, g_rot, euler, k, c):
    """World axis of Euler column c of chain joint k (turning that column alone
    rotates the joint's subtree about this axis through the joint)."""
    gp = prot if k == 0 else q_at(g_rot, k - 1)
    if c == 0:
        return qrot(gp, (0.0, 0.0, 1.0))
    if c == 1:
        return qrot(qmul(gp, from_euler_zyx(euler[k, 0], 0.0, 0.0)), (0.0, 1.0, 0.0))
    return qrot(q_at(g_rot, k), (1.0, 0.0, 0.0))


@njit(cache=True, inline='always')
def jacobian_step(prot, local, euler, free, lo, hi, weight, handle, eff, g_rot, g_pos, cols, dofs, damping,
                  max_step):
    """One damped least-squares step on the free Euler columns toward ``handle``, in place:
    d_theta = W J^T (J W J^T + damping^2 I)^-1 (handle - eff), W = diag(weight), the largest
    angle change capped at ``max_step``. Columns that would cross a limit are clamped there
    and frozen, and the rest re-solved for what is left of the error (up to three rounds).
    The 3 x 3 system is kept in registers (a general R-row update in memory cost the DLS
    solver 3.3 -> 6.4 us a frame, measured). cols (>= 3n, 3), dofs (>= 3n, 2) int64: scratch."""
    m = 0
    for k in range(local.shape[0]):
        for c in range(3):
            if free[k, c] and weight[k] > 0.0:
                a = hinge_axis(prot, g_rot, euler, k, c)
                col = cross(a, vsub(eff, v_at(g_pos, k)))
                cols[m, 0] = col[0] * math.sqrt(weight[k])
                cols[m, 1] = col[1] * math.sqrt(weight[k])
                cols[m, 2] = col[2] * math.sqrt(weight[k])
                dofs[m, 0], dofs[m, 1] = k, c
                m += 1
    r = vsub(handle, eff)
    for _round in range(3):
        a00 = a11 = a22 = damping * damping
        a01 = a02 = a12 = 0.0
        for i in range(m):
            if dofs[i, 0] >= 0:
                x, y, z = cols[i, 0], cols[i, 1], cols[i, 2]
                a00 += x * x
                a11 += y * y
                a22 += z * z
                a01 += x * y
                a02 += x * z
                a12 += y * z
        # inverse of the symmetric 3x3 by cofactors
        c00, c01, c02 = a11 * a22 - a12 * a12, a02 * a12 - a01 * a22, a01 * a12 - a02 * a11
        det = a00 * c00 + a01 * c01 + a02 * c02
        if not abs(det) > 1e-300:
            return
        c11, c12, c22 = a00 * a22 - a02 * a02, a01 * a02 - a00 * a12, a00 * a11 - a01 * a01
        x0 = (c00 * r[0] + c01 * r[1] + c02 * r[2]) / det
        x1 = (c01 * r[0] + c11 * r[1] + c12 * r[2]) / det
        x2 = (c02 * r[0] + c12 * r[1] + c22 * r[2]) / det
        # cap the largest angle change: the linearisation holds for small turns
        biggest = 0.0
        for i in range(m):
            if dofs[i, 0] >= 0:
                d = (cols[i, 0] * x0 + cols[i, 1] * x1 + cols[i, 2] * x2) * math.sqrt(weight[dofs[i, 0]])
                biggest = max(biggest, abs(d))
        scale = 1.0 if biggest <= max_step else max_step / biggest
        clamped = False
        for i in range(m):
            k, c = dofs[i, 0], dofs[i, 1]
            if k < 0:
                continue
            d = (cols[i, 0] * x0 + cols[i, 1] * x1 + cols[i, 2] * x2) * math.sqrt(weight[k]) * scale
            want = euler[k, c] + d
            got = clamp_angle(want, lo[k, c], hi[k, c])
            if got != want:
                # take what the limit allows, freeze it, and leave the rest to the others
                got_d = got - euler[k, c]
                euler[k, c] = got
                sw = 1.0 / math.sqrt(weight[k])
                r = (r[0] - cols[i, 0] * sw * got_d, r[1] - cols[i, 1] * sw * got_d, r[2] - cols[i, 2] * sw * got_d)
                dofs[i, 0] = -1
                clamped = True
        if not clamped:
            for i in range(m):
                k, c = dofs[i, 0], dofs[i, 1]
                if k >= 0:
                    euler[k, c] += (cols[i, 0] * x0 + cols[i, 1] * x1 + cols[i, 2] * x2) * math.sqrt(weight[k]) * scale
            break
    for k in range(local.shape[0]):
        if weight[k] > 0.0 and (free[k, 0] or free[k, 1] or free[k, 2]):
            q_put(local, k, from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2]))


# --------------------------------------------------------------------------
# One Levenberg-Marquardt loop. Each problem (position here, the chain's end and the two
# arms in engine.adapt) is a typing.NamedTuple class of its arrays and tolerances; its
# parts are the generic functions below, compiled for it by its type (numba overloads
# picked at compile time). Passing compiled functions as arguments instead would put the
# dispatchers' per-process ids into the cache key (numba #6264, #2956): every run a miss.

def lm_save(problem):
    """Keep what a step changes (the problem's pose), so :func:`lm_restore` can undo it."""


def lm_restore(problem):
    """Put back the pose :func:`lm_save` kept, bit for bit."""


def lm_step(problem, state, damping):
    """One damped least-squares step from ``state`` (what :func:`lm_eval` returned for
    the current pose) with ``damping``, in place on the problem's pose."""


def lm_eval(problem):
    """The current pose's state: a tuple whose first item is the cost the loop lowers
    (what a step must make smaller to be kept), the rest what the problem's step needs.
    Also refreshes the problem's buffers (globals, residual) from the pose."""


def lm_done(problem, state):
    """The problem's tolerances are met at ``state``."""


def lm_parts(cls, save, restore, step, evaluate, done):
    """Make ``cls`` (a typing.NamedTuple class) a problem of :func:`lm_loop`: its parts
    are plain Python functions with the parameters of :func:`lm_save` ... :func:`lm_done`,
    compiled inline into the loop for problems of that type (so no short-circuit
    ``and``/``or`` in them: numba's inliner warns of its phi nodes; use ``&``/``|``)."""
    for stub, impl in ((lm_save, save), (lm_restore, restore), (lm_step, step), (lm_eval, evaluate),
                       (lm_done, done)):
        _overload_for(stub, cls, impl)


def _overload_for(stub, cls, impl):
    """``impl`` as ``stub``'s implementation when its first argument is a ``cls``."""
    def typer(problem, *rest):
        if isinstance(problem, types.BaseNamedTuple) and problem.instance_class is cls:
            return impl
        return None
    # numba checks that the typing function's parameters are the implementation's
    typer.__signature__ = inspect.signature(stub)
    overload(stub, inline='always')(typer)


@njit(cache=True)
def lm_loop(problem, state, lm, stop):
    """Damped Newton (Levenberg-Marquardt) steps on ``problem`` from its current pose,
    whose :func:`lm_eval` is ``state``; a step that does not lower the cost
    (``state[0]``) is undone. Returns (final state, steps taken, undone ones included).

    ``lm`` = (damping, least damping, damping cap, undo ends): after an undo the damping
    is multiplied by 4 (and the loop ends above the cap, or at once with ``undo ends``),
    after a success halved down to the least. ``stop`` = (steps, stall, rel stall,
    halving): ends when :func:`lm_done`, or when a success gains less than max(stall,
    rel stall * cost), or with ``halving`` does not halve the cost."""
    lam, lam_min, lam_cap, undo_ends = lm
    steps, stall, stall_rel, halving = stop
    it = 0
    if lm_done(problem, state):
        return state, it
    while it < steps:
        it += 1
        lm_save(problem)
        lm_step(problem, state, lam)
        trial = lm_eval(problem)
        if not trial[0] < state[0]:
            lm_restore(problem)
            state = lm_eval(problem)    # the same state again, and the buffers it refreshes
            lam *= 4.0
            if undo_ends or lam > lam_cap:
                break
            continue
        gain = state[0] - trial[0]
        halved = trial[0] < 0.5 * state[0]
        state = trial
        lam = max(lam_min, lam * 0.5)
        if lm_done(problem, state) or gain < max(stall, stall_rel * state[0]) or (halving and not halved):
            break
    return state, it


class PositionProblem(NamedTuple):
    """The chain's effector onto ``handle``: the loop of the CCD finish (``engine.ccd``)
    and of the DLS solver (``engine.dls``), steps by :func:`jacobian_step`. State (error
    cm, effector (3,))."""
    prot: tuple         # (4,) the chain root's parent's global rotation
    ppos: tuple         # (3,) and position, cm
    ch: Chain
    local: np.ndarray   # (n,4) the chain's local rotations, in place
    euler: np.ndarray   # (n,3) their Euler angles, radians, in place
    handle: tuple       # (3,) cm
    s: Scratch
    tol: float          # cm


@njit(cache=True)
def copy_rows(src, dst):
    """The rows ``src (m, w)`` and ``dst (n, w)`` have in common, from src into dst
    (a pose into its backup, and back): element by element, as the arrays never overlap
    (a slice assignment makes a temporary copy in case they do)."""
    for k in range(min(src.shape[0], dst.shape[0])):
        for c in range(src.shape[1]):
            dst[k, c] = src[k, c]


# The parts read the problem's fields into locals before calling anything: numba counts a
# reference to every array of the problem when a part is handed it inline, and the count
# is pruned only when the part's last use of the problem comes before its first call.

def _position_save(problem):
    local, euler, s = problem.local, problem.euler, problem.s
    bak_l, bak_e = s.bak_l, s.bak_e
    copy_rows(local, bak_l)
    copy_rows(euler, bak_e)


def _position_restore(problem):
    local, euler, s = problem.local, problem.euler, problem.s
    bak_l, bak_e = s.bak_l, s.bak_e
    copy_rows(bak_l, local)
    copy_rows(bak_e, euler)


def _position_step(problem, state, damping):
    prot, local, euler, handle, ch, s = (problem.prot, problem.local, problem.euler, problem.handle, problem.ch,
                                         problem.s)
    free, lo, hi, weight, g_rot, g_pos, cols, dofs = ch.free, ch.lo, ch.hi, ch.weight, s.g_rot, s.g_pos, s.cols, s.dofs
    jacobian_step(prot, local, euler, free, lo, hi, weight, handle, state[1], g_rot, g_pos, cols, dofs, damping,
                  MAX_STEP)


def _position_eval(problem):
    prot, ppos, local, euler, handle, ch, s = (problem.prot, problem.ppos, problem.local, problem.euler,
                                               problem.handle, problem.ch, problem.s)
    offsets, eff_off, lo, hi, hold, g_rot, g_pos = ch.offsets, ch.eff_off, ch.lo, ch.hi, ch.hold, s.g_rot, s.g_pos
    eff = held_fk(prot, ppos, offsets, eff_off, local, euler, lo, hi, hold, g_rot, g_pos)   # the step's pose, held
    return vnorm(vsub(eff, handle)), eff


def _position_done(problem, state):
    return not state[0] >= problem.tol      # (a NaN error too: the pose stays)


lm_parts(PositionProblem, _position_save, _position_restore, _position_step, _position_eval, _position_done)
