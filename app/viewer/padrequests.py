"""What the user asks of the PC pad (its widget, the timeline while a take is shown, scripts):
:class:`PadRequest`, each checked once (:func:`check_request`) and carried out in order in the
frame's update (:func:`step`) on the pad's model (app.viewer.pcpad)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.viewer import pcpad
from app.viewer.capture import safe_stem, write_new
from engine import synth


@dataclass(frozen=True)
class PadRequest:
    """One thing the user asked of the pad (its widget, a script), carried out in order by
    :func:`step` in the frame's update. ``action`` is a key of :data:`PAD_ACTIONS`."""
    action: str
    value: object = None          # the action's argument: scores (2,), a take index, a preset, an option
    final: bool = False           # "marker": the last point of a drag (draw mode: the stroke becomes a take)


def _marker(state, pad, r):
    pcpad.set_scores(state, r.value, final=r.final)


def _stroke_start(state, pad, r):
    pad.stroke = []


def _stroke_end(state, pad, r):
    pcpad.finish_stroke(state)


def _preset(state, pad, r):
    pcpad.apply_preset(state, r.value)


def _remake_preset(state, pad, r):
    """The amount slider let go: the preset shown is made again with the new amount."""
    if pad.anim is not None and pad.path_kind == pad.preset:
        pcpad.apply_preset(state, pad.preset, replace=True)


def _take(state, pad, r):
    pcpad.show_take(state, int(r.value))


def _forget(state, pad, r):
    if 0 <= pad.take < len(pad.shot_takes(state.shot.name)):
        pcpad.delete_take(state, pad.take)


def _back(state, pad, r):
    pcpad.release(state)


def _play(state, pad, r):
    """Play/pause: pause what plays, play the paused take, or else the shot's own 2-PC path."""
    if pad.playing:
        pad.playing = False
    elif pad.anim is not None:
        pad.playing = True
    else:
        pcpad.play_source_path(state)


def _seek(state, pad, r):
    """The timeline dragged while a take is shown: that frame of the take, paused."""
    if pad.anim is not None:
        pad.playing = False
        pad.play_time = min(float(r.value), pad.anim.num_frames - 1) / pad.anim.fps
        pcpad.show_frame(pad, pad.play_time * pad.anim.fps)


def _detail(state, pad, r):
    """The source-detail box: the marker's pose or the take shown made again with it or without
    (a take of the other kind is another take: both stay to compare)."""
    pad.detail = bool(r.value)
    take = pcpad.shown_take(state)
    if take is not None and take.detail != pad.detail:
        pcpad.make_take(state, take.points, take.times, take.kind)
    elif pad.live and pad.marker is not None:
        pad.pose = pcpad.pose_at_scores(state, pad.marker)


def _export(state, pad, r):
    """The take shown as BVH in a new file of the working directory (never over an earlier one)."""
    out = write_new(".", f"hitpoint_synth_{safe_stem(state.shot.name)}_", ".bvh",
                    lambda path: pcpad.export_animation(state, path))
    pad.info = f"wrote {out}"


def _option(name: str):
    def set_option(state, pad, r):
        setattr(pad, name, r.value)
    return set_option


# action -> (carry it out, what its value must be: None, "scores", "index", "frame", a tuple of choices, bool,
# float)
PAD_ACTIONS = {
    "marker": (_marker, "scores"), "stroke_start": (_stroke_start, None), "stroke_end": (_stroke_end, None),
    "preset": (_preset, tuple(pcpad.PRESET_LABELS)), "remake_preset": (_remake_preset, None),
    "take": (_take, "index"), "forget": (_forget, None), "back": (_back, None), "play": (_play, None),
    "seek": (_seek, "frame"),
    "export": (_export, None), "mode": (_option("mode"), pcpad.PAD_MODES), "amount": (_option("amount"), float),
    "fix_hand": (_option("fix_hand"), bool), "plant_feet": (_option("plant_feet"), bool),
    "detail": (_detail, bool),
    "loop": (_option("loop"), bool),
}


def check_request(action, value=None, final: bool = False) -> PadRequest:
    """A PadRequest whose value suits its action, or ValueError naming what is wrong (scripts
    are checked with this when loaded)."""
    if action not in PAD_ACTIONS:
        raise ValueError(f"unknown PC pad action {action!r} (known: {', '.join(PAD_ACTIONS)})")
    kind = PAD_ACTIONS[action][1]
    if kind == "scores":
        value = np.asarray(value, float).reshape(-1)[:2]
        ok = value.size == 2 and bool(np.isfinite(value).all())
    elif kind == "frame":
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and 0.0 <= value <= synth.MAX_SYNTH_FRAMES
        value = float(value) if ok else value
    elif kind == "index":
        ok = isinstance(value, int) and not isinstance(value, bool) and 0 <= value < pcpad.MAX_TAKES_PER_SHOT
    elif kind is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and 0.0 <= value <= 1.0
        value = float(value) if ok else value
    elif kind is bool:
        ok = isinstance(value, bool)
    else:
        ok = value is None if kind is None else value in kind
    if not ok:
        raise ValueError(f"PC pad action {action!r}: bad value {value!r}")
    return PadRequest(action, value, bool(final))


def step(state, requests, dt: float) -> None:
    """The pad's part of the frame's update: refit for a new shot, advance what plays, carry out
    ``requests`` in order. While the target is dragged nothing happens: a drag can switch shots
    every frame and the refit takes ~100 ms (the widget says so)."""
    if state.dragging_target:
        return
    pad = pcpad.sync(state)
    if pad is None:
        return
    pcpad.advance(pad, dt)
    for request in requests:
        try:
            PAD_ACTIONS[request.action][0](state, pad, request)
        except Exception as e:     # a bad take or a failed export: a panel message, not a dead window
            state.report(f"pc pad: {request.action}: {e}")
