"""Synthesis of new animations from paths in a shot's PC space (dissertation 3.2).

A path is a list of score points ``(N, 2)`` for the first two PCs. It becomes
an animation by resampling it to frames (from timestamps, or stretched over the
source's length) and turning every frame's scores into a pose with
:meth:`engine.pca.ShotPCA.pose_from_scores`.

Presets (Figure 3.7) derive a path from the shot's own score path:
``exaggerated`` (larger radius about the path's centre), ``toned_down``
(smaller radius) and ``aborted`` (leave the path at some frame and head
straight for the rest pose's scores). The score path splits into preparation,
stroke and return sections (Figure 3.4) at the backlift peak and at the end of
the follow-through.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .pca import ShotPCA
from .skeleton import Clip

PRESETS = ("exaggerated", "toned_down", "aborted")
DEFAULT_AMOUNT = {"exaggerated": 0.4, "toned_down": 0.4, "aborted": 0.5}
SECTION_NAMES = ("preparation", "stroke", "return")


# ------------------------------------------------------------------- sections
@dataclass
class Sections:
    labels: np.ndarray   # (F,) 0 preparation, 1 stroke, 2 return
    backlift: int        # first stroke frame: the bat's highest point before the hit
    hit_frame: int
    stroke_end: int      # first return frame: the follow-through has stopped

    def segments(self, path: np.ndarray) -> list[tuple[int, np.ndarray]]:
        """``[(label, points (n, d))]`` consecutive runs of ``path (F, d)`` per
        section, each sharing its first point with the previous run's last so a
        polyline drawn per run has no gaps."""
        F = len(self.labels)
        starts = [0] + list(np.flatnonzero(np.diff(self.labels)) + 1)
        ends = starts[1:] + [F - 1]
        return [(int(self.labels[a]), path[a:b + 1]) for a, b in zip(starts, ends)]


def shot_sections(bat_positions: np.ndarray, hit_frame: int, stop_fraction: float = 0.15) -> Sections:
    """Split a shot at its backlift peak and at the end of its follow-through.

    ``bat_positions (F, 3)``: FK position of the bat per frame. The backlift
    peak is the bat's highest frame before the hit; the stroke ends at the
    first frame after the hit where the bat's speed has fallen below
    ``stop_fraction`` of its peak (the "corner" of Figure 3.4), or at its
    slowest frame after the hit if it never does.
    """
    b = np.asarray(bat_positions, float)
    F = b.shape[0]
    h = int(np.clip(hit_frame, 0, F - 1))
    backlift = int(np.argmax(b[:h, 1])) if h > 0 else 0
    speed = np.linalg.norm(np.gradient(b, axis=0), axis=1) if F > 1 else np.zeros(F)
    end = F - 1
    if h < F - 1:
        after = speed[h + 1:]
        peak = speed[backlift:].max()
        slow = np.nonzero(after < stop_fraction * peak)[0]
        end = h + 1 + int(slow[0] if len(slow) else np.argmin(after))
    labels = np.zeros(F, dtype=np.int64)
    labels[backlift:] = 1
    labels[end:] = 2
    if end <= backlift:  # degenerate shots: no stroke section to speak of
        labels[backlift:] = 2
    return Sections(labels, backlift, h, max(end, backlift))


# ---------------------------------------------------------------- resampling
def resample_path(points: np.ndarray, frames: int | None = None, times: np.ndarray | None = None,
                  fps: float = 30.0) -> np.ndarray:
    """Path points ``(N, d)`` -> one point per frame ``(F, d)``.

    With ``times (N,)`` (seconds, non-decreasing) the frames follow that
    timing at ``fps``; otherwise the points are taken as evenly spaced in time
    and stretched over ``frames`` frames.
    """
    p = np.asarray(points, float)
    if p.ndim != 2 or p.shape[0] < 1:
        raise ValueError("a path needs at least one point of scores")
    if not np.all(np.isfinite(p)):
        raise ValueError("path contains NaN or infinity")
    N = p.shape[0]
    if times is not None:
        t = np.asarray(times, float)
        if t.shape != (N,) or not np.all(np.isfinite(t)):
            raise ValueError("path timestamps must be one finite number per point")
        if np.any(np.diff(t) < 0):
            raise ValueError("path timestamps must not decrease")
        if not fps > 0:
            raise ValueError("fps must be positive")
        F = int(round((t[-1] - t[0]) * fps)) + 1
        u = t[0] + np.arange(F) / fps
        return np.stack([np.interp(u, t, p[:, c]) for c in range(p.shape[1])], axis=1)
    if frames is None or frames < 1:
        raise ValueError("the number of frames must be at least 1")
    if N == 1:
        return np.repeat(p, frames, axis=0)
    u = np.linspace(0.0, N - 1, frames)
    i = np.minimum(u.astype(np.int64), N - 2)
    w = (u - i)[:, None]
    return p[i] * (1 - w) + p[i + 1] * w


# -------------------------------------------------------------------- presets
def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


def scale_envelope(F: int, sections: Sections | None = None, ease: float = 0.15) -> np.ndarray:
    """(F,) weight of a radius change: 0 at the first and last frame (stance and
    rest pose stay as captured), 1 from the backlift to the end of the stroke.
    Without sections it ramps over the first and last ``ease`` of the frames."""
    f = np.arange(F, dtype=float)
    if sections is not None and 0 < sections.backlift < sections.stroke_end < F - 1:
        a, b = sections.backlift, sections.stroke_end
    else:
        a = max(1, int(round(ease * (F - 1))))
        b = F - 1 - a
        if b <= a:
            return np.ones(F)
    up = _smoothstep(f / a)
    down = _smoothstep((F - 1 - f) / (F - 1 - b))
    return np.minimum(up, down)


def scaled_path(path: np.ndarray, factor: float, envelope: np.ndarray | None = None,
                centre: np.ndarray | None = None) -> np.ndarray:
    """``path (F, d)`` with its radius about ``centre`` (default: the path's mean)
    multiplied by ``factor`` where ``envelope`` is 1 (blended where it is between)."""
    p = np.asarray(path, float)
    c = p.mean(axis=0) if centre is None else np.asarray(centre, float)
    w = np.ones(len(p)) if envelope is None else np.asarray(envelope, float)
    return c + (p - c) * (1.0 + (factor - 1.0) * w)[:, None]


def aborted_path(path: np.ndarray, abort_frame: int) -> np.ndarray:
    """Follow ``path (F, d)`` up to ``abort_frame``, then head in a straight line
    for its last point (the rest pose) over the remaining frames, leaving with the
    path's speed along that line and easing in to rest."""
    p = np.asarray(path, float)
    F = len(p)
    a = int(np.clip(abort_frame, 0, F - 1))
    out = p.copy()
    n = F - 1 - a
    if n < 1:
        return out
    start, rest = p[a], p[-1]
    d = rest - start
    length = float(np.linalg.norm(d))
    if length < 1e-12:
        out[a:] = start
        return out
    v = p[min(a + 1, F - 1)] - p[max(a - 1, 0)]
    v0 = np.clip(np.dot(v / 2, d) / length ** 2 * n, 0.0, 3.0)   # ds/du at the start
    u = np.arange(1, n + 1) / n
    # cubic Hermite s(u): s(0)=0, s'(0)=v0, s(1)=1, s'(1)=0
    s = (u ** 3 - 2 * u ** 2 + u) * v0 + (-2 * u ** 3 + 3 * u ** 2)
    out[a + 1:] = start + s[:, None] * d
    return out


def preset_path(path: np.ndarray, preset: str, amount: float | None = None,
                sections: Sections | None = None, abort_frame: int | None = None) -> np.ndarray:
    """A preset variation of a shot's own score path ``(F, d)`` (Figure 3.7).

    exaggerated: radius x (1 + amount); toned_down: radius x (1 - amount),
    amount in [0, 1); aborted: leave the path at ``abort_frame`` or, without
    it, at ``amount`` of the way from the backlift to the hit frame.
    """
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r} (one of {', '.join(PRESETS)})")
    amount = DEFAULT_AMOUNT[preset] if amount is None else float(amount)
    if not np.isfinite(amount) or amount < 0:
        raise ValueError(f"preset amount must be a number >= 0, got {amount}")
    p = np.asarray(path, float)
    F = len(p)
    if preset == "aborted":
        if abort_frame is None:
            if amount > 1:
                raise ValueError(f"aborted: amount is a fraction of the stroke in [0, 1], got {amount}")
            a, h = (sections.backlift, sections.hit_frame) if sections else (0, F - 1)
            abort_frame = int(round(a + amount * max(h - a, 0)))
        if not 0 <= abort_frame < F:
            raise ValueError(f"abort frame {abort_frame} outside 0..{F - 1}")
        return aborted_path(p, abort_frame)
    if preset == "toned_down" and amount >= 1:
        raise ValueError(f"toned_down: amount must be below 1, got {amount}")
    factor = 1 + amount if preset == "exaggerated" else 1 - amount
    return scaled_path(p, factor, scale_envelope(F, sections))


