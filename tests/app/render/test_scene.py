"""Offscreen rendering (EGL, Mesa llvmpipe): the batsman, pitch, ball and overlays
land where the camera projects them, and poses move pixels."""
import dataclasses

import numpy as np
import pytest

from engine import quat
from engine.skeleton import bind_positions, forward_kinematics, skinning_matrices

SIZE = (320, 240)
EYE, TARGET = np.array([-430.0, 150.0, 160.0]), np.array([0.0, 95.0, 90.0])
ROOT = np.array([0.0, 97.0, 90.0])     # in front of the stumps, near the popping crease


@pytest.fixture(scope="module", params=[True, False], ids=["software_gl", "plain"])
def renderer(rig, request):
    """Every render test runs on both paths: the software-GL profile forced on and off."""
    from app.render import SceneRenderer, offscreen_context
    ctx = offscreen_context()
    r = SceneRenderer(ctx, rig, software_gl=request.param)
    yield r
    ctx.release()


def pose(rig, rotations=None, root=ROOT):
    sk = rig.skeleton
    local = quat.identity((sk.num_joints,))
    for name, (axis, deg) in (rotations or {}).items():
        local[sk.index(name)] = quat.from_axis_angle(np.asarray(axis, float), np.radians(deg))
    t = sk.offsets.copy()
    t[0] = root
    g_r, g_p = forward_kinematics(sk.parents, t, local)
    return g_p, skinning_matrices(g_r, g_p, bind_positions(sk))


ARMS_DOWN = {"LeftArm": ((0, 0, 1), -70), "RightArm": ((0, 0, 1), 70), "Hips": ((0, 1, 0), -90)}


def view_of(skin, **kw):
    from app.render import SceneView, look_at, perspective
    return SceneView(look_at(EYE, TARGET), perspective(40.0, SIZE[0] / SIZE[1], 5.0, 12000.0), SIZE, skin, **kw)


def project(v, p):
    """Pixel (column, row from the top) of world point ``p``."""
    c = v.proj @ v.view @ np.append(p, 1.0)
    ndc = c[:3] / c[3]
    return (ndc[0] * 0.5 + 0.5) * v.size[0], (0.5 - ndc[1] * 0.5) * v.size[1]


def render(renderer, v):
    from app.render import render_image
    with renderer.ctx:      # current again even after another test made its own context
        return render_image(renderer, v).astype(int)


def changed(a, b, tol=12):
    return np.abs(a - b).sum(-1) > tol


