"""Uneven ground in the viewer (``hitpoint view --terrain SPEC``): the terrain mesh drawn
instead of the pitch, under the library's captures (e.g. a ``hitpoint terrain`` result)."""
from __future__ import annotations

import numpy as np

from app.viewer.state import AppState

MARGIN_CM = 150.0       # the mesh reaches this far past every shot's joints
CELL_CM = 5.0


def show_terrain(state: AppState, spec: str) -> None:
    """Build the terrain of ``spec`` around the library's shots (stairs along the first
    shot's walk) into ``state.terrain``."""
    from app.cli.terrain_strip import load_terrain
    from app.render.props import terrain_prop
    from engine.terrain import terrain_mesh
    if not state.shots:
        return
    ground = load_terrain(spec, state.shots[0].clip.root_positions)
    pos = np.concatenate([s.fk[1].reshape(-1, 3) for s in state.shots])
    lo, hi = pos.min(0) - MARGIN_CM, pos.max(0) + MARGIN_CM
    state.terrain = terrain_prop(*terrain_mesh(ground, (lo[0], hi[0]), (lo[2], hi[2]), CELL_CM))
