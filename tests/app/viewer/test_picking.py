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
        cam.pan(d, -d, 674)
        cam.zoom(d / 1e4)
        view, proj = matrices(cam)
        assert np.isfinite(view).all() and np.isfinite(proj).all()
        assert -5 <= cam.pitch <= 89 and 60 <= cam.distance <= 5000
    cam.reset()
    assert np.allclose(cam.pivot, OrbitCamera().pivot)