def test_image_shape_and_sky_gradient(renderer, rig):
    img = render(renderer, view_of(None, show_pitch=False))    # no ground, no stadium: sky only
    assert img.shape == (SIZE[1], SIZE[0], 3)
    top, horizon = img[2].mean(0), img[SIZE[1] // 3].mean(0)
    assert top[2] > top[0] and horizon.sum() > top.sum()   # blue zenith, paler toward the horizon


def test_batsman_drawn_where_the_skeleton_projects(renderer, rig):
    g_p, M = pose(rig, ARMS_DOWN)
    with_body = render(renderer, view_of(M, shadows=False))
    empty = render(renderer, view_of(None, shadows=False))
    mask = changed(with_body, empty)
    v = view_of(M)
    px = np.array([project(v, p) for p in g_p])
    lo, hi = px.min(0) - 25, px.max(0) + 25     # the mesh surrounds the joints
    rows, cols = np.nonzero(mask)
    assert mask.sum() > 2000
    assert cols.min() >= lo[0] and cols.max() <= hi[0] and rows.min() >= lo[1] - 15 and rows.max() <= hi[1]
    # and it is mostly white kit
    assert with_body[mask].mean() > 150


def test_pitch_visible_and_green_outfield(renderer, rig):
    v = view_of(None)
    img = render(renderer, v)
    no_pitch = render(renderer, dataclasses.replace(v, show_pitch=False))
    c, r = map(int, project(v, np.array([60.0, 0.0, 230.0])))      # on the strip
    strip = img[r, c]
    assert strip[0] > strip[2] + 30 and abs(strip[0] - strip[1]) < 50  # sandy
    assert changed(img, no_pitch)[r, c]
    c, r = map(int, project(v, np.array([400.0, 0.0, -250.0])))     # outfield beside the strip
    grass = img[r, c]
    assert grass[1] > grass[0] and grass[1] > grass[2]


def test_crease_lines_are_white(renderer, rig):
    v = view_of(None)
    img = render(renderer, v)
    c, r = map(int, project(v, np.array([-60.0, 0.0, 122.0])))   # popping crease
    patch = img[r - 1:r + 2, c - 1:c + 2].reshape(-1, 3)
    assert patch.sum(1).max() > 600


def test_ball_drawn_where_projected(renderer, rig):
    ball = np.array([-150.0, 110.0, 220.0])
    v = view_of(None, shadows=False)
    a = render(renderer, dataclasses.replace(v, ball_position=ball))
    b = render(renderer, v)
    rows, cols = np.nonzero(changed(a, b))
    assert len(rows) > 10
    c, r = project(v, ball)
    assert abs(cols.mean() - c) < 2.0 and abs(rows.mean() - r) < 2.0
    red = a[int(round(r)), int(round(c))]
    assert red[0] > 2 * red[1]


def test_pose_changes_move_pixels(renderer, rig):
    _, M0 = pose(rig, ARMS_DOWN)
    raised = dict(ARMS_DOWN, LeftArm=((0, 0, 1), 40), LeftForeArm=((0, 1, 0), -90))
    _, M1 = pose(rig, raised)
    a, b = render(renderer, view_of(M0)), render(renderer, view_of(M1))
    assert changed(a, b).sum() > 500


def test_shadow_darkens_the_ground(renderer, rig):
    g_p, M = pose(rig, ARMS_DOWN)
    lit = render(renderer, view_of(M, shadows=False))
    shadowed = render(renderer, view_of(M, shadows=True))
    darker = (lit.sum(-1) - shadowed.sum(-1)) > 30
    assert darker.sum() > 200


def test_overlays_target_ghost_and_lines(renderer, rig):
    g_p, M = pose(rig, ARMS_DOWN)
    base = view_of(M)
    plain = render(renderer, base)
    target = np.array([0.0, 120.0, -60.0])
    with_target = render(renderer, dataclasses.replace(base, target_position=target))
    c, r = project(base, target)
    assert changed(with_target, plain)[int(r), int(c)]
    line = np.array([[-100.0, 200.0, 400.0], [-100.0, 200.0, -200.0]])
    with_line = render(renderer, dataclasses.replace(base, polylines=[(line, (1, 1, 0, 1), 4.0)]))
    c, r = project(base, line.mean(0))
    assert with_line[int(r), int(c)][2] < 100 and with_line[int(r), int(c)][:2].min() > 180   # yellow
    _, M1 = pose(rig, dict(ARMS_DOWN, LeftArm=((0, 0, 1), 40)))
    ghost = render(renderer, dataclasses.replace(base, ghost_skin_matrices=M1, ghost_alpha=0.4))
    assert changed(ghost, plain).sum() > 100
    skel = render(renderer, dataclasses.replace(base, skeleton_lines=[(g_p, rig.skeleton.parents, (1, 0, 0, 1))],
                                                crosses=[(g_p[:3], (0, 1, 1, 1), 10.0)],
                                                points=[(g_p[:3], (1, 0, 1, 1), 8.0)]))
    c, r = project(base, g_p[rig.skeleton.index("Spine1")])
    assert skel[int(r), int(c)][0] > 150 and skel[int(r), int(c)][1] < 120   # red line on top of the body


def test_the_ghost_is_as_translucent_as_asked(renderer, rig):
    """Blended at alpha a, no pixel moves more than a of the way to the ghost's colour: the
    depth pre-pass writes no colour (it once drew the ghost opaque on the plain path)."""
    _, M = pose(rig, ARMS_DOWN)
    base = view_of(M)
    plain = render(renderer, base)
    _, M1 = pose(rig, dict(ARMS_DOWN, LeftArm=((0, 0, 1), 40)))
    moved = {}
    for alpha in (0.1, 0.25):
        ghost = render(renderer, dataclasses.replace(base, ghost_skin_matrices=M1, ghost_alpha=alpha))
        moved[alpha] = np.abs(ghost - plain).max(-1)
        assert moved[alpha].max() <= 255 * alpha + 4, alpha
    seen = moved[0.25] > 8
    assert seen.sum() > 300                                   # the raised arm and the body
    assert moved[0.25][seen].mean() > 1.8 * moved[0.1][seen].mean()


def test_look_at_and_perspective_centre_the_target():
    from app.render import look_at, perspective
    V = look_at((100.0, 50.0, 300.0), (0.0, 100.0, 0.0))
    P = perspective(45.0, 1.5, 1.0, 1000.0)
    c = P @ V @ np.array([0.0, 100.0, 0.0, 1.0])
    assert np.allclose(c[:2] / c[3], 0.0, atol=1e-5)
    assert -1 < c[2] / c[3] < 1
    assert np.allclose(V[:3, :3] @ V[:3, :3].T, np.eye(3), atol=1e-6)


def test_render_strip_cli(tmp_path):
    from typer.testing import CliRunner
    from app.cli import cli
    from engine.library import load_library
    shots = load_library()
    runner = CliRunner()
    bad = runner.invoke(cli, ["render-strip", "--shot", "no_such_shot", "--out", str(tmp_path / "x.png")])
    assert bad.exit_code == 2 and not (tmp_path / "x.png").exists()
    assert shots, "the bundled shot library is empty"
    out = tmp_path / "strip.png"
    ok = runner.invoke(cli, ["render-strip", "--shot", shots[0].name, "--out", str(out), "--frames", "3",
                             "--size", "96x128"])
    assert ok.exit_code == 0, ok.output
    from PIL import Image
    img = Image.open(out)
    assert img.width == 3 * 96


def test_strip_frames_include_the_hit_frame():
    from app.cli.render import strip_frames
    for n, h, k in ((69, 30, 9), (10, 0, 4), (5, 4, 10), (100, 57, 1)):
        f = strip_frames(n, h, k)
        assert h in f and f == sorted(set(f)) and 0 <= min(f) and max(f) < n and len(f) <= k


def _linear_blend(mesh, M, normals=True):
    """Reference skinning ``sum_k w_k M_k p`` in float64: positions (V,3) and normals (V,3)."""
    M = np.asarray(M, float)[mesh.joints]
    p = np.concatenate([mesh.positions, np.ones((len(mesh.positions), 1))], 1)
    pos = np.einsum("vk,vkab,vb->va", mesh.weights, M, p)[:, :3]
    nrm = np.einsum("vk,vkab,vb->va", mesh.weights, M[..., :3, :3], mesh.normals) if normals else None
    return pos, nrm


def test_gpu_skinning_matches_linear_blend(renderer, rig):
    """The transform-feedback buffers the lit pass, the shadow caster and the ghost draw
    hold sum_k w_k M_k p (within 1e-3 cm) for the pose just rendered, and a second pose
    replaces the first."""
    for rotations in (dict(ARMS_DOWN, LeftForeArm=((0, 1, 0), -70)), {"Spine": ((1, 0, 0), 30)}):
        _, M = pose(rig, rotations)
        _, G = pose(rig, dict(rotations, Hips=((0, 1, 0), 45)))
        render(renderer, view_of(M, ghost_skin_matrices=G))
        with renderer.ctx:
            body, ghost = renderer.posed.body.read(), renderer.ghost.posed.body.read()
            caster = renderer.posed.caster.read() if renderer.posed.caster is not None else None
        pos, nrm = _linear_blend(renderer.posed.mesh, M)
        assert np.abs(body[:, :3] - pos).max() < 1e-3 and np.abs(body[:, 3:] - nrm).max() < 1e-4
        assert np.abs(ghost[:, :3] - _linear_blend(renderer.ghost.posed.mesh, G)[0]).max() < 1e-3
        if caster is not None:
            assert np.abs(caster - _linear_blend(renderer.shadow_mesh, M, False)[0]).max() < 1e-3


def test_sun_fit_holds_casters_and_their_shadows():
    from app.render.scene import SUN_DIR, fit_sun
    pts = np.random.default_rng(1).uniform(-60.0, 180.0, (300, 3))
    pts[:, 1] = np.abs(pts[:, 1])
    vp, quad = fit_sun(pts, 384)
    ground = pts - (pts[:, 1:2] / SUN_DIR[1]) * SUN_DIR
    ground[:, 1] = 0.0
    c = np.concatenate([pts, ground]) @ vp[:3, :3].T.astype(float) + vp[:3, 3]
    assert np.abs(c).max() < 1.0                      # inside the shadow map and its depth range
    assert np.allclose(quad[:, 1], 0.0)
    # the receiver quad (a rectangle on the ground) covers every shadow point
    a, b, d = quad[0, [0, 2]], quad[1, [0, 2]], quad[5, [0, 2]]
    uv = np.stack([(ground[:, [0, 2]] - a) @ (b - a) / np.dot(b - a, b - a),
                   (ground[:, [0, 2]] - a) @ (d - a) / np.dot(d - a, d - a)], 1)
    assert uv.min() >= 0.0 and uv.max() <= 1.0


def test_cached_layers_follow_camera_and_ghost(renderer, rig):
    """The static layer (per camera) and the ghost layer (per pose) never show stale pixels."""
    from app.render import look_at
    _, M = pose(rig, ARMS_DOWN)
    _, G = pose(rig, dict(ARMS_DOWN, LeftArm=((0, 0, 1), 40)))
    a = view_of(M, ghost_skin_matrices=G)
    b = dataclasses.replace(a, view=look_at(EYE + np.array([0.0, 80.0, -150.0]), TARGET))
    first, other, again = render(renderer, a), render(renderer, b), render(renderer, a)
    assert np.array_equal(first, again) and changed(first, other).sum() > 5000
    no_ghost = render(renderer, dataclasses.replace(a, ghost_skin_matrices=None))
    other_ghost = render(renderer, dataclasses.replace(a, ghost_skin_matrices=M))
    assert changed(first, no_ghost).sum() > 100 and changed(first, other_ghost).sum() > 100
    assert np.array_equal(render(renderer, a), first)


def test_antialias_toggle_softens_edges_only(renderer, rig):
    """Into a single-sampled target on software GL, ``antialias`` changes pixels along edges
    only (a small share of the image, some of them on the batsman's outline) and keeps the
    picture; the plain path, multisampled, ignores it."""
    _, M = pose(rig, ARMS_DOWN)
    ctx = renderer.ctx
    with ctx:
        fbo = ctx.framebuffer([ctx.texture(SIZE, 4)], ctx.depth_renderbuffer(SIZE))

        def shot(aa):
            renderer.render(view_of(M, antialias=aa, ball_position=ROOT + (0.0, 40.0, 120.0)), fbo)
            return np.frombuffer(fbo.read(components=3), np.uint8).reshape(SIZE[1], SIZE[0], 3)[::-1].astype(int)

        off, on, off_again = shot(False), shot(True), shot(False)
        fbo.release()
    assert np.array_equal(off, off_again)
    if not renderer.software_gl:              # the plain path multisamples everything already
        assert np.array_equal(off, on)
        return
    diff = changed(off, on, tol=6)
    assert 0.002 < diff.mean() < 0.15
    assert np.abs(off.mean((0, 1)) - on.mean((0, 1))).max() < 3.0


def test_compositor_draws_every_scene_into_the_frame(renderer):
    """At scale 1 every scene is drawn straight into the frame, at the viewport's corner."""
    from app.render.compose import Compositor
    ctx = renderer.ctx
    with ctx:
        comp = Compositor(ctx, software_gl=renderer.software_gl)
        comp.resize((64, 48), (0, 0, 64, 48), (64, 48), 1.0)
        drawn = []

        def draw(color):
            def render(fbo):
                fbo.use()
                fbo.clear(*color, 1.0)
                drawn.append(color)
                return True
            return render

        red, green = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)
        for color in (red, green, green):
            comp.draw_scene(draw(color))
            assert np.frombuffer(comp.frame.read(components=3), np.uint8)[:3].tolist() == [
                int(255 * c) for c in color]
        assert drawn == [red, green, green] and comp.direct
        comp.release()


