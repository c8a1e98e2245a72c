"""The source's detail beyond the PC pad's two PCs (engine.synth): which source frame each frame
of a take corresponds to, and the source's scores of the remaining PCs there."""
from __future__ import annotations

import numpy as np

from .pca import ShotPCA
from .synth import check_scores


def frame_map(frames: int, source_frames: int) -> np.ndarray:
    """(frames,) source frame for each frame, by stretching time linearly."""
    if frames == 1:
        return np.zeros(1, dtype=np.int64)
    return np.rint(np.arange(frames) * (source_frames - 1) / (frames - 1)).astype(np.int64)


DETAIL_WIDTH = 0.01     # of the guide's score spread: how far off the guide its detail still comes from one frame
DETAIL_BLOCK = 512      # take frames per block of distances (a 10-minute take against a long capture)
DETAIL_MAPS = ("time", "aligned", "nearest")
ALIGN_CELLS = 25_000_000   # take frames x source frames the alignment holds (int32: 100 MB)


def source_detail(pca: ShotPCA, scores: np.ndarray, how: str, k: int = 2) -> np.ndarray:
    """The source's scores of the PCs after the first ``k`` ``(F, K - k)`` for a take whose first
    ``k`` scores per frame are ``scores (F, k)``: the dissertation's remedy for what two PCs lose
    (3.2.4: "a higher-dimensional principal component space would lead to better results"). The
    pad moves the first two; the rest is the source's detail. Measured 2026-12-04 on the bundled
    shots, the 2-PC path of a shot against the shot: joints 5-11 cm off on average, the cover
    drive's bat 94 cm from its hit point at the hit, the square cut's backlift 73 cm low and the
    exaggerated straight drive's backlift 25 cm below the shot's own; with the detail the shot's
    own path gives back the shot exactly. ``how``, which source frame each take frame takes it from:

    * "time": the same time (a take on the shot's timeline: a preset, the 2-PC path);
    * "aligned": the frames whose first scores lie nearest, in the shot's order (a drawn path: it
      walks the shot's time as it walks its path, :func:`align_to_guide`);
    * "nearest": the frames whose first scores lie nearest, softly (a Gaussian of DETAIL_WIDTH of
      the guide's spread), for the marker's still pose: it moves smoothly and on the guide is the
      source's (where the guide crosses itself it blends the two crossings' detail)."""
    s = check_scores(scores)
    if how not in DETAIL_MAPS:
        raise ValueError(f"unknown detail map {how!r} (one of {', '.join(DETAIL_MAPS)})")
    if how == "aligned" and len(s) * len(pca.scores) > ALIGN_CELLS:
        how = "nearest"        # the alignment's table would pass ~100 MB: soft nearest, block by block
    if how != "nearest":
        m = frame_map(len(s), pca.scores.shape[0]) if how == "time" else align_to_guide(s, pca.scores[:, :k])
        return pca.scores[m, k:].copy()
    guide = pca.scores[:, :k]
    width = DETAIL_WIDTH * float(np.sqrt(np.mean(guide.var(axis=0)))) + 1e-12
    out = np.empty((len(s), pca.scores.shape[1] - k))
    for a in range(0, len(s), DETAIL_BLOCK):           # (block, F_source) distances at a time
        d2 = np.sum((s[a:a + DETAIL_BLOCK, None, :] - guide[None, :, :]) ** 2, axis=-1)
        w = np.exp(-(d2 - d2.min(axis=1, keepdims=True)) / (2.0 * width * width))
        out[a:a + DETAIL_BLOCK] = (w / w.sum(axis=1, keepdims=True)) @ pca.scores[:, k:]
    return out


def align_to_guide(scores: np.ndarray, guide: np.ndarray) -> np.ndarray:
    """(F,) frames of ``guide (S, k)``, never going back, whose scores lie nearest ``scores (F, k)``
    in total (squared distance; dynamic programming, O(F S))."""
    F, S = len(scores), len(guide)
    back = np.empty((F, S), np.int32)          # the best previous frame <= each frame
    cost = np.sum((scores[0][None, :] - guide) ** 2, axis=-1)
    for t in range(1, F):
        best = np.minimum.accumulate(cost)
        idx = np.arange(S)
        back[t] = np.maximum.accumulate(np.where(cost <= best, idx, 0))
        cost = best + np.sum((scores[t][None, :] - guide) ** 2, axis=-1)
    m = np.empty(F, np.int64)
    m[-1] = int(np.argmin(cost))
    for t in range(F - 1, 0, -1):
        m[t - 1] = back[t, m[t]]
    return m
