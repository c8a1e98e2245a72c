"""A take's synthesis from its path in a shot's PC space: the path resampled once, the source's
detail beyond two PCs (engine.synth_detail), the clip (engine.synth.synthesise), the take's hit
frame and whether it leaves the ball. One recipe for the CLI's ``synth`` and the viewer's PC pad;
their clean-up (engine.cleanup) follows."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import synth, synth_detail
from .pca import ShotPCA
from .skeleton import Clip


class TakeClip(NamedTuple):
    path: np.ndarray        # (N, 2) the points resampled to the clip's frames
    clip: Clip              # before clean-up
    hit_frame: int          # the take's own (synth.take_hit_frame)
    leaves: bool            # the take aborts before the hit (synth.leaves_ball)


def make(pca: ShotPCA, points: np.ndarray, times: np.ndarray | None, fps: float, frames: int | None, *,
         same_timeline: bool, detail: bool, preset: str | None, amount: float | None,
         sections: synth.Sections, guide: np.ndarray, source_hit_frame: int,
         abort_frame: int | None = None) -> TakeClip:
    """The take of ``points`` (N, 2) PC scores (``times`` (N,) s, or None: ``frames`` frames at
    ``fps``). ``same_timeline``: the take keeps the shot's timing (a preset, the shot's own path),
    so the source's detail is taken frame by frame and the hit is the shot's frame; else both
    follow the alignment with ``guide`` (the shot's own path, synth.source_path)."""
    per_frame = synth.resample_path(points, frames, times, fps)
    more = synth_detail.source_detail(pca, per_frame, "time" if same_timeline else "aligned") if detail else None
    # the path is resampled once: one point a frame is its own resampling
    clip = synth.synthesise(pca, per_frame, frames=len(per_frame), fps=fps, detail=more)
    hit = synth.take_hit_frame(per_frame, guide, source_hit_frame, same_timeline)
    leaves = synth.leaves_ball(preset, clip.num_frames, sections, amount, abort_frame)
    return TakeClip(per_frame, clip, hit, leaves)
