"""The docked panel on the right (ImGui). It writes only to the settings and the
requests (``app.viewer.requests``: captures, reload, the PC pad's); the state is read for readouts. Top to bottom: shot and solver settings (falloff
first), playback, overlays, readouts, the blend plot, the PC pad, messages."""
from __future__ import annotations

import math
import time

import numpy as np
from imgui_bundle import imgui, implot

from app.viewer.settings import (COMPARE_CHOICES, FACES, FALLOFF_BAND, FALLOFF_RANGE, GHOST_MODES, ITERATIONS_RANGE,
                                 RENDER_SCALE_RANGE, SOLVERS, SPEED_RANGE, TOLERANCE_RANGE, TRUNK_REACH_RANGE, TWISTS,
                                 ViewerSettings)
from app.ui.wagonwheel import draw_wagon_wheel
from app.ui.padwidget import draw_pc_pad
from app.viewer import pcpad
from app.viewer.requests import Requests
from app.viewer.state import AppState
from engine import field

PANEL_WIDTH = 360
VIEWPORT_SHOWS = {"pc pad": "PC pad pose", "adapted": "adapted shot", "source": "source shot"}
_WINDOW_FLAGS = (imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize
                 | imgui.WindowFlags_.no_collapse | imgui.WindowFlags_.no_saved_settings)
ERROR_COLOR = imgui.ImVec4(1.0, 0.45, 0.4, 1.0)
DIM = imgui.ImVec4(0.65, 0.67, 0.7, 1.0)
BLUE = imgui.ImVec4(0.3, 0.55, 1.0, 1.0)
RED = imgui.ImVec4(0.95, 0.25, 0.2, 1.0)
COMPILING_COLOR = imgui.ImVec4(1.0, 0.8, 0.3, 1.0)


def draw_panel(settings: ViewerSettings, state: AppState, rect: tuple, requests: Requests) -> None:
    """The panel window at ``rect = (x, y, w, h)``; one-off actions (captures, a reload, what
    the user asks of the PC pad) go to ``requests`` (the loop hands them on)."""
    x, y, w, h = rect
    imgui.set_next_window_pos(imgui.ImVec2(x, y))
    imgui.set_next_window_size(imgui.ImVec2(w, h))
    imgui.begin("Hitpoint", None, _WINDOW_FLAGS)
    try:
        _messages(state)
        _settings_section(settings, state)
        _readouts_section(settings, state)
        _blend_plot(settings, state)
        _pc_pad(state, requests.pad)
        _playback_section(settings, state)
        _overlay_section(settings)
        _capture_section(settings, state, requests)
    finally:
        imgui.end()


def _settings_section(settings: ViewerSettings, state: AppState) -> None:
    imgui.separator_text("Shot and solver")
    _falloff_slider(settings, state)
    _shot_choice(settings, state)
    _solver_settings(settings)


def _shot_choice(settings: ViewerSettings, state: AppState) -> None:
    chosen = state.shot
    auto_label = f"auto: {chosen.name}" if chosen is not None and settings.pinned_shot is None else "auto (ball path)"
    preview = auto_label if settings.pinned_shot is None else f"pinned: {settings.pinned_shot}"
    if imgui.begin_combo("source", preview):
        if imgui.selectable(auto_label + "##auto", settings.pinned_shot is None)[0]:
            settings.pinned_shot = None
        for s in state.shots:
            if imgui.selectable(s.name, settings.pinned_shot == s.name)[0]:
                settings.pinned_shot = s.name
        imgui.end_combo()
    if chosen is not None:
        imgui.text_colored(DIM, f"{chosen.name}: {chosen.num_frames} frames, hit frame {chosen.hit_frame}")
        _description(chosen, state.shots)
    else:
        imgui.text_colored(ERROR_COLOR, "no shot loaded")
    t = settings.target
    changed, xy = imgui.drag_float2("target x, y", [float(t[0]), float(t[1])], 0.5, format="%.1f cm")
    if changed:
        settings.target = np.array([xy[0], xy[1], t[2]])


