"""The panel's PC-score pad (dissertation 3.2, Figures 3.3, 3.4, 3.7).

A square pad in the space of the current shot's first two principal
components (whole body, 107 parameters). The shot's own score path is drawn as
a guide, coloured by section (preparation red, stroke green, return blue). In
"pose" mode dragging the marker sets the pose live (P = (L S)^T * D + M, the PCs after the
first two from the shot unless "source detail" is off: engine.synth_detail); in
"draw" mode the stroke drawn with the mouse, with its timing, becomes a new
animation that plays in the viewport. Preset buttons make the exaggerated,
toned-down and aborted variations of Figure 3.7 (amount slider). Below, the
explained variance per PC and cumulative.

Every animation made (a drawn path, a preset, the 2-PC source path) is a
:class:`Take`, kept per shot name in ``PadState.takes``: switching shots (the
ball path, a library reload) clears only what plays, the shot's takes come back
when it does and the pad's "take" list picks among them. A take keeps what made
it (the PC-score points, their times, the preset and clean-up options), not the
clip: re-synthesis is deterministic, so the session (``app.session``) stores
only that and the clip is made again when the take is picked.

This module is the pad's model, run in the frame's update (``app.update``): the
widget (``app.padwidget``), the timeline and scripts only ask, with
``app.viewer.padrequests.PadRequest``, whose ``step`` refits, plays and carries the requests
out; :func:`active_pose` is the pose the viewport shows instead of the adapted shot. No
imgui here.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from app.viewer.state import Pose
from app.viewer.takeball import ball_in_take, take_impact
from engine import bvh, cleanup, synth, synth_detail, synth_take
from engine import pca as pcam
from engine.skeleton import pose_fk

SECTION_RGBA = ((0.93, 0.26, 0.22, 1.0), (0.25, 0.78, 0.35, 1.0), (0.30, 0.55, 1.0, 1.0))
DRAWN_RGBA = (1.0, 0.62, 0.15, 1.0)
PRESET_RGBA = (0.85, 0.45, 0.95, 1.0)
MARKER_RGBA = (1.0, 1.0, 1.0, 1.0)
PRESET_LABELS = {"exaggerated": "exaggerated", "toned_down": "toned down", "aborted": "aborted"}
MIN_POINT_SPACING = 0.004     # of the pad's width: closer drawn points are merged
MAX_TAKE_POINTS = 4000        # points of one drawn stroke (over a minute of drawing at 60 Hz)
MAX_TAKES_PER_SHOT = 64       # the oldest take of a shot goes when a new one would exceed this
DRAWN, SOURCE = "drawn", "source (2 PCs)"
TAKE_KINDS = (DRAWN, SOURCE, *PRESET_LABELS)
PAD_MODES = ("pose", "draw")      # drag the marker | record a path


@dataclass
class Take:
    """One synthesised animation of a shot: what made it, and (cached) the clip."""
    kind: str                             # one of TAKE_KINDS
    points: np.ndarray                    # (N, 2) PC scores, as drawn or the preset's path
    times: np.ndarray | None = None       # (N,) seconds from the first point; None: over the shot
    amount: float = 0.4                   # the preset's amount (presets only)
    fix_hand: bool = True
    plant_feet: bool = True
    detail: bool = True                   # the PCs after the first two from the source (engine.synth_detail)
    anim: object = None                   # engine.skeleton.Clip, made when first shown
    anim_global: tuple | None = None
    path: np.ndarray | None = None        # (F, 2) the points resampled to the clip's frames
    note: str = ""
    cleanup: dict = field(default_factory=dict)   # engine.cleanup.CleanupResult.summary() of the clip
    impact: object = None                 # app.takeball.TakeImpact: the ball it meets, made with the clip
    made_ms: float = math.nan             # synthesis, clean-up and ball of the clip (wall time)

    def same_recipe(self, other: "Take") -> bool:
        return (self.kind == other.kind and self.amount == other.amount and self.fix_hand == other.fix_hand
                and self.plant_feet == other.plant_feet and self.detail == other.detail
                and self.points.shape == other.points.shape and np.array_equal(self.points, other.points)
                and (self.times is None) == (other.times is None)
                and (self.times is None or np.array_equal(self.times, other.times)))

    def label(self, index: int) -> str:
        extra = (f" {self.amount:.2f}" if self.kind in PRESET_LABELS else
                 f", {self.times[-1]:.1f} s" if self.times is not None else "")
        return f"{index + 1}. {self.name}{extra}"

    @property
    def name(self) -> str:
        """What the take is, said to the user."""
        return "shot's own path" if self.kind == SOURCE and self.detail else PRESET_LABELS.get(self.kind, self.kind)


@dataclass
class PadState:
    """Everything the pad owns; kept on the app state as ``state.pc_pad``."""
    shot_key: tuple | None = None
    pca: object = None                    # engine.pca.ShotPCA (whole body)
    sections: object = None               # engine.synth.Sections
    guide: np.ndarray | None = None       # (F, 2) the shot's own scores
    lo: np.ndarray = field(default_factory=lambda: np.array([-1.0, -1.0]))   # pad extents (scores)
    hi: np.ndarray = field(default_factory=lambda: np.array([1.0, 1.0]))
    mode: str = "pose"                    # "pose": drag the marker; "draw": record a path
    marker: np.ndarray | None = None      # (2,) scores
    live: bool = False                    # the marker drives the viewport pose
    stroke: list = field(default_factory=list)    # [(pc1, pc2, seconds)] while drawing
    clock: float = 0.0                    # seconds of pad time (sum of frame dts)
    path: np.ndarray | None = None        # (F, 2) scores of the current animation
    path_kind: str = ""                   # "drawn" or a preset name
    anim: object = None                   # engine.skeleton.Clip
    anim_global: tuple | None = None      # ((F, J, 4), (F, J, 3)) its FK
    playing: bool = False
    play_time: float = 0.0
    loop: bool = True
    preset: str = "exaggerated"
    amount: float = 0.4
    fix_hand: bool = True
    plant_feet: bool = True
    detail: bool = True                   # the source's detail beyond the two PCs (marker and new takes)
    pose: Pose | None = None              # what the viewport shows while live/playing
    impact: object = None                 # the shown take's app.takeball.TakeImpact
    ball: np.ndarray | None = None        # (3,) its ball at the frame shown
    info: str = ""                        # one line about the last animation
    pose_us: float = 0.0                  # last pose-from-scores + FK time
    takes: dict = field(default_factory=dict)     # shot name -> [Take], oldest first
    take: int = -1                        # the take shown, index into the current shot's list
    generation: int = 0                   # +1 whenever ``takes`` changes (app.session saves then)

    def shot_takes(self, name: str | None) -> list:
        return self.takes.get(name, []) if name is not None else []


def pad_state(state) -> PadState:
    pad = state.pc_pad
    if pad is None:
        pad = PadState()
        state.pc_pad = pad
    return pad


def sync(state) -> PadState | None:
    """The pad for the state's current shot (the PCA is refitted when the shot changes)."""
    pad = pad_state(state)
    shot, rig = state.shot, state.rig
    if shot is None or rig is None:
        return None
    key = (state.shot_index, shot.name, shot.num_frames)
    if pad.shot_key != key:
        pad.pca = pcam.fit_clip(rig, shot.clip, "body")
        pad.sections = synth.shot_sections(shot.fk[1][:, rig.bat_joint], shot.hit_frame)
        pad.guide = synth.source_path(pad.pca)
        lo, hi = pad.guide.min(axis=0), pad.guide.max(axis=0)
        centre, half = (lo + hi) / 2, max(float((hi - lo).max()) / 2, 1e-3) * 1.4
        pad.lo, pad.hi = centre - half, centre + half
        pad.shot_key = key
        # what plays belongs to the old shot; its takes stay in pad.takes for its return
        pad.marker, pad.live, pad.playing, pad.pose = None, False, False, None
        pad.path, pad.anim, pad.anim_global, pad.stroke, pad.info = None, None, None, [], ""
        pad.impact = pad.ball = None
        pad.take = -1
    return pad


