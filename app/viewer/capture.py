"""Capture: screenshots of the whole window (F12) and an export of the adapted
shot: one folder per export holding the rendered frames (PNG sequence and an
mp4 through imageio-ffmpeg) and the motion itself as BVH and glTF, so the user
can take what they made into their own tools. The folder is written under a
temporary name beside the target and renamed when complete: a failed export
leaves nothing half-written."""
from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import time
from pathlib import Path

import imageio.v2 as iio2
import imageio.v3 as iio
import numpy as np

from engine import bvh
from engine.atomic import atomic_output   # refuses a missing folder: a typo makes no tree
from engine.gltf_export import write_gltf


def read_rgb(fbo) -> np.ndarray:
    """``(h, w, 3)`` uint8 image of a framebuffer, top row first."""
    w, h = fbo.size
    data = fbo.read(components=3, alignment=1)
    return np.frombuffer(data, np.uint8).reshape(h, w, 3)[::-1].copy()


def write_png(path: str | Path, image: np.ndarray) -> Path:
    """Write a PNG atomically (temp file in the same folder, then rename)."""
    path = Path(path)
    with atomic_output(path) as tmp:
        iio.imwrite(tmp, image, extension=".png")
    return path


MAX_SAME_NAME = 10_000     # names tried for one millisecond before giving up (a folder full of them)
MAX_STEM_CHARS = 60        # a shot name in a file name is cut to this and made filesystem-safe


def safe_stem(text: str) -> str:
    """``text`` usable in a file name anywhere: letters, digits, ``-`` and ``_`` only."""
    stem = "".join(c if c.isalnum() or c in "-_" else "_" for c in str(text))[:MAX_STEM_CHARS]
    return stem or "shot"


def _stamped_names(prefix: str, suffix: str):
    """``{prefix}YYYYmmdd_HHMMSS_mmm{suffix}``, then ``..._mmm_2{suffix}``, ``_3``...: to the
    millisecond, so two captures in one second differ, and a counter for the same millisecond."""
    now = time.time()
    stamp = time.strftime("%Y%m%d_%H%M%S", time.localtime(now)) + f"_{int(now * 1000) % 1000:03d}"
    yield f"{prefix}{stamp}{suffix}"
    for n in range(2, MAX_SAME_NAME + 1):
        yield f"{prefix}{stamp}_{n}{suffix}"


def reserve_new(folder: str | os.PathLike, prefix: str, suffix: str, directory: bool = False) -> Path:
    """Create, and so claim, a new empty file (or folder) with a time-stamped name in
    ``folder``: the creation is exclusive (O_EXCL / mkdir), so nothing is ever
    overwritten, not even by another viewer writing there in the same millisecond.
    The caller replaces it atomically, or removes it with ``release``."""
    folder = Path(folder)
    for name in _stamped_names(prefix, suffix):
        path = folder / name
        try:
            if directory:
                os.mkdir(path)
            else:
                os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))
        except FileExistsError:
            continue
        return path
    raise FileExistsError(f"{folder}: {MAX_SAME_NAME} files named {prefix}...{suffix} this millisecond")


def release(path: Path) -> None:
    """Remove a name claimed by ``reserve_new`` that was never written (still empty)."""
    with contextlib.suppress(OSError):
        if path.is_dir():
            path.rmdir()                 # only if still empty
        elif path.stat().st_size == 0:
            path.unlink()


def write_new(folder: str | os.PathLike, prefix: str, suffix: str, write) -> Path:
    """``write(path)`` into a newly claimed time-stamped name (``reserve_new``); on
    failure the claimed name is given back. Returns the path written."""
    path = reserve_new(folder, prefix, suffix)
    try:
        write(path)
    except BaseException:
        release(path)
        raise
    return path


def write_new_png(image: np.ndarray, folder: str | os.PathLike | None = None) -> Path:
    """An F12 screenshot: ``hitpoint_<time to the ms>.png`` in ``folder`` (default: the
    working directory), never over an earlier one."""
    return write_new(Path.cwd() if folder is None else folder, "hitpoint_", ".png",
                     lambda path: write_png(path, image))