def _description(chosen, shots) -> None:
    """The shot's description, wrapped, in a block as tall as the longest in the
    library: what follows stays put when the ball path picks another shot
    (and the panel is not redrawn whole)."""
    width = imgui.get_content_region_avail().x
    tallest = max((imgui.calc_text_size(s.description, False, width).y for s in shots if s.description),
                  default=0.0)
    if tallest <= 0:
        return
    top = imgui.get_cursor_pos_y()
    if chosen.description:
        imgui.push_text_wrap_pos(0.0)
        imgui.text_colored(DIM, chosen.description)
        imgui.pop_text_wrap_pos()
    imgui.set_cursor_pos_y(top + tallest + imgui.get_style().item_spacing.y)


def _falloff_slider(settings: ViewerSettings, state: AppState) -> None:
    changed, v = imgui.slider_float("falloff", settings.falloff, *FALLOFF_RANGE, "%.0f cm")
    if changed:
        settings.falloff = v
    # Mark the dissertation's useful 70-110 band on the slider's frame.
    lo, hi = imgui.get_item_rect_min(), imgui.get_item_rect_max()
    frame_w = imgui.calc_item_width()
    span = FALLOFF_RANGE[1] - FALLOFF_RANGE[0]
    x0 = lo.x + frame_w * (FALLOFF_BAND[0] - FALLOFF_RANGE[0]) / span
    x1 = lo.x + frame_w * (FALLOFF_BAND[1] - FALLOFF_RANGE[0]) / span
    dl = imgui.get_window_draw_list()
    dl.add_rect_filled(imgui.ImVec2(x0, hi.y - 4), imgui.ImVec2(x1, hi.y), imgui.get_color_u32(
        imgui.ImVec4(0.3, 0.85, 0.4, 0.8)))
    # Orange tick: the largest falloff that keeps this shot's ends fully FK (2.2.5).
    adapter = state.adapters.get(state.shot_index)
    limit = getattr(adapter, "max_falloff", None) if adapter is not None else None
    if limit is not None and FALLOFF_RANGE[0] <= limit <= FALLOFF_RANGE[1]:
        tx = lo.x + frame_w * (limit - FALLOFF_RANGE[0]) / span
        dl.add_line(imgui.ImVec2(tx, lo.y), imgui.ImVec2(tx, hi.y), imgui.get_color_u32(
            imgui.ImVec4(1.0, 0.6, 0.15, 0.9)), 2.0)
    if imgui.is_item_hovered():
        tip = "IK falloff distance (section 2.2.5); green: the useful 70-110 cm band"
        if limit is not None:
            tip += f"\norange: {limit:.0f} cm, the largest that keeps this shot's ends fully FK"
        imgui.set_tooltip(tip)


SOLVER_LABELS = {"learnt": "LEARNT", "learnt+ccd": "LEARNT+CCD"}
SOLVER_TIPS = {"learnt": "learnt IK (Ong & Hilton 2005): the arm where the library's data puts it for the bat;\n"
                         "the bat misses by what the data gives (the readout says how far)",
               "learnt+ccd": "the learnt pose as CCD's start, then exact"}


def _solver_line(name: str) -> None:
    """Radio buttons of solvers side by side, the learnt ones on a second line."""
    if name == "learnt":
        imgui.text("          ")
    imgui.same_line()


