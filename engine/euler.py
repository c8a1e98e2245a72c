"""Euler angles continuous over time, for the files users load elsewhere (BVH, CSV).

A rotation has two Euler triples in any Tait-Bryan order (``R_i(a) R_j(b) R_k(c)``
equals ``R_i(a+180) R_j(180-b) R_k(c+180)``), each defined up to 360 degrees per
channel. ``quat.to_euler`` returns the branch with the middle angle in [-90, 90]
and every angle in [-180, 180]: an arm swinging past 180 degrees or an elbow
flexed past 90 then jumps by up to 360 degrees from one frame to the next, and
anything that interpolates channels (retiming, motion blur, resampling) spins
the joint. :func:`continuous` picks, per frame, the branch nearest the previous
frame and then unwraps each channel, so the angles change as little as the
motion does.

Frames whose rotation equals a ``reference`` triple (the file the clip was read
from) keep those numbers exactly: reading a file and writing it back changes no
number it does not have to.
"""
from __future__ import annotations

import numpy as np

from . import quat

# A reference triple is kept where its rotation is this close to the clip's
# (1 - |q . q_ref|; 1e-12 is ~2e-4 degrees, far below a file's 6 decimals' worth of change).
SAME_ROTATION = 1e-12


def wrap(degrees: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-180, 180)."""
    return (np.asarray(degrees, float) + 180.0) % 360.0 - 180.0


def other_branch(euler: np.ndarray) -> np.ndarray:
    """``(..., 3)`` degrees -> the other triple of the same rotation, wrapped (any order)."""
    e = np.asarray(euler, float)
    return wrap(np.stack([e[..., 0] + 180.0, 180.0 - e[..., 1], e[..., 2] + 180.0], -1))


def within(e: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Whether angles ``e`` (degrees) lie in [lo, hi], or a whole turn away from it."""
    return ((e >= lo) & (e <= hi)) | ((e - 360.0 >= lo) & (e - 360.0 <= hi)) | ((e + 360.0 >= lo) & (e + 360.0 <= hi))


