"""Capture: screenshots of the whole window (F12) and an export of the adapted
shot: one folder per export holding the rendered frames (PNG sequence and an
mp4 through imageio-ffmpeg, H.264 yuv420p tagged and converted as BT.709) and
the motion itself as BVH and glTF, so the user can take what they made into
their own tools. The folder is written under a temporary name beside the target
and renamed when complete: a failed export leaves nothing half-written.

Frames are encoded by a background thread (:class:`FrameEncoder`) while the
caller renders the next ones; :class:`ExportJob` spreads an export over viewer
frames (a few frames rendered per ``step``, with its ``progress``), so the
viewer never freezes. :func:`clean_render` turns the editing overlays off for a
clean video."""
from __future__ import annotations

import contextlib
import dataclasses
import os
import queue
import shutil
import tempfile
import threading
import time
from dataclasses import fields
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


def _claim_temp_folder(path: str | os.PathLike) -> tuple[Path, Path]:
    """(target, a new temporary folder beside it) for a folder written then renamed."""
    target = Path(path)
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise FileExistsError(f"{target} already exists")
    if not target.parent.is_dir():   # one new folder, never a whole tree from a typo
        raise FileNotFoundError(f"{target}: folder {target.parent} does not exist")
    return target, Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp"))


def _publish(tmp: Path, target: Path) -> None:
    mask = os.umask(0)
    os.umask(mask)
    os.chmod(tmp, 0o777 & ~mask)    # mkdtemp makes it private
    os.replace(tmp, target)


@contextlib.contextmanager
def atomic_folder(path: str | os.PathLike):
    """Yield a temporary folder beside ``path``; on success it is renamed to
    ``path`` (which must not exist, or be empty), on error it is removed."""
    target, tmp = _claim_temp_folder(path)
    try:
        yield tmp
        _publish(tmp, target)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


# H.264 that players show in the right colours: RGB -> Y'CbCr with the BT.709
# matrix (ffmpeg's default is BT.601), limited range, tagged as such; odd sizes
# padded by a pixel (not stretched).
VIDEO_OUTPUT_PARAMS = ["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2,scale=out_color_matrix=bt709:out_range=tv,"
                       "format=yuv420p", "-colorspace", "bt709", "-color_primaries", "bt709",
                       "-color_trc", "bt709", "-color_range", "tv",
                       "-x264-params", "colorprim=bt709:transfer=bt709:colormatrix=bt709"]
ENCODER_QUEUE = 8          # frames waiting for the encoder: bounded memory, the renderer waits past it


class FrameEncoder:
    """Writes ``(h,w,3)`` uint8 frames to ``frame_0000.png...`` and/or ``{stem}.mp4``
    in ``out_dir`` on a background thread: ``put`` hands a frame over (waiting only
    when ``ENCODER_QUEUE`` frames are pending), ``close`` waits for the rest and
    raises what the thread met; ``written`` counts the frames done."""

    def __init__(self, out_dir: Path, stem: str, fps: float, png: bool = True, mp4: bool = True):
        self.out_dir, self.stem, self.fps, self.png, self.mp4 = Path(out_dir), stem, fps, png, mp4
        self.written = 0
        self._queue: queue.Queue = queue.Queue(ENCODER_QUEUE)
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="hitpoint-encoder", daemon=True)
        self._thread.start()

    def put(self, image: np.ndarray) -> None:
        if self._error is not None:
            raise self._error
        while self._thread.is_alive():
            try:
                self._queue.put(image, timeout=0.1)
                return
            except queue.Full:
                continue
        raise self._error or RuntimeError("the encoder stopped")

    def close(self) -> int:
        """Wait for every frame; the number written (raises the encoder's error)."""
        if self._thread.is_alive():
            self._queue.put(None)
            self._thread.join()
        if self._error is not None:
            raise self._error
        return self.written

    def _run(self) -> None:
        writer = None
        try:
            if self.mp4:     # imageio-ffmpeg (a dependency) bundles the ffmpeg binary
                writer = iio2.get_writer(self.out_dir / f"{self.stem}.mp4", fps=self.fps, codec="libx264",
                                         macro_block_size=1, output_params=VIDEO_OUTPUT_PARAMS,
                                         ffmpeg_log_level="error")
            while (img := self._queue.get()) is not None:
                if self.png:
                    write_png(self.out_dir / f"frame_{self.written:04d}.png", img)
                if writer is not None:
                    writer.append_data(img)
                self.written += 1
        except BaseException as e:       # handed to the caller by put / close
            self._error = e
            with contextlib.suppress(queue.Empty):
                while True:
                    self._queue.get_nowait()     # free a renderer waiting on a full queue
        finally:
            if writer is not None:
                try:
                    writer.close()
                except Exception as e:
                    self._error = self._error or e


def write_frames(images, out_dir: Path, stem: str, fps: float, png: bool = True, mp4: bool = True,
                 on_progress=None) -> int:
    """Stream ``(h,w,3)`` uint8 images to ``frame_0000.png...`` and/or
    ``{stem}.mp4`` (H.264, yuv420p BT.709: plays everywhere) in ``out_dir``,
    encoding on a background thread while ``images`` renders the next ones;
    ``on_progress(frames_rendered)`` after each. Returns the number of frames."""
    encoder = FrameEncoder(out_dir, stem, fps, png, mp4)
    try:
        for count, img in enumerate(images, 1):
            encoder.put(img)
            if on_progress is not None:
                on_progress(count)
    finally:
        written = encoder.close()
    return written


