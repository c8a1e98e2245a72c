"""Learnt IK as a solver of the shot adapter (issue 17 item 2; Ong & Hilton 2005).

Four solvers adapt a shot (:data:`SOLVERS`): ``ccd`` and ``dls`` (engine.adapt), and

* ``learnt`` - the pure lookup: the lead-arm chain (Spine .. lead hand, effector the
  bat joint) where the library's model says it is for each frame's bat handle
  (the same handles CCD is given, :func:`handles`), the bat error being whatever the
  data gives; the trail hand is then put back on its source grip, as the other
  solvers keep it (CCD on the trail-arm chain for the wrist, the hand turned);
* ``learnt+ccd`` - that learnt pose as CCD's start (``Adapter.adapt(start=...)``),
  then the adapter's own exact solve, grip and two-arm fallback included.

Both use the learnt pose weighted by the importance blend (a slerp from the source
pose, ``blend`` 1 = the lookup), so a frame of blend 0 is exactly the source and the
motion stays continuous where the blend starts; at the hit frame (blend 1) the
pose is the lookup itself. The model is trained on a library (optionally without
the adapted shot: ``leave_out``) and cached per left-out shot by :class:`LearntSolver`.
"""
from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from . import ccd, quat
from .adapt import Adaptation, AdaptSettings, check_point, check_settings
from .adapt import SOLVERS as KERNEL_SOLVERS
from .fk_nb import frames_fk
from .skeleton import carried_pose

if TYPE_CHECKING:       # engine.learnt_ik (scipy's k-means) loads when a model is trained: the
    from . import learnt_ik as L    # viewer imports this module for SOLVERS at its start

LEARNT_SOLVERS = ("learnt", "learnt+ccd")
SOLVERS = KERNEL_SOLVERS + LEARNT_SOLVERS
LEAD_CHAIN = "left_arm"
TRAIL_CHAIN = "right_arm"
GRIP_KEPT_CM = 0.05     # learnt+ccd: a trail hand further than this from its grip ...
RETRIES = 3             # ... pulls the start back to the source (halving, then the source) ...
RETRY_SPREAD = 2        # ... on its frames and this many either side


def check_solver(name: str) -> None:
    if name not in SOLVERS:
        raise ValueError(f"solver must be one of {', '.join(SOLVERS)}, got {name!r}")


def check(settings: AdaptSettings) -> None:
    """engine.adapt.check_settings, with the learnt solvers allowed."""
    check_solver(settings.solver)
    check_settings(replace(settings, solver="ccd") if settings.solver in LEARNT_SOLVERS else settings)


class LearntSolver:
    """The lead arm's learnt model trained on ``shots`` (all on ``rig``'s skeleton),
    trained once per left-out shot and kept (the viewer re-solves every frame of a drag)."""

    def __init__(self, rig, shots, settings: L.LearntSettings | None = None):
        self.rig = rig
        self.shots = list(shots)
        self.settings = settings
        self._models: dict = {}

    def model(self, leave_out: str | None = None) -> L.LimbModel:
        """The model trained on every shot but ``leave_out`` (a shot name; None: all)."""
        if leave_out not in self._models:
            from . import learnt_ik as L
            training = [s.clip.local_rotations for s in self.shots if s.name != leave_out]
            if not training:
                raise ValueError(f"learnt solver: nothing to train on without {leave_out!r} "
                                 f"(the library has {len(self.shots)} shot(s); drop --leave-out or add shots)")
            self._models[leave_out] = L.train_chains(self.rig, training, self.settings, names=(LEAD_CHAIN,))[LEAD_CHAIN]
        return self._models[leave_out]

    def adapt(self, adapter, desired_hit_point, settings: AdaptSettings, leave_out: bool = False) -> Adaptation:
        """``adapter``'s shot adapted by ``settings.solver`` (one of :data:`SOLVERS`);
        ``leave_out``: the learnt model does not know the adapted shot."""
        model = None
        if settings.solver in LEARNT_SOLVERS:      # ccd and dls need no model: none is trained for them
            model = self.model(adapter.shot.name if leave_out else None)
        return adapt(adapter, desired_hit_point, settings, model)


def adapt(adapter, desired_hit_point, settings: AdaptSettings, model: L.LimbModel | None = None) -> Adaptation:
    """Any of the four solvers; ``model`` (the lead arm's, :meth:`LearntSolver.model`)
    is needed by the learnt ones only."""
    check(settings)
    if settings.solver in KERNEL_SOLVERS:
        return adapter.adapt(desired_hit_point, settings)
    if model is None:
        raise ValueError(f"solver {settings.solver!r} needs a trained model")
    exact = settings.solver == "learnt+ccd"
    kernel_settings = replace(settings, solver="ccd")
    desired = check_point(desired_hit_point, "desired hit point")
    blend = adapter.blend(float(settings.falloff))
    if exact:
        return _exact(adapter, model, desired, blend, kernel_settings)
    return _pure(adapter, learnt_start(adapter, model, desired, blend), desired, blend, kernel_settings)


def _exact(adapter, model: L.LimbModel, desired: np.ndarray, blend: np.ndarray,
           settings: AdaptSettings) -> Adaptation:
    """learnt+ccd: the adapter's exact solve from the learnt start. Where the trail hand
    cannot get back on its grip from there (the lookup can give an arm configuration
    from another shot whose torso leaves the trail arm short), the start is pulled
    halfway back to the source on those frames and their neighbours, and solved again
    (at most RETRIES times; then the source there: CCD's own start)."""
    trust = np.ones_like(blend)
    found = looked_up(adapter, model, desired, blend)
    for attempt in range(RETRIES + 1):
        start = _weighted(adapter, found, blend * trust)
        a = adapter.adapt(desired, settings, start=start)
        off = (a.grip_error_cm > GRIP_KEPT_CM) & (trust > 0)
        if not off.any():
            return a
        near = np.convolve(off, np.ones(2 * RETRY_SPREAD + 1), mode="same") > 0
        trust = np.where(near, 0.0 if attempt == RETRIES - 1 else trust * 0.5, trust)
    return a