def test_level_of_detail_follows_screen_size_and_keeps_the_silhouette(renderer, rig):
    """The farther (smaller on screen) he is, the coarser the level drawn: the finest
    close up, the coarsest far away; every level covers the pixels of the finest
    (silhouettes agree to within a few percent) posed by the same matrices."""
    from app.render import SceneView, look_at, perspective
    _, M = pose(rig, dict(ARMS_DOWN, LeftForeArm=((0, 1, 0), -70)))
    last = len(renderer.body_levels) - 1
    assert last >= 1, "the bundled mesh file has no coarser levels"

    def view(distance, skin=M, **kw):
        eye = np.array(TARGET) + (np.array(EYE) - np.array(TARGET)) * distance
        return SceneView(look_at(eye, TARGET), perspective(40.0, SIZE[0] / SIZE[1], 5.0, 12000.0), SIZE, skin,
                         show_pitch=False, shadows=False, **kw)

    distances = (0.2, 0.3, 0.5, 0.7, 1.0, 2.0)
    levels = [renderer.body.detail_level(v, v.proj @ v.view, by_size=True) for v in map(view, distances)]
    assert levels == sorted(levels) and levels[0] == 0 and levels[-1] == last
    chosen = [renderer.body.detail_level(v, v.proj @ v.view, by_size=renderer.software_gl) for v in map(view, distances)]
    assert chosen == (levels if renderer.software_gl else [0] * len(levels))   # the plain path: the finest
    masks = []
    for level in range(last + 1):
        img = render(renderer, view(0.5, detail=level))
        masks.append(changed(img, render(renderer, view(0.5, skin=None, detail=level))))
    for level in range(1, last + 1):
        union, inter = (masks[0] | masks[level]).sum(), (masks[0] & masks[level]).sum()
        assert union > 2000 and inter / union > 0.93, level


