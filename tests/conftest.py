import os
from pathlib import Path

import pytest
from hypothesis import settings

# The fuzz tests run the same thousands of cases on every run (CI must not pass or
# fail by luck); `pytest --hypothesis-profile=explore` draws new ones.
settings.register_profile("default", derandomize=True, print_blob=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile("default")

ROOT = Path(__file__).resolve().parent.parent
MOCAP = ROOT.parent / "shared" / "mocap"
# Offscreen rendering uses Mesa's EGL; never ask for a display.
os.environ.setdefault("PYOPENGL_PLATFORM", "egl")


@pytest.fixture(scope="session")
def rig():
    from engine.rig import default_rig
    return default_rig()