def handles(adapter, desired: np.ndarray, blend: np.ndarray) -> np.ndarray:
    """The bat joint's handle each frame ``(F, 3)`` (dissertation 2.2.4-2.2.5, as the
    adapter's kernel): the hit frame's offset to ``desired`` in bat-joint space, carried
    by each frame's bat and weighted by its blend."""
    h, b = adapter.hit_frame, adapter.bat
    offset = quat.rotate(quat.conjugate(adapter.src_grot[h, b]), desired - adapter.src_gpos[h, b])
    return adapter.src_gpos[:, b] + blend[:, None] * quat.rotate(adapter.src_grot[:, b], offset)


def _weighted(adapter, found: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """The source's lead-arm chain slerped toward ``found`` by ``weight (F,)`` (0: the source, exactly)."""
    start = adapter.src_local.copy()
    active = np.flatnonzero(weight > 0.0)
    chain = np.asarray(adapter.rig.chains[LEAD_CHAIN].joints, np.int64)
    src = start[active][:, chain]
    start[np.ix_(active, chain)] = quat.slerp(src, found[active][:, chain],
                                              np.broadcast_to(weight[active, None], src.shape[:-1]))
    return start


def learnt_start(adapter, model: L.LimbModel, desired: np.ndarray, blend: np.ndarray) -> np.ndarray:
    """Local rotations ``(F, J, 4)``: the source, with the lead-arm chain looked up by the
    model for each frame's handle (frames of blend > 0) and slerped from the source's by
    the blend."""
    return _weighted(adapter, looked_up(adapter, model, desired, blend), blend)


def looked_up(adapter, model: L.LimbModel, desired: np.ndarray, blend: np.ndarray) -> np.ndarray:
    """Local rotations ``(F, J, 4)``: the source, with the lead-arm chain as the model
    gives it for each frame's handle on the frames of blend > 0."""
    from . import learnt_ik as L
    start = adapter.src_local.copy()
    active = np.flatnonzero(blend > 0.0)
    if not len(active):
        return start
    limb = model.limb
    chain = np.asarray(adapter.rig.chains[LEAD_CHAIN].joints, np.int64)
    in_limb = np.array([list(limb.joints).index(j) for j in chain])     # the chain's joints in the limb
    target = handles(adapter, desired, blend)[active, None, :]
    start[np.ix_(active, chain)] = L.lookup_world(model, adapter.src_grot[active, limb.parent],
                                                  adapter.src_gpos[active, limb.parent], target)[:, in_limb]
    return start


def _pure(adapter, start: np.ndarray, desired: np.ndarray, blend: np.ndarray, settings: AdaptSettings) -> Adaptation:
    """The learnt pose as it is; the trail hand back on its source grip: CCD on the trail
    arm (from the source's) for the wrist's position, then the hand turned to the grip.
    Frames of blend 0 keep the source's pose and FK; only the others are computed."""
    local = start.copy()
    grot, gpos = adapter.src_grot.copy(), adapter.src_gpos.copy()
    active = np.flatnonzero(blend > 0.0)
    if len(active):
        sub = local[active]
        g, p = _fk(adapter, active, sub)
        if settings.fix_right_hand:
            ch = ccd.chain_arrays(adapter.rig, TRAIL_CHAIN)
            t_pos, _ = grip_targets(adapter, g, p, active)
            sub[:, ch.joints] = ccd.solve(ch, g[:, ch.parent], p[:, ch.parent], sub[:, ch.joints], t_pos,
                                          tolerance=settings.tolerance, iterations=settings.iterations)[0]
            g, p = _fk(adapter, active, sub)
            # the hand's own rotation turned to the grip (the wrist stays where CCD put it)
            rh = adapter.rhand
            sub[:, rh] = quat.mul(quat.conjugate(g[:, adapter.parents[rh]]), grip_targets(adapter, g, p, active)[1])
            g, p = _fk(adapter, active, sub)
        local[active], grot[active], gpos[active] = sub, g, p
    t_pos, t_rot = grip_targets(adapter, grot, gpos)
    rh = adapter.rhand
    return Adaptation(adapter.trans[:, 0].copy(), local, grot, gpos, blend.copy(),
                      handles(adapter, desired, blend), desired,
                      float(np.linalg.norm(gpos[adapter.hit_frame, adapter.bat] - desired)),
                      np.linalg.norm(gpos[:, rh] - t_pos, axis=-1),
                      quat.angle_between(grot[:, rh], t_rot))


def _fk(adapter, frames: np.ndarray, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations and positions of ``local (K, J, 4)``, the shot's ``frames (K,)``
    (engine.fk_nb's compiled FK)."""
    K, J = local.shape[:2]
    rot, pos = np.empty((K, J, 4)), np.empty((K, J, 3))
    frames_fk(adapter.parents, np.ascontiguousarray(adapter.trans[frames]), np.ascontiguousarray(local),
              np.ones(J, np.bool_), rot, pos)
    return rot, pos


def grip_targets(adapter, grot: np.ndarray, gpos: np.ndarray, frames=slice(None)) -> tuple[np.ndarray, np.ndarray]:
    """The trail hand's source grip (position, rotation) carried by the pose's lead hand,
    for poses ``grot``, ``gpos`` of the shot's ``frames`` (default: all)."""
    lh = adapter.lhand
    return carried_pose(grot[:, lh], gpos[:, lh], adapter.rel_pos[frames], adapter.rel_rot[frames])
