"""Key poses -> per-frame world targets for the shot solver.

A shot is a list of ``(t, {channel: value})`` keys, ``t`` in seconds relative
to impact (t = 0 is the hit frame). Each channel is interpolated on its own
keys with a monotone cubic (PCHIP): no overshoot, so a planted foot keyed
twice at the same spot stays exactly there, and a hold is a hold.

Channels (world space, cm / degrees):
  hips_pos (3), hips_ypr (3)      pelvis position, yaw/pitch/roll (see shots_ik.ypr)
  chest_ypr (3)                   Spine2 orientation
  look (3)                        point the eyes look at (head stays level)
  l_toe, r_toe (3)                ball of the foot (ToeBase joint)
  l_yaw, r_yaw, l_heel, r_heel    foot direction; heel raise about the toe (deg)
  grip (3) or hit (3) or toe (3)  left grip point / bat-joint at impact / bat toe
  bat_d (3), bat_n (3)            bat axis handle->toe and face normal (world)
  wrist_pref (1)                  preferred radial deviation of the wrists (deg)
"""
from __future__ import annotations

import numpy as np
from scipy.interpolate import PchipInterpolator

from engine import quat

from .shots_ik import perp, rot_axis, to_q, unit, ypr

FPS = 30.0
ANKLE_ABOVE_TOE = np.array([0.0, -6.0, 13.0])   # ToeBase offset under Foot (rig)
GRIP_TO_TOE = 81.0                                # bat length 86 - grip_to_top 5
BAT_FROM_GRIP = np.array([0.0, 6.6, -53.0])       # Bat joint - left grip, in LeftHand frame

VECTOR = {"hips_pos": 3, "hips_ypr": 3, "chest_ypr": 3, "look": 3, "l_toe": 3, "r_toe": 3,
          "l_yaw": 1, "r_yaw": 1, "l_heel": 1, "r_heel": 1, "grip": 3, "bat_d": 3, "bat_n": 3,
          "wrist_pref": 1, "head_tilt": 1}


