"""The panel's PC-score pad (dissertation 3.2, Figures 3.3, 3.4, 3.7).

A square pad in the space of the current shot's first two principal
components (whole body, 107 parameters). The shot's own score path is drawn as
a guide, coloured by section (preparation red, stroke green, return blue). In
"pose" mode dragging the marker sets the pose live (P = (L S)^T * D + M); in
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

The viewer calls :func:`draw_pc_pad` from the panel (before its engine update)
and, after the update, :func:`active_pose`: when it returns a pose the viewport
shows it instead of the adapted shot. :func:`set_scores` serves scripted drags.
The logic (everything but ``draw_pc_pad``) works without imgui.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from app.state import Pose

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


@dataclass
class Take:
    """One synthesised animation of a shot: what made it, and (cached) the clip."""
    kind: str                             # one of TAKE_KINDS
    points: np.ndarray                    # (N, 2) PC scores, as drawn or the preset's path
    times: np.ndarray | None = None       # (N,) seconds from the first point; None: over the shot
    amount: float = 0.4                   # the preset's amount (presets only)
    fix_hand: bool = True
    plant_feet: bool = True
    anim: object = None                   # engine.skeleton.Clip, made when first shown
    anim_global: tuple | None = None
    path: np.ndarray | None = None        # (F, 2) the points resampled to the clip's frames
    note: str = ""

    def same_recipe(self, other: "Take") -> bool:
        return (self.kind == other.kind and self.amount == other.amount and self.fix_hand == other.fix_hand
                and self.plant_feet == other.plant_feet and self.points.shape == other.points.shape
                and np.array_equal(self.points, other.points)
                and (self.times is None) == (other.times is None)
                and (self.times is None or np.array_equal(self.times, other.times)))

    def label(self, index: int) -> str:
        extra = (f" {self.amount:.2f}" if self.kind in PRESET_LABELS else
                 f", {self.times[-1]:.1f} s" if self.times is not None else "")
        return f"{index + 1}. {PRESET_LABELS.get(self.kind, self.kind)}{extra}"


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
    pose: Pose | None = None              # what the viewport shows while live/playing
    info: str = ""                        # one line about the last animation
    pose_us: float = 0.0                  # last pose-from-scores + FK time
    takes: dict = field(default_factory=dict)     # shot name -> [Take], oldest first
    take: int = -1                        # the take shown, index into the current shot's list
    generation: int = 0                   # +1 whenever ``takes`` changes (app.session saves then)

    def shot_takes(self, name: str | None) -> list:
        return self.takes.get(name, []) if name is not None else []


def pad_state(state) -> PadState:
    pad = getattr(state, "pc_pad", None)
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
        from engine import pca as pcam
        from engine import synth
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
        pad.take = -1
    return pad


def _fk_pose(rig, root, local):
    from engine.skeleton import pose_fk
    return pose_fk(rig.skeleton, root, local)


def _fk_single(rig, root, local):
    """FK of one pose by the engine's compiled FK (the marker moves every frame)."""
    from engine.skeleton import pose_fk
    return pose_fk(rig.skeleton, root, local, compiled=True)


def pose_at_scores(state, scores) -> Pose:
    """World pose for two scores (no clean-up: this is the live, raw pose)."""
    pad = sync(state)
    t0 = time.perf_counter()
    root, local = pad.pca.pose_from_scores(np.asarray(scores, float)[:2])
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
    from engine import synth
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
    _make_animation(state, pts, times, DRAWN)
    return True


def apply_preset(state, preset: str | None = None, amount: float | None = None,
                 replace: bool = False) -> None:
    """Animate a preset variation of the shot (Figure 3.7); ``replace``: in place of
    the take shown (its amount re-made when the slider is let go)."""
    from engine import synth
    pad = sync(state)
    if pad is None:
        return
    pad.preset = preset or pad.preset
    pad.amount = pad.amount if amount is None else float(amount)
    path = synth.preset_path(pad.guide, pad.preset, pad.amount, pad.sections)
    _make_animation(state, path, None, pad.preset, replace=replace)


def play_source_path(state) -> None:
    """Animate the shot's own 2-PC path (what the pad's two PCs alone give)."""
    pad = sync(state)
    if pad is not None:
        _make_animation(state, pad.guide, None, SOURCE)