def preset_factor(preset: str, amount: float | None = None) -> float:
    """Radius ratio of a scaling preset."""
    amount = DEFAULT_AMOUNT[preset] if amount is None else float(amount)
    return {"exaggerated": 1 + amount, "toned_down": 1 - amount}[preset]


# ------------------------------------------------------------------ synthesis
def synthesise(pca: ShotPCA, path: np.ndarray, frames: int | None = None,
               times: np.ndarray | None = None, fps: float = 30.0) -> Clip:
    """An animation from a score path ``(N, k)`` (k = 2 for the PC pad).

    Without ``times`` the path is stretched over ``frames`` frames (default:
    the number of frames the PCA was fitted on)."""
    frames = pca.scores.shape[0] if frames is None and times is None else frames
    per_frame = resample_path(path, frames, times, fps)
    if per_frame.shape[1] > pca.num_components:
        raise ValueError(f"path has {per_frame.shape[1]} scores per point but the shot has "
                         f"{pca.num_components} components")
    root, rot = pca.pose_from_scores(per_frame)
    return Clip(root, rot, fps)


def source_path(pca: ShotPCA, k: int = 2) -> np.ndarray:
    """The shot's own score path ``(F, k)`` (the guide drawn in the PC pad)."""
    return pca.scores[:, :k].copy()


