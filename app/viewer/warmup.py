"""The engine compiled behind the window. On a fresh install numba compiles the solver's
kernels (tens of seconds, then cached on disk) while the window shows the source shot and
the panel says so. The update solves from the frame ``solver_ready`` is set, and the PC pad
(its compiled FK, synthesis and clean-up) from ``ready``. A thread runs a solve and a pad take
on scratch copies of the library; nothing of the viewer's state is touched.

With ``apart`` and a cold cache the compiling itself runs in a child process
(``python -m app.warmup``) that fills the disk cache, and the thread then only loads it:
compiling in this process would hold numba's global compiler lock for tens of seconds, and the
window's own small kernels (shadow fit, screen boxes) waited on it at their first use (the
first frame came at 55 s, measured). The child also leaves this process's GIL alone.

With ``softgl`` (the window runs the software-GL profile) the profile's kernels are compiled
too, after the solver's (``app.softgl.kernels``): until then the window draws the plain way.
Last, and waited for by nobody, a second child compiles the learnt solvers' kernels, so a
later switch to one does not stall the window compiling them."""
from __future__ import annotations

import dataclasses
import subprocess
import sys
import threading
import time

from numba.core.dispatcher import Dispatcher

from app.softgl import kernels as softgl_kernels
from app.viewer import pcpad
from app.viewer.settings import SOLVERS, ViewerSettings
from app.viewer.state import AppState
from app.viewer.update import load_library, solve
from engine import arms_nb, cleanup_nb, end_nb, frames_nb, learnt_ik
from engine.learnt_solver import LEARNT_SOLVERS


class EngineWarmup:
    def __init__(self, state: AppState, settings: ViewerSettings, apart: bool = False, softgl: bool = False):
        self._state = AppState(rig=state.rig, shots=state.shots, hit_points=state.hit_points,
                               bind_positions=state.bind_positions, ball_start=state.ball_start)
        self._settings = dataclasses.replace(settings, overlays=dataclasses.replace(settings.overlays))
        self.apart, self.softgl = apart, softgl
        self.solver_ready, self.ready = threading.Event(), threading.Event()
        self.error: str = ""               # why warming failed (the main thread then compiles as it goes)
        self.seconds = 0.0                 # how long it took
        self._thread = threading.Thread(target=self._run, name="hitpoint-engine-warmup", daemon=True)

    def start(self) -> "EngineWarmup":
        self._thread.start()
        return self

    def wait(self) -> None:
        self._thread.join()

    @property
    def stage(self) -> str:
        """What is still compiling, for the panel: "solver", "pc pad" or "" (done)."""
        return "" if self.ready.is_set() else "pc pad" if self.solver_ready.is_set() else "solver"

    def _run(self) -> None:
        t0 = time.perf_counter()
        try:
            if self.apart and not kernels_cached(self.softgl):
                subprocess.run([sys.executable, "-m", "app.viewer.warmup"] + ["--softgl"] * self.softgl,
                               check=False, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            self._warm_solver()
            self.solver_ready.set()
            if self.softgl:
                softgl_kernels.compile_all()
            self._warm_pad()
            if self.apart and not kernels_cached(learnt=True):     # behind everything, never waited for
                subprocess.Popen([sys.executable, "-m", "app.viewer.warmup", "--learnt"],
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        except Exception as e:      # a broken shot says so when the update solves it; never in this thread
            self.error = f"{type(e).__name__}: {e}"
        finally:
            self.solver_ready.set()
            self.ready.set()
            self.seconds = time.perf_counter() - t0

    def _warm_solver(self, solvers=None) -> None:
        """CCD and DLS on the shot the settings choose: every kernel a solve runs, compiled;
        a learnt solver too when it is the one in use (its model trains on the scratch
        state: not every start pays for that); or the ``solvers`` given."""
        state, settings = self._state, self._settings
        warm = solvers or [s for s in SOLVERS if s not in LEARNT_SOLVERS or s == settings.solver]
        for solver in sorted(warm, key=lambda name: name != settings.solver):   # the one in use first
            settings.solver = solver
            solve(state, settings)

    def _warm_pad(self) -> None:
        """A marker drag and a preset take (synthesis and clean-up) on the scratch state."""
        state = self._state
        state.shot_index = max(state.shot_index, 0)
        pcpad.set_scores(state, [0.0, 0.0])
        pcpad.apply_preset(state, "exaggerated")


def warmed_kernels(learnt: bool = False) -> list:
    """The compiled kernels of the solvers and the clean-up, or (``learnt``) the learnt
    solvers' (their model's training and lookup)."""
    modules = (learnt_ik,) if learnt else (frames_nb, end_nb, arms_nb, cleanup_nb)
    return [v for module in modules for v in vars(module).values()
            if isinstance(v, Dispatcher) and v.py_func.__module__ == module.__name__]


def kernels_cached(softgl: bool = False, learnt: bool = False) -> bool:
    """Whether numba's disk cache holds ``warmed_kernels(learnt)`` for the engine's sources
    as they are (a fresh index for each), and with ``softgl`` the software-GL profile's."""
    return (all(k._cache._cache_file._load_index() for k in warmed_kernels(learnt))
            and (not softgl or softgl_kernels.cached()))


if __name__ == "__main__":      # the children of ``apart``: compile into the disk cache, then exit
    scratch = AppState()
    if load_library(scratch):
        child = EngineWarmup(scratch, ViewerSettings(), softgl="--softgl" in sys.argv)
        if "--learnt" in sys.argv:    # a later switch to a learnt solver finds its kernels compiled
            child._warm_solver(LEARNT_SOLVERS)
        else:
            child._run()