def test_level_of_detail_does_not_flicker_at_a_threshold(renderer, rig):
    """Zooming in and out across a level's threshold by less than the hysteresis keeps
    the level; well past it, the level changes."""
    from app.render import SceneView, look_at, perspective
    from app.render.body import LOD_HYSTERESIS
    _, M = pose(rig, ARMS_DOWN)
    assert len(renderer.body_levels) >= 2, "the bundled mesh file has no coarser levels"

    def level(distance):
        eye = np.array(TARGET) + (np.array(EYE) - np.array(TARGET)) * distance
        v = SceneView(look_at(eye, TARGET), perspective(40.0, SIZE[0] / SIZE[1], 5.0, 12000.0), SIZE, M)
        return renderer.body.detail_level(v, v.proj @ v.view, by_size=True)

    # find a distance where the level changes, walking outwards
    d = np.geomspace(0.15, 2.0, 200)
    levels = [level(x) for x in d]
    k = next(i for i in range(1, len(d)) if levels[i] != levels[i - 1])
    edge = d[k]
    near, far = levels[k - 1], levels[k]
    assert far > near
    small = 1 + LOD_HYSTERESIS / 3
    flips = {level(edge / small), level(edge * small), level(edge / small), level(edge * small)}
    assert flips == {far}                          # just past it, back and forth: no change
    assert level(edge / (1 + 3 * LOD_HYSTERESIS)) == near   # well inside: the finer level again