def _fk_pose(rig, root, local):
    return pose_fk(rig.skeleton, root, local)


def _fk_single(rig, root, local):
    """FK of one pose by 3x3 matrices (the marker moves every frame)."""
    return pose_fk(rig.skeleton, root, local, one_pose=True)


def pose_at_scores(state, scores) -> Pose:
    """World pose for two scores (no clean-up: this is the live, raw pose)."""
    pad = sync(state)
    t0 = time.perf_counter()
    s = np.asarray(scores, float)[:2]
    if pad.detail:
        s = np.concatenate([s, synth_detail.source_detail(pad.pca, s[None], "nearest")[0]])
    root, local = pad.pca.pose_from_scores(s)
    g_rot, g_pos = _fk_single(state.rig, root, local)
    pad.pose_us = (time.perf_counter() - t0) * 1e6
    return Pose(g_rot, g_pos)


def set_scores(state, scores, final: bool = False) -> None:
    """Move the marker (mouse or scripted drag). In draw mode the positions are
    recorded and, on the final one, become an animation."""
    pad = sync(state)
    if pad is None:
        return
    s = np.asarray(scores, float)[:2]
    if not np.all(np.isfinite(s)):
        raise ValueError("PC scores must be finite")
    pad.marker = s
    if pad.mode == "draw":
        _add_stroke_point(pad, s)
        if final:
            finish_stroke(state)
        return
    pad.playing = False
    pad.live = True
    pad.pose = pose_at_scores(state, s)


