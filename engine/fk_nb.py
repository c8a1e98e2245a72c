"""Forward kinematics for compiled (numba) kernels: the twin of
:func:`engine.skeleton.forward_kinematics` (the same products in the same order), on
one pose at a time with quaternions as (w, x, y, z) tuples (:mod:`engine.quat_nb`).

:func:`tree_fk` walks a skeleton (or a limb) by its parents array; :func:`chain_fk`
walks one solver chain below a given parent transform; :func:`frames_fk` is a whole
clip. All three go through :func:`joint_fk`.
"""
from __future__ import annotations

from numba import njit

from .quat_nb import q_at, q_put, qmul, qrot, v_at, v_put, vadd


@njit(cache=True)
def joint_fk(parent_rot, parent_pos, offset, local):
    """A joint's global (rotation, position) from its parent's and its local transform."""
    return qmul(parent_rot, local), vadd(parent_pos, qrot(parent_rot, offset))


@njit(cache=True)
def tree_fk(parents, trans, local, mask, out_rot, out_pos):
    """Globals ``out_rot (J,4)``, ``out_pos (J,3)`` of the joints in ``mask (J,)`` of one
    pose (``trans (J,3)``, ``local (J,4)``; parents before children). A joint without a
    parent (-1) takes its local transform; a masked joint's parent must be computed (or
    masked) already."""
    for j in range(parents.shape[0]):
        if not mask[j]:
            continue
        p = parents[j]
        if p < 0:
            q_put(out_rot, j, q_at(local, j))
            v_put(out_pos, j, v_at(trans, j))
        else:
            g, x = joint_fk(q_at(out_rot, p), v_at(out_pos, p), v_at(trans, j), q_at(local, j))
            q_put(out_rot, j, g)
            v_put(out_pos, j, x)


@njit(cache=True)
def frames_fk(parents, trans, local, mask, out_rot, out_pos):
    """:func:`tree_fk` of every frame of ``trans (F,J,3)``, ``local (F,J,4)``."""
    for f in range(local.shape[0]):
        tree_fk(parents, trans[f], local[f], mask, out_rot[f], out_pos[f])


@njit(cache=True)
def chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos):
    """Globals of the chain joints into g_rot (n,4), g_pos (n,3); returns the effector.

    prot, ppos: global rotation / position of the chain root's parent.
    """
    r = prot
    p = ppos
    for k in range(offsets.shape[0]):
        r, p = joint_fk(r, p, v_at(offsets, k), q_at(local, k))
        q_put(g_rot, k, r)
        v_put(g_pos, k, p)
    return vadd(p, qrot(r, (eff_off[0], eff_off[1], eff_off[2])))