def _brute_rect(a, b, vp, n=4001):
    """NDC box of the samples of segment a->b in front of GL's near plane and on screen."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    p = np.concatenate([a + t * (b - a), np.ones((n, 1))], 1) @ vp.astype(float).T
    p = p[p[:, 2] + p[:, 3] >= 0]
    ndc = p[:, :2] / p[:, 3:]
    ndc = ndc[np.all(np.abs(ndc) <= 1.0, axis=1)]
    return None if not len(ndc) else (*ndc.min(0), *ndc.max(0))


def test_changed_region_of_lines_is_what_shows_of_them():
    """A line's box is the part of it one sees: clipped to the near plane (the ball's path
    from the bowler runs behind the eye) and to the screen; a solid through the near plane
    may cover anything, one wholly behind it nothing."""
    from app.render import look_at, perspective
    from app.softgl.screen_box import segments_rect as _segments_rect
    vp = perspective(38.0, 4 / 3, 5.0, 12000.0) @ look_at(EYE, TARGET)
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(300):
        a, b = rng.uniform(-2500, 2500, 3), rng.uniform(-2500, 2500, 3)
        got, want = _segments_rect(a[None], b[None], vp), _brute_rect(a, b, vp)
        if want is None:
            continue
        checked += 1
        assert got is not None
        assert got[0] <= want[0] + 1e-9 and got[1] <= want[1] + 1e-9
        assert got[2] >= want[2] - 1e-9 and got[3] >= want[3] - 1e-9
        clip = np.array([[*a, 1.0], [*b, 1.0]]) @ vp.astype(float).T
        if np.all(clip[:, 2] + clip[:, 3] > 0):            # (sampling is too coarse near the plane)
            assert np.allclose(got, want, atol=5e-3)      # and hardly more
    assert checked > 50
    behind = EYE + 2.0 * (EYE - TARGET)                   # well behind the camera
    assert _segments_rect(behind[None], (behind + 10)[None], vp) is None
    cube = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T
    assert _segments_rect(behind + 5 * cube, behind + 5 * cube, vp, filled=True) is None
    through = EYE + 20.0 * cube                           # the camera inside a box
    assert _segments_rect(through, through, vp, filled=True) == (-1.0, -1.0, 1.0, 1.0)


def test_frame_damage_merges_and_remembers_the_last_frame():
    from app.softgl.present import FrameDamage, merge_rects
    rng = np.random.default_rng(3)
    rects = [tuple(int(v) for v in (*rng.integers(0, 600, 2), *rng.integers(1, 80, 2))) for _ in range(40)]
    merged = merge_rects(rects)
    assert 0 < len(merged) <= len(rects)
    cover = np.zeros((700, 700), bool)
    for x, y, w, h in merged:
        cover[y:y + h, x:x + w] = True
    for x, y, w, h in rects:                                # every changed pixel is presented
        assert cover[y:y + h, x:x + w].all()
    assert len(merge_rects([(0, 0, 10, 10), (500, 500, 10, 10)])) == 2   # far apart: two draws

    class Lazy:
        def __init__(self, box):
            self.asked, self._box = 0, box

        def box(self):
            self.asked += 1
            return self._box

    d = FrameDamage()
    assert d.take() is None                                 # a new frame: all of it
    lazy = Lazy((5, 5, 10, 10))
    d.add([(100, 100, 20, 20), lazy])
    assert sorted(d.take()) == [(5, 5, 10, 10), (100, 100, 20, 20)]
    d.add([(300, 300, 5, 5)])
    assert sorted(d.take()) == [(5, 5, 10, 10), (100, 100, 20, 20), (300, 300, 5, 5)]   # and the last frame's
    skipped = Lazy((1, 1, 1, 1))
    d.add([skipped])
    d.take(resolve=False)                                   # headless: nothing is worked out
    assert skipped.asked == 0
    d.everything()
    assert d.take() is None


def _ground_color_at(positions, colors, x, z):
    """Colour of ground triangles (non-overlapping) at points ``x, z``, barycentric; NaN off them."""
    tri_p, tri_c = positions.reshape(-1, 3, 3)[:, :, [0, 2]].astype(float), colors.reshape(-1, 3, 3).astype(float)
    a, b, c = tri_p[:, 0], tri_p[:, 1], tri_p[:, 2]
    p = np.stack([x, z], 1)[:, None, :]
    v0, v1, v2 = b - a, c - a, p - a
    den = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
    s = (v2[..., 0] * v1[:, 1] - v1[:, 0] * v2[..., 1]) / den
    t = (v0[:, 0] * v2[..., 1] - v2[..., 0] * v0[:, 1]) / den
    inside = (s >= -1e-9) & (t >= -1e-9) & (s + t <= 1 + 1e-9)
    hits = inside.sum(1)
    k = inside.argmax(1)
    s, t = s[np.arange(len(k)), k][:, None], t[np.arange(len(k)), k][:, None]
    out = tri_c[k, 0] + s * (tri_c[k, 1] - tri_c[k, 0]) + t * (tri_c[k, 2] - tri_c[k, 0])
    return out, hits


def test_ground_cells_do_not_overlap_and_keep_the_painted_colours():
    """The ground is drawn once per pixel (no overdraw), and every point of it has the
    colour the painter's order of its layers gave it."""
    from app.render import props
    positions, colors = props.ground()
    layers = props.ground_layers()
    rng = np.random.default_rng(5)
    near = np.stack([rng.uniform(-700, 700, 3000), rng.uniform(-400, props.PITCH_LENGTH + 400, 3000)], 1)
    far = rng.uniform(-39000, 39000, (500, 2))
    pts = np.concatenate([near, far])
    got, hits = _ground_color_at(positions, colors, pts[:, 0], pts[:, 1])
    painted = np.empty_like(got)
    for layer in layers:                                    # painter's order: the last one wins
        x0, x1, z0, z1, _ = layer
        m = (pts[:, 0] > x0) & (pts[:, 0] < x1) & (pts[:, 1] > z0) & (pts[:, 1] < z1)
        if m.any():
            painted[m] = props.layer_color(layer, pts[m, 0], pts[m, 1])
    on_edge = hits != 1                                     # exactly on a shared edge: two cells
    assert on_edge.mean() < 0.01
    assert np.abs(got - painted)[~on_edge].max() < 0.01    # sRGB 0-1: under 3 levels of 255
    # no two triangles overlap: total area equals the area covered
    tri = positions.reshape(-1, 3, 3)[:, :, [0, 2]].astype(float)
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    assert area == pytest.approx(80000.0 ** 2, rel=1e-6)