def _add_stroke_point(pad: PadState, s) -> None:
    if len(pad.stroke) >= MAX_TAKE_POINTS:      # a take stays a size the session can hold
        return
    spacing = MIN_POINT_SPACING * float((pad.hi - pad.lo)[0])
    if pad.stroke and np.hypot(*(np.array(pad.stroke[-1][:2]) - s)) < spacing:
        return
    pad.stroke.append((float(s[0]), float(s[1]), pad.clock))


def finish_stroke(state) -> bool:
    """Turn the recorded stroke into an animation with the stroke's timing (a
    stroke drawn without time, e.g. in one frame, is stretched over the shot)."""
    pad = pad_state(state)
    stroke, pad.stroke = pad.stroke, []
    if len(stroke) < 2:
        return False
    pts = np.array([p[:2] for p in stroke])
    t = np.array([p[2] for p in stroke])
    fps = state.fps
    times = t - t[0] if (t[-1] - t[0]) * fps >= 2 else None
    if times is not None and times[-1] > synth.MAX_PATH_SECONDS:   # the engine's bound on a take
        state.report(f"pc pad: a stroke over {synth.MAX_PATH_SECONDS:.0f} s is stretched over the shot")
        times = None
    make_take(state, pts, times, DRAWN)
    return True


def apply_preset(state, preset: str | None = None, amount: float | None = None,
                 replace: bool = False) -> None:
    """Animate a preset variation of the shot (Figure 3.7); ``replace``: in place of
    the take shown (its amount re-made when the slider is let go)."""
    pad = sync(state)
    if pad is None:
        return
    pad.preset = preset or pad.preset
    pad.amount = pad.amount if amount is None else float(amount)
    path = synth.preset_path(pad.guide, pad.preset, pad.amount, pad.sections)
    make_take(state, path, None, pad.preset, replace=replace)


def play_source_path(state) -> None:
    """Animate the shot's own path (with the source's detail the shot itself; without, what the
    pad's two PCs alone give)."""
    pad = sync(state)
    if pad is not None:
        make_take(state, pad.guide, None, SOURCE)