def _make_animation(state, points, times, kind: str, replace: bool = False) -> None:
    """A new take of the current shot from ``points`` (and ``times``), shown and playing;
    the same recipe as a take the shot has already shows that one instead."""
    pad = pad_state(state)
    take = Take(kind, np.array(points, float), None if times is None else np.array(times, float),
                float(pad.amount), bool(pad.fix_hand), bool(pad.plant_feet))
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
    from engine import cleanup, synth
    pad = pad_state(state)
    shot, rig = state.shot, state.rig
    fps = float(shot.clip.fps)
    frames = None if take.times is not None else shot.num_frames
    anim = synth.synthesise(pad.pca, take.points, frames=frames, times=take.times, fps=fps)
    take.note = ""
    if take.fix_hand or take.plant_feet:
        res = cleanup.cleanup(rig, shot.skeleton, anim, shot.clip, take.fix_hand, take.plant_feet)
        anim = res.clip
        s = res.summary()
        if "hand_error_cm_max" in s:
            take.note = f", hand error max {s['hand_error_cm_max']:.1f} cm"
    take.anim = anim
    take.anim_global = _fk_pose(rig, anim.root_positions, anim.local_rotations)
    take.path = synth.resample_path(take.points, frames, take.times, fps)


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
    pad.playing, pad.live, pad.play_time = True, False, 0.0
    pad.info = f"{PRESET_LABELS.get(take.kind, take.kind)}: {take.anim.num_frames} frames{take.note}"
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
    i = int(min(round(f), F - 1))
    g_rot, g_pos = pad.anim_global
    pad.pose = Pose(g_rot[i], g_pos[i])
    if pad.path is not None and i < len(pad.path):
        pad.marker = pad.path[i]


def release(state) -> None:
    """Give the viewport back to the adapted shot."""
    pad = pad_state(state)
    pad.live = pad.playing = False
    pad.pose = None


def active_pose(state) -> Pose | None:
    """The pose the viewport should show instead of the adapted shot, or None."""
    pad = getattr(state, "pc_pad", None)
    if pad is None or pad.shot_key is None:
        return None
    if state.shot is None or pad.shot_key[:2] != (state.shot_index, state.shot.name):
        return None
    # live marker, or an animation playing or paused on a frame ("back to shot" clears it)
    return pad.pose if (pad.live or pad.playing or pad.anim is not None) else None


def export_animation(state, path) -> str:
    """Write the current synthesised animation as BVH (atomically)."""
    from engine import bvh
    pad = pad_state(state)
    if pad.anim is None:
        raise ValueError("no synthesised animation to export")
    bvh.write(path, state.shot.skeleton, pad.anim)
    return str(path)


# ---------------------------------------------------------------- the widget
def _u32(rgba, alpha=None):
    from imgui_bundle import imgui
    r, g, b, a = rgba
    return imgui.get_color_u32(imgui.ImVec4(r, g, b, a if alpha is None else alpha))


def draw_pc_pad(state) -> bool:
    """Draw the pad in the current imgui window; True when it changed the pose."""
    from imgui_bundle import imgui
    pad = sync(state)
    if pad is None:
        imgui.text_disabled("PC pad: no shot loaded")
        return False
    io = imgui.get_io()
    advance(pad, io.delta_time)
    changed = False

    ex = pad.pca.explained
    imgui.text(f"PC1 {100 * ex[0]:.1f}%  PC2 {100 * ex[1] if len(ex) > 1 else 0:.1f}%  "
               f"together {100 * pad.pca.cumulative[min(1, len(ex) - 1)]:.1f}%")
    if imgui.radio_button("pose", pad.mode == "pose"):
        pad.mode = "pose"
    imgui.same_line()
    if imgui.radio_button("draw path", pad.mode == "draw"):
        pad.mode = "draw"
    imgui.same_line()
    if imgui.button("back to shot"):
        release(state)
        changed = True
    changed |= _take_list(state, pad)
    changed |= _pad_area(state, pad)
    changed |= _preset_controls(state, pad)
    _variance_plot(pad)
    return changed


