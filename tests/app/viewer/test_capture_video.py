"""The video of an export: BT.709 colour (converted and tagged), encoded on a
background thread, an export spread over viewer frames with its progress, a
clean render without the editing overlays (app.viewer.capture)."""
import subprocess
import threading

import imageio_ffmpeg
import numpy as np
import pytest

from app.viewer import capture
from app.viewer.settings import Overlays
from engine.skeleton import Clip, Skeleton

COLOURS = [(220, 30, 30), (30, 200, 40), (40, 60, 210), (128, 128, 128)]


def bars(h=33, w=47):
    """Odd-sized test image: four colour bars."""
    img = np.zeros((h, w, 3), np.uint8)
    for k, c in enumerate(COLOURS):
        img[:, k * w // 4:(k + 1) * w // 4] = c
    return img


def decoded(path):
    """First frame of ``path`` as ffmpeg decodes it by its own tags, and the stream line."""
    info = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-i", str(path)], capture_output=True, text=True).stderr
    gen = imageio_ffmpeg.read_frames(str(path))
    meta = next(gen)
    w, h = meta["size"]
    frame = np.frombuffer(next(gen), np.uint8).reshape(h, w, 3)
    gen.close()
    return frame, next(line for line in info.splitlines() if "Video:" in line)


def test_mp4_is_bt709_in_colour_and_tags_and_padded_not_stretched(tmp_path):
    enc = capture.FrameEncoder(tmp_path, "v", 30.0, png=True)
    for _ in range(4):
        enc.put(bars())
    assert enc.close() == 4 and len(list(tmp_path.glob("frame_*.png"))) == 4
    frame, stream = decoded(tmp_path / "v.mp4")
    assert "yuv420p(tv, bt709" in stream and "bt709/unknown" not in stream
    assert frame.shape == (34, 48, 3)                                  # padded by a pixel
    w = 47
    for k, c in enumerate(COLOURS):
        x = k * w // 4 + w // 8
        assert np.abs(frame[16, x].astype(int) - c).max() <= 6, (c, frame[16, x])   # BT.601 would be ~20 off


def test_the_encoder_runs_on_its_own_thread_and_reports_its_error(tmp_path):
    import shutil
    folder = tmp_path / "frames"
    folder.mkdir()
    enc = capture.FrameEncoder(folder, "v", 30.0, png=True, mp4=False)
    assert enc._thread is not threading.current_thread() and enc._thread.daemon
    shutil.rmtree(folder)                   # the PNGs cannot be written (root ignores permissions)
    with pytest.raises(FileNotFoundError):
        for _ in range(3 * capture.ENCODER_QUEUE):      # the renderer is never left waiting
            enc.put(bars())
        enc.close()


def tiny_take(frames=12):
    skel = Skeleton(["Root", "Tip"], [-1, 0], [[0, 90, 0], [0, 20, 0]])
    q = np.tile([1.0, 0, 0, 0], (frames, 2, 1))
    return skel, Clip(np.tile([0.0, 90, 0], (frames, 1)), q, 30.0)


def test_an_export_job_spreads_over_steps_with_progress_then_lands(tmp_path):
    skel, clip = tiny_take()
    out = tmp_path / "export"
    job = capture.ExportJob(out, clip.num_frames, 30.0, skel, clip, "t", ["png", "mp4", "bvh"])
    rendered, steps, seen = [], 0, []
    while not job.step(lambda f: rendered.append(f) or bars(), budget_s=0.0):   # one frame a step
        steps += 1
        seen.append(job.progress)
        assert not out.exists()                                          # nothing visible until complete
    assert rendered == list(range(clip.num_frames)) and steps == clip.num_frames
    assert seen == sorted(seen) and 0 <= seen[0] < 1 and job.progress == 1.0 and job.done
    assert sorted(p.name for p in out.iterdir()) == sorted(
        [f"frame_{i:04d}.png" for i in range(clip.num_frames)] + ["t.mp4", "t.bvh"])
    assert [p.name for p in tmp_path.iterdir()] == ["export"]


def test_a_failing_or_aborted_export_job_leaves_nothing(tmp_path):
    skel, clip = tiny_take()

    def broken(f):
        if f == 3:
            raise RuntimeError("GPU lost")
        return bars()
    job = capture.ExportJob(tmp_path / "a", clip.num_frames, 30.0, skel, clip, "t", ["png", "bvh"])
    with pytest.raises(RuntimeError, match="GPU lost"):
        while not job.step(broken):
            pass
    job2 = capture.ExportJob(tmp_path / "b", clip.num_frames, 30.0, skel, clip, "t", ["mp4"])
    job2.step(lambda f: bars(), budget_s=0.0)
    job2.abort()
    assert list(tmp_path.iterdir()) == []


def test_clean_render_turns_the_editing_aids_off_and_restores_them():
    o = Overlays(skeleton=True)
    before = vars(o).copy()
    with pytest.raises(KeyError):
        with capture.clean_render(o):
            assert o.ghost == "off" and not any(getattr(o, n) for n in capture.CLEAN_OFF)
            assert o.ball and o.pitch                                   # the scene itself stays
            assert not o.target                                         # nor the disc the user drags
            raise KeyError("mid-export failure")
    assert vars(o) == before


def test_a_clean_render_draws_no_target():
    from app.render.submit import build_scene_view
    from app.viewer.camera import OrbitCamera
    from app.viewer.settings import ViewerSettings
    from app.viewer.state import AppState
    settings, state = ViewerSettings(), AppState()
    args = (state, settings, OrbitCamera(), (320, 240))
    assert build_scene_view(*args).target_position is not None
    with capture.clean_render(settings.overlays):
        assert build_scene_view(*args).target_position is None


def test_the_panel_draws_the_export_progress_bar():
    from app.viewer.loop import App
    app = App((640, 360), headless=True)
    try:
        app.frame(dt=1 / 60)
        errors = app.state.errors
        app.state.export_progress = 0.4          # what the loop keeps while an ExportJob runs
        app.frame(dt=1 / 60)
        app.state.export_progress = None
        app.frame(dt=1 / 60)
        assert app.state.errors == errors, app.state.messages
    finally:
        app.close()
