import os
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MOCAP = ROOT.parent / "shared" / "mocap"
# Offscreen rendering uses Mesa's EGL; never ask for a display.
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")


@pytest.fixture(scope="session")
def rig():
    from engine.rig import default_rig
    return default_rig()