def make_take(state, points, times, kind: str, replace: bool = False) -> None:
    """A new take of the current shot from ``points`` (and ``times``), shown and playing;
    the same recipe as a take the shot has already shows that one instead."""
    pad = pad_state(state)
    take = Take(kind, np.array(points, float), None if times is None else np.array(times, float),
                float(pad.amount), bool(pad.fix_hand), bool(pad.plant_feet), bool(pad.detail))
    takes = pad.takes.setdefault(state.shot.name, [])
    same = next((i for i, t in enumerate(takes) if t.same_recipe(take)), None)
    if same is not None:
        show_take(state, same)
        return
    synthesise_take(state, take)
    if replace and 0 <= pad.take < len(takes) and takes[pad.take].kind == kind:
        takes[pad.take] = take
    else:
        takes.append(take)
        del takes[:-MAX_TAKES_PER_SHOT]
        pad.take = len(takes) - 1
    pad.generation += 1
    show_take(state, pad.take)


def synthesise_take(state, take: Take) -> None:
    """Make the take's clip for the current shot (deterministic: the same recipe gives
    the same clip, which is why sessions store recipes, not clips)."""
    pad = pad_state(state)
    shot, rig = state.shot, state.rig
    t0 = time.perf_counter()
    same_timeline = take.times is None and take.kind != DRAWN
    made = synth_take.make(pad.pca, take.points, take.times, float(shot.clip.fps),
                           None if take.times is not None else shot.num_frames, same_timeline=same_timeline,
                           detail=take.detail, preset=take.kind if take.kind in synth.PRESETS else None,
                           amount=take.amount, sections=pad.sections, guide=pad.guide,
                           source_hit_frame=shot.hit_frame)
    take.path, anim, hit, leaves = made
    # a take meets the ball as the shot does, where the shot does, with its face
    # (engine.cleanup_hit); an aborted take leaves it
    res = cleanup.cleanup(rig, shot.skeleton, anim, shot.clip, take.fix_hand, take.plant_feet,
                          source_hit_frame=None if leaves else shot.hit_frame, hit_frame=hit)
    anim = res.clip
    s = take.cleanup = res.summary()
    take.note = f", hand error max {s['hand_error_cm_max']:.1f} cm" if "hand_error_cm_max" in s else ""
    if leaves:
        take.note += ", leaves the ball"
    elif "bat_moved_cm" in s:
        take.note += f", bat brought {s['bat_moved_cm']:.0f} cm to the hit point"
    take.anim = anim
    take.anim_global = _fk_pose(rig, anim.root_positions, anim.local_rotations)
    take.impact = take_impact(rig, shot, *take.anim_global, hit, state.ball_start, leaves)
    take.made_ms = (time.perf_counter() - t0) * 1e3


def show_take(state, index: int) -> None:
    """Show and play take ``index`` of the current shot (re-synthesised if it came from a
    session or its clip was never made)."""
    pad = sync(state)
    takes = pad.shot_takes(state.shot.name) if pad is not None else []
    if not 0 <= index < len(takes):
        return
    take = takes[index]
    if take.anim is None:
        synthesise_take(state, take)
    pad.take = index
    pad.anim, pad.anim_global, pad.path, pad.path_kind = take.anim, take.anim_global, take.path, take.kind
    pad.impact = take.impact
    pad.playing, pad.live, pad.play_time = True, False, 0.0
    pad.info = f"{take.name}: {take.anim.num_frames} frames{take.note}"
    advance(pad, 0.0)


def delete_take(state, index: int) -> None:
    """Forget take ``index`` of the current shot (what plays stops if it was that take)."""
    pad = sync(state)
    takes = pad.shot_takes(state.shot.name) if pad is not None else []
    if not 0 <= index < len(takes):
        return
    del takes[index]
    pad.generation += 1
    if index == pad.take:
        release(state)
        pad.take, pad.anim, pad.anim_global, pad.path, pad.info = -1, None, None, None, ""
        pad.impact = pad.ball = None
    elif index < pad.take:
        pad.take -= 1