def bat_frame(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """LeftHand world rotation ``(..., 3, 3)`` from the bat axis (exact) and face normal."""
    Z = -unit(d)
    Y = unit(perp(n, Z))
    X = np.cross(Y, Z)
    return np.stack([X, Y, Z], -1)


def grip_from_hit(hit, d, n) -> np.ndarray:
    """Left grip point that puts the Bat joint at ``hit`` with bat axis d and face n."""
    return np.asarray(hit, float) - bat_frame(np.asarray(d, float), np.asarray(n, float)) @ BAT_FROM_GRIP


def resolve_bat_keys(keys: list, shoulders=None) -> list:
    """Turn 'hit' and 'toe' bat keys into 'grip' keys (per key, exact), and
    give 'bat_auto' keys the face normal that lets the forearms point from
    the shoulders toward the hands: ``shoulders(t) -> (2, 3)``."""
    out = []
    for t, k in keys:
        k = dict(k)
        if k.pop("bat_auto", False):
            d = unit(np.asarray(k["bat_d"], float))
            mid = shoulders(t).mean(0)
            k["bat_n"] = np.cross(-d, unit(perp(np.asarray(k["grip"], float) - mid, d)))
        if "hit" in k:
            k["grip"] = grip_from_hit(k.pop("hit"), k["bat_d"], k["bat_n"])
        if "toe" in k:
            k["grip"] = np.asarray(k.pop("toe"), float) - GRIP_TO_TOE * unit(np.asarray(k["bat_d"], float))
        out.append((t, k))
    return out


def sample(keys: list, channel: str, times: np.ndarray) -> np.ndarray:
    """Channel values at ``times`` ``(F, n)``; exact key values at both ends."""
    pts = [(t, np.atleast_1d(np.asarray(k[channel], float))) for t, k in keys if channel in k]
    ts = np.array([p[0] for p in pts])
    vs = np.stack([p[1] for p in pts])
    if len(pts) < 2 or np.any(np.diff(ts) <= 0):
        raise ValueError(f"channel {channel}: keys must be at increasing times ({ts})")
    out = PchipInterpolator(ts, vs, axis=0)(np.clip(times, ts[0], ts[-1]))
    out[times <= ts[0]] = vs[0]
    out[times >= ts[-1]] = vs[-1]
    return out


BODY = ("hips_pos", "hips_ypr", "chest_ypr")


def tracks(keys: list, times: np.ndarray, solver=None) -> dict:
    """Sampled channels ``{name: (F, n)}``; ``solver`` (a PoseSolver) places
    the shoulders for 'bat_auto' keys."""
    from .shots_ik import shoulder_positions

    def shoulders(t):
        b = {c: sample(keys, c, np.array([t]))[0] for c in BODY}
        return shoulder_positions(solver, b["hips_pos"], ypr(*b["hips_ypr"]), ypr(*b["chest_ypr"]))

    keys = resolve_bat_keys(keys, shoulders)
    out = {c: sample(keys, c, times) for c in VECTOR if any(c in k for _, k in keys)}
    # a key segment before the hit whose face would turn faster than FACE_TURN_PER_FRAME
    # (the normal, interpolated apart from the axis, swinging past it: the face flips over
    # in a frame) turns as one rotation instead
    face = unit(perp(out["bat_n"], unit(out["bat_d"])))
    turn = np.degrees(np.arccos(np.clip((face[1:] * face[:-1]).sum(-1), -1.0, 1.0)))     # (F-1,)
    ts = np.array([t for t, k in keys if "bat_d" in k])
    seg = np.clip(np.searchsorted(ts, times, side="right") - 1, 0, len(ts) - 2)
    bad = np.isin(seg, seg[1:][(turn > FACE_TURN_PER_FRAME) & (times[1:] < 0.0)])
    if bad.any():
        rot = sample_bat_rotation(keys, times)
        out["bat_d"][bad], out["bat_n"][bad] = -rot[bad, :, 2], rot[bad, :, 1]
    return out


FACE_TURN_PER_FRAME = 75.0   # deg: a segment whose face turns faster turns as one rotation


def sample_bat_rotation(keys: list, times: np.ndarray) -> np.ndarray:
    """The bat's rotation ``(F, 3, 3)`` (bat_frame) between its keys, interpolated as one
    rotation: its quaternion's components by a monotone cubic, normalised. The axis and
    the face normal interpolated apart can pass through a normal along the axis, where
    the face flips over in one frame (the straight drive's turned 170 degrees between two
    frames at the top of its backlift)."""
    pts = [(t, bat_frame(np.asarray(k["bat_d"], float), np.asarray(k["bat_n"], float)))
           for t, k in keys if "bat_d" in k]
    ts = np.array([t for t, _ in pts])
    if len(pts) < 2 or np.any(np.diff(ts) <= 0):
        raise ValueError(f"bat keys must lie at increasing times ({ts})")
    q = to_q(np.stack([m for _, m in pts]))
    for i in range(1, len(q)):             # the shorter way round from each key to the next
        if q[i] @ q[i - 1] < 0.0:
            q[i] = -q[i]
    out = PchipInterpolator(ts, q, axis=0)(np.clip(times, ts[0], ts[-1]))
    out[times <= ts[0]] = q[0]
    out[times >= ts[-1]] = q[-1]
    return quat.to_matrix(out / np.linalg.norm(out, axis=-1, keepdims=True))


def targets(tr: dict) -> dict:
    """Solver targets (see ``PoseSolver.solve``) from sampled tracks."""
    T = {"hips_pos": tr["hips_pos"],
         "hips_rot": ypr(*tr["hips_ypr"].T),
         "chest_rot": ypr(*tr["chest_ypr"].T),
         "look": tr["look"],
         "grip": tr["grip"],
         "bat_rot": bat_frame(tr["bat_d"], tr["bat_n"]),
         "wrist_pref": tr["wrist_pref"][:, 0]}
    if "head_tilt" in tr:
        T["head_tilt"] = tr["head_tilt"][:, 0]
    for s in ("l", "r"):
        yaw, heel = tr[s + "_yaw"][:, 0], tr[s + "_heel"][:, 0]
        foot = rot_axis(1, yaw) @ rot_axis(0, heel)
        T[s + "_foot_rot"] = foot
        T[s + "_ankle"] = tr[s + "_toe"] - foot @ ANKLE_ABOVE_TOE
        # toes stay flat on the ground while the heel is up
        T[s + "_toe_bend"] = np.clip(-heel, -60.0, 30.0)
        # knees point over the toes, a little outward
        side = 1.0 if s == "l" else -1.0
        T[s + "_knee_dir"] = foot @ unit(np.array([0.12 * side, 0.0, 1.0]))
    return T