def _take_list(state, pad: PadState) -> bool:
    """The shot's takes (drawn paths, presets): pick one to play it again, or forget it."""
    from imgui_bundle import imgui
    takes = pad.shot_takes(state.shot.name)
    if not takes:
        imgui.text_disabled("takes: none yet (draw a path or pick a preset)")
        return False
    changed = False
    preview = takes[pad.take].label(pad.take) if 0 <= pad.take < len(takes) else f"{len(takes)} kept"
    imgui.set_next_item_width(imgui.get_content_region_avail().x - 70)
    if imgui.begin_combo("##takes", f"take: {preview}"):
        for i, take in enumerate(takes):
            if imgui.selectable(f"{take.label(i)}##take{i}", i == pad.take)[0]:
                _guarded(state, show_take, i)
                changed = True
        imgui.end_combo()
    imgui.same_line()
    if imgui.button("forget") and 0 <= pad.take < len(takes):
        delete_take(state, pad.take)
        changed = True
    if imgui.is_item_hovered():
        imgui.set_tooltip("remove the take shown from this shot's list (and the saved session)")
    return changed


def _guarded(state, fn, *args) -> None:
    """``fn(state, *args)``; a ValueError (a bad take) is a panel message."""
    try:
        fn(state, *args)
    except ValueError as e:
        state.report(f"pc pad: {e}")


def _pad_area(state, pad: PadState) -> bool:
    from imgui_bundle import imgui
    width = imgui.get_content_region_avail().x
    size = float(max(min(width, 420.0), 80.0))
    imgui.push_style_var(imgui.StyleVar_.window_padding, imgui.ImVec2(0, 0))
    imgui.begin_child("##pc_pad_area", imgui.ImVec2(size, size), imgui.ChildFlags_.borders,
                      imgui.WindowFlags_.no_scrollbar | imgui.WindowFlags_.no_scroll_with_mouse)
    origin = imgui.get_cursor_screen_pos()
    ox, oy = origin.x, origin.y
    imgui.invisible_button("##pc_pad_button", imgui.ImVec2(size, size))
    active, activated = imgui.is_item_active(), imgui.is_item_activated()
    deactivated, hovered = imgui.is_item_deactivated(), imgui.is_item_hovered()
    span = pad.hi - pad.lo

    def px(s):
        u = (np.asarray(s, float) - pad.lo) / span
        return imgui.ImVec2(ox + float(u[0]) * size, oy + float(1 - u[1]) * size)

    def scores_at(pos):
        return pad.lo + span * np.array([(pos.x - ox) / size, 1 - (pos.y - oy) / size])

    dl = imgui.get_window_draw_list()
    dl.add_rect_filled(imgui.ImVec2(ox, oy), imgui.ImVec2(ox + size, oy + size), _u32((0.08, 0.09, 0.11, 1)))
    axis = _u32((1, 1, 1, 0.18))
    dl.add_line(px((pad.lo[0], 0)), px((pad.hi[0], 0)), axis, 1.0)
    dl.add_line(px((0, pad.lo[1])), px((0, pad.hi[1])), axis, 1.0)
    # the shot's own path, by section (Figure 3.4)
    for label, seg in pad.sections.segments(pad.guide):
        if len(seg) > 1:
            dl.add_polyline([px(p) for p in seg], _u32(SECTION_RGBA[label]), 2.5, 0)
    if pad.path is not None and len(pad.path) > 1:
        col = DRAWN_RGBA if pad.path_kind == "drawn" else PRESET_RGBA
        dl.add_polyline([px(p) for p in pad.path], _u32(col, 0.9), 2.0, 0)
    if len(pad.stroke) > 1:
        dl.add_polyline([px(p[:2]) for p in pad.stroke], _u32(DRAWN_RGBA), 2.5, 0)
    # start and hit frame on the guide
    dl.add_circle_filled(px(pad.guide[0]), 4.0, _u32(SECTION_RGBA[0]))
    dl.add_circle(px(pad.guide[pad.sections.hit_frame]), 5.0, _u32((1, 1, 0.3, 1)), 0, 1.5)
    if pad.marker is not None:
        m = px(pad.marker)
        dl.add_circle_filled(m, 6.0, _u32(MARKER_RGBA if pad.live or pad.playing else (0.7, 0.7, 0.7, 1)))
        dl.add_circle(m, 8.0, _u32((0, 0, 0, 1)), 0, 1.5)
    dl.add_text(imgui.ImVec2(ox + 4, oy + size - 18), _u32((1, 1, 1, 0.5)), "PC1 ->")
    dl.add_text(imgui.ImVec2(ox + 4, oy + 2), _u32((1, 1, 1, 0.5)), "PC2")
    changed = False
    mouse = imgui.get_io().mouse_pos
    if pad.mode == "pose" and active:
        set_scores(state, scores_at(mouse))
        changed = True
    elif pad.mode == "draw":
        if activated:
            pad.stroke = []
        if active:
            _add_stroke_point(pad, scores_at(mouse))
            pad.marker = pad.stroke[-1][:2] if pad.stroke else pad.marker
        if deactivated:
            changed = finish_stroke(state)
    if hovered and not active:
        s = scores_at(mouse)
        imgui.set_tooltip(f"PC1 {s[0]:.2f}, PC2 {s[1]:.2f}")
    imgui.end_child()
    imgui.pop_style_var()
    return changed


