"""The PC pad's widget in the panel (dissertation 3.2, Figures 3.3, 3.4, 3.7): draws the
pad's model (``app.pcpad.PadState``) and turns what the user does into
``app.viewer.padrequests.PadRequest`` s, which the frame's update carries out. It changes nothing itself:
the refit, the synthesis and the clean-up run in the update, never while drawing."""
from __future__ import annotations

import numpy as np
from imgui_bundle import imgui, implot

from app.viewer.padrequests import PadRequest
from app.viewer.pcpad import DRAWN_RGBA, MARKER_RGBA, PRESET_LABELS, PRESET_RGBA, SECTION_RGBA, PadState


def _u32(rgba, alpha=None):
    r, g, b, a = rgba
    return imgui.get_color_u32(imgui.ImVec4(r, g, b, a if alpha is None else alpha))


def current_pad(state) -> PadState | None:
    """The pad when it is fitted to the shot shown (the update refits it the frame a shot changes)."""
    pad, shot = state.pc_pad, state.shot
    if pad is None or shot is None or pad.shot_key != (state.shot_index, shot.name, shot.num_frames):
        return None
    return pad


def draw_pc_pad(state, requests: list) -> None:
    """Draw the pad in the current imgui window; what the user does is appended to ``requests``."""
    pad = current_pad(state)
    if pad is None:
        imgui.text_disabled("PC pad: no shot loaded" if state.shot is None else "PC pad: fitting the shot...")
        return
    ask = requests.append
    ex = pad.pca.explained
    imgui.text(f"PC1 {100 * ex[0]:.1f}%  PC2 {100 * ex[1] if len(ex) > 1 else 0:.1f}%  "
               f"together {100 * pad.pca.cumulative[min(1, len(ex) - 1)]:.1f}%")
    if imgui.radio_button("pose", pad.mode == "pose"):
        ask(PadRequest("mode", "pose"))
    imgui.same_line()
    if imgui.radio_button("draw path", pad.mode == "draw"):
        ask(PadRequest("mode", "draw"))
    imgui.same_line()
    if imgui.button("back to shot"):
        ask(PadRequest("back"))
    _take_list(state, pad, ask)
    _pad_area(pad, ask)
    _preset_controls(pad, ask)
    _variance_plot(pad)


def _take_list(state, pad: PadState, ask) -> None:
    """The shot's takes (drawn paths, presets): pick one to play it again, or forget it."""
    takes = pad.shot_takes(state.shot.name)
    if not takes:
        imgui.text_disabled("takes: none yet (draw a path or pick a preset)")
        return
    preview = takes[pad.take].label(pad.take) if 0 <= pad.take < len(takes) else f"{len(takes)} kept"
    imgui.set_next_item_width(imgui.get_content_region_avail().x - 70)
    if imgui.begin_combo("##takes", f"take: {preview}"):
        for i, take in enumerate(takes):
            if imgui.selectable(f"{take.label(i)}##take{i}", i == pad.take)[0]:
                ask(PadRequest("take", i))
        imgui.end_combo()
    imgui.same_line()
    if imgui.button("forget"):
        ask(PadRequest("forget"))
    if imgui.is_item_hovered():
        imgui.set_tooltip("remove the take shown from this shot's list (and the saved session)")


def _pad_area(pad: PadState, ask) -> None:
    """The square of PC1 x PC2 scores: the shot's path by section, the take's path, the stroke
    being drawn and the marker; a press drags the marker (pose) or records a stroke (draw)."""
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

    _draw_paths(pad, px, ox, oy, size)
    mouse = imgui.get_io().mouse_pos
    if pad.mode == "draw" and activated:
        ask(PadRequest("stroke_start"))
    if active:
        ask(PadRequest("marker", scores_at(mouse)))
    if pad.mode == "draw" and deactivated:
        ask(PadRequest("stroke_end"))
    if hovered and not active:
        s = scores_at(mouse)
        imgui.set_tooltip(f"PC1 {s[0]:.2f}, PC2 {s[1]:.2f}")
    imgui.end_child()
    imgui.pop_style_var()


def _draw_paths(pad: PadState, px, ox: float, oy: float, size: float) -> None:
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


def _preset_controls(pad: PadState, ask) -> None:
    imgui.text_colored(imgui.ImVec4(*SECTION_RGBA[0]), "preparation")
    imgui.same_line()
    imgui.text_colored(imgui.ImVec4(*SECTION_RGBA[1]), "stroke")
    imgui.same_line()
    imgui.text_colored(imgui.ImVec4(*SECTION_RGBA[2]), "return")
    for i, (key, label) in enumerate(PRESET_LABELS.items()):
        if i:
            imgui.same_line()
        if imgui.button(label):
            ask(PadRequest("preset", key))
    lo_hi = (0.0, 0.95) if pad.preset == "toned_down" else (0.0, 1.0)
    changed, v = imgui.slider_float("amount", pad.amount, *lo_hi, "%.2f")
    if changed:
        ask(PadRequest("amount", float(v)))
    if imgui.is_item_deactivated_after_edit():
        ask(PadRequest("remake_preset"))        # the preset shown, made again when the slider is let go
    _checkbox("re-attach right hand", "fix_hand", pad.fix_hand, ask)
    imgui.same_line()
    _checkbox("plant feet", "plant_feet", pad.plant_feet, ask)
    _checkbox("source detail", "detail", pad.detail, ask)
    if imgui.is_item_hovered():
        imgui.set_tooltip("PCs 3 and on from the shot (off: the first two PCs alone, as in the dissertation)")
    if imgui.button("pause" if pad.playing else "play"):
        ask(PadRequest("play"))
    imgui.same_line()
    _checkbox("loop", "loop", pad.loop, ask)
    if pad.anim is not None:
        imgui.same_line()
        if imgui.button("export BVH"):
            ask(PadRequest("export"))
    if pad.info:                         # wrapped: a take's line says its clean-up, longer than the panel
        imgui.push_style_color(imgui.Col_.text, imgui.get_style_color_vec4(imgui.Col_.text_disabled))
        imgui.text_wrapped(pad.info)
        imgui.pop_style_color()


def _checkbox(label: str, option: str, value: bool, ask) -> None:
    changed, v = imgui.checkbox(label, value)
    if changed:
        ask(PadRequest(option, bool(v)))


def _variance_plot(pad: PadState) -> None:
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