def write_motion(out_dir: Path, stem: str, skeleton, clip, formats, takes=None, source_capture=None) -> list[Path]:
    """The clip as ``{stem}.bvh`` / ``.glb`` / ``.gltf`` in ``out_dir`` (those asked for);
    the glTF holds ``takes`` (engine.export.shot_takes: adapted + source, the ball) if given.
    A user's capture (``source_capture``, engine.capture.Capture) goes back on its own skeleton:
    the BVH in its units, the glTF at its real size without the batsman's mesh."""
    paths = []
    if "bvh" in formats:
        paths.append(out_dir / f"{stem}.bvh")
        if source_capture is None:
            bvh.write(paths[-1], skeleton, clip)
        else:
            source_capture.write(paths[-1], clip.local_rotations, clip.root_positions, name=stem)
    anims = clip if takes is None else takes
    if source_capture is not None:
        skeleton, anims = _on_capture_skeleton(source_capture, anims)
    for ext in ("glb", "gltf"):
        if ext in formats:
            paths.append(write_gltf(out_dir / f"{stem}.{ext}", skeleton, anims, name=stem,
                                    with_mesh=source_capture is None))
    return paths


def _on_capture_skeleton(source_capture, anims):
    """(the capture's file skeleton in cm, ``anims`` (a clip or engine.gltf_export.Take list) on it)."""
    def moved(c):
        return source_capture.to_file_cm(c.local_rotations, c.root_positions)
    if not isinstance(anims, list):
        return moved(anims)
    takes = [dataclasses.replace(t, clip=moved(t.clip)[1]) for t in anims]
    return moved(anims[0].clip)[0], takes


def export_shot(out_dir, images, fps: float, skeleton, clip, stem: str = "shot", formats=None, takes=None,
                on_progress=None) -> Path:
    """One export folder ``out_dir``: motion files first (quick, and a bad clip
    fails before any rendering), then the frames. Atomic (see ``atomic_folder``)."""
    formats = check_formats(formats)
    with atomic_folder(out_dir) as tmp:
        write_motion(tmp, stem, skeleton, clip, formats, takes)
        if "png" in formats or "mp4" in formats:
            write_frames(images, tmp, stem, fps, png="png" in formats, mp4="mp4" in formats,
                         on_progress=on_progress)
    return Path(out_dir)


class ExportJob:
    """An export spread over viewer frames, so the window never freezes: the motion
    files at once, then each :meth:`step` renders frames with ``render(f) -> (h,w,3)``
    on the caller's (GL) thread for about ``budget_s`` and hands them to the
    background encoder. ``progress`` in [0, 1] for the panel; ``done`` once the
    folder is complete and renamed into place; :meth:`abort` (or an error) leaves
    nothing."""

    def __init__(self, out_dir, num_frames: int, fps: float, skeleton, clip, stem: str = "shot", formats=None,
                 takes=None, source_capture=None):
        formats = check_formats(formats)
        self.target, self.tmp = _claim_temp_folder(out_dir)
        self.num_frames, self.next_frame, self.done = int(num_frames), 0, False
        self.encoder = None
        try:
            write_motion(self.tmp, stem, skeleton, clip, formats, takes, source_capture)
            if "png" in formats or "mp4" in formats:
                self.encoder = FrameEncoder(self.tmp, stem, fps, "png" in formats, "mp4" in formats)
            else:
                self.num_frames = 0
        except BaseException:
            self.abort()
            raise

    @property
    def progress(self) -> float:
        """Share of the frames encoded (rendered ones still queued do not count)."""
        if self.done or self.num_frames == 0:
            return 1.0 if self.done else 0.0
        return min(self.encoder.written, self.num_frames) / self.num_frames

    def step(self, render, budget_s: float = 0.02) -> bool:
        """Render and queue frames for about ``budget_s`` (at least one); finish when all
        are rendered. True when the export is complete. Errors abort and re-raise."""
        try:
            start = time.perf_counter()
            while self.next_frame < self.num_frames:
                self.encoder.put(render(self.next_frame))
                self.next_frame += 1
                if time.perf_counter() - start >= budget_s:
                    return False
            if self.encoder is not None:
                self.encoder.close()
            _publish(self.tmp, self.target)
            self.done = True
            return True
        except BaseException:
            self.abort()
            raise

    def abort(self) -> None:
        """Stop and remove the temporary folder (a finished export is kept)."""
        if self.encoder is not None:
            with contextlib.suppress(BaseException):
                self.encoder.close()
        if not self.done:
            shutil.rmtree(self.tmp, ignore_errors=True)


# Overlays a clean render turns off: the editing aids (ghost, lines, crosses, paths);
# the batsman, the ball and the ground stay.
CLEAN_OFF = ("skeleton", "hit_points", "ball_path", "desired_point", "bat_path", "source_bat_path", "flight",
             "target")


@contextlib.contextmanager
def clean_render(overlays):
    """Within: ``overlays`` (app.viewer.settings.Overlays) without the editing aids,
    for a clean video; restored after, whatever happens."""
    saved = {f.name: getattr(overlays, f.name) for f in fields(overlays)}
    try:
        for name in CLEAN_OFF:
            setattr(overlays, name, False)
        overlays.ghost = "off"
        yield overlays
    finally:
        for name, value in saved.items():
            setattr(overlays, name, value)


def describe_export(out_dir: Path) -> str:
    """One line for the panel: where, and what (frames counted, other files named)."""
    files = sorted(p.name for p in Path(out_dir).iterdir())
    frames = sum(1 for f in files if f.startswith("frame_") and f.endswith(".png"))
    others = [f for f in files if not (f.startswith("frame_") and f.endswith(".png"))]
    parts = ([f"{frames} PNG frames"] if frames else []) + others
    return f"{out_dir}: {', '.join(parts) if parts else 'nothing'}"
