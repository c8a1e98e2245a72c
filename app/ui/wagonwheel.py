"""The wagon wheel in the panel: where the ball goes, seen from above with the bowler at
the top and the off side on the right (a right-hander) — the live Figure 2.6.

Drawn: the current direction (green off the face, red off the edge or the back; a PC-pad
take's while it plays), the source shot's own direction (grey), the directions of the
last solves as the target moved (dots, fading with age) and the direction asked for
(yellow). A click or a drag
on the wheel, or a fielding position picked under it ("mid-off"), asks for that direction
(``settings.aim_direction``/``direction``: the update turns the face once the target holds
still); a right click, or "as the shot goes", drops the request.
It writes settings only; the engine runs in the update."""
from __future__ import annotations

import math

from imgui_bundle import imgui

from engine import field

WHEEL_PX = (120.0, 220.0)        # the wheel's size range in the panel
FACE_RGBA = (0.35, 0.85, 0.40, 1.0)
MISS_RGBA = (0.95, 0.35, 0.30, 1.0)
SOURCE_RGBA = (0.70, 0.70, 0.70, 0.9)
ASKED_RGBA = (1.00, 0.85, 0.20, 1.0)
FIELD_RGBA = (0.20, 0.42, 0.20, 1.0)
PITCH_RGBA = (0.78, 0.72, 0.55, 1.0)


def _u32(rgba, alpha: float | None = None) -> int:
    r, g, b, a = rgba
    return imgui.get_color_u32(imgui.ImVec4(r, g, b, a if alpha is None else alpha))


def point_at(centre: tuple, radius: float, azimuth_deg: float) -> tuple[float, float]:
    """Screen point (y down) of an azimuth: 0 up (toward the bowler), + clockwise (off side)."""
    a = math.radians(azimuth_deg)
    return centre[0] + radius * math.sin(a), centre[1] - radius * math.cos(a)


def azimuth_of(centre: tuple, x: float, y: float) -> float:
    """The azimuth (deg) a screen point shows, the inverse of :func:`point_at`."""
    return math.degrees(math.atan2(x - centre[0], centre[1] - y))


def draw_wagon_wheel(settings, state) -> None:
    r = state.readouts
    if not r.contact:
        imgui.text_disabled("wagon wheel: no hit yet")
        return
    size = float(min(max(imgui.get_content_region_avail().x * 0.6, WHEEL_PX[0]), WHEEL_PX[1]))
    origin = imgui.get_cursor_screen_pos()
    imgui.invisible_button("##wagon_wheel", imgui.ImVec2(size, size))
    centre, radius = (origin.x + size / 2, origin.y + size / 2), size / 2 - 4
    _ask(settings, centre, radius)
    dl = imgui.get_window_draw_list()
    c = imgui.ImVec2(*centre)
    dl.add_circle_filled(c, radius, _u32(FIELD_RGBA), 48)
    dl.add_rect_filled(imgui.ImVec2(c.x - 3, c.y - radius * 0.45), imgui.ImVec2(c.x + 3, c.y), _u32(PITCH_RGBA))
    # the trail is where the adapted shot's ball went as the target moved: not a take's
    trail = [az for _, az in state.azimuth_trail] if state.shown_impact is r else []
    for i, az in enumerate(trail):
        if math.isfinite(az):
            dl.add_circle_filled(imgui.ImVec2(*point_at(centre, radius * 0.8, az)), 2.5,
                                 _u32(FACE_RGBA, 0.15 + 0.6 * (i + 1) / len(trail)))
    _ray(dl, centre, radius, r.source_azimuth_deg, SOURCE_RGBA, 1.5)
    if settings.aim_direction:
        _ray(dl, centre, radius, settings.direction, ASKED_RGBA, 2.0)
    now = state.shown_impact            # the adapted shot's, a playing take's, none for the pad's marker
    if now is not None and now.contact != "none":      # a left ball goes nowhere the batsman sent it
        _ray(dl, centre, radius, now.ball_azimuth_deg, FACE_RGBA if now.contact == "face" else MISS_RGBA, 3.0)
    dl.add_text(imgui.ImVec2(c.x - 12, origin.y + 2), _u32(SOURCE_RGBA), "bowler")
    dl.add_text(imgui.ImVec2(origin.x + size - 22, c.y - 7), _u32(SOURCE_RGBA), "off")
    dl.add_text(imgui.ImVec2(origin.x + 2, c.y - 7), _u32(SOURCE_RGBA), "leg")
    _positions(settings)
    _caption(settings, r)
    _elevation(settings, r)


