"""A one-line note on stderr while numba compiles the engine's kernels for longer than a
moment (a fresh install, or an engine change: the kernels are then cached on disk and later
runs load them in well under a second). Without it a first ``hitpoint adapt`` or viewer
start sat silent for half a minute."""
from __future__ import annotations

import sys
import threading
import time

from numba.core import event

NOTE_AFTER_S = 1.0          # a compile still running this long after it began gets the note
NOTE = "compiling the engine's kernels (first run after an install or update, about a minute; cached after)..."


class CompileNote(event.Listener):
    """Listens to numba's ``numba:compile`` events (cache misses only) from any thread."""

    def __init__(self, stream, after_s: float = NOTE_AFTER_S):
        self.stream, self.after_s = stream, after_s
        self.depth = 0                      # compiles running (a kernel compiles the kernels it calls)
        self.started_at: float | None = None
        self.printed = False
        self._lock = threading.Lock()

    def on_start(self, ev) -> None:
        with self._lock:
            self.depth += 1
            if self.depth == 1 and not self.printed:
                self.started_at = time.monotonic()
                timer = threading.Timer(self.after_s, self._still_compiling)
                timer.daemon = True
                timer.start()

    def on_end(self, ev) -> None:
        with self._lock:
            self.depth = max(self.depth - 1, 0)

    @property
    def compiling(self) -> bool:
        return self.depth > 0

    def _still_compiling(self) -> None:
        with self._lock:
            if self.printed or self.depth == 0:
                return
            self.printed = True
        print(NOTE, file=self.stream, flush=True)


_installed: CompileNote | None = None


def install(stream=None) -> CompileNote | None:
    """Listen for compiles from now on (once per process; the CLI does it for every command
    that runs the engine). Only for a person at a terminal: a pipe or a test reading stderr
    gets the command's own lines and nothing else."""
    global _installed
    stream = stream or sys.stderr
    if _installed is None and stream.isatty():
        _installed = CompileNote(stream)
        event.register("numba:compile", _installed)
    return _installed
