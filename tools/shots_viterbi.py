"""Dynamic programming for the shot authoring: the cheapest path through per-frame candidates
(an elbow's place on its circle, a bat roll, a grip) with charges between frames."""
from __future__ import annotations

import numpy as np


def step_charge(points: np.ndarray, allowed: np.ndarray, weight: float) -> np.ndarray:
    """Viterbi transition charges ``(F-1, K, K)`` for candidate points ``(F, K, 3)``: ``weight``
    per cm^2 that going from candidate i at frame f to j at f + 1 moves further than
    ``allowed (F-1,)`` cm."""
    moved = np.linalg.norm(points[1:, None, :] - points[:-1, :, None], axis=-1)          # (F-1, from, to)
    return weight * np.maximum(0.0, moved - allowed[:, None, None]) ** 2


def continuity_charge(cost: np.ndarray, points: np.ndarray, allowed: np.ndarray, weight: float) -> np.ndarray:
    """Transition charges ``(F-1, K, K)`` between states whose sub-choices (``cost (F, K, P)``,
    candidate points ``(F, K, P, 3)``) are made per frame: what moving from state i at frame f
    to j at f + 1 with its sub-choices continuous (``weight`` per cm^2 a point moves further
    than ``allowed (F-1,)``) costs beyond taking each frame's best sub-choice."""
    F, K, P = cost.shape
    out = np.zeros((F - 1, K, K))
    best = cost.min(2)
    flat, pts = cost.reshape(F, K * P), points.reshape(F, K * P, 3)
    sq = np.einsum("fnd,fnd->fn", pts, pts)
    for f in range(F - 1):
        # |a - b|^2 by one matrix product: (K*P)^2 pairs a frame
        d2 = sq[f][:, None] + sq[f + 1][None, :] - 2.0 * pts[f] @ pts[f + 1].T
        tot = 0.5 * flat[f][:, None] + 0.5 * flat[f + 1][None, :] \
            + weight * np.maximum(0.0, np.sqrt(np.maximum(d2, 0.0)) - allowed[f]) ** 2
        out[f] = tot.reshape(K, P, K, P).min(axis=(1, 3)) - 0.5 * best[f][:, None] - 0.5 * best[f + 1][None, :]
    return out


def viterbi(cost: np.ndarray, psi: np.ndarray, weight: float, extra=None) -> np.ndarray:
    """Cheapest path of indices ``(F,)`` through ``cost (F, K)`` with a
    ``weight * (circular angle step in radians)^2`` charge between frames, plus
    ``extra[f, i, j]`` ``(F-1, K, K)`` (or ``extra(f)``, ``(K, K)``) from index i at
    frame f to j at f + 1."""
    F, K = cost.shape
    # the first and last frames are shared by every shot: pin them to their
    # own best choice so the path cannot make them differ between shots
    cost = cost.copy()
    for f in (0, F - 1):
        keep = np.argmin(cost[f])
        cost[f] = np.inf
        cost[f, keep] = 0.0
    step = np.abs(np.angle(np.exp(1j * (psi[:, None] - psi[None, :]))))
    trans = weight * step ** 2
    acc = cost[0].copy()
    back = np.zeros((F, K), int)
    for f in range(1, F):
        step_extra = 0.0 if extra is None else extra(f - 1) if callable(extra) else extra[f - 1]
        tot = acc[:, None] + trans + step_extra                                  # from i to j
        back[f] = np.argmin(tot, axis=0)
        acc = tot[back[f], np.arange(K)] + cost[f]
    path = np.zeros(F, int)
    path[-1] = int(np.argmin(acc))
    for f in range(F - 1, 0, -1):
        path[f - 1] = back[f, path[f]]
    return path