# ---------------------------------------------------------------- path specs
@dataclass
class PathSpec:
    points: np.ndarray | None = None      # (N, 2)
    times: np.ndarray | None = None       # (N,) seconds
    fps: float | None = None
    preset: str | None = None
    amount: float | None = None
    abort_frame: int | None = None


def parse_path_spec(obj) -> PathSpec:
    """A path description from JSON: a list of ``[pc1, pc2]`` (or ``[pc1, pc2, t]``
    with t in seconds), ``{"points": [...], "times": [...], "fps": 30}`` or
    ``{"preset": "exaggerated|toned_down|aborted", "amount": x, "abort_frame": n}``."""
    if isinstance(obj, dict):
        if "preset" in obj:
            unknown = set(obj) - {"preset", "amount", "abort_frame"}
            if unknown:
                raise ValueError(f"path: unknown key {sorted(unknown)[0]!r} next to 'preset'")
            preset = obj["preset"]
            if preset not in PRESETS:
                raise ValueError(f"path: unknown preset {preset!r} (one of {', '.join(PRESETS)})")
            amount = obj.get("amount")
            if amount is not None and (isinstance(amount, bool) or not isinstance(amount, (int, float))):
                raise ValueError("path: 'amount' must be a number")
            af = obj.get("abort_frame")
            if af is not None and (isinstance(af, bool) or not isinstance(af, int)):
                raise ValueError("path: 'abort_frame' must be an integer frame")
            return PathSpec(preset=preset, amount=amount, abort_frame=af)
        if "points" not in obj:
            raise ValueError("path: an object needs 'points' or 'preset'")
        spec = parse_path_spec(obj["points"])
        if "times" in obj:
            spec.times = _numbers(obj["times"], "times")
        if "fps" in obj:
            spec.fps = float(_numbers([obj["fps"]], "fps")[0])
            if not spec.fps > 0:
                raise ValueError("path: 'fps' must be positive")
        return spec
    if not isinstance(obj, list) or not obj:
        raise ValueError("path: expected a non-empty list of [pc1, pc2] points or a preset object")
    rows = []
    for i, p in enumerate(obj):
        if not isinstance(p, list) or len(p) not in (2, 3):
            raise ValueError(f"path: point {i} must be [pc1, pc2] or [pc1, pc2, seconds]")
        rows.append(_numbers(p, f"point {i}"))
    if len({len(r) for r in rows}) != 1:
        raise ValueError("path: either every point has a timestamp or none has")
    arr = np.array(rows)
    if arr.shape[1] == 3:
        return PathSpec(points=arr[:, :2], times=arr[:, 2])
    return PathSpec(points=arr)


def _numbers(values, what: str) -> np.ndarray:
    if not isinstance(values, list) or any(isinstance(v, bool) or not isinstance(v, (int, float))
                                           for v in values):
        raise ValueError(f"path: {what} must be a list of numbers")
    arr = np.array(values, float)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"path: {what} contains NaN or infinity")
    return arr


def path_from_spec(spec: PathSpec, pca: ShotPCA, sections: Sections | None = None) -> np.ndarray:
    """The per-point score path ``(N, 2)`` a spec describes on this shot."""
    if spec.preset is not None:
        return preset_path(source_path(pca), spec.preset, spec.amount, sections, spec.abort_frame)
    return spec.points
