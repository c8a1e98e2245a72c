"""Damped-least-squares (Jacobian) IK, the alternative to CCD (dissertation 1.7.2).

Same chain, DOFs, limits and start pose as :mod:`engine.ccd`; per-joint
stiffness weights W^-1 make the torso turn less than the arm:
``d_theta = W^-1 J^T (J W^-1 J^T + damping^2 I)^-1 (handle - effector)``,
with limits enforced by clamping and freezing the clamped columns.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .ccd import ITERATIONS, TOLERANCE, ChainArrays, _check_handles, _STALL, _STALL_REL, limit_euler
from .humerus_nb import open_window
from .step_nb import NO, Chain, PositionProblem, lm_eval, lm_loop, scratch

DAMPING = 1.0           # cm


def default_stiffness(n: int) -> np.ndarray:
    """Stiffness per chain joint, root-most first: the torso end is three
    times as stiff as the hand end (like CCD's lower-joint bias)."""
    return np.linspace(3.0, 1.0, n)


@njit(cache=True, inline='always')
def dls_frame(prot, ppos, ch, local, euler, damping, handle, tol, max_iter, s):
    """Solve one frame in place (local (n,4), euler (n,3) radians) by damped Newton
    steps weighted by ``ch.weight (n,)`` = 1 / stiffness; an overshoot (or a limit in
    the way) is undone and damped harder. Returns (error cm, iterations)."""
    problem = PositionProblem(prot, ppos, ch, local, euler, handle, s, tol)
    (err, _), it = lm_loop(problem, lm_eval(problem), (damping, damping, 1e4 * (damping + 1.0), NO),
                           (max_iter, _STALL, _STALL_REL, NO))
    return err, it


@njit(cache=True)
def dls_batch(prot, ppos, ch, local, euler, damping, handles, tol, max_iter, out_err, out_iter):
    """Every frame solved in place (``ch``: the Chain's fields as a plain tuple)."""
    ch = Chain(*ch)
    s = scratch(local.shape[1])
    for f in range(local.shape[0]):
        pr = (prot[f, 0], prot[f, 1], prot[f, 2], prot[f, 3])
        pp = (ppos[f, 0], ppos[f, 1], ppos[f, 2])
        h = (handles[f, 0], handles[f, 1], handles[f, 2])
        open_window(local[f], ch.hold)
        e, i = dls_frame(pr, pp, ch, local[f], euler[f], damping, h, tol, max_iter, s)
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
              chain.kernel_tuple("stiffness", 1.0 / stiff) if stiffness is None else tuple(chain.packed(1.0 / stiff)),
              local, euler, float(damping), handles, float(tolerance),
              int(iterations), err, its)
    return local, err, its
