"""The BVH hierarchy we write is clean for importers: every leaf joint ends in an
End Site with a length (the Bat too), and no joint has both a JOINT child and an
End Site (engine.bvh.write)."""
import numpy as np

from engine import bvh
from engine.skeleton import Clip


def hierarchy(text):
    """``{joint: (children, end site offset or None)}`` by a plain brace walk."""
    tokens = text[:text.index("MOTION")].split()
    out, stack, i = {}, [], 0
    while i < len(tokens):
        t = tokens[i]
        if t in ("ROOT", "JOINT"):
            name = tokens[i + 1]
            if stack:
                out[stack[-1]][0].append(name)
            out[name] = ([], None)
            stack.append(name)
            i += 2
        elif t == "End":
            k = tokens.index("OFFSET", i)
            out[stack[-1]] = (out[stack[-1]][0], np.array(tokens[k + 1:k + 4], float))
            i = tokens.index("}", k) + 1
        elif t == "}":
            stack.pop()
            i += 1
        else:
            i += 1
    return out


def test_every_leaf_has_an_end_site_and_no_joint_has_both(rig, tmp_path):
    from engine.library import load_library
    shot = load_library(rig=rig)[0]
    assert rig.skeleton.end_sites.get(rig.skeleton.index("LeftHand")) is not None   # the rig's data has both
    path = tmp_path / "s.bvh"
    bvh.write(path, shot.skeleton, Clip(shot.clip.root_positions, shot.clip.local_rotations, shot.clip.fps))
    text = path.read_text()
    tree = hierarchy(text)
    assert set(tree) == set(rig.skeleton.names)
    for name, (children, end) in tree.items():
        assert (end is None) == bool(children), name
        if end is not None:
            assert np.linalg.norm(end) > 1.0, name          # a bone of a length, not Blender's 1 mm stub
    bat_end = tree["Bat"][1]
    bat_offset = rig.skeleton.offsets[rig.skeleton.index("Bat")]
    assert np.dot(bat_end, bat_offset) > 0.99 * np.linalg.norm(bat_end) * np.linalg.norm(bat_offset)  # on down the bat
    assert "CHANNELS 0\n" in text                          # the Bat stays a fixed joint
    skel2, clip2 = bvh.read(path)
    assert skel2.names == [n for n in tree]                 # depth-first, as written
    q1 = clip2.local_rotations[:, [skel2.names.index(n) for n in rig.skeleton.names]]
    assert np.all(np.abs(np.sum(q1 * shot.clip.local_rotations, -1)) > 1 - 1e-12)


def test_format_bvh_keeps_the_structure_by_default(rig):
    from engine.library import load_library
    shot = load_library(rig=rig)[0]
    tree = hierarchy(bvh.format_bvh(shot.skeleton, shot.clip))
    assert tree["Bat"][1] is None and tree["LeftHand"][1] is None and tree["Head"][1] is not None
