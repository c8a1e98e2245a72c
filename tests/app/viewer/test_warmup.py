"""The engine compiled behind the window (app.warmup) and the CLI's compile note (app.cli.compile_note)."""
import io
import threading
import time

import numpy as np

from app.cli.compile_note import NOTE, CompileNote
from app.viewer.settings import ViewerSettings
from app.viewer.state import AppState
from app.viewer.update import choose, default_target, load_library, update
from app.viewer.warmup import EngineWarmup


def _library():
    state, settings = AppState(), ViewerSettings()
    assert load_library(state, None)
    settings.target = default_target(state)
    return state, settings


class Compiling:
    """A warm-up that has not finished: the update must not solve."""
    solver_ready, ready = threading.Event(), threading.Event()
    stage = "solver"


def test_while_the_solver_compiles_the_source_of_the_chosen_shot_shows():
    state, settings = _library()
    state.engine_warmup = Compiling()
    update(state, settings, 1 / 60)
    assert state.adaptation is None and state.solve_count == 0 and state.pose_source == "source"
    assert state.shot_index == choose(state, settings)[0]
    assert np.allclose(state.pose.global_positions, state.source_pose.global_positions)


def test_the_warm_up_touches_nothing_of_the_viewer_then_the_update_solves():
    state, settings = _library()
    warmup = EngineWarmup(state, settings).start()
    warmup.wait()
    assert warmup.solver_ready.is_set() and warmup.ready.is_set() and warmup.error == "", warmup.error
    assert state.adaptation is None and not state.adapters and state.pc_pad is None and not state.messages
    state.engine_warmup = warmup
    update(state, settings, 1 / 60)
    assert state.adaptation is not None and state.pose_source == "adapted" and state.errors == 0


def test_the_compile_note_is_one_line_once_a_compile_outlasts_a_moment():
    out = io.StringIO()
    note = CompileNote(out, after_s=0.05)
    note.on_start(None)
    note.on_end(None)                  # a quick compile (a cache load's size): no note
    time.sleep(0.15)
    assert out.getvalue() == ""
    note.on_start(None)
    note.on_start(None)                # a kernel compiling what it calls
    time.sleep(0.15)
    note.on_end(None)
    note.on_end(None)
    note.on_start(None)
    time.sleep(0.15)
    note.on_end(None)
    assert out.getvalue() == NOTE + "\n"


def test_the_learnt_child_compiles_the_learnt_solvers_and_the_cache_check_knows_their_kernels(monkeypatch):
    """The second child warms the learnt solvers (a later switch to one finds its kernels
    cached) and the check for it asks for the learnt lookup's kernels, not the others'."""
    import app.viewer.warmup as warmup_module
    from app.viewer.settings import SOLVERS
    from engine import learnt_ik
    from engine.learnt_solver import LEARNT_SOLVERS
    state, settings = _library()
    used = []
    monkeypatch.setattr(warmup_module, "solve", lambda st, se: used.append(se.solver))
    EngineWarmup(state, settings)._warm_solver()
    assert set(used) == {s for s in SOLVERS if s not in LEARNT_SOLVERS} and used[0] == settings.solver
    used.clear()
    EngineWarmup(state, settings)._warm_solver(LEARNT_SOLVERS)
    assert used == list(LEARNT_SOLVERS)
    assert learnt_ik._lookup_frames in warmup_module.warmed_kernels(learnt=True)
    assert learnt_ik._lookup_frames not in warmup_module.warmed_kernels()
    assert {k.py_func.__module__ for k in warmup_module.warmed_kernels()} == {
        "engine.frames_nb", "engine.end_nb", "engine.arms_nb", "engine.cleanup_nb"}