def _solver_settings(settings: ViewerSettings) -> None:
    imgui.text("left wrist")
    for dof in (0, 2):
        imgui.same_line()
        if imgui.radio_button(f"{dof} DOF", settings.wrist_dof == dof):
            settings.wrist_dof = dof
    imgui.text("solver    ")
    for name in SOLVERS:
        _solver_line(name)          # the learnt ones on a line of their own
        if imgui.radio_button(SOLVER_LABELS.get(name, name.upper()), settings.solver == name):
            settings.solver = name
        if imgui.is_item_hovered() and name in SOLVER_TIPS:
            imgui.set_tooltip(SOLVER_TIPS[name])
    if settings.solver in ("learnt", "learnt+ccd") or settings.compare_solver in ("learnt", "learnt+ccd"):
        changed, v = imgui.checkbox("learn without this shot", settings.learnt_leave_out)
        if changed:
            settings.learnt_leave_out = v
    imgui.text("compare   ")
    for name in COMPARE_CHOICES:
        _solver_line(name)
        if imgui.radio_button(f"{SOLVER_LABELS.get(name, name.upper()) if name != 'off' else 'off'}##compare",
                              settings.compare_solver == name):
            settings.compare_solver = name
    if imgui.is_item_hovered():
        imgui.set_tooltip("the ghost shows this solver's pose for the same shot and point (instead of the source)")
    if settings.solver == "ccd":
        imgui.text("arm rolls ")
        for name in TWISTS:
            imgui.same_line()
            if imgui.radio_button(name, settings.twist == name):
                settings.twist = name
        if imgui.is_item_hovered():
            imgui.set_tooltip("follow: the left arm's roll joints keep the source's twist, so the bat face\n"
                              "stays square to the ball; lead: CCD turns them too (the dissertation's CCD)")
    imgui.text("bat face  ")
    for name in FACES:
        imgui.same_line()
        if imgui.radio_button(f"{name}##face", settings.face == name):
            settings.face = name
    if imgui.is_item_hovered():
        imgui.set_tooltip("keep: after the bat reaches the ball, the arm turns the face back to the source's\n"
                          "(turned a little with the hit point: move it off, the ball goes further off);\n"
                          "free: the position solve alone")
    _trunk_settings(settings)
    changed, v = imgui.slider_int("iterations", settings.iterations, *ITERATIONS_RANGE)
    if changed:
        settings.iterations = v
    changed, v = imgui.slider_float("tolerance", settings.tolerance, *TOLERANCE_RANGE, "%.4f cm",
                                    imgui.SliderFlags_.logarithmic)
    if changed:
        settings.tolerance = v
    changed, v = imgui.checkbox("right hand follows the grip", settings.fix_right_hand)
    if changed:
        settings.fix_right_hand = v


def _toggle(label: str, value: bool, tip: str) -> bool:
    """A checkbox with a tooltip; the value it leaves."""
    changed, v = imgui.checkbox(label, value)
    if imgui.is_item_hovered():
        imgui.set_tooltip(tip)
    return v if changed else value


def _trunk_settings(settings: ViewerSettings) -> None:
    if not settings.hold_trunk:
        settings.carry_lean = _toggle(
            "lean into the hit", settings.carry_lean,
            "the hit frame is solved first and the frames around it start from its trunk,\n"
            "by their share of the adaptation: the body leans into the hit over the frames\n"
            "instead of turning at the hit alone (off: every frame solved on its own)")
    settings.hold_trunk = _toggle(
        "hold the trunk", settings.hold_trunk,
        "each spine joint stays within this many degrees of the source's: far from the\n"
        "source's hit point the batsman keeps his posture, and the face and the right\n"
        "hand's grip give where the arms alone cannot keep them (the bat still reaches)")
    if settings.hold_trunk:
        imgui.same_line()
        imgui.set_next_item_width(120)
        changed, v = imgui.slider_float("##trunk_reach", settings.trunk_reach, *TRUNK_REACH_RANGE, "%.0f deg")
        if changed:
            settings.trunk_reach = v


def _playback_section(settings: ViewerSettings, state: AppState) -> None:
    if not imgui.collapsing_header("Playback", imgui.TreeNodeFlags_.default_open):
        return
    if imgui.button("Pause" if settings.playing else "Play"):
        settings.playing = not settings.playing
    imgui.same_line()
    if imgui.button("Hit frame") and state.shot is not None:
        settings.playing, settings.frame = False, float(state.shot.hit_frame)
    imgui.same_line()
    changed, v = imgui.checkbox("slow motion", settings.slow_motion)
    if changed:
        settings.slow_motion = v
    changed, v = imgui.slider_float("speed", settings.speed, *SPEED_RANGE, "%.2fx",
                                    imgui.SliderFlags_.logarithmic)
    if changed:
        settings.speed = v
    imgui.push_text_wrap_pos(0.0)
    imgui.text_colored(DIM, "space play/pause, <- -> step, H hit frame, S slow motion, [ ] speed, "
                            "F12 screenshot, R reset view; drag the target, right/left drag orbit, "
                            "middle or shift drag pan, wheel zoom")
    imgui.pop_text_wrap_pos()


