"""The engine compiled behind the window. On a fresh install numba compiles the solver's
kernels (tens of seconds, then cached on disk): a thread does it on scratch copies of the
library while the window shows the source shot playing and the panel says so. The update
solves from the frame ``solver_ready`` is set, and the PC pad (its compiled FK, synthesis and
clean-up) from ``ready``. Nothing of the viewer's state is touched by the thread."""
from __future__ import annotations

import dataclasses
import threading
import time

from app import pcpad
from app.settings import ViewerSettings
from app.state import AppState
from app.update import solve


class EngineWarmup:
    def __init__(self, state: AppState, settings: ViewerSettings):
        self._state = AppState(rig=state.rig, shots=state.shots, hit_points=state.hit_points,
                               bind_positions=state.bind_positions, ball_start=state.ball_start)
        self._settings = dataclasses.replace(settings, overlays=dataclasses.replace(settings.overlays))
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
            self._warm_solver()
            self.solver_ready.set()
            self._warm_pad()
        except Exception as e:      # a broken shot says so when the update solves it; never in this thread
            self.error = f"{type(e).__name__}: {e}"
        finally:
            self.solver_ready.set()
            self.ready.set()
            self.seconds = time.perf_counter() - t0

    def _warm_solver(self) -> None:
        """Both solvers on the shot the settings choose: every kernel a solve runs, compiled."""
        state, settings = self._state, self._settings
        for solver in (settings.solver, *(s for s in ("ccd", "dls") if s != settings.solver)):
            settings.solver = solver
            solve(state, settings)

    def _warm_pad(self) -> None:
        """A marker drag and a preset take (synthesis and clean-up) on the scratch state."""
        state = self._state
        state.shot_index = max(state.shot_index, 0)
        pcpad.set_scores(state, [0.0, 0.0])
        pcpad.apply_preset(state, "exaggerated")
