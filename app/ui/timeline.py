"""The timeline scrubber along the bottom of the 3D view: one tick per frame,
the hit frame marked in red, the current frame as a handle; clicking or
dragging anywhere on the track scrubs (writes ``settings.frame``; while a PC-pad
take is shown, the take's frames, asked of the pad)."""
from __future__ import annotations

import numpy as np
from imgui_bundle import imgui

from app.viewer import pcpad
from app.viewer.padrequests import PadRequest
from app.viewer.settings import ViewerSettings
from app.viewer.state import AppState

TIMELINE_HEIGHT = 46
_FLAGS = (imgui.WindowFlags_.no_move | imgui.WindowFlags_.no_resize | imgui.WindowFlags_.no_collapse
          | imgui.WindowFlags_.no_title_bar | imgui.WindowFlags_.no_scrollbar
          | imgui.WindowFlags_.no_saved_settings)
TRACK_MARGIN = 12.0


def frame_at(x: float, track_x0: float, track_x1: float, num_frames: int) -> float:
    """The frame under window x on a track spanning [track_x0, track_x1]."""
    a = (x - track_x0) / max(track_x1 - track_x0, 1.0)
    return float(np.clip(np.round(a * (num_frames - 1)), 0, num_frames - 1))


def track_x(frame: float, track_x0: float, track_x1: float, num_frames: int) -> float:
    return track_x0 + (track_x1 - track_x0) * frame / max(num_frames - 1, 1)


def track_span(rect: tuple) -> tuple[float, float]:
    """Window x of the track's first and last frame, for a timeline at ``rect``."""
    x, _, w, _ = rect
    play_w = 56.0
    return x + TRACK_MARGIN + play_w, x + w - TRACK_MARGIN


def draw_timeline(settings: ViewerSettings, state: AppState, rect: tuple, pad_requests: list | None = None) -> None:
    """The adapted shot's timeline (writes ``settings.frame`` and ``settings.playing``), or while
    a PC-pad take is in the viewport the take's: its frames, its hit, its play/pause and
    scrubbing as PC-pad requests (``pad_requests``), so the handle follows what is shown."""
    x, y, w, h = rect
    imgui.set_next_window_pos(imgui.ImVec2(x, y))
    imgui.set_next_window_size(imgui.ImVec2(w, h))
    imgui.begin("##timeline", None, _FLAGS)
    try:
        take = pcpad.take_timeline(state) if pad_requests is not None else None
        if take is None:
            if imgui.button("Pause" if settings.playing else " Play ", imgui.ImVec2(48, h - 16)):
                settings.playing = not settings.playing
            imgui.same_line()
            hit = state.shot.hit_frame if state.shot is not None else None
            label = f"{settings.frame:5.1f}/{state.num_frames - 1}  x{settings.playback_rate:.2f}"
            scrubbed = _track(rect, state.num_frames, hit, settings.frame, label)
            if scrubbed is not None:
                settings.frame, settings.playing = scrubbed, False
        else:
            if imgui.button("Pause" if take.playing else " Play ", imgui.ImVec2(48, h - 16)):
                pad_requests.append(PadRequest("play"))
            imgui.same_line()
            label = f"take {take.frame:5.1f}/{take.frames - 1}" + ("  (ball left)" if take.hit_frame is None else "")
            scrubbed = _track(rect, take.frames, take.hit_frame, take.frame, label)
            if scrubbed is not None:
                pad_requests.append(PadRequest("seek", scrubbed))
    finally:
        imgui.end()


def _track(rect: tuple, n: int, hit_frame: int | None, frame: float, label: str) -> float | None:
    """Draw a track of ``n`` frames, the hit marked, the handle at ``frame``; the frame under
    the mouse while the track is held, else None."""
    x0, x1 = track_span(rect)
    top, bottom = rect[1] + 6.0, rect[1] + rect[3] - 6.0
    imgui.set_cursor_screen_pos(imgui.ImVec2(x0 - 6, top))
    imgui.invisible_button("##track", imgui.ImVec2(max(x1 - x0 + 12, 1), max(bottom - top, 1)))
    scrubbed = frame_at(imgui.get_io().mouse_pos.x, x0, x1, n) if imgui.is_item_active() else None
    dl = imgui.get_window_draw_list()
    col = imgui.get_color_u32
    mid = (top + bottom) / 2
    dl.add_rect_filled(imgui.ImVec2(x0, mid - 3), imgui.ImVec2(x1, mid + 3),
                       col(imgui.ImVec4(0.25, 0.27, 0.3, 1)), 3.0)
    step = max(1, int(np.ceil(n / max((x1 - x0) / 6.0, 1))))  # ticks at least 6 px apart
    tick = col(imgui.ImVec4(0.55, 0.57, 0.6, 1))
    for f in range(0, n, step):
        tx = track_x(f, x0, x1, n)
        big = f % (step * 5) == 0
        dl.add_line(imgui.ImVec2(tx, mid + 5), imgui.ImVec2(tx, mid + (11 if big else 8)), tick)
    if hit_frame is not None:  # hit frame: red marker across the track
        hx = track_x(hit_frame, x0, x1, n)
        red = col(imgui.ImVec4(0.95, 0.2, 0.2, 1))
        dl.add_line(imgui.ImVec2(hx, top), imgui.ImVec2(hx, bottom), red, 2.0)
        dl.add_triangle_filled(imgui.ImVec2(hx - 5, top), imgui.ImVec2(hx + 5, top), imgui.ImVec2(hx, top + 7), red)
    cx = track_x(frame, x0, x1, n)
    dl.add_circle_filled(imgui.ImVec2(cx, mid), 7.0, col(imgui.ImVec4(0.95, 0.95, 0.95, 1)))
    dl.add_text(imgui.ImVec2(x0, top - 4), col(imgui.ImVec4(0.8, 0.8, 0.8, 1)), label)
    return scrubbed
