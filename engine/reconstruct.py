"""Rebuilding a motion from a few joints' positions (reference 002, sections 5.2-5.3).

Kept: the root (hips) position and the hands' and feet's positions, each frame.
``learnt``: the body model (every joint under the world, constraint = hands and
feet relative to the hips in world axes) guesses the root's orientation and the
joints no chain holds (neck, head, toes); then each limb's own model (left and
right arm, left and right leg, constraint = its end joint relative to its root
in its parent's frame) gives the limb, parents' limbs first (the right arm hangs
from the spine the left-arm chain turns). ``learnt+ccd`` finishes each chain with
CCD from the learnt pose so the kept joints are met. ``ccd``, the baseline: every
chain solved by CCD from the rest pose, the root unturned.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import ccd, learnt_ik as L, quat
from .skeleton import Clip, Skeleton, pose_fk

KEEP = ("hips", "hands", "feet")
LIMBS = ("left_arm", "right_arm", "left_leg", "right_leg")
METHODS = ("learnt", "learnt+ccd", "ccd")


def kept_joints(rig, keep=KEEP) -> list[int]:
    """Skeleton indices kept for ``keep`` roles: hips = the root, hands = the arm
    chains' last joints, feet = the leg chains' last joints."""
    roles = {"hips": [0],
             "hands": [rig.chains[c].joints[-1] for c in ("left_arm", "right_arm")],
             "feet": [rig.chains[c].joints[-1] for c in ("left_leg", "right_leg")]}
    unknown = [k for k in keep if k not in roles]
    if unknown:
        raise ValueError(f"--keep: unknown {unknown[0]!r} (use {', '.join(KEEP)})")
    if sorted(set(keep)) != sorted(KEEP):
        raise ValueError(f"--keep must name all of {', '.join(KEEP)} (the models' constraints)")
    return [int(j) for k in KEEP for j in roles[k]]


def kept_positions(rig, global_positions: np.ndarray, keep=KEEP) -> np.ndarray:
    """``(F, J, 3)``: the kept joints' positions, NaN for every other joint."""
    out = np.full(global_positions.shape, np.nan)
    idx = kept_joints(rig, keep)
    out[:, idx] = global_positions[:, idx]
    return out


@dataclass
class Reconstructor:
    rig: object
    body: L.LimbModel
    limbs: dict          # chain name -> LimbModel, in solving order (parents' limbs first)


def _end_limbs(rig) -> dict:
    """The four chains as limbs ending at their last joint (hand, foot), parents' limbs
    first (a limb comes after any limb holding its parent joint)."""
    limbs = {n: L.chain_limb(rig, n, [rig.chains[n].joints[-1]]) for n in LIMBS}
    order, left = {}, list(limbs)
    while left:
        ready = [n for n in left if not any(limbs[n].parent in limbs[o].joints for o in left if o != n)]
        if not ready:
            raise ValueError("learnt IK: limbs hang from each other in a loop")
        order[ready[0]] = limbs[ready[0]]
        left.remove(ready[0])
    return order


def train_reconstructor(rig, clips, settings: L.LearntSettings | None = None) -> Reconstructor:
    """Models trained on the local rotations ``(F, J, 4)`` of each clip in ``clips``."""
    local = np.concatenate([np.asarray(c, float) for c in clips])
    limbs = _end_limbs(rig)
    body = L.train(L.body_limb(rig.skeleton, [int(lb.effector_joints[0]) for lb in limbs.values()]), local,
                   settings)
    return Reconstructor(rig, body, {n: L.train(lb, local[:, lb.joints], settings) for n, lb in limbs.items()})


def _end_chain(rig, name: str) -> ccd.ChainArrays:
    """The rig chain with its last joint as the effector (the kept hand, not the bat)."""
    ch = ccd.chain_arrays(rig, name)
    if ch.effector == ch.joints[-1]:
        return ch
    return replace(ch, effector=int(ch.joints[-1]), eff_off=np.zeros(3))


def _ccd_chain(rig, name, root, local, targets, hold=None) -> None:
    """CCD of chain ``name`` from ``local``'s pose toward the kept ``targets (F, J, 3)``, in
    place; the chain's joints where ``hold (n,)`` is true are not turned. A frame the CCD
    leaves short is solved again from the frame before's answer and from the rest pose, the
    best kept: from the learnt guess CCD can stall against the limits on a target the arm
    reaches (the cover drive's right hand, two frames after its hit, 5.9 cm short at 34 cm
    from the shoulder)."""
    ch = _end_chain(rig, name)
    if hold is not None:
        ch = ccd.with_locked(ch, hold)
    g_rot, g_pos = pose_fk(rig.skeleton, root, local)
    prot, ppos, target = g_rot[:, ch.parent], g_pos[:, ch.parent], targets[:, ch.effector]
    start = local[:, ch.joints]
    solved, err, _ = ccd.solve(ch, prot, ppos, start, target)
    held = np.zeros(len(ch.joints), bool) if hold is None else np.asarray(hold, bool)
    for f in np.flatnonzero(err > ccd.TOLERANCE):      # a few frames at most
        for other in (solved[max(f - 1, 0)], quat.identity((len(ch.joints),))):
            other = np.where(held[:, None], start[f], other)[None]     # held joints stay as they are
            again, e, _ = ccd.solve(ch, prot[f:f + 1], ppos[f:f + 1], other, target[f:f + 1])
            if e[0] < err[f]:
                solved[f], err[f] = again[0], e[0]
    local[:, ch.joints] = solved


