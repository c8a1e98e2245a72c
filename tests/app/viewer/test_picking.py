"""Camera and picking maths (no window): rays through projected points hit
them, target drags stay on their plane and in bounds, gestures stay sane."""
import numpy as np

from app.viewer import picking
from app.viewer.camera import OrbitCamera

VIEWPORT = (0, 0, 920, 674)


def matrices(cam):
    return cam.view(), cam.proj(VIEWPORT[2] / VIEWPORT[3])


def test_projected_point_ray_passes_through_it():
    rng = np.random.default_rng(1)
    cam = OrbitCamera()
    for _ in range(50):
        cam.orbit(*rng.uniform(-200, 200, 2))
        cam.zoom(rng.uniform(-3, 3))
        view, proj = matrices(cam)
        p = rng.uniform([-150, 0, -100], [150, 250, 300])
        px = picking.project(p, VIEWPORT, view, proj)
        if not np.isfinite(px).all():
            continue
        o, d = picking.pixel_ray(*px, VIEWPORT, view, proj)
        assert abs(np.linalg.norm(d) - 1) < 1e-9
        closest = o + np.dot(p - o, d) * d
        assert np.linalg.norm(closest - p) < 1e-6 * max(1.0, np.linalg.norm(p - o))


def test_target_plane_hit_is_on_the_plane_and_picks_the_target():
    cam = OrbitCamera()
    view, proj = matrices(cam)
    target = np.array([30.0, 80.0, picking.TARGET_PLANE_Z])
    px = picking.project(target, VIEWPORT, view, proj)
    hit = picking.target_plane_hit(*px, VIEWPORT, view, proj)
    assert np.allclose(hit, target, atol=1e-6)
    assert picking.hits_target(*px, VIEWPORT, view, proj, target)
    far = picking.project(target + [200, 0, 0], VIEWPORT, view, proj)
    assert not picking.hits_target(*far, VIEWPORT, view, proj, target)


def test_rays_missing_the_plane_give_none_and_clamp_bounds():
    assert picking.ray_plane(np.zeros(3), np.array([1.0, 0, 0]), (0, 0, -60), (0, 0, 1)) is None
    assert picking.ray_plane(np.zeros(3), np.array([0, 0, 1.0]), (0, 0, -60), (0, 0, 1)) is None  # behind
    p = picking.clamp_target([1e9, -1e9, 5.0])
    assert p[2] == picking.TARGET_PLANE_Z and p[0] == picking.TARGET_BOUNDS[0, 1] and p[1] == picking.TARGET_BOUNDS[1, 0]


def test_camera_gestures_keep_finite_matrices():
    cam = OrbitCamera()
    for d in (1e6, -1e6, 0.0):
        cam.orbit(d, d)
        cam.pan(d, -d, 920, 674)
        cam.zoom(d / 1e4)
        view, proj = matrices(cam)
        assert np.isfinite(view).all() and np.isfinite(proj).all()
        assert -5 <= cam.pitch <= 89 and 60 <= cam.distance <= 5000
    cam.reset()
    assert np.allclose(cam.pivot, OrbitCamera().pivot)


def test_a_narrow_window_keeps_the_batsman_in_view():
    """A viewport narrower than the default (a window snapped to half a screen: 600 x 1050)
    keeps the default's horizontal field of view: what lies at the sides of the default view
    stays inside the narrow one, and a wide viewport keeps the vertical field of view."""
    cam = OrbitCamera()
    view = cam.view()
    wide, narrow = VIEWPORT, (0, 0, 600, 1050)
    edges = [picking.pixel_ray(x, 337.0, wide, view, cam.proj(920 / 674)) for x in (5.0, 915.0)]
    for o, d in edges:
        p = o + 560.0 * d                                  # at the pivot's depth
        x, y = picking.project(p, narrow, view, cam.proj(600 / 1050))
        assert 0.0 < x < 600.0 and 0.0 < y < 1050.0
    assert cam.fovy_for(920 / 674) == cam.fovy and cam.fovy_for(2.5) == cam.fovy
    assert cam.fovy < cam.fovy_for(600 / 1050) <= 150.0 and cam.fovy_for(1e-9) == 150.0


def test_a_pan_moves_the_scene_with_the_pointer():
    """A pan of (dx, dy) pixels moves a point at the pivot's depth by (dx, dy) on screen, in
    the default viewport and in a narrow one."""
    for vp in (VIEWPORT, (0, 0, 600, 1050)):
        cam = OrbitCamera()
        point = cam.pivot.copy()
        before = picking.project(point, vp, cam.view(), cam.proj(vp[2] / vp[3]))
        cam.pan(30.0, -20.0, vp[2], vp[3])
        after = picking.project(point, vp, cam.view(), cam.proj(vp[2] / vp[3]))
        assert np.allclose(after - before, (30.0, -20.0), atol=0.5), (vp, after - before)
