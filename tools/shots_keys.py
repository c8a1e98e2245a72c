"""Key poses -> per-frame world targets for the shot solver.

A shot is a list of ``(t, {channel: value})`` keys, ``t`` in seconds relative
to impact (t = 0 is the hit frame). Each channel is interpolated on its own
keys with a monotone cubic (PCHIP): no overshoot, so a planted foot keyed
twice at the same spot stays exactly there, and a hold is a hold.

Channels (world space, cm / degrees):
  hips_pos (3), hips_ypr (3)      pelvis position, yaw/pitch/roll (see shots_maths.ypr)
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

from engine.rig import default_rig

from .shots_ik import bat_from_grip, grip_frame
from .shots_maths import perp, rot_axis, unit, ypr

FPS = 30.0
ANKLE_ABOVE_TOE = np.array([0.0, -6.0, 13.0])   # ToeBase offset under Foot (rig)
GRIP_TO_TOE = 81.0                                # bat length 86 - grip_to_top 5
BAT_FROM_GRIP = bat_from_grip(default_rig())      # Bat joint - left grip, in the bat's frame
FOREARM_IN_BAT = grip_frame(default_rig())[0]     # LeftHand's X (the forearm's way) in the bat's frame

VECTOR = {"hips_pos": 3, "hips_ypr": 3, "chest_ypr": 3, "look": 3, "l_toe": 3, "r_toe": 3,
          "l_yaw": 1, "r_yaw": 1, "l_heel": 1, "r_heel": 1, "grip": 3, "bat_d": 3, "bat_n": 3,
          "wrist_pref": 1, "head_tilt": 1}


def bat_frame(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The bat's world frame ``(..., 3, 3)`` (shots_ik.grip_frame) from its axis ``d``
    (handle -> toe, kept exactly) and face normal ``n``."""
    Z = -unit(d)
    Y = unit(perp(n, Z))
    X = np.cross(Y, Z)
    return np.stack([X, Y, Z], -1)


def face_for_forearm(d: np.ndarray, x: np.ndarray, forearm_in_bat: np.ndarray = FOREARM_IN_BAT) -> np.ndarray:
    """The face normal ``(3,)`` that turns the bat about its axis ``d`` so that the top
    hand's forearm (LeftHand's X, ``forearm_in_bat`` in the bat's frame) points along ``x``
    as nearly as the grip lets it: across the handle, exactly."""
    u = unit(perp(np.asarray(x, float), d))
    v = np.cross(-d, u)                       # (u, v, -d) right-handed, about the handle
    phi = np.arctan2(forearm_in_bat[1], forearm_in_bat[0])
    return np.sin(phi) * u + np.cos(phi) * v


def grip_from_hit(hit, d, n) -> np.ndarray:
    """Left grip point that puts the Bat joint at ``hit`` with bat axis d and face n."""
    return np.asarray(hit, float) - bat_frame(np.asarray(d, float), np.asarray(n, float)) @ BAT_FROM_GRIP


def resolve_bat_keys(keys: list, shoulders=None, forearm_in_bat: np.ndarray = FOREARM_IN_BAT) -> list:
    """Turn 'hit' and 'toe' bat keys into 'grip' keys (per key, exact), and give 'bat_x' keys
    the face normal that points the top forearm along their ``bat_x``, and 'bat_auto' keys
    the one that points it from the shoulders toward the hands (``shoulders(t) -> (2, 3)``),
    as the grip holds the bat (``forearm_in_bat``: LeftHand's X in the bat's frame)."""
    out = []
    for t, k in keys:
        k = dict(k)
        x = k.pop("bat_x", None)
        if k.pop("bat_auto", False):
            x = np.asarray(k["grip"], float) - shoulders(t).mean(0)
        if x is not None:
            k["bat_n"] = face_for_forearm(unit(np.asarray(k["bat_d"], float)), x, forearm_in_bat)
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

    # a face keyed by the forearm's way is the rig's grip's: the same forearm turns the bat
    # differently in another grip
    forearm = FOREARM_IN_BAT if solver is None else grip_frame(solver.rig)[0]
    keys = resolve_bat_keys(keys, shoulders, forearm)
    out = {c: sample(keys, c, times) for c in VECTOR if any(c in k for _, k in keys) and c != "bat_n"}
    out["bat_n"] = sample_face(keys, times)
    return out


def transport(d: np.ndarray, n0: np.ndarray) -> np.ndarray:
    """Unit normals ``(F, 3)`` perpendicular to the axes ``d (F, 3)``: ``n0`` carried
    along the axis path without turning about it (discrete parallel transport)."""
    ref = np.empty_like(d)
    ref[0] = unit(perp(n0, d[0]))
    for i in range(1, len(d)):          # a loop over samples, authoring time only
        ref[i] = unit(perp(ref[i - 1], d[i]))
    return ref


def sample_face(keys: list, times: np.ndarray, per_second: float = 600.0) -> np.ndarray:
    """Face normals ``(F, 3)``: the keyed normals exactly at the keys, and between
    them the face turned about the bat's axis by the shorter way, evenly (a monotone
    cubic of the angle). The normal interpolated apart from the axis can swing through
    it, where the face flips over in one frame (the straight drive's turned 169 degrees
    between two frames at the top of its backlift, the sweep's 174 after the hit)."""
    key_t = np.array([t for t, k in keys if "bat_n" in k])
    key_n = np.stack([np.asarray(k["bat_n"], float) for t, k in keys if "bat_n" in k])
    if len(key_t) < 2 or np.any(np.diff(key_t) <= 0):
        raise ValueError(f"bat keys must lie at increasing times ({key_t})")
    # a fine grid through every key and frame time: the transport does not depend on the frame rate
    grid = np.union1d(np.union1d(np.arange(key_t[0], key_t[-1], 1.0 / per_second), key_t),
                      np.clip(times, key_t[0], key_t[-1]))
    d = unit(sample(keys, "bat_d", grid))
    ref = transport(d, key_n[0])
    at = np.searchsorted(grid, key_t)
    n = unit(perp(key_n, d[at]))
    angle = np.arctan2((np.cross(ref[at], n) * d[at]).sum(-1), (ref[at] * n).sum(-1))
    angle = np.concatenate([[angle[0]], angle[0] + np.cumsum(np.angle(np.exp(1j * np.diff(angle))))])
    theta = PchipInterpolator(key_t, angle)(grid)
    face = np.cos(theta)[:, None] * ref + np.sin(theta)[:, None] * np.cross(d, ref)
    return face[np.searchsorted(grid, np.clip(times, key_t[0], key_t[-1]))]


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