def test_blended_layers_leave_the_depth_buffer_alone(renderer, rig):
    """Overlay lines and points, the ghost and the batsman's shadow on the ground are blended
    over the scene, depth-tested but not writing depth: the depth buffer is the one of the
    scene without them (a line written into it hid the hit points drawn after it)."""
    g_p, M = pose(rig, ARMS_DOWN)
    _, M1 = pose(rig, dict(ARMS_DOWN, LeftArm=((0, 0, 1), 40)))
    line = np.array([[-100.0, 150.0, 300.0], [60.0, 100.0, -100.0]])
    bare = view_of(M, shadows=False)
    dressed = dataclasses.replace(bare, shadows=True, ghost_skin_matrices=M1, ghost_alpha=0.4,
                                  polylines=[(line, (1, 1, 0, 1), 6.0)], points=[(g_p[:5], (1, 0, 1, 1), 10.0)],
                                  crosses=[(g_p[5:8], (0, 1, 1, 1), 10.0)])
    ctx = renderer.ctx
    with ctx:
        fbo = ctx.framebuffer([ctx.texture(SIZE, 4)], ctx.depth_renderbuffer(SIZE))
        depths, images = [], []
        for v in (bare, dressed):
            renderer.render(v, fbo=fbo)
            depths.append(np.frombuffer(fbo.read(attachment=-1, dtype="f4", components=1), np.float32))
            images.append(np.frombuffer(fbo.read(components=3), np.uint8).reshape(-1, 3).astype(int))
    assert changed(images[1], images[0]).sum() > 200           # they were drawn
    np.testing.assert_array_equal(depths[1], depths[0])