def _overlay_section(settings: ViewerSettings) -> None:
    if not imgui.collapsing_header("Overlays"):
        return
    o = settings.overlays
    changed, v = imgui.slider_float("render scale", settings.render_scale, *RENDER_SCALE_RANGE, "%.2f")
    if changed:
        settings.render_scale = v
    if imgui.is_item_hovered():
        imgui.set_tooltip("3D view resolution relative to the window (lower it on a slow GPU)")
    changed, v = imgui.checkbox("antialias the batsman", settings.antialias)
    if changed:
        settings.antialias = v
    if imgui.is_item_hovered():
        imgui.set_tooltip("FXAA over the batsman, ball and target (about 3 ms a frame in software GL);"
                          " the pitch and stadium are multisampled whenever the camera holds still")
    imgui.text("source pose")
    for mode in GHOST_MODES:
        imgui.same_line()
        if imgui.radio_button(f"{mode}##ghost", o.ghost == mode):
            o.ghost = mode
    items = [("hit_points", "FK hit points"), ("ball_path", "ball path"), ("desired_point", "desired hit point"),
             ("bat_path", "bat path"), ("source_bat_path", "source bat path"), ("flight", "ball flight"),
             ("ball", "ball"), ("target", "target"), ("skeleton", "adapted skeleton"), ("pitch", "pitch")]
    for i, (name, label) in enumerate(items):
        if i % 2:
            imgui.same_line(175)
        changed, v = imgui.checkbox(label, getattr(o, name))
        if changed:
            setattr(o, name, v)


def _fmt(value: float, spec: str) -> str:
    """A readout's number, or a dash while there is none (the solver still compiling)."""
    return format(value, spec) if math.isfinite(value) else "-"


def _readouts_section(settings: ViewerSettings, state: AppState) -> None:
    imgui.separator_text("Readouts")
    r, t = state.readouts, state.timing.shown     # timings: quarter-second means
    if imgui.begin_table("readouts", 2, imgui.TableFlags_.sizing_stretch_prop):
        rows = [_solver_row(settings, state), *_error_rows(state),
                ("engine per frame", f"{t.get('engine', r.engine_ms):.2f} ms"),
                ("whole-shot solve", f"{t.get('solve', r.solve_ms):.2f} ms"),
                ("render", f"{t.get('render', r.render_ms):.2f} ms"),
                ("frame", f"{t.get('frame', r.frame_ms):.2f} ms  ({t.get('fps', r.fps):.0f} fps)"),
                _frame_shown_row(settings, state),
                ("viewport shows", VIEWPORT_SHOWS.get(state.pose_source, state.pose_source))]
        c = r.compare
        if c:
            rows += [(f"ghost: {c['solver']}", f"{c['us_per_frame']:.1f} us a frame"),
                     ("ghost bat / grip", f"{c['bat_error_cm']:.2f} / {c['max_grip_error_cm']:.2f} cm")]
        take = pcpad.shown_take(state)
        if take is not None and take.impact is not None:     # the take's ball, not the adapted shot's
            d = take.impact.hit_point
            rows.append(("take's hit point", f"{d[0]:.1f}, {d[1]:.1f}, {d[2]:.1f}"))
        elif state.desired_hit_point is not None:
            d = state.desired_hit_point
            rows.append(("desired hit point", f"{d[0]:.1f}, {d[1]:.1f}, {d[2]:.1f}"))
        if state.shown_impact is not None:
            rows += _impact_rows(state.shown_impact)
        for label, value in rows:
            imgui.table_next_row()
            imgui.table_next_column()
            imgui.text_colored(DIM, label)
            imgui.table_next_column()
            if label == "ball meets bat" and state.shown_impact.contact in ("edge", "back"):
                imgui.text_colored(ERROR_COLOR, value)     # the back or the edge of the bat: say so
            else:
                imgui.text(value)
        imgui.end_table()
    draw_wagon_wheel(settings, state)


def _solver_row(settings: ViewerSettings, state: AppState) -> tuple[str, str]:
    """What the pose in the viewport cost: a PC-pad take's making (synthesis, clean-up and
    ball, once), else the adapted shot's solver a frame."""
    take = pcpad.shown_take(state)
    if take is not None:
        return ("take made in", f"{_fmt(take.made_ms, '.1f')} ms")
    return (settings.solver, f"{_fmt(state.readouts.us_per_frame, '.1f')} us a frame")


