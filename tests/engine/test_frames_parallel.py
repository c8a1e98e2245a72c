"""Whole shots adapted on several threads (engine.frames_parallel) are the one-call answer, bit
for bit: the frames are independent, and each worker has its own outputs and hold windows."""
import numpy as np
import pytest

from engine import frames_parallel
from engine.adapt import AdaptSettings, Adapter
from engine.library import load_library

FIELDS = ("local_rotations", "global_rotations", "global_positions", "blend", "handles", "grip_error_cm",
          "grip_error_deg")


@pytest.fixture(scope="module")
def library(rig):
    return load_library(rig=rig)


def _adapt(monkeypatch, adapter, target, settings, threads, **kw):
    monkeypatch.setenv("HITPOINT_THREADS", str(threads))
    return adapter.adapt(target, settings, **kw)


@pytest.mark.parametrize("shot_name, settings", [
    ("back_foot_defence", AdaptSettings()),
    ("forward_defence", AdaptSettings(wrist_dof=2, trunk_reach=10.0)),
    ("leg_glance", AdaptSettings(solver="dls")),
    ("square_cut", AdaptSettings(face="free", twist="lead")),
])
def test_threads_give_the_one_call_answer(rig, library, monkeypatch, shot_name, settings):
    shot = next(s for s in library if s.name == shot_name)
    adapter = Adapter(rig, shot)
    assert np.count_nonzero(adapter.blend(settings.falloff) > 0) >= 3 * frames_parallel.MIN_FRAMES  # 3 workers
    rng = np.random.default_rng(7)
    for target in shot.hit_point + rng.uniform(-30, 30, size=(3, 3)):
        one = _adapt(monkeypatch, adapter, target, settings, 1)
        for threads in (2, 3):
            many = _adapt(monkeypatch, adapter, target, settings, threads)
            for name in FIELDS:
                assert np.array_equal(getattr(many, name), getattr(one, name)), (threads, name)
            assert many.bat_error_cm == one.bat_error_cm


def test_threads_from_a_start_pose_give_the_one_call_answer(rig, library, monkeypatch):
    """learnt+ccd's way in: the chains start from a pose other than the source's."""
    shot = next(s for s in library if s.name == "back_foot_defence")
    adapter = Adapter(rig, shot)
    start = shot.clip.local_rotations.copy()
    start[:, 1:] = start[::-1, 1:]      # any finite pose will do: the frames reversed
    target = shot.hit_point + np.array([12.0, -9.0, 6.0])
    one = _adapt(monkeypatch, adapter, target, AdaptSettings(), 1, start=start)
    many = _adapt(monkeypatch, adapter, target, AdaptSettings(), 2, start=start)
    assert np.array_equal(many.local_rotations, one.local_rotations)


def test_the_worker_count(monkeypatch):
    monkeypatch.setenv("HITPOINT_THREADS", "3")
    assert frames_parallel.worker_count() == 3
    for unset in ("", "0", "two", "-1"):
        monkeypatch.setenv("HITPOINT_THREADS", unset)
        assert 1 <= frames_parallel.worker_count() <= frames_parallel.MAX_WORKERS


def test_a_shot_with_few_frames_to_solve_is_one_call(rig, library, monkeypatch):
    """The drives solve a handful of frames near the hit: handing them out would cost more
    than it saves, so they stay on the caller's thread (with the lean carried, after the hit
    frame's own solve, itself one call, and not solved again)."""
    calls = []
    real = frames_parallel.adapt_frames
    monkeypatch.setattr(frames_parallel, "adapt_frames", lambda frames, *a: calls.append(len(frames)) or real(frames, *a))
    monkeypatch.setenv("HITPOINT_THREADS", "4")
    alone = AdaptSettings(carry_lean=False)
    shot = next(s for s in library if s.name == "straight_drive")
    Adapter(rig, shot).adapt(shot.hit_point + np.array([5.0, 5.0, 5.0]), alone)
    assert calls == [shot.num_frames]
    calls.clear()
    Adapter(rig, shot).adapt(shot.hit_point + np.array([5.0, 5.0, 5.0]))
    assert calls == [1, shot.num_frames - 1]         # the hit, then the others
    calls.clear()
    shot = next(s for s in library if s.name == "back_foot_defence")
    Adapter(rig, shot).adapt(shot.hit_point + np.array([5.0, 5.0, 5.0]), alone)
    assert len(calls) == 4 and sum(calls) == shot.num_frames
