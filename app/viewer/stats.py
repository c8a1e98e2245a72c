"""Frame-time statistics: per-frame totals and the engine/render/UI split,
time to first frame; written as JSON (atomically)."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from engine.atomic import write_text

# frame: one loop iteration, start to start of the next (the frame before is shown or
# waited for inside it: ``wait``); render and compose: submitting the scene and the UI.
PHASES = ("frame", "engine", "render", "ui", "compose", "wait")


class FrameStats:
    def __init__(self, started_at: float | None = None):
        self.started_at = time.perf_counter() if started_at is None else started_at
        self.window_at: float | None = None
        self.first_frame_at: float | None = None
        self.samples: dict[str, list[float]] = {p: [] for p in PHASES}

    def mark_window(self) -> None:
        self.window_at = time.perf_counter()

    def record(self, **ms: float) -> None:
        if self.first_frame_at is None:
            self.first_frame_at = time.perf_counter()
        for phase in PHASES:
            self.samples[phase].append(float(ms.get(phase, 0.0)))

    def summary(self, skip: int = 0, **extra) -> dict:
        """Median/p95/p99/mean/max per phase (ms) over frames after ``skip``."""
        out = {"frames": len(self.samples["frame"]), "skipped_warmup_frames": skip}
        for phase, values in self.samples.items():
            v = np.asarray(values[skip:] if len(values) > skip else values, float)
            out[f"{phase}_ms"] = ({"median": _r(np.median(v)), "p95": _r(np.percentile(v, 95)),
                                   "p99": _r(np.percentile(v, 99)), "mean": _r(v.mean()), "max": _r(v.max())}
                                  if v.size else None)
        if self.first_frame_at is not None:
            out["time_to_first_frame_s"] = _r(self.first_frame_at - self.started_at)
            if self.window_at is not None:
                out["window_to_first_frame_s"] = _r(self.first_frame_at - self.window_at)
        out.update(extra)
        return out

    def write(self, path: str | Path, skip: int = 0, **extra) -> dict:
        data = self.summary(skip, **extra)
        write_json_atomic(path, data)
        return data


def write_json_atomic(path: str | Path, data) -> None:
    write_text(path, json.dumps(data, indent=1) + "\n")


def _r(x) -> float:
    return round(float(x), 4)
