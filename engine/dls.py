"""Damped-least-squares (Jacobian) IK, the alternative to CCD (dissertation 1.7.2).

Same chain, DOFs, limits and start pose as :mod:`engine.ccd`; per-joint
stiffness weights W^-1 make the torso turn less than the arm:
``d_theta = W^-1 J^T (J W^-1 J^T + damping^2 I)^-1 (handle - effector)``,
with limits enforced by clamping and freezing the clamped columns.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .ccd import ITERATIONS, TOLERANCE, ChainArrays, _check_handles, _STALL, _STALL_REL, chain_fk, chain_scratch, jacobian_step, limit_euler
from .quat_nb import vnorm, vsub

DAMPING = 1.0           # cm
MAX_STEP = 0.25         # rad per iteration and DOF


def default_stiffness(n: int) -> np.ndarray:
    """Stiffness per chain joint, root-most first: the torso end is three
    times as stiff as the hand end (like CCD's lower-joint bias)."""
    return np.linspace(3.0, 1.0, n)


@njit(cache=True)
def dls_frame(prot, ppos, offsets, eff_off, local, euler, free, lo, hi, weight, damping, handle,
              tol, max_iter, g_rot, g_pos, scratch_cols, scratch_dofs, bak_local, bak_euler):
    """Solve one frame in place (local (n,4), euler (n,3) radians).
    weight (n,) = 1 / stiffness. Returns (error cm, iterations)."""
    eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
    err = vnorm(vsub(eff, handle))
    if not err >= tol:
        return err, 0
    lam = damping
    it = 0
    while it < max_iter:
        it += 1
        bak_local[:local.shape[0]] = local
        bak_euler[:euler.shape[0]] = euler
        jacobian_step(prot, local, euler, free, lo, hi, weight, handle, eff, g_rot, g_pos,
                      lam, MAX_STEP, scratch_cols, scratch_dofs)
        eff2 = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
        err2 = vnorm(vsub(eff2, handle))
        if not err2 < err:
            # overshoot (or a limit in the way): undo and damp harder
            local[:] = bak_local[:local.shape[0]]
            euler[:] = bak_euler[:euler.shape[0]]
            eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
            lam *= 4.0
            if lam > 1e4 * (damping + 1.0):
                break
            continue
        gain = err - err2
        eff = eff2
        err = err2
        lam = max(damping, lam * 0.5)
        if err < tol or gain < max(_STALL, _STALL_REL * err):
            break
    return err, it


@njit(cache=True)
def dls_batch(prot, ppos, offsets, eff_off, local, euler, free, lo, hi, weight, damping,
              handles, tol, max_iter, out_err, out_iter):
    n = offsets.shape[0]
    g_rot, g_pos, cols, dofs, bak_l, bak_e = chain_scratch(n)
    for f in range(local.shape[0]):
        pr = (prot[f, 0], prot[f, 1], prot[f, 2], prot[f, 3])
        pp = (ppos[f, 0], ppos[f, 1], ppos[f, 2])
        h = (handles[f, 0], handles[f, 1], handles[f, 2])
        e, i = dls_frame(pr, pp, offsets, eff_off, local[f], euler[f], free, lo, hi, weight, damping,
                         h, tol, max_iter, g_rot, g_pos, cols, dofs, bak_l, bak_e)
        out_err[f] = e
        out_iter[f] = i


def solve(chain: ChainArrays, parent_rotations, parent_positions, local_rotations, handles,
          tolerance: float = TOLERANCE, iterations: int = ITERATIONS, stiffness=None,
          damping: float = DAMPING):
    """DLS for a batch of independent frames; arguments and results as
    :func:`engine.ccd.solve`."""
    handles = np.ascontiguousarray(np.atleast_2d(handles), float)
    _check_handles(handles)
    local = np.array(local_rotations, float, copy=True, order="C")
    F, n = local.shape[:2]
    euler = np.ascontiguousarray(np.radians(limit_euler(local, np.degrees(np.stack([chain.lo, chain.hi], -1)))))
    stiff = default_stiffness(n) if stiffness is None else np.asarray(stiffness, float)
    err = np.empty(F)
    its = np.empty(F, np.int64)
    dls_batch(np.ascontiguousarray(parent_rotations, float), np.ascontiguousarray(parent_positions, float),
              chain.offsets, chain.eff_off, local, euler, chain.free, chain.lo, chain.hi,
              1.0 / stiff, float(damping), handles, float(tolerance), int(iterations), err, its)
    return local, err, its
