"""The humerus's axial rotation held inside its documented range by every solver, compiled.

The rig's Euler twist of the upper arm (Arm x + ArmRoll x) is the humerus's axial rotation
only near the T-pose (Codman's paradox: an arm swung across the chest with no axial rotation
reads x = 180), so no box on it can be the documented range. The solvers read the axial
rotation as ISB does (Wu et al. 2005, humerothoracic Y-X-Y: plane of elevation, elevation,
axial rotation, + internal; the check in tools/shots_check.humerothoracic reads the same
from rotation matrices) and turn the arm back inside the range: the Newton solvers after
every step, CCD once, on the pose its sweeps converge to (held after every sweep, the hold's
swings steered the later sweeps to the far side of the arm: in the leg glance a right elbow
47 cm off the source's for one frame). With the arm near hanging
(or straight up) the plane and the axial rotation are one turn: the range fades out there
over ``FADE`` about the edges of ``BAND``, as the check's reading does.

A chain's ``hold`` is a plain tuple (idx (3,) int64 = [chest, arm, side], range (2,),
window (2,) radians): ``chest`` the chain index of the thorax joint (-1: the chain root's
parent), ``arm`` the chain index of the upper arm (its roll joint is the next; -1: nothing
held), ``side`` +1 left, -1 right; ``range`` the rig's [-external, internal] rotation;
``window`` the frame's, the range widened to take in the start pose (:func:`open_window`,
as ``quat_nb.widen_limits`` does for the Euler limits: a pose already outside may stay
there or move back in). The reading needs only the chain's own local rotations from the
chest to the roll joint, so no solver has to pass a parent transform for it.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .fk_nb import chain_fk
from .quat_nb import (axis_angle, clamp_angle, dot, from_euler_zyx, other_branch, outside, q_at, q_put, qconj, qmul,
                      to_euler_zyx, v_at, vnorm, vsub, wrap)

BAND = (math.radians(20.0), math.radians(160.0))   # elevation where the axial rotation is a turn of its own
FADE = math.radians(10.0)
COS_FULL = math.cos(BAND[0] + 0.5 * FADE)   # |cos elevation| below this: the range holds in full
SWING_STEP = math.radians(15.0) # the search for the swing that keeps the effector: step, and steps
# each way: at most 30 deg, since a larger swing is the elbow going round the arm (searched
# to 180, a swing for a hair less excess popped the back-foot defence's right elbow 51 cm
# between two frames)
SWING_STEPS = 2


def no_hold() -> tuple:
    """The hold of a chain without an upper arm (legs, a capture rig without roll joints)."""
    return (np.array([-1, -1, 1], np.int64), np.zeros(2), np.array([-2.0 * math.pi, 2.0 * math.pi]))


@njit(cache=True)
def sub_hold(hold, a):
    """The hold of the part of its chain from index ``a`` on (the same window): the chest
    must be in it or be its root's parent, else nothing is held."""
    idx, rng, window = hold
    kc = idx[0] - a
    if idx[1] < a or kc < -1:
        return (np.array([-1, -1, idx[2]], np.int64), rng, window)
    return (np.array([kc, idx[1] - a, idx[2]], np.int64), rng, window)


@njit(cache=True)
def _humerus(rel, side):
    """The humerus's ISB axes in the chest's frame from its roll joint's rotation ``rel``
    (w, x, y, z), the left arm mirrored onto ISB's right: y (elbow -> shoulder, unit) and z
    (the flexion axis made normal to y, not unit: only angles are read from it)."""
    w, x, y, z = rel
    mx = -1.0 if side > 0 else 1.0
    # the rotation matrix's first two columns: the bone (x) and the flexion axis (y)
    b = (1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y + w * z), 2.0 * (x * z - w * y))
    f = (2.0 * (x * y - w * z), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z + w * x))
    hy = (side * mx * -b[0], -side * b[1], -side * b[2])
    hz = (mx * f[0], f[1], f[2])
    d = dot(hz, hy)
    return hy, (hz[0] - d * hy[0], hz[1] - d * hy[1], hz[2] - d * hy[2])


@njit(cache=True)
def reading(rel, side):
    """(plane of elevation, elevation, axial rotation) radians of an upper arm whose roll
    joint's rotation in the chest's frame is ``rel`` (w, x, y, z); ISB's right arm, the
    left mirrored onto it (the bone along +x on the left arm and -x on the right, the
    elbow's flexion axis y; the chest's y up and z forward, so the thorax's axes are
    x = chest z forward, y = chest y up, z = x cross y)."""
    hy, hz = _humerus(rel, side)
    elevation = math.acos(min(1.0, max(-1.0, hy[1])))
    plane = math.atan2(-hy[2], hy[0])
    return plane, elevation, _axial(hy, hz)


