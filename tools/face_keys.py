"""Search a shot's bat keys for faces that keep its arms smooth. Writes nothing.

A bat key without a face (``shots_defs.bat`` with neither ``n`` nor ``x``) takes the face
that points the top forearm from the shoulders to the hands (``shots_keys.face_for_forearm``).
Between two such keys the face can turn further about the handle than the arms can follow,
and an elbow swings round its arm in a frame. This tries, key by key (greedy, in time
order), eight faces about each such key's axis, away from the swing (0.21 s either side of
the hit) and the shared stance and rest, and keeps a face where the shot's score
(:func:`score`) falls by more than ``MIN_GAIN`` while nothing the library's tests hold
gets worse: the hit's problems, the face's turn a frame, the bat's acceleration outside
the swing, the clamp into the limits, the grip moved by ``make_shots.unfold``.

    python -m tools.face_keys SHOT [--keys 4,9] [--faces 8]

It prints each trial and the faces to key (``n=...`` in the shot's definition). Its
choices are proposals: look at the shot before keying one (``tools.closeup_shots``).
"""
import argparse
import sys

import numpy as np

from engine.library import Shot
from engine.rig import default_rig

from . import make_shots
from . import shots_check as chk
from .shots_defs import SHOTS

SWING_S = 0.21          # keys this near the hit belong to the swing
STANCE_S = -0.75        # keys before this are the stance's
FACE_TURN_MAX = chk.FACE_TURN_DEG - 0.5    # deg a frame outside the contact, with a margin
MIN_GAIN = 3.0


def candidate_faces(d: np.ndarray, count: int = 8) -> np.ndarray:
    """``count`` unit face normals ``(count, 3)`` square to the bat's axis ``d``, evenly
    round it, the first the one nearest straight up."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    ref = np.array([0.0, 1.0, 0.0]) if abs(d[1]) < 0.95 else np.array([1.0, 0.0, 0.0])
    u = ref - d * (d @ ref)
    u /= np.linalg.norm(u)
    v = np.cross(d, u)
    a = np.radians(np.arange(count) * 360.0 / count)
    return np.cos(a)[:, None] * u + np.sin(a)[:, None] * v


def score(fig: dict) -> float:
    """One number to lower: a pop over 20 cm counts as 20 small ones."""
    return (20 * fig["big_pops"] + fig["pops"] + fig["pop_excess_cm"] / 20 + fig["horizontal"]
            + fig["axial"] + fig["folds"])


def measure(name: str, keyed, rig) -> dict:
    """Build shot ``name`` from ``keyed`` (keys, description) and read what the search weighs."""
    _, clip, hit, _, info = make_shots.build(name, rig, keyed=keyed)
    return figures(name, rig, clip, hit, info)


def figures(name: str, rig, clip, hit: int, info: dict) -> dict:
    """What the searches weigh in a built shot (make_shots.build's clip, hit frame and info):
    shots_check.arm_figures, the face's largest turn a frame outside the contact, the jerk (the
    bat's largest acceleration outside the swing less the swing's: > 0 is a jerk), the clamp,
    the unfold, the hit's problems and azimuth, and the ``score``."""
    shot = Shot(name, f"{name}.bvh", hit, "", rig.skeleton, clip, rig.bat_joint)
    g_rot, g_pos = shot.fk
    fig = chk.arm_figures(rig, g_rot, g_pos)
    turns = chk.face_turns_deg(rig, g_rot)
    acc = chk.bat_acceleration(g_pos, rig.bat_joint)
    swing = np.abs(np.arange(len(acc)) - hit) <= chk.SWING_FRAMES
    m = chk.hit_measures(rig, shot)
    fig.update(face_turn=float(turns[np.abs(np.arange(len(turns)) + 0.5 - hit) > chk.CONTACT_FRAMES].max()),
               jerk=float(acc[~swing].max() - acc[swing].max()), clamp=info["clamped_deg"],
               unfold=info["unfold_cm"],
               hit_problems=len(chk.hit_problems(name, m)), azimuth=m["azimuth_deg"])
    fig["score"] = score(fig)
    return fig


def acceptable(trial: dict, base: dict) -> bool:
    return (trial["hit_problems"] <= base["hit_problems"] and trial["face_turn"] <= FACE_TURN_MAX
            and trial["jerk"] <= -1.0 and trial["clamp"] <= max(base["clamp"], 10.0)
            and trial["unfold"] <= base["unfold"] + 5.0)


def free_keys(keys: list) -> list[int]:
    """Indices of the keys whose face the search may choose."""
    return [i for i, (t, k) in enumerate(keys)
            if k.get("bat_auto") and abs(t) >= SWING_S and t > STANCE_S and 2 <= i < len(keys) - 2]


def with_faces(name: str, faces: dict) -> tuple[list, str]:
    """Shot ``name``'s (keys, description) with ``faces`` {key index: normal} keyed."""
    keys, desc = SHOTS[name]()
    keys = list(keys)
    for i, n in faces.items():
        k = dict(keys[i][1])
        k.pop("bat_auto")
        k["bat_n"] = n
        keys[i] = (keys[i][0], k)
    return keys, desc


def search(name: str, only=None, count: int = 8, rig=None, out=print) -> dict:
    """Greedy over :func:`free_keys` (or ``only``), ``count`` faces a key; returns
    {key index: face normal}."""
    rig = rig or default_rig()
    base = best = measure(name, SHOTS[name](), rig)
    out(f"{name}: as keyed {_line(base)}")
    keys, _ = SHOTS[name]()
    chosen = {}
    for i in free_keys(keys):
        if only and i not in only:
            continue
        for n in candidate_faces(keys[i][1]["bat_d"], count):
            trial_faces = {**chosen, i: np.round(n, 2)}
            trial = measure(name, with_faces(name, trial_faces), rig)
            ok = acceptable(trial, base)
            out(f"  key {i} (t {keys[i][0]:+.2f} s) face {np.round(n, 2).tolist()}: "
                f"{'' if ok else 'refused '}{_line(trial)}")
            if ok and trial["score"] < best["score"] - MIN_GAIN:
                best, chosen = trial, trial_faces
    out(f"{name}: keyed {', '.join(f'key {i} n={tuple(v.tolist())}' for i, v in chosen.items()) or 'nothing'}"
        f" -> {_line(best)}")
    return chosen


def _line(f: dict) -> str:
    return (f"score {f['score']:.0f}: pops {f['pops']} (>20 cm {f['big_pops']}, {f['pop_excess_cm']:.0f} cm), "
            f"horizontal {f['horizontal']}, axial {f['axial']}, folds {f['folds']}; face turn {f['face_turn']:.1f}, "
            f"clamp {f['clamp']:.1f}, unfold {f['unfold']:.0f} cm, azimuth {f['azimuth']:+.1f}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("shot", choices=sorted(SHOTS))
    ap.add_argument("--keys", help="only these key indices, comma-separated")
    ap.add_argument("--faces", type=int, default=8, help="faces tried a key, evenly round its axis")
    a = ap.parse_args(argv)
    only = {int(k) for k in a.keys.split(",")} if a.keys else None
    search(a.shot, only, a.faces)
    return 0


if __name__ == "__main__":
    sys.exit(main())
