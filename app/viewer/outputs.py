"""What the user asked the viewer to write: screenshots and exports, queued and run after
the frame's render, an export a few frames at a time (``capture.ExportJob``) so the window
never freezes. It reads the state and the settings and writes only files and the state's
capture readouts (``last_capture``, ``last_export``, ``export_progress``)."""
from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from app.viewer import capture, pcpad
from app.viewer.state import ExportNote
from app.viewer.update import ball_at, pose_at
from engine.export import shot_takes, take_animation
from engine.skeleton import Clip

EXPORT_BUDGET_S = 0.02     # export rendering per viewer frame: the window stays responsive


class Outputs:
    """``render_scene(fbo) -> bool`` draws this frame's scene into ``fbo``; ``frame()`` gives
    the last composed frame's framebuffer and ``viewport_px()`` the scene's ``(x, y, w, h)``."""

    def __init__(self, ctx, state, settings, render_scene, frame, viewport_px):
        self.ctx, self.state, self.settings = ctx, state, settings
        self._render_scene, self._frame, self._viewport_px = render_scene, frame, viewport_px
        self._screenshots: list[Path | None] = []
        self._exports: list[tuple] = []
        self._job = None          # (capture.ExportJob, framebuffer, folder, claimed) while one runs

    def screenshot(self, path=None) -> None:
        """Screenshot to ``path``, or (None: F12) to a new time-stamped name claimed when written."""
        self._screenshots.append(Path(path) if path else None)

    def export(self, out_dir=None, formats=None) -> None:
        """Export into the new folder ``out_dir``, or (None) a new time-stamped one; ``formats``
        as ``capture.check_formats`` returns them (None: the default ones)."""
        self._exports.append((Path(out_dir) if out_dir else None, formats))

    def read_frame(self) -> np.ndarray:
        """The last composed frame ``(h, w, 3)`` uint8."""
        return capture.read_rgb(self._frame())

    def step(self) -> None:
        """After the frame's render: the queued screenshots, then about EXPORT_BUDGET_S of export."""
        while self._screenshots:
            path = self._screenshots.pop(0)
            try:
                image = self.read_frame()
                written = capture.write_new_png(image) if path is None else capture.write_png(path, image)
                self.state.last_capture = str(written)
            except Exception as e:
                self.state.report(f"screenshot: {type(e).__name__}: {e}")
        if self._job is None and self._exports:
            self._start(*self._exports.pop(0))
        if self._job is not None:
            self._step(EXPORT_BUDGET_S)

    def finish(self) -> None:
        """Run the export under way and the queued ones to the end (at exit, scripted runs)."""
        while self._job is not None or self._exports:
            if self._job is None:
                self._start(*self._exports.pop(0))
            else:
                self._step(1.0)

    def _start(self, out, formats) -> None:
        """An export job for what the viewport shows (:func:`export_subject`): the motion (BVH /
        glTF with its takes and the ball) at once, then every frame rendered at the viewport's
        size (PNG sequence, mp4) a few at a time."""
        state, claimed = self.state, out is None
        try:
            out = capture.new_export_dir() if claimed else out
            subject = export_subject(state)
            job = capture.ExportJob(out, subject.clip.num_frames, state.fps, state.shot.skeleton, subject.clip,
                                    subject.stem, formats, subject.animations, state.shot.capture)
        except Exception as e:
            self._failed(out, claimed, e)
            return
        _, _, w, h = self._viewport_px()
        fbo = self.ctx.framebuffer([self.ctx.texture((w, h), 4)], self.ctx.depth_renderbuffer((w, h)))
        self._job = (job, fbo, out, claimed, subject.place)

    def _step(self, budget_s: float) -> bool:
        """Render the export's next frames for about ``budget_s`` (the pose on screen is put
        back after); True when no export runs any more."""
        job, fbo, out, claimed, place = self._job
        state, settings, keep = self.state, self.settings, self.settings.frame

        def render(f: int):
            place(f)
            with capture.clean_render(settings.overlays) if settings.clean_video else nullcontext():
                self._render_scene(fbo)
            return capture.read_rgb(fbo)
        try:
            done = job.step(render, budget_s)
        except Exception as e:
            self._end()
            self._failed(out, claimed, e)
            return True
        finally:
            pose_at(state, keep)
            ball_at(state, keep)
        state.export_progress = job.progress
        if done:
            self._end()
            state.last_capture = str(out)
            state.last_export = ExportNote(True, capture.describe_export(Path(out)))
        return done

    def _end(self) -> None:
        _, fbo, _, _, _ = self._job
        for a in (*fbo.color_attachments, fbo.depth_attachment):
            a.release()
        fbo.release()
        self._job, self.state.export_progress = None, None

    def _failed(self, out, claimed: bool, e: Exception) -> None:
        if claimed and out is not None:
            capture.release(out)
        self.state.report(f"export: {type(e).__name__}: {e}")
        self.state.last_export = ExportNote(False, f"export to {out} failed: {e}")


@dataclass(frozen=True)
class ExportSubject:
    clip: Clip                   # the motion written (cm, the rig's joints)
    stem: str                    # file names
    animations: list | None      # the glTF's (engine.gltf_export.Take: this one and the source, each with its ball)
    place: Callable[[int], None]  # puts the viewport's pose and ball at a frame of it, for the rendered frames


def export_subject(state) -> ExportSubject:
    """What an export writes: the PC-pad take in the viewport (its clip, its ball, the source
    beside it in the glTF), else the adapted shot (the source when nothing is adapted)."""
    shot, take = state.shot, pcpad.shown_take(state)
    if shot is None:
        raise ValueError("no shot loaded")
    if take is not None:
        imp = take.impact
        stem = capture.safe_stem(f"{shot.name}_{take.kind}_take")
        animations = [take_animation(state.rig, shot, take.anim, "synthesised", stem, imp.hit_point, state.ball_start,
                                     imp.hit_frame, imp.flight.path),
                      take_animation(state.rig, shot, shot.clip, "source", f"{shot.name}_source", shot.hit_point,
                                     state.ball_start)]
        return ExportSubject(take.anim, stem, animations, lambda f: pcpad.pose_take_frame(state, take, f))
    adapted = state.adaptation

    def place(f: int) -> None:
        pose_at(state, float(f))
        ball_at(state, float(f))
    if adapted is None:
        return ExportSubject(shot.clip, shot.name, None, place)
    clip = Clip(adapted.root_positions, adapted.local_rotations, shot.clip.fps)
    return ExportSubject(clip, f"{shot.name}_adapted", shot_takes(state.rig, shot, clip, state.desired_hit_point,
                                                                  state.ball_start, shot.hit_point), place)
