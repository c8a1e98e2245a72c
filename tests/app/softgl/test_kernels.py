"""app.softgl.kernels: until the software-GL kernels are compiled the window draws the plain
way (whole UI, whole present, ghost in the scene); the warm-up's compile gives numba's cache
the very signatures the viewer calls, so the window never compiles them itself."""
import pytest

from app.softgl import kernels

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")


@pytest.fixture
def not_ready(monkeypatch):
    monkeypatch.setattr(kernels, "_ready", type(kernels._ready)())       # a fresh, unset event
    monkeypatch.setattr(kernels, "cached", lambda: False)
    monkeypatch.setattr(kernels, "compile_all", lambda: None)             # the warm-up still compiling
    yield
    assert not kernels._ready.is_set()


def test_every_kernel_of_the_profile_is_covered():
    names = {k.py_func.__name__ for k in kernels.dispatchers()}
    assert {"_triangle_rects", "_triangle_hashes", "_band_signatures", "_select", "_ndc_box", "_fold"} <= names


def test_until_ready_the_ui_is_drawn_whole_and_the_kernels_never_called(not_ready, monkeypatch):
    from app.viewer.loop import App
    from app.softgl import ui_damage
    calls = []
    monkeypatch.setattr(ui_damage.DamageTracker, "plan", lambda *a, **k: calls.append(1))
    app = App((640, 400), headless=True)
    try:
        assert app.gui.damage is not None and app.scene_renderer.software_gl     # the profile is on (llvmpipe)
        for _ in range(3):
            app.frame(dt=1 / 60)
        assert not calls and not kernels.ready()
        assert (app.screenshot().astype(int).sum(axis=2) > 60).mean() > 0.5    # the frame drawn all the same
    finally:
        app.close()


def test_the_warm_up_compiles_the_signatures_the_viewer_calls():
    """Every kernel run the way the window runs it adds no signature to those compile_all made."""
    from app.render.compose import Compositor
    from app.softgl import present
    from app.viewer.loop import App
    kernels.compile_all()
    before = {k.py_func.__name__: set(k.signatures) for k in kernels.dispatchers()}
    app = App((640, 400), headless=True)
    try:
        app.settings.overlays.ghost = "mesh"
        app.scrub(app.state.shot.hit_frame)
        for _ in range(4):
            app.frame(dt=1 / 60)
        box = app.scene_renderer.changed.box()                    # what a partial present asks
        assert box is not None and box[2] > 0
        present.merge_rects([tuple(int(v) for v in box), (0, 0, 16, 16), (8, 8, 16, 16)])
        assert isinstance(app.compositor, Compositor)
    finally:
        app.close()
    after = {k.py_func.__name__: set(k.signatures) for k in kernels.dispatchers()}
    assert after == before
    assert all(before.values())