def degrees_outside(e: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Degrees by which angles ``e`` lie outside [lo, hi] on the circle, per angle (0
    inside; a range may run past +-180: an angle a whole turn away inside it is inside)."""
    gap = np.minimum(np.abs(wrap(lo - e)), np.abs(wrap(e - hi)))
    return np.where(within(e, lo, hi), 0.0, gap)


def _outside(e: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """:func:`degrees_outside` summed over channels."""
    return degrees_outside(e, lo, hi).sum(-1)


def _distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Sum over channels of the circular distance (degrees) ``(...)``."""
    return np.abs(wrap(a - b)).sum(-1)


def _branch_states(e: np.ndarray, start_state: np.ndarray, fixed: np.ndarray | None = None) -> np.ndarray:
    """Which branch (0, 1) each frame takes ``(F, J)``: the one nearest the branch
    taken at the previous frame, but branch 0 where ``fixed (F, J)`` (a kept reference
    triple: the frames after it follow its numbers). ``e (F, J, 2, 3)`` the two branches
    per frame.

    Each frame maps the previous state to the next by one of four functions
    (constant 0, constant 1, keep, swap); composing them is a scan, vectorised:
    the state after frame f is the last constant before f, flipped once per swap
    since."""
    F = e.shape[0]
    d = _distance(e[1:, :, :, None], e[:-1, :, None, :])       # (F-1, J, now, prev)
    nxt = np.argmin(d, axis=2)                                  # (F-1, J, prev) -> now
    const = nxt[..., 0] == nxt[..., 1]
    swap = (nxt[..., 0] == 1) & (nxt[..., 1] == 0)
    first = np.ones((1, e.shape[1]), bool)                      # frame 0: the start state
    const = np.concatenate([first, const], 0)
    value = np.concatenate([start_state[None], nxt[..., 0]], 0)
    swap = np.concatenate([~first, swap], 0)
    if fixed is not None:                                       # constant 0 there
        const, swap = const | fixed, swap & ~fixed
        value = np.where(fixed, 0, value)
    idx = np.where(const, np.arange(F)[:, None], 0)
    last = np.maximum.accumulate(idx, axis=0)                   # last constant at or before f
    swaps = np.cumsum(swap, axis=0)
    flips = swaps - np.take_along_axis(swaps, last, 0)
    return (np.take_along_axis(value, last, 0) + flips) % 2


def _unwrap(values: np.ndarray, anchored: np.ndarray, anchor_values: np.ndarray) -> np.ndarray:
    """``values (F, J, 3)`` made continuous: anchored frames ``(F, J)`` take
    ``anchor_values`` exactly, every other frame the previous frame's angle plus
    the wrapped change."""
    F = values.shape[0]
    step = np.concatenate([np.zeros_like(values[:1]), wrap(np.diff(values, axis=0))], 0)
    total = np.cumsum(step, axis=0)
    last = np.maximum.accumulate(np.where(anchored, np.arange(F)[:, None], 0), axis=0)[..., None]
    last = np.broadcast_to(last, values.shape)
    out = np.take_along_axis(anchor_values, last, 0) + total - np.take_along_axis(total, last, 0)
    return np.where(anchored[..., None], anchor_values, out)


def _start(e0: np.ndarray, limits: np.ndarray | None) -> np.ndarray:
    """Branch (0, 1) of frame 0 per joint ``(J,)``: the one inside ``limits`` if any."""
    if limits is None:
        return np.zeros(e0.shape[0], int)
    lim = np.asarray(limits, float)
    s0, s1 = (_outside(e0[:, b], lim[..., 0], lim[..., 1]) for b in (0, 1))
    return (s1 < s0 - 1e-9).astype(int)


def continuous_order(q: np.ndarray, order: str, limits: np.ndarray | None = None,
                     reference: np.ndarray | None = None) -> np.ndarray:
    """Euler angles ``(F, J, 3)`` degrees in ``order`` of rotations ``q (F, J, 4)``
    (w,x,y,z), continuous over frames (see the module's doc).

    ``limits (J, 3, 2)`` degrees in the same order: frame 0 starts from the branch
    inside them (a flexed elbow as a pure flexion). ``reference (F, J, 3)``: where
    its rotation equals ``q``'s, its numbers are kept."""
    q = np.asarray(q, float)
    principal = quat.to_euler(q, order)
    e = np.stack([principal, other_branch(principal)], 2)                  # (F, J, 2, 3)
    anchored = np.zeros(q.shape[:2], bool)
    anchor = np.zeros(principal.shape)
    if reference is not None:
        ref = np.asarray(reference, float)
        same = 1.0 - np.abs(np.sum(quat.from_euler(ref, order) * quat.normalize(q), -1)) < SAME_ROTATION
        # a kept triple is branch 0 of its frame: the next frames follow it, not the principal one
        e[..., 0, :] = np.where(same[..., None], ref, e[..., 0, :])
        e[..., 1, :] = np.where(same[..., None], other_branch(ref), e[..., 1, :])
        anchored |= same
        anchor = np.where(same[..., None], ref, anchor)
    start = np.where(anchored[0], 0, _start(e[0], limits))
    # a kept triple is unwrapped from as it stands: its frame must take branch 0 (taking the
    # other shifted every later frame's numbers off the rotation: a synthesised golf take's
    # hips turned up to 180 deg in 426 frames, its planted foot sliding 35 cm in the file)
    state = _branch_states(e, start, anchored)
    chosen = np.take_along_axis(e, state[..., None, None], 2)[:, :, 0]
    first = chosen[0] if limits is None else _into_limits(chosen[0], limits)
    anchor[0] = np.where(anchored[0][:, None], anchor[0], first)
    anchored[0] = True      # frame 0 starts every joint's run
    return _unwrap(chosen, anchored, anchor)


def _into_limits(e0: np.ndarray, limits: np.ndarray) -> np.ndarray:
    """Frame 0's angles ``(J, 3)`` shifted by whole turns to lie in ``limits`` where they fit."""
    lim = np.asarray(limits, float)
    shifted = e0 + 360.0 * np.round((0.5 * (lim[..., 0] + lim[..., 1]) - e0) / 360.0)
    fits = (shifted >= lim[..., 0] - 1e-9) & (shifted <= lim[..., 1] + 1e-9)
    return np.where(fits, shifted, e0)


def continuous(q: np.ndarray, orders: list[str], limits: np.ndarray | None = None,
               reference: np.ndarray | None = None) -> np.ndarray:
    """Per joint in its own channel ``orders[j]`` ("ZYX", "XYZ", ...; "" = no
    rotation channels, zeros): :func:`continuous_order` over all joints,
    ``(F, J, 3)`` degrees. ``limits`` and ``reference`` as there, per joint."""
    q = np.asarray(q, float)
    out = np.zeros(q.shape[:-1] + (3,))
    for order in sorted(set(orders) - {""}):
        sel = [j for j, o in enumerate(orders) if o == order]
        out[:, sel] = continuous_order(q[:, sel], order, None if limits is None else np.asarray(limits)[sel],
                                       None if reference is None else np.asarray(reference)[:, sel])
    return out