def test_coarse_levels_take_the_self_shadow_per_pixel_like_the_finest(renderer, rig):
    """The vertex-lit levels light per vertex but look the shadow map up per pixel: close
    up, his whites differ from the finest level's by under 2.3 / 255 on average (with the
    lookup per vertex, 2.9: blotches of shadow smeared over the shoulders and face)."""
    from app.render import SceneView, look_at, perspective
    assert len(renderer.body_levels) >= 2, "the bundled mesh file has no coarser levels"
    _, M = pose(rig, ARMS_DOWN)
    close = SceneView(look_at(np.array([-250.0, 160.0, 60.0]), TARGET), perspective(40.0, 1.0, 5.0, 12000.0),
                      (400, 400), M)
    finest = render(renderer, dataclasses.replace(close, detail=0))
    whites = finest.min(-1) > 170
    assert whites.sum() > 20000
    for level in range(1, len(renderer.body_levels)):
        coarse = render(renderer, dataclasses.replace(close, detail=level))
        assert np.abs(coarse - finest).mean(-1)[whites].mean() < 2.3, level


def test_a_single_sampled_target_gets_a_multisampled_static_scene(renderer, rig):
    """Into a single-sampled target (the viewer's frame) the static scene is multisampled, on
    both paths: the picture is that of a 4x MSAA still but for the batsman's edges (software
    GL draws him single-sampled over the cached scene)."""
    from app.render import render_image
    _, M = pose(rig, ARMS_DOWN)
    ctx = renderer.ctx
    with ctx:
        fbo = ctx.framebuffer([ctx.texture(SIZE, 4)], ctx.depth_renderbuffer(SIZE))
        renderer.render(view_of(M, detail=0), fbo)
        frame = np.frombuffer(fbo.read(components=3), np.uint8).reshape(SIZE[1], SIZE[0], 3)[::-1].astype(int)
        still = render_image(renderer, view_of(M, detail=0)).astype(int)
        fbo.release()
    assert changed(frame, still, tol=6).mean() < (0.02 if renderer.software_gl else 1e-3)


