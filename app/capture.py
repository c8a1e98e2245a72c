"""Capture: screenshots of the whole window (F12) and an export of the adapted
shot as a PNG sequence (or an mp4 when imageio-ffmpeg is available)."""
from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np


def read_rgb(fbo) -> np.ndarray:
    """``(h, w, 3)`` uint8 image of a framebuffer, top row first."""
    w, h = fbo.size
    data = fbo.read(components=3, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()


def write_png(path: str | Path, image: np.ndarray) -> Path:
    """Write a PNG atomically (temp file in the same folder, then rename)."""
    import imageio.v3 as iio
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    from engine.atomic import atomic_output
    with atomic_output(path) as tmp:
        iio.imwrite(tmp, image, extension=".png")
    return path


def default_screenshot_path() -> Path:
    return Path.cwd() / time.strftime("hitpoint_%Y%m%d_%H%M%S.png")


def default_export_dir() -> Path:
    return Path.cwd() / time.strftime("hitpoint_export_%Y%m%d_%H%M%S")


def have_ffmpeg() -> bool:
    try:
        import imageio_ffmpeg  # noqa: F401
    except ImportError:
        return False
    return True


def export_frames(images, out_dir: str | Path, fps: float, video: bool | None = None) -> Path:
    """Write an iterable of ``(h,w,3)`` images as ``frame_0000.png...`` in
    ``out_dir`` (plus ``shot.mp4`` if ffmpeg is available and ``video`` is not
    False). Returns the folder."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    video = have_ffmpeg() if video is None else video
    frames = []
    for i, img in enumerate(images):
        write_png(out_dir / f"frame_{i:04d}.png", img)
        if video:
            frames.append(img)
    if video and frames:
        import imageio.v2 as iio2
        tmp = out_dir / ".shot.mp4"
        with iio2.get_writer(tmp, fps=fps, codec="libx264", macro_block_size=2) as writer:
            for img in frames:
                writer.append_data(img)
        os.replace(tmp, out_dir / "shot.mp4")
    return out_dir