def _reach_through_parent(rig, name, root, local, targets) -> None:
    """Where limb ``name``'s kept end is still short and the limb hangs from another limb's
    chain (the right arm from the spine the left-arm chain turns), solve it again with those
    joints in its chain, then that other limb with them held; a frame is kept only where
    both ends then meet better. The learnt spine can leave the right shoulder beyond the
    arm's reach of the kept hand (the pull after its hit: 60-67 cm, the arm is 54)."""
    ch = _end_chain(rig, name)
    host = next((n for n in LIMBS if n != name and ch.parent in rig.chains[n].joints), None)
    if host is None:
        return
    host_joints = list(rig.chains[host].joints)
    joints = host_joints[: host_joints.index(ch.parent) + 1] + list(ch.joints)
    long_chain = ccd.joint_chain(rig, joints, ch.effector, name=name)
    host_ch = _end_chain(rig, host)
    ends = [ch.effector, host_ch.effector]
    g_rot, g_pos = pose_fk(rig.skeleton, root, local)
    short = np.linalg.norm(g_pos[:, ch.effector] - targets[:, ch.effector], axis=-1) > ccd.TOLERANCE * 10
    if not short.any():
        return
    f = np.flatnonzero(short)
    before = np.linalg.norm(g_pos[f][:, ends] - targets[f][:, ends], axis=-1).sum(-1)
    trial = local[f].copy()
    solved, _, _ = ccd.solve(long_chain, g_rot[f, long_chain.parent], g_pos[f, long_chain.parent],
                             trial[:, long_chain.joints], targets[f, ch.effector])
    trial[:, long_chain.joints] = solved
    _ccd_chain(rig, host, root[f], trial, targets[f], hold=np.isin(host_ch.joints, joints))
    after = np.linalg.norm(pose_fk(rig.skeleton, root[f], trial)[1][:, ends] - targets[f][:, ends], axis=-1).sum(-1)
    better = after < before
    local[f[better]] = trial[better]


def rebuild(rec: Reconstructor, targets: np.ndarray, ccd_finish: bool = False) -> Clip:
    """The motion as a Clip from the kept joints' world positions ``targets (F, J, 3)``
    cm (others NaN, see :func:`kept_positions`) by the learnt models (``ccd_finish``:
    then CCD on each chain from the learnt pose)."""
    rig = rec.rig
    root = targets[:, 0].copy()
    b = rec.body.limb
    local = L.lookup(rec.body, L.constraints(b, None, targets, targets[:, b.effector_joints]))[0]
    for name, m in rec.limbs.items():
        g_rot, g_pos = pose_fk(rig.skeleton, root, local)
        x = L.constraints(m.limb, g_rot, g_pos, targets[:, m.limb.effector_joints])
        local[:, m.limb.joints] = L.lookup(m, x)[0]
        if ccd_finish:
            _ccd_chain(rig, name, root, local, targets)
    if ccd_finish:
        for name in rec.limbs:
            _reach_through_parent(rig, name, root, local, targets)
    return Clip(root, local)


def rebuild_ccd(rig, targets: np.ndarray) -> Clip:
    """The baseline: every chain solved by CCD from the rest pose, the root unturned,
    at the kept hips ``targets (F, J, 3)``."""
    root = targets[:, 0].copy()
    local = quat.identity(targets.shape[:2])
    for name in _end_limbs(rig):
        _ccd_chain(rig, name, root, local, targets)
    return Clip(root, local)


def position_rmse(skeleton: Skeleton, truth: Clip, rebuilt: Clip) -> tuple[np.ndarray, float]:
    """Per-joint position RMSE over frames ``(J,)`` cm and the overall RMSE (all joints
    and frames) of ``rebuilt`` against ``truth`` on the same skeleton."""
    _, p = pose_fk(skeleton, truth.root_positions, truth.local_rotations)
    _, r = pose_fk(skeleton, rebuilt.root_positions, rebuilt.local_rotations)
    d2 = ((p - r) ** 2).sum(-1)
    return np.sqrt(d2.mean(axis=0)), float(np.sqrt(d2.mean()))


def rebuild_shot(rig, shot, training, method: str = "learnt", keep=KEEP,
                 settings: L.LearntSettings | None = None, frames: slice = slice(None)) -> Clip:
    """``shot``'s frames rebuilt from its kept joints by ``method`` (see METHODS), the
    models trained on the local rotations ``(F, J, 4)`` in ``training`` (unused by ccd)."""
    if method not in METHODS:
        raise ValueError(f"reconstruct method must be one of {', '.join(METHODS)}, got {method!r}")
    targets = kept_positions(rig, shot.fk[1][frames], keep)
    if method == "ccd":
        clip = rebuild_ccd(rig, targets)
    else:
        clip = rebuild(train_reconstructor(rig, training, settings), targets, ccd_finish=method == "learnt+ccd")
    clip.fps = shot.clip.fps
    return clip


def two_fold(rig, shot, method: str = "learnt", keep=KEEP, settings: L.LearntSettings | None = None) -> Clip:
    """Leave-out for a lone capture: each half of it rebuilt by models trained on the
    other half only (no frame is rebuilt by a model that saw it)."""
    F = shot.num_frames
    if F < 4:
        raise ValueError(f"leave-out needs at least 4 frames to split, the capture has {F}")
    h = F // 2
    local = shot.clip.local_rotations
    first = rebuild_shot(rig, shot, [local[h:]], method, keep, settings, slice(0, h))
    second = rebuild_shot(rig, shot, [local[:h]], method, keep, settings, slice(h, F))
    return Clip(np.concatenate([first.root_positions, second.root_positions]),
                np.concatenate([first.local_rotations, second.local_rotations]), shot.clip.fps)