def _preset_controls(state, pad: PadState) -> bool:
    from imgui_bundle import imgui
    changed = False
    imgui.text_colored(imgui.ImVec4(*SECTION_RGBA[0]), "preparation")
    imgui.same_line()
    imgui.text_colored(imgui.ImVec4(*SECTION_RGBA[1]), "stroke")
    imgui.same_line()
    imgui.text_colored(imgui.ImVec4(*SECTION_RGBA[2]), "return")
    for i, (key, label) in enumerate(PRESET_LABELS.items()):
        if i:
            imgui.same_line()
        if imgui.button(label):
            _guarded(state, apply_preset, key)
            changed = True
    lo_hi = (0.0, 0.95) if pad.preset == "toned_down" else (0.0, 1.0)
    c, v = imgui.slider_float("amount", pad.amount, *lo_hi, "%.2f")
    if c:
        pad.amount = v
    if imgui.is_item_deactivated_after_edit() and pad.anim is not None and pad.path_kind == pad.preset:
        apply_preset(state, pad.preset, replace=True)   # re-made when the slider is let go
        changed = True
    _, pad.fix_hand = imgui.checkbox("re-attach right hand", pad.fix_hand)
    imgui.same_line()
    _, pad.plant_feet = imgui.checkbox("plant feet", pad.plant_feet)
    if imgui.button("pause" if pad.playing else "play"):
        if pad.playing:
            pad.playing = False
        elif pad.anim is not None:
            pad.playing = True
        else:
            play_source_path(state)
        changed = True
    imgui.same_line()
    _, pad.loop = imgui.checkbox("loop", pad.loop)
    if pad.anim is not None:
        imgui.same_line()
        if imgui.button("export BVH"):
            try:
                from app.capture import safe_stem, write_new   # never over an earlier export
                out = write_new(".", f"hitpoint_synth_{safe_stem(state.shot.name)}_", ".bvh",
                                lambda path: export_animation(state, path))
                pad.info = f"wrote {out}"
            except (OSError, ValueError) as e:
                state.report(f"pc pad: export: {e}")
    if pad.info:
        imgui.text_disabled(pad.info)
    return changed


def _variance_plot(pad: PadState) -> None:
    from imgui_bundle import imgui, implot
    k = min(10, len(pad.pca.explained))
    xs = np.arange(1, k + 1, dtype=float)
    ex = 100 * np.asarray(pad.pca.explained[:k], float)
    cum = 100 * np.asarray(pad.pca.cumulative[:k], float)
    if implot.begin_plot("##pc_variance", imgui.ImVec2(-1, 130)):
        implot.setup_axes("PC", "% variance", implot.AxisFlags_.auto_fit, implot.AxisFlags_.lock)
        implot.setup_axis_limits(implot.ImAxis_.y1, 0, 100, implot.Cond_.always)
        implot.setup_legend(implot.Location_.east)
        implot.plot_bars("per PC", xs, ex, 0.6)
        spec = implot.Spec()
        spec.line_color, spec.line_weight = imgui.ImVec4(0.95, 0.25, 0.2, 1.0), 2.0
        implot.plot_line("cumulative", xs, cum, spec=spec)
        implot.end_plot()
