"""The rig as data: skeleton, per-joint DOFs and limits, IK chains, bat and ball.

Everything here comes from a JSON file (``assets/rig.json`` for the bundled
batsman), never from joint names in code, so another skeleton can be mapped in.
DOFs and limits are per Euler axis of ``R = Rz(z) Ry(y) Rx(x)``; arrays use the
axis order (z, y, x) to match the Euler angles returned by ``quat.to_euler(q, "ZYX")``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .skeleton import Skeleton

EULER_ORDER = "ZYX"
_AXIS_COLUMN = {"z": 0, "y": 1, "x": 2}


@dataclass
class Chain:
    joints: list[int]        # root-most first; IK may rotate these
    effector: int            # joint whose position is driven


@dataclass
class Rig:
    skeleton: Skeleton
    dof: np.ndarray          # (J, 3) bool, columns (z, y, x)
    limits: np.ndarray       # (J, 3, 2) degrees, [lo, hi] per column
    chains: dict[str, Chain]
    bat: dict
    ball_radius: float
    wrist: int               # joint index of the lockable wrist
    wrist_default_dof: int
    feet: dict[str, list[int]] = field(default_factory=dict)
    animated_joints: int = 0  # joints that carry animation (PCA parameters)
    roles: dict = field(default_factory=dict)  # role -> joint(s), for a rig built from a profile
    # the humerus's axial rotation (engine.humerus_nb): {"chest": joint, "rolls": {roll joint:
    # +1 left / -1 right}, "range": (-external, internal) degrees}; empty: not held
    humerus: dict = field(default_factory=dict)

    @property
    def bat_joint(self) -> int:
        return self.chains["left_arm"].effector

    def dof_mask(self, wrist_dof: int | None = None) -> np.ndarray:
        """DOF mask with the wrist set to 0 or 2 DOF (None: the rig's default)."""
        wd = self.wrist_default_dof if wrist_dof is None else wrist_dof
        if wd not in (0, 2):
            raise ValueError(f"wrist DOF must be 0 or 2, got {wd}")
        m = self.dof.copy()
        m[self.wrist] = False
        if wd == 2:
            m[self.wrist] = self.dof[self.wrist]
        return m


def load_rig(path: str | Path) -> Rig:
    """Load a rig JSON file; unknown parents or bad limits raise ``ValueError``."""
    return rig_from_dict(json.loads(Path(path).read_text()))


def rig_from_dict(data: dict) -> Rig:
    """A rig from the parsed contents of a rig JSON file (``load_rig``)."""
    joints = data["joints"]
    names = [j["name"] for j in joints]
    parents, offsets = [], []
    J = len(joints)
    dof = np.zeros((J, 3), bool)
    limits = np.zeros((J, 3, 2))
    orders, has_pos, end_sites = [], [], {}
    for i, j in enumerate(joints):
        p = j["parent"]
        if p is not None and p not in names[:i]:
            raise ValueError(f"rig: joint {j['name']!r} has unknown or later parent {p!r}")
        parents.append(-1 if p is None else names.index(p))
        offsets.append(j["offset"])
        for axis in j.get("dof", ""):
            dof[i, _AXIS_COLUMN[axis]] = True
        for axis, (lo, hi) in j.get("limits", {}).items():
            if lo > hi:
                raise ValueError(f"rig: joint {j['name']!r} axis {axis}: limit {lo} > {hi}")
            limits[i, _AXIS_COLUMN[axis]] = (lo, hi)
        orders.append(EULER_ORDER if j.get("dof", "") or p is None else "")
        has_pos.append(p is None)
        if "end_site" in j:
            end_sites[i] = np.array(j["end_site"], float)
    skel = Skeleton(names, np.array(parents), np.array(offsets, float), orders, has_pos, end_sites)
    chains = {}
    for key, c in data["chains"].items():
        idx = skel.chain(c["start"], c["end"])
        chains[key] = Chain(idx, skel.index(c["effector"]))
    feet = {k: [skel.index(n) for n in v] for k, v in data.get("feet", {}).items()}
    return Rig(skel, dof, limits, chains, data["bat"], data["ball"]["diameter"] / 2,
               skel.index(data["wrist"]["joint"]), int(data["wrist"]["default_dof"]), feet,
               int(data.get("animated_joints", J)), humerus=_humerus(skel, data.get("humerus")))


def _humerus(skel: Skeleton, h: dict | None) -> dict:
    """The rig's humerus entry with joint indices; each roll joint's parent (the upper arm)
    turns about its x too."""
    if not h:
        return {}
    if not 0.0 <= h["internal"] <= 180.0 or not 0.0 <= h["external"] <= 180.0:
        raise ValueError("rig: humerus internal/external rotation must be 0..180 degrees")
    rolls = {skel.index(h["left"]): 1, skel.index(h["right"]): -1}
    return {"chest": skel.index(h["chest"]), "rolls": rolls, "range": (-float(h["external"]), float(h["internal"]))}


def assets_dir() -> Path:
    return Path(__file__).resolve().parent.parent / "assets"


def default_rig() -> Rig:
    return load_rig(assets_dir() / "rig.json")
