"""Synthesis of new animations from paths in a shot's PC space (dissertation 3.2).

A path is a list of score points ``(N, 2)`` for the first two PCs. It becomes
an animation by resampling it to frames (from timestamps, or stretched over the
source's length) and turning every frame's scores into a pose with
:meth:`engine.pca.ShotPCA.pose_from_scores`.

The PCs after the path's two can come from the source shot (engine.synth_detail), what the
dissertation suggests for the artefacts of two PCs alone.

Presets (Figure 3.7) derive a path from the shot's own score path:
``exaggerated`` (larger radius about the path's centre), ``toned_down``
(smaller radius) and ``aborted`` (leave the path at some frame and head
straight for the rest pose's scores). The score path splits into preparation,
stroke and return sections (Figure 3.4) at the backlift peak and at the end of
the follow-through.
"""
from __future__ import annotations

import reprlib
from dataclasses import dataclass

import numpy as np

from .bvh import quoted
from .pca import ShotPCA
from .skeleton import Clip

PRESETS = ("exaggerated", "toned_down", "aborted")
DEFAULT_AMOUNT = {"exaggerated": 0.4, "toned_down": 0.4, "aborted": 0.5}
SECTION_NAMES = ("preparation", "stroke", "return")

# Bounds of a path (the messages name them). A path file is user input: without
# them a huge timestamp asks for billions of frames and a score near 1e308
# overflows the pose to infinity.
MAX_PATH_POINTS = 100_000          # points of a drawn or written path
MAX_PATH_SECONDS = 600.0           # last timestamp - first: ten minutes of animation
MAX_SYNTH_FRAMES = int(MAX_PATH_SECONDS * 60) + 1   # ten minutes at 60 fps, both ends (~4 s, 400 MB to make)
MAX_ABS_SCORE = 1_000.0            # |PC score|: the bundled shots stay within ~12 standardised
                                   # units, so this is ~100x any real shot and every pose stays finite
