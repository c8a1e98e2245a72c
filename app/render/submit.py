"""Render submission: turn the state, settings and camera into one
``app.render.SceneView`` (plain arrays) for ``SceneRenderer.render``."""
from __future__ import annotations

from collections import OrderedDict

import numpy as np

from app.render.scene import SceneView
from app.viewer.camera import OrbitCamera
from app.viewer.picking import TARGET_NORMAL
from app.viewer.settings import ViewerSettings
from app.viewer.state import AppState
from engine.skeleton import skinning_matrices

HIT_POINT_RGBA = (0.2, 0.45, 1.0, 1.0)          # the nine FK hit points: blue crosses
CHOSEN_RGBA = (0.55, 0.8, 1.0, 1.0)
BALL_PATH_RGBA = (1.0, 1.0, 1.0, 0.55)
DESIRED_RGBA = (1.0, 0.85, 0.1, 1.0)
BAT_PATH_RGBA = (1.0, 0.55, 0.1, 0.95)
SOURCE_BAT_PATH_RGBA = (0.6, 0.65, 0.75, 0.7)
FLIGHT_RGBA = (0.3, 1.0, 0.45, 0.9)
SKELETON_RGBA = (1.0, 0.9, 0.2, 1.0)
GHOST_SKELETON_RGBA = (0.7, 0.8, 1.0, 0.8)


# Software GL redraws the static layer for every new view; multisampled it costs ~17 ms a
# frame more on llvmpipe, so an orbit draws it single-sampled and the 4x MSAA copy is made
# once the camera has held still this long (orbit in an Xvfb window: 35 -> 17 ms).
CAMERA_SETTLE_S = 0.2

def build_scene_view(state: AppState, settings: ViewerSettings, camera: OrbitCamera,
                     size: tuple[int, int]):
    """The ``SceneView`` of this frame for a viewport of ``size = (w, h)`` pixels."""
    w, h = int(size[0]), int(size[1])
    o = settings.overlays
    parents = state.rig.skeleton.parents if state.rig is not None else None
    view = SceneView(view=camera.view(), proj=camera.proj(w / max(h, 1)), size=(w, h),
                     skin_matrices=_skin(state.pose, state, skinning_matrices))
    view.show_pitch = o.pitch and state.terrain is None
    view.terrain = state.terrain
    view.antialias = bool(settings.antialias)
    view.camera_moving = state.camera_still_s < CAMERA_SETTLE_S
    view.target_position = np.asarray(settings.target, np.float32) if o.target else None
    view.target_normal = TARGET_NORMAL
    view.target_highlight = bool(state.hover_target or state.dragging_target)
    ghost, ghost_mode = ghost_pose(state, settings)
    if ghost is not None and ghost_mode == "mesh":
        view.ghost_skin_matrices = _skin(ghost, state, skinning_matrices)
    lines = []
    if ghost is not None and ghost_mode == "skeleton":
        lines.append((ghost.global_positions, parents, GHOST_SKELETON_RGBA))
    if state.pose is not None and o.skeleton:
        lines.append((state.pose.global_positions, parents, SKELETON_RGBA))
    view.skeleton_lines = lines
    crosses, points, polylines = [], [], []
    if o.hit_points and len(state.hit_points):
        crosses.append((state.hit_points.astype(np.float32), HIT_POINT_RGBA, 8.0))
        if state.shot is not None:
            crosses.append((state.hit_points[state.shot_index:state.shot_index + 1].astype(np.float32),
                            CHOSEN_RGBA, 11.0))
    if o.ball_path:
        polylines.append((np.array([state.ball_start, settings.target], np.float32), BALL_PATH_RGBA, 1.5))
    if o.desired_point and state.desired_hit_point is not None:
        points.append((state.desired_hit_point[None].astype(np.float32), DESIRED_RGBA, 9.0))
    bat = state.rig.bat_joint if state.rig is not None else None
    if o.source_bat_path and state.shot is not None:
        polylines.append((state.shot.fk[1][:, bat].astype(np.float32), SOURCE_BAT_PATH_RGBA, 1.5))
    if o.bat_path and state.adaptation is not None:
        polylines.append((state.adaptation.global_positions[:, bat].astype(np.float32), BAT_PATH_RGBA, 2.5))
    if o.flight and state.shown_flight is not None and len(state.shown_flight) > 1:
        polylines.append((state.shown_flight.astype(np.float32), FLIGHT_RGBA, 2.0))
    view.crosses, view.points, view.polylines = crosses, points, polylines
    if o.ball and state.ball_position is not None:
        view.ball_position = np.asarray(state.ball_position, np.float32)
    return view


def ghost_pose(state: AppState, settings: ViewerSettings):
    """(pose, "mesh" | "skeleton" | "off") the ghost draws, in the ghost overlay's mode: the
    compared solver's pose when a comparison is asked, else the source."""
    if settings.compare_solver != "off" and state.compare_pose is not None:
        return state.compare_pose, settings.overlays.ghost
    return state.source_pose, settings.overlays.ghost


_SKIN_CACHE: OrderedDict = OrderedDict()     # pose bytes -> skinning matrices; the last few


def _skin(pose, state: AppState, skinning_matrices) -> np.ndarray | None:
    """Skinning matrices ``(J,4,4)`` of ``pose``; the last few are remembered (while the
    target is dragged the source pose stays the same frame after frame)."""
    if pose is None or state.bind_positions is None:
        return None       # nothing to pose (no library): the renderer draws no batsman
    key = b"".join(np.ascontiguousarray(a, float).tobytes() for a in (
        pose.global_rotations, pose.global_positions, state.bind_positions))
    m = _SKIN_CACHE.get(key)
    if m is None:
        m = skinning_matrices(pose.global_rotations, pose.global_positions, state.bind_positions)
        m.flags.writeable = False          # shared between frames' views
        _SKIN_CACHE[key] = m
        while len(_SKIN_CACHE) > 4:
            _SKIN_CACHE.popitem(last=False)
    else:
        _SKIN_CACHE.move_to_end(key)
    return m