@njit(cache=True)
def _axial(hy, hz):
    """The axial rotation (radians, + internal) from :func:`_humerus`'s axes: the thorax's
    up read in the humerus's x-z plane."""
    return math.atan2(hy[0] * hz[2] - hy[2] * hz[0], hz[1])


@njit(cache=True)
def band_weight(elevation):
    """1 inside BAND, 0 outside, faded over FADE about its edges."""
    return min(1.0, max(0.0, min(elevation - BAND[0], BAND[1] - elevation) / FADE + 0.5))


@njit(cache=True)
def _relative(local, idx):
    """The upper arm's roll joint in the chest's frame, and the arm's parent in it."""
    r = (1.0, 0.0, 0.0, 0.0)
    for k in range(idx[0] + 1, idx[1]):
        r = qmul(r, q_at(local, k))
    return qmul(qmul(r, q_at(local, idx[1])), q_at(local, idx[1] + 1))


@njit(cache=True)
def _allowed(cos_elevation, window):
    """The frame's window widened by the fade at an elevation given by its cosine (the
    humerus's y read in the chest's up): (lo, hi) radians."""
    if abs(cos_elevation) <= COS_FULL:          # inside the band: no arccos
        return window[0], window[1]
    widen = (1.0 - band_weight(math.acos(min(1.0, max(-1.0, cos_elevation))))) * math.pi
    return window[0] - widen, window[1] + widen


@njit(cache=True)
def open_window(local, hold):
    """Set the hold's window for a frame whose start pose is ``local (n,4)``: its range
    taken out to the start's own axial rotation where the start lies past it."""
    idx, rng, window = hold
    if idx[1] < 0:      # nothing held: the window all round (a [0, 0] one had the two-arm
        release(hold)   # solve swing the chain's last joint, index -1, on capture rigs)
        return
    window[0], window[1] = rng[0], rng[1]
    hy, hz = _humerus(_relative(local, idx), idx[2])
    axial = _axial(hy, hz)
    lo, hi = _allowed(hy[1], window)
    # (a hair beyond: the solvers read the start from its globals, a float's width apart)
    if axial > hi:
        window[1] += axial - hi + 1e-9
    elif axial < lo:
        window[0] -= lo - axial + 1e-9


@njit(cache=True)
def _excess(rel, side, window):
    """Radians the axial rotation of the upper arm whose roll joint's rotation in the
    chest's frame is ``rel`` lies outside the frame's window, and the signed turn about
    the bone to its nearer edge."""
    hy, hz = _humerus(rel, side)
    a_lo, a_hi = _allowed(hy[1], window)
    if a_hi - a_lo >= 2.0 * math.pi:
        return 0.0, 0.0
    axial = _axial(hy, hz)
    if a_lo <= axial <= a_hi:
        return 0.0, 0.0
    to_lo, to_hi = wrap(a_lo - axial), wrap(a_hi - axial)
    turn = to_lo if abs(to_lo) < abs(to_hi) else to_hi
    return abs(turn), turn


@njit(cache=True)
def _swing_about(axis, chest_inv, hum, window, side, out0):
    """The smallest turn of SWING_STEP's (radians) of the upper arm about ``axis``
    (shoulder -> effector, world) that brings its axial rotation inside the window, or
    failing that the one that leaves it least outside, if less than unturned (``out0``).
    ``chest_inv``: the chest's global rotation inverted; ``hum``: the roll joint's global
    rotation. (Bisecting down to the
    window's edge instead of stopping a step inside it left more arms past the range over
    the shots' grids: the next step starts at the edge.)"""
    best, best_out = 0.0, out0
    for i in range(2 * SWING_STEPS):
        phi = (i // 2 + 1) * SWING_STEP * (1.0 if i % 2 == 0 else -1.0)
        out, _ = _excess(qmul(chest_inv, qmul(axis_angle(axis, phi), hum)), side, window)
        if out < best_out - 1e-9:
            best, best_out = phi, out
            if out == 0.0:
                break
    return best


@njit(cache=True)
def _put_arm(local, euler, lo, hi, k, q):
    """Joint ``k``'s local rotation ``q`` on the Euler branch nearer its limits (then its
    current angles), clamped into them."""
    e1 = to_euler_zyx(q)
    e2 = other_branch(e1)
    s1 = s2 = d1 = d2 = 0.0
    for c in range(3):
        s1 += outside(e1[c], lo[k, c], hi[k, c])
        s2 += outside(e2[c], lo[k, c], hi[k, c])
        d1 += abs(wrap(e1[c] - euler[k, c]))
        d2 += abs(wrap(e2[c] - euler[k, c]))
    e = e2 if s2 < s1 - 1e-12 or (abs(s2 - s1) <= 1e-12 and d2 < d1) else e1
    for c in range(3):
        euler[k, c] = clamp_angle(e[c], lo[k, c], hi[k, c])
    q_put(local, k, from_euler_zyx(euler[k, 0], euler[k, 1], euler[k, 2]))


@njit(cache=True)
def held_fk(prot, ppos, offsets, eff_off, local, euler, lo, hi, hold, g_rot, g_pos):
    """:func:`engine.fk_nb.chain_fk` of the pose after :func:`hold_axial` held it (in place):
    the solvers' FK after a step. Returns the effector."""
    return hold_fk(prot, ppos, offsets, eff_off, local, euler, lo, hi, hold, g_rot, g_pos,
                   chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos))