PATH_FPS_RANGE = (1.0, 1000.0)     # frames per second of a timed path
MAX_EXAGGERATION = 10.0            # "exaggerated" amount: radius x 11 at most


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
    and stretched over ``frames`` frames. ValueError for a path out of bounds
    (see :func:`check_scores`) or more than MAX_SYNTH_FRAMES frames.
    """
    p = check_scores(points)
    N = p.shape[0]
    if times is not None:
        t = check_times(times, N)
        F = frame_count(t, fps)
        u = t[0] + np.arange(F) / fps
        return np.stack([np.interp(u, t, p[:, c]) for c in range(p.shape[1])], axis=1)
    if frames is None or not 1 <= frames <= MAX_SYNTH_FRAMES:
        raise ValueError(f"the number of frames must be 1..{MAX_SYNTH_FRAMES} (MAX_SYNTH_FRAMES), got {frames}")
    if N == 1:
        return np.repeat(p, frames, axis=0)
    u = np.linspace(0.0, N - 1, frames)
    i = np.minimum(u.astype(np.int64), N - 2)
    w = (u - i)[:, None]
    return p[i] * (1 - w) + p[i + 1] * w


def check_scores(points) -> np.ndarray:
    """``points`` as an ``(N, d)`` float array: 1..MAX_PATH_POINTS points, every
    score finite and within +-MAX_ABS_SCORE; else ValueError naming the point."""
    p = np.asarray(points, float)
    if p.ndim != 2 or p.shape[0] < 1 or p.shape[1] < 1:
        raise ValueError("a path needs at least one point of scores")
    if p.shape[0] > MAX_PATH_POINTS:
        raise ValueError(f"a path has at most {MAX_PATH_POINTS} points (MAX_PATH_POINTS), got {p.shape[0]}")
    bad = np.flatnonzero(~(np.abs(p) <= MAX_ABS_SCORE).all(axis=1))   # NaN fails the test too
    if len(bad):
        raise ValueError(f"point {bad[0]}: scores must be finite and within +-{MAX_ABS_SCORE:g} (MAX_ABS_SCORE), "
                         f"got {_shown(p[bad[0]].tolist())}")
    return p


def check_times(times, count: int) -> np.ndarray:
    """``times`` as ``count`` finite, non-decreasing seconds spanning at most
    MAX_PATH_SECONDS; else ValueError."""
    t = np.asarray(times, float)
    if t.shape != (count,):
        raise ValueError(f"a timed path needs one timestamp per point ({count}), got {t.size}")
    if not np.all(np.isfinite(t)):
        raise ValueError("path timestamps must be finite numbers")
    with np.errstate(over="ignore", invalid="ignore"):
        back = np.flatnonzero(np.diff(t) < 0)
    if len(back):
        raise ValueError(f"path timestamps must not decrease (point {back[0] + 1}: {t[back[0] + 1]:g} s "
                         f"after {t[back[0]]:g} s)")
    with np.errstate(over="ignore"):              # -1e308 .. 1e308 spans inf: refused below
        span = t[-1] - t[0]
    if not span <= MAX_PATH_SECONDS:
        raise ValueError(f"a timed path lasts at most {MAX_PATH_SECONDS:g} s (MAX_PATH_SECONDS), got {span:.6g} s")
    return t


def frame_count(times: np.ndarray, fps: float) -> int:
    """Frames of a timed path (checked by :func:`check_times`) at ``fps``: at most MAX_SYNTH_FRAMES."""
    lo, hi = PATH_FPS_RANGE
    if not lo <= fps <= hi:
        raise ValueError(f"fps must be {lo:g}..{hi:g}, got {fps:g}")
    F = int(round((times[-1] - times[0]) * fps)) + 1
    if F > MAX_SYNTH_FRAMES:
        raise ValueError(f"the path lasts {F} frames at {fps:g} fps, more than MAX_SYNTH_FRAMES "
                         f"({MAX_SYNTH_FRAMES})")
    return F


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
    amount = check_preset(preset, amount, abort_frame)
    p = np.asarray(path, float)
    F = len(p)
    if preset == "aborted":
        return aborted_path(p, abort_at(F, amount, sections, abort_frame))
    return scaled_path(p, preset_factor(preset, amount), scale_envelope(F, sections))


def abort_at(frames: int, amount: float, sections: Sections | None = None, abort_frame: int | None = None) -> int:
    """The frame an aborted take of ``frames`` frames leaves the shot's path: ``abort_frame``, or
    ``amount`` of the way from the backlift to the hit; ValueError outside the take."""
    if abort_frame is None:
        a, h = (sections.backlift, sections.hit_frame) if sections else (0, frames - 1)
        abort_frame = int(round(a + amount * max(h - a, 0)))
    if not 0 <= abort_frame < frames:
        raise ValueError(f"abort frame {abort_frame} outside 0..{frames - 1}")
    return int(abort_frame)


def leaves_ball(preset: str | None, frames: int, sections: Sections, amount: float | None = None,
                abort_frame: int | None = None) -> bool:
    """Whether a take leaves the ball instead of meeting it: an aborted shot that leaves the
    path before the hit (dissertation 3.2.3: "the bat is lifted away from its previous
    trajectory") plays no ball; every other take meets it."""
    if preset != "aborted":
        return False
    amount = check_preset(preset, amount, abort_frame)
    return abort_at(frames, amount, sections, abort_frame) < sections.hit_frame


def take_hit_frame(take_scores: np.ndarray, shot_scores: np.ndarray, hit_frame: int, same_timeline: bool) -> int:
    """A take's hit frame: the shot's own where the take runs on its timeline (a preset, the
    2-PC path), else where the take's scores ``(F, 2)`` pass nearest the shot's at its hit
    (``shot_scores (F_shot, 2)``): a drawn path has its own timing."""
    if same_timeline and hit_frame < len(take_scores):
        return int(hit_frame)
    return int(np.argmin(np.linalg.norm(take_scores - shot_scores[hit_frame], axis=-1)))


def check_preset(preset, amount=None, abort_frame=None) -> float:
    """The amount a preset runs with (``amount`` or its default), after checking
    the three: a known preset; an amount in 0..MAX_EXAGGERATION for exaggerated,
    a fraction for the others (below 1 for toned_down, which would shrink the
    path to a point); an abort frame, for aborted only, in 0..MAX_SYNTH_FRAMES-1."""
    if not isinstance(preset, str) or preset not in PRESETS:
        raise ValueError(f"unknown preset {_shown(preset)} (one of {', '.join(PRESETS)})")
    if amount is None:
        amount = DEFAULT_AMOUNT[preset]
    high = MAX_EXAGGERATION if preset == "exaggerated" else 1.0
    if not _is_number(amount) or not 0 <= amount <= high or (preset == "toned_down" and amount == 1):
        limit = {"exaggerated": f"0..{MAX_EXAGGERATION:g} (MAX_EXAGGERATION)",
                 "toned_down": "0..1, below 1"}.get(preset, "0..1")
        raise ValueError(f"{preset}: 'amount' must be a number in {limit}, got {_shown(amount)}")
    if abort_frame is not None:
        if preset != "aborted":
            raise ValueError(f"{preset}: 'abort_frame' belongs to the aborted preset only")
        if not _is_whole(abort_frame) or not 0 <= abort_frame < MAX_SYNTH_FRAMES:
            raise ValueError(f"aborted: 'abort_frame' must be a whole frame in 0..{MAX_SYNTH_FRAMES - 1}, "
                             f"got {_shown(abort_frame)}")
    return float(amount)


def _is_number(v) -> bool:
    """A finite real number (int or float, never a bool) that converts to float."""
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
        return False
    try:
        return bool(np.isfinite(float(v)))
    except OverflowError:          # an int beyond float range
        return False


def _shown(value) -> str:
    """A user's value for a message, bounded however large it is (reprlib stops early)."""
    try:
        return quoted(value if isinstance(value, str) else reprlib.repr(value))
    except ValueError:             # an int of more than 4300 digits has no repr
        return f"a {type(value).__name__}"


def _is_whole(v) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def preset_factor(preset: str, amount: float | None = None) -> float:
    """Radius ratio of a scaling preset."""
    amount = DEFAULT_AMOUNT[preset] if amount is None else float(amount)
    return {"exaggerated": 1 + amount, "toned_down": 1 - amount}[preset]


# ------------------------------------------------------------------ synthesis
def synthesise(pca: ShotPCA, path: np.ndarray, frames: int | None = None,
               times: np.ndarray | None = None, fps: float = 30.0, detail: np.ndarray | None = None) -> Clip:
    """An animation from a score path ``(N, k)`` (k = 2 for the PC pad).

    Without ``times`` the path is stretched over ``frames`` frames (default:
    the number of frames the PCA was fitted on). ``detail (F, K - k)``: the scores of
    the PCs the path does not give, per frame (engine.synth_detail.source_detail); None: those
    PCs are 0, the dissertation's ``P = (L S)^T * D + M`` with the path's k alone."""
    frames = pca.scores.shape[0] if frames is None and times is None else frames
    per_frame = resample_path(path, frames, times, fps)
    if per_frame.shape[1] > pca.num_components:
        raise ValueError(f"path has {per_frame.shape[1]} scores per point but the shot has "
                         f"{pca.num_components} components")
    if detail is not None:
        want = (per_frame.shape[0], pca.num_components - per_frame.shape[1])
        if np.shape(detail) != want:
            raise ValueError(f"detail must be {want} scores, got {np.shape(detail)}")
        per_frame = np.concatenate([per_frame, detail], axis=1)
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
    ``{"preset": "exaggerated|toned_down|aborted", "amount": x, "abort_frame": n}``.
    Every bound of the module is checked here; ValueError (one line) otherwise."""
    if isinstance(obj, dict):
        return _parse_preset(obj) if "preset" in obj else _parse_timed(obj)
    if not isinstance(obj, list) or not obj:
        raise ValueError("path: expected a non-empty list of [pc1, pc2] points or a preset object")
    if len(obj) > MAX_PATH_POINTS:
        raise ValueError(f"path: at most {MAX_PATH_POINTS} points (MAX_PATH_POINTS), got {len(obj)}")
    for i, p in enumerate(obj):
        if not isinstance(p, list) or len(p) not in (2, 3) or not all(map(_is_number, p)):
            raise ValueError(f"path: point {i} must be [pc1, pc2] or [pc1, pc2, seconds] (finite numbers), "
                             f"got {_shown(p)}")
        if len(p) != len(obj[0]):
            raise ValueError(f"path: point {i}: either every point has a timestamp or none has")
    arr = np.array(obj, float)
    try:
        check_scores(arr[:, :2])
        times = check_times(arr[:, 2], len(arr)) if arr.shape[1] == 3 else None
    except ValueError as e:
        raise ValueError(f"path: {e}") from None
    return PathSpec(points=arr[:, :2], times=times)


def _parse_preset(obj: dict) -> PathSpec:
    _refuse_unknown_keys(obj, {"preset", "amount", "abort_frame"}, "'preset'")
    try:
        check_preset(obj["preset"], obj.get("amount"), obj.get("abort_frame"))
    except ValueError as e:
        raise ValueError(f"path: {e}") from None
    amount = obj.get("amount")
    return PathSpec(preset=obj["preset"], amount=None if amount is None else float(amount),
                    abort_frame=obj.get("abort_frame"))


def _parse_timed(obj: dict) -> PathSpec:
    """``{"points": [[pc1, pc2], ...], "times": [...], "fps": n}``."""
    if "points" not in obj:
        raise ValueError("path: an object needs 'points' or 'preset'")
    _refuse_unknown_keys(obj, {"points", "times", "fps"}, "'points'")
    if not isinstance(obj["points"], list):     # a nested object would recurse without end
        raise ValueError("path: 'points' must be a list of [pc1, pc2] points")
    spec = parse_path_spec(obj["points"])
    if "times" in obj:
        times = obj["times"]
        if spec.times is not None:
            raise ValueError("path: timestamps both in the points and in 'times'")
        if not isinstance(times, list) or not all(map(_is_number, times)):
            raise ValueError("path: 'times' must be a list of finite numbers (seconds)")
        try:
            spec.times = check_times(times, len(spec.points))
        except ValueError as e:
            raise ValueError(f"path: {e}") from None
    if "fps" in obj:
        lo, hi = PATH_FPS_RANGE
        if not _is_number(obj["fps"]) or not lo <= obj["fps"] <= hi:
            raise ValueError(f"path: 'fps' must be a number in {lo:g}..{hi:g}, got {_shown(obj['fps'])}")
        spec.fps = float(obj["fps"])
    return spec


def _refuse_unknown_keys(obj: dict, known: set, beside: str) -> None:
    unknown = sorted(map(str, set(obj) - known))
    if unknown:
        raise ValueError(f"path: unknown key {quoted(unknown[0])} next to {beside} "
                         f"(known: {', '.join(sorted(known))})")


def path_from_spec(spec: PathSpec, pca: ShotPCA, sections: Sections | None = None) -> np.ndarray:
    """The per-point score path ``(N, 2)`` a spec describes on this shot."""
    if spec.preset is not None:
        return check_scores(preset_path(source_path(pca), spec.preset, spec.amount, sections, spec.abort_frame))
    return check_scores(spec.points)


def check_finite_clip(clip: Clip) -> None:
    """The last guard before an animation is written: every value finite."""
    if not (np.isfinite(clip.root_positions).all() and np.isfinite(clip.local_rotations).all()):
        raise ValueError("the synthesised animation has non-finite values; nothing was written")
