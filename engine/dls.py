"""Damped-least-squares (Jacobian) IK, the alternative to CCD (dissertation 1.7.2).

Same chain, DOFs, limits and start pose as :mod:`engine.ccd`; per-joint
stiffness weights W^-1 make the torso turn less than the arm:
``d_theta = W^-1 J^T (J W^-1 J^T + damping^2 I)^-1 (handle - effector)``,
with limits enforced by clamping and freezing the clamped columns.
"""
from __future__ import annotations

import numpy as np

from .ccd import ITERATIONS, STALL, STALL_REL, TOLERANCE, ChainArrays, NO_GOAL, _check_handles, limit_euler
from .kinematics_nb import Chain, Pose, new_work
from .nb import kernel
from .quat_nb import q_at
from .solve_nb import POSITION, Damping, lm_solve

DAMPING = 1.0           # cm
MAX_STEP = 0.25         # rad per iteration and DOF


def default_stiffness(n: int) -> np.ndarray:
    """Stiffness per chain joint, root-most first: the torso end is three
    times as stiff as the hand end (like CCD's lower-joint bias)."""
    return np.linspace(3.0, 1.0, n)


@kernel
def schedule(damping):
    """Damping from ``damping`` up (x4 after a step that did not help) until 1e4 times it."""
    return Damping(damping, damping, 1e4 * (damping + 1.0), MAX_STEP, 0.0, STALL, STALL_REL)


@kernel
def dls_frame(prot, ppos, chain, pose, handle, tol, max_iter, damping, w):
    """Solve one frame in place (weights ``chain.weight`` = 1 / stiffness).
    Returns (error cm, iterations)."""
    _, err, it = lm_solve(POSITION, prot, ppos, chain, pose, chain, pose, 0, (handle, NO_GOAL[1], NO_GOAL[2]),
                          tol, 0.0, schedule(damping), max_iter, w)
    return err, it


@kernel
def dls_batch(prot, ppos, chain_fields, local, euler, handles, tol, max_iter, damping, out_err, out_iter):
    """Every frame solved in place; ``chain_fields`` as :func:`engine.ccd.ccd_batch`'s."""
    chain = Chain(*chain_fields)
    w = new_work(chain.order.shape[0])
    for f in range(local.shape[0]):
        pose = Pose(local[f], euler[f], euler[f], chain.lo, chain.hi)
        e, i = dls_frame(q_at(prot, f), (ppos[f, 0], ppos[f, 1], ppos[f, 2]), chain, pose,
                         (handles[f, 0], handles[f, 1], handles[f, 2]), tol, max_iter, damping, w)
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
              tuple(chain.packed(1.0 / stiff)), local, euler, handles, float(tolerance), int(iterations),
              float(damping), err, its)
    return local, err, its
