"""Time as an input. Each frame, after the UI and before the update, time moves the frame
as a drag on the timeline would, and the settings are kept consistent with the library and
with the shot the update is about to show: the frame within that shot, on its hit frame when
the user watched the hit of the shot it replaces, and a pinned shot the library no longer
has unpinned. So the update only reads the settings (``app.update``)."""
from __future__ import annotations

import numpy as np

from app.viewer.settings import ViewerSettings
from app.viewer.state import AppState
from app.viewer.update import choose, solver_ready


def step(settings: ViewerSettings, state: AppState, dt: float) -> None:
    """Advance playback by ``dt`` seconds (a shot's fps, the playback rate, looping)."""
    settings.sanitise()
    if not state.shots:
        return
    if settings.pinned_shot is not None and settings.pinned_shot not in {s.name for s in state.shots}:
        settings.pinned_shot = None
    shot = next_shot(settings, state)
    old = state.shot
    if old is not None and shot is not old:
        if not settings.playing and abs(settings.frame - old.hit_frame) < 1e-6:
            settings.frame = float(shot.hit_frame)          # watching the hit: stay on it
    last = shot.num_frames - 1
    if settings.playing:
        settings.frame += max(dt, 0.0) * float(shot.clip.fps) * settings.playback_rate
        if settings.frame > last:
            settings.frame = settings.frame % (last + 1) if settings.loop else float(last)
            settings.playing = settings.loop
    settings.frame = float(np.clip(settings.frame, 0.0, last))


def next_shot(settings: ViewerSettings, state: AppState):
    """The shot this frame's update will show: the one the settings choose when it re-solves."""
    if settings.engine_key() == state.solved_key or not solver_ready(state) and state.adaptation is not None:
        return state.shot
    return state.shots[choose(state, settings)[0]]
