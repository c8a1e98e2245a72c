"""UI damage tracking (app.softgl.ui_damage): redrawing only the changed bands of the
panel must give exactly the pixels of a full redraw, frame after frame, while
the panel's readouts and plot change under a drag."""
import numpy as np
import pytest

from app.softgl import ui_damage as U

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")


def _geometry(quads, clip=(0, 0, 100, 100)):
    """UiGeometry of axis-aligned quads [(x0, y0, x1, y1, colour_word)], one command."""
    words, idx = [], []
    for k, (x0, y0, x1, y1, col) in enumerate(quads):
        for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1)):
            words.append(np.array([x, y, 0, 0], np.float32).view(np.uint32).tolist() + [col])
        b = 4 * k
        idx += [b, b + 1, b + 2, b, b + 2, b + 3]
    return U.UiGeometry(words=np.array(words, np.uint32),
                        positions=np.ascontiguousarray(np.array(words, np.uint32)[:, :2]).view(np.float32),
                        indices=np.array(idx, np.uint32).reshape(-1, 3),
                        tri_cmd=np.zeros(len(idx) // 3, int),
                        clips=np.array([clip], np.float32), textures=np.array([1]))


def _plan(tracker, geo, keep=(50, 0, 100, 100)):
    return tracker.plan(geo, (0, 0, 100, 100), [keep], key="fbo")


def test_unchanged_panel_redraws_nothing_inside_keep():
    geo = _geometry([(50, 0, 100, 100, 1), (60, 20, 90, 28, 2)])
    t = U.DamageTracker()
    _plan(t, geo)
    assert t.last_dirty_fraction == 1.0          # first frame: everything
    idx, batches = _plan(t, geo)
    assert t.last_dirty_fraction == 0.0
    assert not batches                           # nothing outside keep either


def test_changed_line_redraws_its_bands_only_and_everything_under_them():
    t = U.DamageTracker()
    _plan(t, _geometry([(50, 0, 100, 100, 1), (60, 20, 90, 28, 2)]))
    idx, batches = _plan(t, _geometry([(50, 0, 100, 100, 1), (60, 20, 90, 28, 3)]))
    assert 0 < t.last_dirty_fraction <= 0.16     # two 8-px bands of 100
    (batch,) = batches
    assert batch.rect[1] <= 20 and batch.rect[3] >= 28 and batch.rect[3] - batch.rect[1] <= 16
    # the opaque background quad is redrawn first inside the band, then the line
    assert batch.count == 12 and list(idx[:6]) == [0, 1, 2, 0, 2, 3]


def test_reordered_triangles_are_a_change():
    t = U.DamageTracker()
    a, b = (60, 20, 90, 28, 2), (62, 22, 80, 26, 3)
    _plan(t, _geometry([(50, 0, 100, 100, 1), a, b]))
    _plan(t, _geometry([(50, 0, 100, 100, 1), b, a]))
    assert t.last_dirty_fraction > 0


def test_outside_keep_is_always_drawn_and_regions_tile_the_display():
    t = U.DamageTracker()
    geo = _geometry([(0, 90, 100, 100, 5)])      # a timeline strip across the whole width
    _plan(t, geo)
    idx, batches = _plan(t, geo)
    assert [tuple(map(float, b.rect)) for b in batches] == [(0, 0, 50, 100)]   # clip ∩ outside
    assert batches[0].count == 6
    parts = U.outside([(20, 30, 60, 70)], (0, 0, 100, 100))
    assert sum((r[2] - r[0]) * (r[3] - r[1]) for r in parts) == 100 * 100 - 40 * 40


def test_regions_outside_several_keeps_tile_the_rest_of_the_display():
    keeps = [(50, 0, 100, 100), (0, 90, 50, 100)]      # a panel and a timeline under the view
    parts = U.outside(keeps, (0, 0, 100, 100))
    covered = np.zeros((100, 100), int)
    for x0, y0, x1, y1 in parts + keeps:
        covered[int(y0):int(y1), int(x0):int(x1)] += 1
    assert (covered == 1).all()                         # no gap, no overlap


def test_each_keep_is_tracked_on_its_own():
    t = U.DamageTracker()
    keeps = [(50, 0, 100, 100), (0, 90, 50, 100)]
    base = [(50, 0, 100, 100, 1), (0, 90, 50, 100, 1), (60, 20, 90, 28, 2), (10, 92, 20, 98, 4)]
    t.plan(_geometry(base), (0, 0, 100, 100), keeps, key="fbo")
    moved = base[:3] + [(12, 92, 22, 98, 4)]            # only the timeline's playhead moves
    idx, batches = t.plan(_geometry(moved), (0, 0, 100, 100), keeps, key="fbo")
    assert batches and all(b.rect[1] >= 90 and b.rect[2] <= 50 for b in batches)
    assert 0 < t.last_dirty_fraction < 0.1


def test_new_target_or_no_keep_redraws_everything():
    geo = _geometry([(50, 0, 100, 100, 1)])
    t = U.DamageTracker()
    _plan(t, geo)
    t.plan(geo, (0, 0, 100, 100), [(50, 0, 100, 100)], key="other fbo")
    assert t.last_dirty_fraction == 1.0
    idx, batches = t.plan(geo, (0, 0, 100, 100), None, key="fbo")
    assert batches[0].rect == (0, 0, 100, 100)


def test_partial_redraws_match_a_full_redraw_during_a_drag():
    """Frame after frame of dragging the target at the hit frame (readouts and the
    blend plot change), the damage-tracked frame equals a full redraw of the UI."""
    from app.viewer.capture import read_rgb
    from app.viewer.script import ScriptPlayer
    from app.viewer.loop import App, layout
    app = App((960, 600), headless=True)
    try:
        player = ScriptPlayer([{"type": "key", "key": "h", "frame": 0},
                               {"type": "drag_target_path", "frame": 2, "frames": 12,
                                "circle": {"center": "target", "radius": 40, "turns": 1}},
                               {"type": "scrub", "frame": 17, "to": 20},
                               {"type": "key", "key": "right", "frame": 19}])
        fractions = []
        rects = layout(app.window.size)
        for i in range(21):
            player.apply(app, i)
            app.frame(dt=1 / 60)
            fractions.append(app.gui.damage.last_dirty_fraction)
            if i in (5, 9, 15, 18, 20):     # dragging; scrubbed; stepped (the timeline changes)
                from imgui_bundle import imgui
                tracked = read_rgb(app.compositor.frame)
                app.gui.invalidate()
                app.gui.render(imgui.get_draw_data(), app.compositor.frame,
                               keep=(rects["panel"], rects["timeline"]))
                full = read_rgb(app.compositor.frame)
                assert np.array_equal(tracked, full), f"frame {i}"
        assert min(fractions[3:16]) < 0.5        # most of the panel is not redrawn while dragging
        assert app.state.errors == 0
    finally:
        app.close()


def test_a_new_shot_does_not_move_the_panel_below_its_description():
    """Descriptions of different lengths sit in a block of one height: picking another
    shot redraws its lines, readouts and plot, not the whole panel."""
    from app.viewer.loop import App
    app = App((960, 600), headless=True)
    try:
        names = sorted(app.state.shots, key=lambda s: len(s.description or ""))
        shortest, longest = names[0].name, names[-1].name
        fractions = []
        for name in (shortest, shortest, shortest, longest, longest, shortest, shortest):
            app.settings.pinned_shot = name
            app.frame(dt=1 / 60)
            fractions.append(app.gui.damage.last_dirty_fraction)
        assert app.state.shot.name == shortest and app.state.errors == 0
        assert max(fractions[3:]) < 0.6, fractions
    finally:
        app.close()
