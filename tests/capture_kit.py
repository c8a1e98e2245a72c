"""Test kit for real-capture tests: small synthetic swings on skeletons named as
each profile family names them (written as BVH text here, not by the engine),
and an independent BVH reader and FK (scipy's rotations, not engine.quat)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from tests.conftest import MOCAP
GOLF = MOCAP / "cmu_63_02_golf_swing.bvh"
WALK = MOCAP / "cmu_02_01_walk.bvh"

# (name, parent, offset cm) of a small humanoid; names are the CMU family's
_BODY = [
    ("Hips", None, (0, 95, 0)), ("LowerBack", "Hips", (0, 8, 0)), ("Spine", "LowerBack", (0, 14, 0)),
    ("Spine1", "Spine", (0, 14, 0)), ("Neck", "Spine1", (0, 14, 0)), ("Head", "Neck", (0, 10, 0)),
    ("LeftShoulder", "Spine1", (4, 10, 0)), ("LeftArm", "LeftShoulder", (14, 0, 0)),
    ("LeftForeArm", "LeftArm", (28, 0, 0)), ("LeftHand", "LeftForeArm", (25, 0, 0)),
    ("RightShoulder", "Spine1", (-4, 10, 0)), ("RightArm", "RightShoulder", (-14, 0, 0)),
    ("RightForeArm", "RightArm", (-28, 0, 0)), ("RightHand", "RightForeArm", (-25, 0, 0)),
    ("LeftUpLeg", "Hips", (9, -5, 0)), ("LeftLeg", "LeftUpLeg", (0, -44, 0)), ("LeftFoot", "LeftLeg", (0, -42, 0)),
    ("LeftToeBase", "LeftFoot", (0, -5, 14)),
    ("RightUpLeg", "Hips", (-9, -5, 0)), ("RightLeg", "RightUpLeg", (0, -44, 0)), ("RightFoot", "RightLeg", (0, -42, 0)),
    ("RightToeBase", "RightFoot", (0, -5, 14)),
]
RENAME = {
    "cmu": {},
    "mixamo": {n: f"mixamorig:{n}" for n, _, _ in _BODY} | {"LowerBack": "mixamorig:Spine", "Spine": "mixamorig:Spine1",
                                                           "Spine1": "mixamorig:Spine2"},
    "neuron": {"LowerBack": "Spine", "Spine": "Spine1", "Spine1": "Spine3"},
    "generic": {"Hips": "pelvis", "LowerBack": "spine_01", "Spine": "spine_02", "Spine1": "spine_03",
                "Neck": "neck_01", "Head": "head", "LeftShoulder": "clavicle_l", "LeftArm": "upperarm_l",
                "LeftForeArm": "lowerarm_l", "LeftHand": "hand_l", "RightShoulder": "clavicle_r",
                "RightArm": "upperarm_r", "RightForeArm": "lowerarm_r", "RightHand": "hand_r",
                "LeftUpLeg": "thigh_l", "LeftLeg": "calf_l", "LeftFoot": "foot_l", "LeftToeBase": "ball_l",
                "RightUpLeg": "thigh_r", "RightLeg": "calf_r", "RightFoot": "foot_r", "RightToeBase": "ball_r"},
}


def swing_angles(frames: int = 60) -> dict[str, np.ndarray]:
    """Euler ZYX degrees per joint (F, 3): both arms down and forward, swung across
    the body by the spine with a speed peak at 2/3 of the clip (the impact)."""
    t = np.linspace(0.0, 1.0, frames)
    s = np.tanh(6.0 * (t - 2.0 / 3.0))                    # backswing -> follow-through
    z = np.zeros(frames)
    col = lambda a, b, c: np.stack([a + z, b + z, c + z], axis=1)  # noqa: E731
    return {
        "Spine": col(0, 25 * s, 10), "Spine1": col(0, 15 * s, 5),
        "LeftShoulder": col(-5, 0, 0), "LeftArm": col(-60, -40 + 5 * s, 10),
        "LeftForeArm": col(0, -20, 0), "LeftHand": col(0, 0, 0),
        "RightShoulder": col(5, 0, 0), "RightArm": col(55, 50 + 5 * s, -10),
        "RightForeArm": col(0, 35, 0), "RightHand": col(0, 0, 0),
        "LeftUpLeg": col(0, 0, -10), "LeftLeg": col(0, 0, 15),
        "RightUpLeg": col(0, 0, -5), "RightLeg": col(0, 0, 10),
    }


def _mirror_name(n: str) -> str:
    return n.replace("Left", "\0").replace("Right", "Left").replace("\0", "Right")


def write_family(path: Path, family: str = "cmu", frames: int = 60, mirrored: bool = False,
                 scale: float = 1.0, order: str = "ZYX") -> Path:
    """A synthetic swing as BVH text. ``mirrored``: reflected across x = 0 (a
    left-hander); ``scale``: file units per cm are 1/scale; ``order``: channels."""
    ang = swing_angles(frames)
    rename = RENAME[family]
    body = list(_BODY)
    if mirrored:        # reflect: offsets x -> -x, the sides swap, Euler (z, y, x) -> (-z, -y, x)
        body = [(_mirror_name(n), p and _mirror_name(p), (-o[0], o[1], o[2])) for n, p, o in body]
        ang = {_mirror_name(n): a * np.array([-1, -1, 1]) for n, a in ang.items()}
    all_pos = family == "mixamo"
    lines, cols = ["HIERARCHY"], []
    kids = {n: [c for c, p, _ in body if p == n] for n, _, _ in body}
    offs = {n: np.array(o, float) / scale for n, _, o in body}

    def emit(n, depth):
        ind = "  " * depth
        lines.append(f"{ind}{'ROOT' if depth == 0 else 'JOINT'} {rename.get(n, n)}")
        lines.append(f"{ind}{{")
        lines.append(f"{ind}  OFFSET " + " ".join(f"{v:.5f}" for v in offs[n]))
        pos = depth == 0 or all_pos
        ch = (["Xposition", "Yposition", "Zposition"] if pos else []) + [f"{a}rotation" for a in order]
        lines.append(f"{ind}  CHANNELS {len(ch)} " + " ".join(ch))
        e = ang.get(n, np.zeros((frames, 3)))
        q = Rotation.from_euler("ZYX", e, degrees=True)
        e_file = q.as_euler(order, degrees=True)
        p = np.tile(offs[n], (frames, 1))
        if depth == 0:
            p = p + np.stack([np.zeros(frames), np.zeros(frames), np.linspace(0, 5, frames) / scale], 1)
        cols.append(np.hstack([p, e_file]) if pos else e_file)
        for c in kids[n]:
            emit(c, depth + 1)
        if not kids[n]:
            lines.extend([f"{ind}  End Site", f"{ind}  {{", f"{ind}    OFFSET 0 3 0", f"{ind}  }}"])
        lines.append(f"{ind}}}")

    emit(body[0][0], 0)
    data = np.hstack(cols)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.0333333"]
    lines += [" ".join(f"{v:.6f}" for v in row) for row in data]
    path.write_text("\n".join(lines) + "\n")
    return path


def read_bvh(path: Path) -> dict:
    """Independent reader: names, parents, offsets, channels, motion (F, C)."""
    tokens = Path(path).read_text().split()
    names, parents, offsets, channels, stack = [], [], [], [], []
    i, last = 0, -1
    while tokens[i] != "MOTION":
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            names.append(tokens[i + 1])
            parents.append(stack[-1] if stack else -1)
            last = len(names) - 1
            i += 2
        elif t == "End":
            last = None
            i += 2
        elif t == "{":
            stack.append(last)
            i += 1
        elif t == "}":
            stack.pop()
            i += 1
        elif t == "OFFSET":
            if last is not None:
                offsets.append([float(v) for v in tokens[i + 1:i + 4]])
            i += 4
        elif t == "CHANNELS":
            n = int(tokens[i + 1])
            channels.append(tokens[i + 2:i + 2 + n])
            i += 2 + n
        else:
            i += 1
    frames = int(tokens[i + 2])
    data = np.array(tokens[i + 6:], float).reshape(frames, -1)
    return {"names": names, "parents": parents, "offsets": np.array(offsets), "channels": channels, "data": data}


def fk(b: dict) -> np.ndarray:
    """Global joint positions (F, J, 3) in file units, from the reader above."""
    F, J = b["data"].shape[0], len(b["names"])
    pos, rot = np.zeros((F, J, 3)), [None] * J
    col = 0
    for j in range(J):
        ch = b["channels"][j]
        vals = b["data"][:, col:col + len(ch)]
        col += len(ch)
        local_t = np.tile(b["offsets"][j], (F, 1))
        for k, c in enumerate(ch):
            if c.endswith("position"):
                local_t[:, "XYZ".index(c[0])] = vals[:, k]
        rch = [k for k, c in enumerate(ch) if c.endswith("rotation")]
        order = "".join(ch[k][0] for k in rch)
        r = Rotation.from_euler(order, vals[:, rch], degrees=True) if rch else Rotation.identity(F)
        p = b["parents"][j]
        if p < 0:
            pos[:, j], rot[j] = local_t, r
        else:
            pos[:, j] = pos[:, p] + rot[p].apply(local_t)
            rot[j] = rot[p] * r
    return pos