# What an export can write; the default is all but the JSON flavour of glTF.
EXPORT_FORMATS = ("png", "mp4", "bvh", "glb", "gltf")
DEFAULT_EXPORT_FORMATS = ("png", "mp4", "bvh", "glb")


def new_export_dir(folder: str | os.PathLike | None = None) -> Path:
    """A new, claimed (empty) export folder ``hitpoint_export_<time to the ms>`` in
    ``folder`` (default: the working directory); ``export_shot`` fills it atomically,
    ``release`` gives it back if the export fails."""
    return reserve_new(Path.cwd() if folder is None else folder, "hitpoint_export_", "", directory=True)


def check_formats(formats) -> tuple[str, ...]:
    """Export formats as a tuple of known names (ValueError names the bad one)."""
    if formats is None:
        return DEFAULT_EXPORT_FORMATS
    if isinstance(formats, str):
        formats = [formats]
    names = tuple(dict.fromkeys(str(f).lower().lstrip(".") for f in formats))
    bad = [f for f in names if f not in EXPORT_FORMATS]
    if bad or not names:
        raise ValueError(f"unknown export format {bad[0] if bad else '(none)'!r} "
                         f"(known: {', '.join(EXPORT_FORMATS)})")
    return names


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike):
    """Yield a temporary folder beside ``path``; on success it is renamed to
    ``path`` (which must not exist, or be empty), on error it is removed."""
    target = Path(path)
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise FileExistsError(f"{target} already exists")
    if not target.parent.is_dir():   # one new folder, never a whole tree from a typo
        raise FileNotFoundError(f"{target}: folder {target.parent} does not exist")
    tmp = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp"))
    try:
        yield tmp
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, 0o777 & ~mask)    # mkdtemp makes it private
        os.replace(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def write_frames(images, out_dir: Path, stem: str, fps: float, png: bool = True, mp4: bool = True) -> int:
    """Stream ``(h,w,3)`` uint8 images to ``frame_0000.png...`` and/or
    ``{stem}.mp4`` (H.264, yuv420p: plays everywhere) in ``out_dir``.
    Returns the number of frames."""
    writer = None
    if mp4:     # imageio-ffmpeg (a dependency) bundles the ffmpeg binary
        writer = iio2.get_writer(out_dir / f"{stem}.mp4", fps=fps, codec="libx264", macro_block_size=2,
                                 ffmpeg_log_level="error")
    count = 0
    try:
        for count, img in enumerate(images, 1):
            if png:
                write_png(out_dir / f"frame_{count - 1:04d}.png", img)
            if writer is not None:
                writer.append_data(img)
    finally:
        if writer is not None:
            writer.close()
    return count


def write_motion(out_dir: Path, stem: str, skeleton, clip, formats) -> list[Path]:
    """The clip as ``{stem}.bvh`` / ``.glb`` / ``.gltf`` in ``out_dir`` (those asked for)."""
    paths = []
    if "bvh" in formats:
        paths.append(out_dir / f"{stem}.bvh")
        bvh.write(paths[-1], skeleton, clip)
    for ext in ("glb", "gltf"):
        if ext in formats:
            paths.append(write_gltf(out_dir / f"{stem}.{ext}", skeleton, clip, name=stem))
    return paths


def export_shot(out_dir, images, fps: float, skeleton, clip, stem: str = "shot", formats=None) -> Path:
    """One export folder ``out_dir``: motion files first (quick, and a bad clip
    fails before any rendering), then the frames. Atomic (see ``atomic_folder``)."""
    formats = check_formats(formats)
    with atomic_folder(out_dir) as tmp:
        write_motion(tmp, stem, skeleton, clip, formats)
        if "png" in formats or "mp4" in formats:
            write_frames(images, tmp, stem, fps, png="png" in formats, mp4="mp4" in formats)
    return Path(out_dir)


def describe_export(out_dir: Path) -> str:
    """One line for the panel: where, and what (frames counted, other files named)."""
    files = sorted(p.name for p in Path(out_dir).iterdir())
    frames = sum(1 for f in files if f.startswith("frame_") and f.endswith(".png"))
    others = [f for f in files if not (f.startswith("frame_") and f.endswith(".png"))]
    parts = ([f"{frames} PNG frames"] if frames else []) + others
    return f"{out_dir}: {', '.join(parts) if parts else 'nothing'}"