def _error_rows(state: AppState) -> list[tuple[str, str]]:
    """The bat's and the grip's errors of what the viewport shows: a PC-pad take's clean-up
    (engine.cleanup), else the adapted shot's solve."""
    take = pcpad.shown_take(state)
    if take is None:
        r = state.readouts
        return [("bat error at hit frame", f"{_fmt(r.bat_error_cm, '.3f')} cm"),
                ("grip error (this frame)", f"{_fmt(r.grip_error_cm, '.2f')} cm  {_fmt(r.grip_error_deg, '.1f')} deg"),
                ("grip error (max)", f"{_fmt(r.max_grip_error_cm, '.2f')} cm"),
                ("trunk vs source (max)", f"{_fmt(r.trunk_turn_deg, '.0f')} deg"),
                ("trunk jump a frame (max)", f"{_fmt(r.trunk_jump_deg, '.0f')} deg")]
    c = take.cleanup
    rows = []
    if "bat_error_cm" in c:
        rows.append(("take's bat error", f"{c['bat_error_cm']:.3f} cm (moved {c['bat_moved_cm']:.0f})"))
    if "hand_error_cm_max" in c:
        rows.append(("take's grip (max)", f"{c['hand_error_cm_max']:.2f} cm  {c['hand_error_deg_max']:.1f} deg"))
    feet = [c[k] for k in ("left_foot_error_cm_max", "right_foot_error_cm_max") if k in c]
    if feet:
        rows.append(("take's feet (max)", f"{max(feet):.2f} cm off"))
    return rows


def _frame_shown_row(settings: ViewerSettings, state: AppState) -> tuple[str, str]:
    """The frame in the viewport: a PC-pad take's while one is shown, else the shot's."""
    take = pcpad.take_timeline(state)
    if take is not None:
        return ("frame shown", f"take {take.frame:.2f} / {take.frames - 1}")
    return ("frame shown", f"{settings.frame:.2f} / {state.num_frames - 1}")


def _impact_rows(r) -> list[tuple[str, str]]:
    """The hit as a batsman would judge it: which part of the bat meets the ball, how far
    the face turned from the source's, where the ball goes (DESIGN.md's azimuth)."""
    if not r.contact:
        return []
    if r.contact == "none":          # an aborted take: the batsman leaves the ball
        return [("ball meets bat", "none: the shot is left"),
                ("ball goes to", f"{r.ball_azimuth_deg:+.0f} deg {field.region(r.ball_azimuth_deg)}")]
    return [("ball meets bat", f"{r.contact} (cos {r.face_to_ball:+.2f})"),
            ("face vs source", f"{r.face_angle_deg:.1f} deg"),
            ("ball goes to", f"{r.ball_azimuth_deg:+.0f} deg {field.region(r.ball_azimuth_deg)}"),
            _elevation_row(r.ball_elevation_deg)]


def _elevation_row(elevation_deg: float) -> tuple[str, str]:
    """The ball's climb off the bat said as a batsman would: "rises 7 deg", "falls 18 deg"
    (into the ground off a defensive bat), not "rises -18"."""
    word = "rises" if elevation_deg >= 0.0 else "falls"
    return ("ball " + word, f"{abs(elevation_deg):.0f} deg")


def _blend_plot(settings: ViewerSettings, state: AppState) -> None:
    a = state.adaptation
    if a is None or state.time_blend is None:
        return
    imgui.separator_text("IK blend over the shot (Figure 2.3)")
    blend = np.asarray(a.blend, float)
    frames = np.arange(blend.size, dtype=float)
    if implot.begin_plot("##blend", imgui.ImVec2(-1, 150)):
        implot.setup_axes("frame", "blend", implot.AxisFlags_.auto_fit, implot.AxisFlags_.lock)
        implot.setup_axis_limits(implot.ImAxis_.y1, -0.05, 1.1, implot.Cond_.always)
        implot.setup_legend(implot.Location_.north, implot.LegendFlags_.horizontal | implot.LegendFlags_.outside)
        spec = implot.Spec()
        spec.line_color, spec.line_weight = BLUE, 2.0
        implot.plot_line("importance", frames, blend, spec=spec)
        spec2 = implot.Spec()
        spec2.line_color, spec2.line_weight = RED, 1.5
        implot.plot_line("time-based", frames, np.asarray(state.time_blend, float), spec=spec2)
        if state.shot is not None:
            implot.tag_x(float(state.shot.hit_frame), RED, "hit")
        changed, x, *_ = implot.drag_line_x(0, float(settings.frame), imgui.ImVec4(1, 1, 1, 0.7), 1.0)
        if changed:
            settings.frame, settings.playing = x, False
        implot.end_plot()


