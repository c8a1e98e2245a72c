"""The damped least-squares step the compiled solvers take (dissertation 1.7.2), the
Levenberg-Marquardt loop around it, and the chain and work-buffer bundles they pass.

A chain is a :data:`Chain` named tuple of flat arrays (numba takes named tuples, so a
kernel takes one argument for the chain instead of eight); :data:`Scratch` holds the
work buffers of one solve, allocated once per batch by :func:`scratch`.

:func:`lm_position` is the loop of the CCD finish (``engine.ccd``) and of the DLS
solver (``engine.dls``): steps from the current pose, a step that does not get closer
undone and damped harder.

Named tuples from Python are typed slowly (~1.3 us for 8 arrays): batch kernels take the
chain as a plain tuple and rebuild it (``Chain(*t)``); a field read inside a loop costs
a reference count, so loops read the fields into locals first.
"""
from __future__ import annotations

import math
from collections import namedtuple

import numpy as np
from numba import njit

from .fk_nb import chain_fk
from .quat_nb import clamp_angle, cross, from_euler_zyx, q_at, q_put, qmul, qrot, v_at, vnorm, vsub

MAX_STEP = 0.25         # rad: the largest angle change of one step (the linearisation holds for small turns)

# Flags handed to kernels as numpy scalars: numba compiles a callee again for every
# literal constant it is called with
YES = np.bool_(True)
NO = np.bool_(False)

Chain = namedtuple("Chain", "joints offsets eff_off free kind lo hi weight")
"""A solver chain: joints (n,) int64 skeleton indices, offsets (n,3), eff_off (3,) the
effector in the last joint's frame, free (n,3) bool Euler columns (z, y, x) the solver may
move, kind (n,) int64 (see engine.ccd), lo/hi (n,3) radians, weight (n,) of the Newton
steps."""

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
    return Chain(ch.joints, ch.offsets, ch.eff_off, ch.free, ch.kind, lo, hi, ch.weight)


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


@njit(cache=True)
def lm_position(prot, ppos, ch, local, euler, handle, eff, err, s, lm, stop):
    """Damped Newton steps (:func:`jacobian_step`) taking the effector, now at ``eff``
    (``err`` from ``handle``), onto ``handle``, in place; a step that does not get
    closer is undone. Returns (effector, error, steps taken).

    ``lm`` = (damping, least damping, damping cap, undo ends): after an undo the damping
    is multiplied by 4 (and the loop ends above the cap, or at once with ``undo ends``),
    after a success halved down to the least. ``stop`` = (steps, tol, stall, rel stall,
    halving): ends within tol, or when a success gains less than max(stall, rel stall *
    error), or with ``halving`` does not halve the error."""
    lam, lam_min, lam_cap, undo_ends = lm
    steps, tol, stall, stall_rel, halving = stop
    n = local.shape[0]
    offsets, eff_off, g_rot, g_pos, bak_l, bak_e = ch.offsets, ch.eff_off, s.g_rot, s.g_pos, s.bak_l, s.bak_e
    free, lo, hi, weight, cols, dofs = ch.free, ch.lo, ch.hi, ch.weight, s.cols, s.dofs
    it = 0
    while it < steps:
        it += 1
        bak_l[:n] = local
        bak_e[:n] = euler
        jacobian_step(prot, local, euler, free, lo, hi, weight, handle, eff, g_rot, g_pos, cols, dofs, lam, MAX_STEP)
        eff2 = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
        err2 = vnorm(vsub(eff2, handle))
        if not err2 < err:
            local[:] = bak_l[:n]
            euler[:] = bak_e[:n]
            eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
            lam *= 4.0
            if undo_ends or lam > lam_cap:
                break
            continue
        gain = err - err2
        halved = err2 < 0.5 * err
        eff = eff2
        err = err2
        lam = max(lam_min, lam * 0.5)
        if err < tol or gain < max(stall, stall_rel * err) or (halving and not halved):
            break
    return eff, err, it
