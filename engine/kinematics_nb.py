"""Compiled forward kinematics and the chain records the compiled solvers share.

:func:`fk_into` is the compiled twin of :func:`engine.skeleton.forward_kinematics`
(same operations in the same order, so both give the same floats); every
kernel computes globals with it: a whole skeleton, a subtree of it, or an IK
chain hanging off its parent joint.

Chains and their per-frame working state travel as typed namedtuples, so no
kernel needs a dozen positional arrays per chain:

* :class:`Chain` (fixed per rig chain): ``offsets (n,3)`` local translations,
  ``eff_off (3,)`` the effector in the last joint's frame, ``link (n,)`` the
  parent of each joint inside the chain (-1: the chain's parent joint),
  ``order (n,)`` 0..n-1, ``free (n,3)`` the Euler columns (z, y, x) a solver
  may move, ``kind (n,)`` (KIND_*), ``lo``/``hi (n,3)`` limits in radians and
  ``weight (n,)`` the least-squares weights (0: never moved by them).
* :class:`Pose` (one frame of one chain, solved in place): ``local (n,4)``,
  ``euler (n,3)`` radians, ``src (n,3)`` the source angles (locked columns go
  back to them), ``lo``/``hi (n,3)`` the limits in force for this frame.
* :class:`Work`: scratch buffers, allocated once per batch (globals of one or
  two chains, their backups, the least-squares :class:`Step`).

Hot loops take the arrays they need rather than these records: numba counts
references on every array of a record a function receives or reads a field
of, and those atomic counts cost more than the maths of a small step.
"""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from .nb import inline_kernel, kernel
from .quat_nb import from_euler_zyx, q_at, q_put, qmul, qrot, v_at, v_put, vadd

KIND_NONE = 0          # no free DOF: never turned
# 1, 2, 3: a single free Euler column (kind - 1 = column z, y, x)
KIND_MULTI = 4         # two or three free columns

Chain = namedtuple("Chain", "offsets eff_off link order free kind lo hi weight")
Pose = namedtuple("Pose", "local euler src lo hi")
# the least-squares step's buffers: Jacobian columns (rows up to 9), their
# weights, (joint, Euler column, frozen) per column, normal matrix, solution, residual
Step = namedtuple("Step", "cols colw dofs A x r")
Work = namedtuple("Work", "g_rot g_pos g2_rot g2_pos bak_l bak_e bak2_l bak2_e step")

IDENTITY = (1.0, 0.0, 0.0, 0.0)
ORIGIN = (0.0, 0.0, 0.0)


@kernel
def fk_into(base_rot, base_pos, parents, trans, local, joints, g_rot, g_pos):
    """Globals of ``joints`` (parents first) into ``g_rot (J,4)`` / ``g_pos (J,3)``.

    ``parents[j] < 0`` hangs joint j off the base transform (identity and
    origin for a skeleton's root, the parent joint for a chain)."""
    for i in range(joints.shape[0]):
        j = joints[i]
        p = parents[j]
        if p < 0:
            pr = base_rot
            pp = base_pos
        else:
            pr = q_at(g_rot, p)
            pp = v_at(g_pos, p)
        v_put(g_pos, j, vadd(pp, qrot(pr, v_at(trans, j))))
        q_put(g_rot, j, qmul(pr, q_at(local, j)))


@kernel
def fk_frames(parents, trans, local, joints, out_rot, out_pos):
    """Whole-skeleton FK of every frame: ``trans (F,J,3)``, ``local (F,J,4)``."""
    for f in range(local.shape[0]):
        fk_into(IDENTITY, ORIGIN, parents, trans[f], local[f], joints, out_rot[f], out_pos[f])


@kernel
def path_fk(base_rot, base_pos, link, offsets, order, eff_off, local, g_rot, g_pos):
    """Globals of a chain's joints (``link``: parent inside the chain, -1 the
    base) into g_rot (n,4), g_pos (n,3); returns the effector (``eff_off`` in
    the last joint's frame)."""
    fk_into(base_rot, base_pos, link, offsets, local, order, g_rot, g_pos)
    n = order.shape[0]
    return vadd(v_at(g_pos, n - 1), qrot(q_at(g_rot, n - 1), (eff_off[0], eff_off[1], eff_off[2])))


@kernel
def chain_fk(base_rot, base_pos, chain, local, g_rot, g_pos):
    """:func:`path_fk` of a :class:`Chain` hanging off (base_rot, base_pos)."""
    return path_fk(base_rot, base_pos, chain.link, chain.offsets, chain.order, chain.eff_off, local, g_rot, g_pos)


@kernel
def sub_chain(chain, a):
    """The chain's joints a..n-1 as a chain of their own (hanging off joint a-1)."""
    m = chain.order.shape[0] - a
    return Chain(chain.offsets[a:], chain.eff_off, chain.link[:m], chain.order[:m], chain.free[a:],
                 chain.kind[a:], chain.lo[a:], chain.hi[a:], chain.weight[a:])


@kernel
def sub_pose(pose, a):
    return Pose(pose.local[a:], pose.euler[a:], pose.src[a:], pose.lo[a:], pose.hi[a:])


@kernel
def hinge_axis(prot, g_rot, euler, k, c):
    """World axis of Euler column c of chain joint k (turning that column alone
    rotates the joint's subtree about this axis through the joint)."""
    gp = prot if k == 0 else q_at(g_rot, k - 1)
    if c == 0:
        return qrot(gp, (0.0, 0.0, 1.0))
    if c == 1:
        return qrot(qmul(gp, from_euler_zyx(euler[k, 0], 0.0, 0.0)), (0.0, 1.0, 0.0))
    return qrot(q_at(g_rot, k), (1.0, 0.0, 0.0))


@inline_kernel
def euler_to_local(pose, k):
    """Joint k's local rotation from its Euler angles."""
    e = pose.euler
    q_put(pose.local, k, from_euler_zyx(e[k, 0], e[k, 1], e[k, 2]))


@kernel
def new_pose(n):
    return Pose(np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3)))


@kernel
def new_work(n):
    """Scratch for solving chains of up to ``n`` joints (two at once: 6n columns of 9 rows)."""
    step = Step(np.empty((6 * n, 9)), np.empty(6 * n), np.empty((6 * n, 3), np.int64), np.empty((9, 9)),
                np.empty(9), np.empty(9))
    return Work(np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 4)), np.empty((n, 3)),
                np.empty((n, 4)), np.empty((n, 3)), np.empty((n, 4)), np.empty((n, 3)), step)


@kernel
def load_pose(pose, local, euler, joints):
    """One frame's chain joints ``joints`` of ``local (J,4)`` / ``euler (J,3)`` into pose
    (local, euler and src)."""
    p_local, p_euler, p_src = pose.local, pose.euler, pose.src
    for k in range(joints.shape[0]):
        for c in range(4):
            p_local[k, c] = local[joints[k], c]
        for c in range(3):
            p_euler[k, c] = euler[joints[k], c]
            p_src[k, c] = euler[joints[k], c]


@kernel
def store_local(pose, joints, local):
    """The pose's local rotations back into one frame's ``local (J,4)``."""
    p_local = pose.local
    for k in range(joints.shape[0]):
        for c in range(4):
            local[joints[k], c] = p_local[k, c]
