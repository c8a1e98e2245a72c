"""Renderer: skinned batsman, cricket ground, props and overlays (moderngl)."""
from .scene import SceneRenderer, SceneView, look_at, offscreen_context, perspective, render_image

__all__ = ["SceneRenderer", "SceneView", "look_at", "offscreen_context", "perspective", "render_image"]
