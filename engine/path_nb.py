"""The cheapest path through per-frame candidates (Viterbi), compiled: the clean-up picks,
frame by frame, which of its passes' answers to keep (engine.cleanup)."""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def cheapest_path(cost, charges):
    """Indices ``(F,)`` int64 of the candidates, one a frame, whose ``cost (F, K)`` plus
    ``charges (F-1, K, K)`` (from candidate i at frame f to j at f + 1) sum least; ties go
    to the lower index."""
    F, K = cost.shape
    acc = cost[0].copy()
    nxt = np.empty(K)
    back = np.zeros((F, K), np.int64)
    for f in range(1, F):
        for j in range(K):
            best, arg = np.inf, 0
            for i in range(K):
                c = acc[i] + charges[f - 1, i, j]
                if c < best:
                    best, arg = c, i
            back[f, j] = arg
            nxt[j] = best + cost[f, j]
        acc[:] = nxt
    path = np.zeros(F, np.int64)
    path[F - 1] = np.argmin(acc)
    for f in range(F - 1, 0, -1):
        path[f - 1] = back[f, path[f]]
    return path
