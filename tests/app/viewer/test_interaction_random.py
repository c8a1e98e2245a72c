"""2,000 frames of random input through the viewer's own input and update
code: drags anywhere (far off-screen too), slider extremes, rapid scrubbing,
keys. Nothing may raise and every pose must stay finite. The scene is drawn
only every 100th frame to keep the test fast."""
import numpy as np
import pytest

from app.errors import UserError
from app.viewer.interaction import KEY_NAMES, LEFT, MIDDLE, RIGHT

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")

SETTINGS = {
    "falloff": [20.0, 200.0, 1e9, -5.0, float("nan"), 90.0],
    "wrist_dof": [0, 2, 7],
    "solver": ["ccd", "dls", "bogus"],
    "iterations": [1, 500, 0, 10**9],
    "tolerance": [1e-4, 1.0, 0.0, float("inf")],
    "speed": [0.05, 4.0, 100.0],
    "slow_motion": [True, False],
    "overlays.ghost": ["off", "mesh", "skeleton", "nonsense"],
    "overlays.flight": [True, False],
    "fix_right_hand": [True, False],
    "antialias": [True, False],
}


def test_random_input_never_breaks_the_viewer(tmp_path, monkeypatch):
    from app.viewer.loop import App
    monkeypatch.chdir(tmp_path)  # F12 among the random keys writes screenshots to the cwd
    rng = np.random.default_rng(7)
    app = App((1280, 720), headless=True)
    try:
        it, s, st = app.interaction, app.settings, app.state
        names = [sh.name for sh in st.shots] + [None]
        W, H = app.window.size
        errors_before = st.errors
        refused = 0
        for i in range(2000):
            r = rng.random()
            if r < 0.35:   # drag the target somewhere, possibly far off the window
                if not st.dragging_target:
                    it.mouse_move(*it.target_pixel())
                    it.mouse_button(LEFT, True)
                scale = 4.0 if rng.random() < 0.2 else 1.0
                it.mouse_move(rng.uniform(-W, 2 * W) * scale, rng.uniform(-H, 2 * H) * scale)
                if rng.random() < 0.1:
                    it.mouse_button(LEFT, False)
            elif r < 0.45:
                it.mouse_button(LEFT, False)
                button = [LEFT, RIGHT, MIDDLE][rng.integers(3)]
                it.mouse_move(rng.uniform(0, W), rng.uniform(0, H))
                it.mouse_button(button, True)
                it.mouse_move(rng.uniform(-W, 2 * W), rng.uniform(-H, 2 * H))
                it.mouse_button(button, False)
            elif r < 0.5:
                it.scroll(rng.uniform(-30, 30))
            elif r < 0.65:
                key = list(SETTINGS)[rng.integers(len(SETTINGS))]
                values = SETTINGS[key]
                try:   # out-of-range and unknown values are refused, the rest clamped
                    s.set(key, values[rng.integers(len(values))])
                except UserError:
                    refused += 1
            elif r < 0.8:     # rapid scrubbing, out of range too
                app.scrub(rng.uniform(-50, 500))
            elif r < 0.85:
                s.pinned_shot = names[rng.integers(len(names))]
            elif r < 0.95:
                name = ["space", "left", "right", "h", "s", "[", "]", "home", "end"][rng.integers(9)]
                it.key(KEY_NAMES[name], True)
                it.key(KEY_NAMES[name], False)
            app.frame(dt=float(rng.choice([0.0, 1 / 60, 0.25])), render=(i % 100 == 0))
            pose = st.pose
            assert pose is not None
            assert np.isfinite(pose.global_positions).all() and np.isfinite(pose.global_rotations).all()
            assert np.isfinite(st.ball_position).all()
            assert np.isfinite(s.target).all() and 0 <= s.frame <= st.num_frames - 1
            assert 20 <= s.falloff <= 200
        assert st.adaptation is not None and np.isfinite(st.adaptation.global_positions).all()
        engine_errors = [m for _, m in st.messages if m.startswith("engine")]
        assert st.errors == errors_before, engine_errors
        assert app.state.solve_count > 100
        assert refused > 0
    finally:
        app.close()
