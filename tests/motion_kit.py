"""Test kit: a smooth random motion inside a rig's limits, for the PCA, synthesis and
PC-pad tests (tests/engine, tests/app/...)."""
import numpy as np

from engine import quat
from engine.skeleton import Clip


def smooth_random_clip(rig, frames=90, seed=0, amplitude=0.6):
    """A smooth random motion inside the rig's limits (sums of slow sinusoids)."""
    rng = np.random.default_rng(seed)
    J = rig.skeleton.num_joints
    t = np.linspace(0, 1, frames)[:, None]
    euler = np.zeros((frames, J, 3))
    for j in range(rig.animated_joints):
        for c in range(3):
            if not rig.dof[j, c]:
                continue
            lo, hi = rig.limits[j, c]
            mid, half = (lo + hi) / 2, (hi - lo) / 2 * amplitude
            w = rng.uniform(0.5, 2.5, 3)
            ph = rng.uniform(0, 2 * np.pi, 3)
            a = rng.uniform(0.2, 1, 3)
            wave = (a * np.sin(2 * np.pi * w * t + ph)).sum(axis=1) / a.sum()
            euler[:, j, c] = np.clip(mid + half * wave, lo, hi)
    rot = quat.from_euler(euler, "ZYX")
    rot[:, rig.animated_joints:] = quat.identity()
    root = np.stack([10 * np.sin(3 * t[:, 0]), 97 - 8 * t[:, 0] ** 2, -20 * t[:, 0]], axis=1)
    # random storage signs: PCA must make them continuous itself
    flip = rng.random((frames, J)) < 0.3
    rot = np.where(flip[..., None], -rot, rot)
    return Clip(root, rot, 30.0)