def _ray(dl, centre, radius, azimuth_deg: float, rgba, thickness: float) -> None:
    if math.isfinite(azimuth_deg):
        dl.add_line(imgui.ImVec2(*centre), imgui.ImVec2(*point_at(centre, radius, azimuth_deg)), _u32(rgba),
                    thickness)


def _ask(settings, centre, radius) -> None:
    """A press or drag inside the wheel asks for its direction; a right click drops it."""
    if imgui.is_item_active() and imgui.is_mouse_down(imgui.MouseButton_.left):
        m = imgui.get_mouse_pos()
        if math.hypot(m.x - centre[0], m.y - centre[1]) > 0.15 * radius:   # the centre has no direction
            settings.aim_direction = True
            settings.direction = round(azimuth_of(centre, m.x, m.y), 1)
    if imgui.is_item_hovered():
        m = imgui.get_mouse_pos()
        where = field.region(azimuth_of(centre, m.x, m.y))
        imgui.set_tooltip(f"click or drag: hit the ball this way ({where}); right click: as the shot goes")
        if imgui.is_mouse_clicked(imgui.MouseButton_.right):
            settings.aim_direction = False


def position_named(settings) -> str:
    """The fielding position the asked direction is (engine.field.POSITIONS), else its degrees,
    or "as the shot goes" with none asked: what the position picker shows."""
    if not settings.aim_direction:
        return "as the shot goes"
    named = [n for n, az in field.POSITIONS.items() if abs(az - settings.direction) < 0.05]
    return named[0] if named else f"{settings.direction:+.0f} deg"


def _positions(settings) -> None:
    """Pick a fielding position, leg side round to the off side, to hit the ball to."""
    imgui.set_next_item_width(imgui.get_content_region_avail().x * 0.6)
    shown = position_named(settings)
    if not imgui.begin_combo("hit it to", shown):
        return
    if imgui.selectable("as the shot goes", not settings.aim_direction)[0]:
        settings.aim_direction = False
    for name, az in sorted(field.POSITIONS.items(), key=lambda item: item[1]):
        if imgui.selectable(f"{name} ({az:+.0f} deg)", shown == name)[0]:
            settings.aim_direction, settings.direction = True, az
    imgui.end_combo()


def _caption(settings, r) -> None:
    if not settings.aim_direction:
        imgui.text_disabled(f"source goes {r.source_azimuth_deg:+.0f} deg; click the wheel to aim")
        return
    if r.aim_reached is None:
        imgui.text_wrapped(f"asked {settings.direction:+.0f} deg ({field.region(settings.direction)}): "
                           "aiming when the target holds still")
        return
    _outcome(f"asked {settings.direction:+.0f} deg ({field.region(settings.direction)}), "
             f"goes {r.ball_azimuth_deg:+.0f}", r.aim_range_deg, r.aim_reached)


def _outcome(text: str, reach: tuple, reached: bool) -> None:
    """What an aim gives and its reach; red with "closest it gives" when the ask was out of it."""
    lo, hi = reach or (float("nan"), float("nan"))
    text = f"{text} (reach {lo:+.0f}..{hi:+.0f})"
    if reached:
        imgui.text_wrapped(text)
    else:
        imgui.push_style_color(imgui.Col_.text, imgui.ImVec4(*MISS_RGBA))
        imgui.text_wrapped(text + ": closest it gives")
        imgui.pop_style_color()


def _elevation(settings, r) -> None:
    """With a direction asked: the ball's elevation asked too (the face tilted), and what it gives."""
    if not settings.aim_direction:
        return
    changed, on = imgui.checkbox("elevation##aim", settings.aim_elevation)
    if changed:
        settings.aim_elevation = on
    if not settings.aim_elevation:
        return
    imgui.same_line()
    changed, v = imgui.slider_float("##aim_elevation", settings.elevation, -60.0, 60.0, "%+.0f deg")
    if changed:
        settings.elevation = v
    if r.aim_elevation_reached is not None:
        _outcome(f"goes {r.ball_elevation_deg:+.0f} deg up", r.aim_elevation_range_deg, r.aim_elevation_reached)
