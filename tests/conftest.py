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


@pytest.fixture(scope="session", autouse=True)
def software_gl_kernels():
    """The software-GL profile's kernels compiled once for the run: the viewer compiles them
    behind its window and stands its tricks aside until then; a test asking for the profile
    wants it whole from its first frame (tests/app/softgl/test_kernels.py covers the wait)."""
    from app.softgl import kernels
    kernels.compile_all()