def advance(pad: PadState, dt: float) -> None:
    """Advance the pad's clock and, while playing, the synthesised animation."""
    pad.clock += max(float(dt), 0.0)
    if not pad.playing or pad.anim is None:
        return
    F = pad.anim.num_frames
    pad.play_time += max(float(dt), 0.0)
    f = pad.play_time * pad.anim.fps
    if f > F - 1:
        if pad.loop:
            pad.play_time = 0.0 if F <= 1 else pad.play_time % ((F - 1) / pad.anim.fps)
            f = pad.play_time * pad.anim.fps
        else:
            f, pad.playing = F - 1, False
    show_frame(pad, f)


def show_frame(pad: PadState, f: float) -> None:
    """The take's pose, ball and marker at (fractional) frame ``f``."""
    i = int(min(round(f), pad.anim.num_frames - 1))
    g_rot, g_pos = pad.anim_global
    pad.pose = Pose(g_rot[i], g_pos[i])
    pad.ball = None if pad.impact is None else ball_in_take(pad.impact, i)
    if pad.path is not None and i < len(pad.path):
        pad.marker = pad.path[i]


def release(state) -> None:
    """Give the viewport back to the adapted shot."""
    pad = pad_state(state)
    pad.live = pad.playing = False
    pad.pose = None


def active_pose(state) -> Pose | None:
    """The pose the viewport should show instead of the adapted shot, or None."""
    pad = state.pc_pad
    if pad is None or pad.shot_key is None:
        return None
    if state.shot is None or pad.shot_key[:2] != (state.shot_index, state.shot.name):
        return None
    # live marker, or an animation playing or paused on a frame ("back to shot" clears it)
    return pad.pose if (pad.live or pad.playing or pad.anim is not None) else None


def active_ball(state):
    """With :func:`active_pose` shown: (the ball ``(3,)``, its flight ``(K, 3)``, the impact's
    readouts) of the take playing, or Nones for the live marker (a pose, no time, no ball)."""
    pad = state.pc_pad
    if pad is None or pad.live or pad.impact is None or active_pose(state) is None:
        return None, None, None
    return pad.ball, pad.impact.flight.path, pad.impact.readouts


def export_animation(state, path) -> str:
    """Write the current synthesised animation as BVH (atomically)."""
    pad = pad_state(state)
    if pad.anim is None:
        raise ValueError("no synthesised animation to export")
    if state.shot.capture is not None:       # a user's shot: back on its own skeleton and units
        state.shot.capture.write(path, pad.anim.local_rotations, pad.anim.root_positions,
                                 name=f"{state.shot.name}_synth")
    else:
        bvh.write(path, state.shot.skeleton, pad.anim)
    return str(path)


@dataclass(frozen=True)
class TakeTimeline:
    frames: int
    hit_frame: int | None         # None: the take leaves the ball
    frame: float
    playing: bool


def take_timeline(state) -> TakeTimeline | None:
    """What the timeline shows while a take is in the viewport (else None: the adapted shot's)."""
    pad = state.pc_pad
    if pad is None or pad.live or pad.anim is None or active_pose(state) is None:
        return None
    imp = pad.impact
    hit = None if imp is None or imp.readouts.contact == "none" else imp.hit_frame
    frame = min(pad.play_time * pad.anim.fps, pad.anim.num_frames - 1)
    return TakeTimeline(pad.anim.num_frames, hit, frame, pad.playing)


def shown_take(state) -> Take | None:
    """The take in the viewport (playing or paused on a frame), else None."""
    pad = state.pc_pad
    if take_timeline(state) is None:
        return None
    takes = pad.shot_takes(state.shot.name)
    return takes[pad.take] if 0 <= pad.take < len(takes) and takes[pad.take].anim is pad.anim else None


def pose_take_frame(state, take: Take, frame: int) -> None:
    """The viewport's pose and ball at ``frame`` of ``take`` (an export renders them)."""
    g_rot, g_pos = take.anim_global
    f = int(min(max(frame, 0), take.anim.num_frames - 1))
    state.pose, state.pose_source = Pose(g_rot[f], g_pos[f]), "pc pad"
    state.ball_position = None if take.impact is None else ball_in_take(take.impact, f)
    state.shown_flight = None if take.impact is None else take.impact.flight.path