def _pc_pad(state: AppState, pad_requests: list) -> None:
    if not imgui.collapsing_header("PC pad", imgui.TreeNodeFlags_.default_open):
        return
    if state.engine_warmup is not None and not state.engine_warmup.ready.is_set():
        imgui.text_colored(DIM, "PC pad: ready once the engine has compiled")
    elif state.dragging_target:
        # A drag can switch shots every frame; the pad refits its PCA per
        # shot (~100 ms), so it waits for the release.
        imgui.text_colored(DIM, "PC pad: updates when the target is released")
    else:
        draw_pc_pad(state, pad_requests)


def _capture_section(settings: ViewerSettings, state: AppState, requests: Requests) -> None:
    if not imgui.collapsing_header("Capture", imgui.TreeNodeFlags_.default_open):
        return
    if imgui.button("Screenshot (F12)"):
        requests.screenshot = True
    imgui.same_line()
    take = pcpad.shown_take(state) is not None
    if imgui.button("Export take###export" if take else "Export shot###export"):
        requests.export = True
    if imgui.is_item_hovered():
        what = "the PC-pad take shown" if take else "the adapted shot"
        imgui.set_tooltip(f"A new folder in the working directory: {what} as\n"
                          "mp4 + PNG frames (viewport size), BVH and glTF (.glb, metres)")
    imgui.same_line()
    changed, clean = imgui.checkbox("clean video", settings.clean_video)
    if changed:
        settings.clean_video = clean
    if imgui.is_item_hovered():
        imgui.set_tooltip("the export's video without the editing aids (ghost, paths, crosses)")
    if imgui.button("Reload shot library"):
        requests.reload = True
    _export_progress(state)
    _last_capture(state)
    if state.session_line:            # where the session autosaves (app.session)
        imgui.push_text_wrap_pos(0.0)
        imgui.text_colored(DIM, state.session_line)
        imgui.pop_text_wrap_pos()


def _export_progress(state: AppState) -> None:
    """The running export's progress bar (capture.ExportJob.progress, kept by the
    loop in ``state.export_progress``; None when no export runs)."""
    progress = state.export_progress
    if progress is not None:
        imgui.progress_bar(float(progress), imgui.ImVec2(-1.0, 0.0), f"exporting {100 * float(progress):.0f} %")


def _last_capture(state: AppState) -> None:
    """Where the last screenshot or export went, or why the export failed."""
    export, last = state.last_export, state.last_capture
    if not export and not last:
        return
    imgui.push_text_wrap_pos(0.0)
    if export and export.ok and last and export.line.startswith(last):
        imgui.text_colored(DIM, f"exported {export.line}")
    elif last:
        imgui.text_colored(DIM, f"wrote {last}")
    if export and not export.ok:
        imgui.text_colored(ERROR_COLOR, export.line)
    imgui.pop_text_wrap_pos()


def _messages(state: AppState) -> None:
    status = {k: v for k, v in state.status.items() if v != "ok"}
    warmup = state.engine_warmup
    compiling = warmup.stage if warmup is not None else ""
    if not state.messages and not status and not compiling:
        return
    imgui.push_text_wrap_pos(0.0)
    if compiling:
        imgui.text_colored(COMPILING_COLOR, f"compiling the {compiling}... (first start after an install or "
                                            f"update; the source shot shows meanwhile)")
    for piece, why in status.items():
        imgui.text_colored(ERROR_COLOR, f"{piece}: {why}")
    now = time.time()
    for t, line in reversed(state.messages[-4:]):
        imgui.text_colored(ERROR_COLOR, f"[{max(now - t, 0):.0f}s ago] {line}")
    imgui.pop_text_wrap_pos()