def test_an_orbit_draws_the_static_scene_single_sampled_until_the_camera_holds_still(renderer, rig):
    """Software GL: while the camera moves the cached static scene is drawn single-sampled
    (its 4x MSAA doubled an orbit's frame time on llvmpipe): edges change, the picture does
    not; still again, it is the multisampled picture again. The plain path ignores it."""
    _, M = pose(rig, ARMS_DOWN)
    ctx = renderer.ctx
    with ctx:
        fbo = ctx.framebuffer([ctx.texture(SIZE, 4)], ctx.depth_renderbuffer(SIZE))

        def shot(moving):
            renderer.render(view_of(M, detail=0, camera_moving=moving), fbo)
            return np.frombuffer(fbo.read(components=3), np.uint8).reshape(SIZE[1], SIZE[0], 3)[::-1].astype(int)

        still, moving, still_again = shot(False), shot(True), shot(False)
        fbo.release()
    assert np.array_equal(still, still_again)
    if not renderer.software_gl:
        assert np.array_equal(still, moving)
        return
    diff = changed(still, moving, tol=6)
    assert 0.001 < diff.mean() < 0.1                                  # edges only
    assert np.abs(still.mean((0, 1)) - moving.mean((0, 1))).max() < 3.0


def test_no_offscreen_gl_is_one_line_for_the_cli(monkeypatch):
    """A machine without EGL: the commands that render say so in one line (exit 2), no traceback."""
    import moderngl

    from app.errors import UserError
    from app.render.scene import offscreen_context

    def no_egl(**kwargs):
        raise Exception("eglGetDisplay failed\nmore detail")
    monkeypatch.setattr(moderngl, "create_standalone_context", no_egl)
    with pytest.raises(UserError) as e:
        offscreen_context()
    assert "\n" not in str(e.value) and "eglGetDisplay failed" in str(e.value)