@njit(cache=True, inline='always')
def hold_fk(prot, ppos, offsets, eff_off, local, euler, lo, hi, hold, g_rot, g_pos, eff):
    """:func:`held_fk` of a pose whose chain FK (``g_rot``, ``g_pos``, effector ``eff``) is
    already computed: the FK again only where the hold swung the arm. Returns the effector.
    Inlined (:func:`held_fk` runs it after every solver step)."""
    idx, window = hold[0], hold[2]
    ka, kc = idx[1], idx[0]
    if ka < 0 or window[1] - window[0] >= 2.0 * math.pi:
        return eff
    # the check here, the hold's call only when it is past (a call with a dozen arrays costs)
    chest = prot if kc < 0 else q_at(g_rot, kc)
    out, _ = _excess(qmul(qconj(chest), qmul(q_at(g_rot, ka), q_at(local, ka + 1))), idx[2], window)
    if out > 0.0 and hold_axial(prot, local, euler, lo, hi, hold, g_rot, g_pos, eff):
        eff = chain_fk(prot, ppos, offsets, eff_off, local, g_rot, g_pos)
    return eff


@njit(cache=True)
def release(hold):
    """Let the arm turn freely this frame (the bat on the ball, the hands on the bat come
    first: a solve the hold kept off its target runs again without it)."""
    hold[2][0], hold[2][1] = -2.0 * math.pi, 2.0 * math.pi


@njit(cache=True)
def held(hold):
    """Whether the hold holds anything this frame."""
    return hold[0][1] >= 0 and hold[2][1] - hold[2][0] < 2.0 * math.pi


@njit(cache=True)
def hold_axial(prot, local, euler, lo, hi, hold, g_rot, g_pos, eff):
    """Swing the whole upper arm about the line from the shoulder to the effector, which
    leaves the effector where it is, by the smallest turn that brings the humerus's axial
    rotation inside the hold's window (or as near as such a turn gets it): in place on
    ``local (n,4)`` and ``euler (n,3)``, the arm's angles clamped to ``lo/hi (n,3)``.
    ``g_rot``/``g_pos``/``eff``: the chain's FK of this pose (``prot``: its root's parent's
    rotation). Returns whether the pose changed (its FK is then stale): not if the arm's
    Euler limits clamp the swing to no gain. A turn about the
    bone instead would move the effector, and the solvers' next step would turn it back:
    measured, it left more arms past the range and cost more."""
    idx, _, window = hold
    kc, ka, side = idx[0], idx[1], idx[2]
    chest_inv = qconj(prot if kc < 0 else q_at(g_rot, kc))
    hum = qmul(q_at(g_rot, ka), q_at(local, ka + 1))
    out, _ = _excess(qmul(chest_inv, hum), side, window)
    u = vsub(eff, v_at(g_pos, ka))
    n = vnorm(u)
    if out == 0.0 or n < 1e-6:
        return False
    axis = (u[0] / n, u[1] / n, u[2] / n)
    phi = _swing_about(axis, chest_inv, hum, window, side, out)
    if phi == 0.0:
        return False
    parent = prot if ka == 0 else q_at(g_rot, ka - 1)
    keep_q, keep_e = q_at(local, ka), (euler[ka, 0], euler[ka, 1], euler[ka, 2])
    _put_arm(local, euler, lo, hi, ka, qmul(qconj(parent), qmul(axis_angle(axis, phi), q_at(g_rot, ka))))
    # the arm's Euler limits may clamp the swing: kept only if the arm still ends less far out
    hum = qmul(qmul(parent, q_at(local, ka)), q_at(local, ka + 1))
    if _excess(qmul(chest_inv, hum), side, window)[0] < out:
        return True
    q_put(local, ka, keep_q)
    euler[ka, 0], euler[ka, 1], euler[ka, 2] = keep_e
    return False
