"""A walk retargeted to uneven terrain (reference 002, section 5.4 and appendix B).

The terrain is a height function H(x, z) cm above the capture's floor (y = 0):
``sine:amp=A,wavelength=L`` (H = A sin(2 pi x / L) cos(2 pi z / L)),
``steps:rise=R,run=D`` (stairs along the walk's direction, the first frame in
the middle of step 0), or ``npy:file=PATH,x0=..,x1=..,z0=..,z1=..`` (a plain
.npy height map (nz, nx) over that extent, bilinear, held at its edges).

Each foot is two contact points: its heel (below the ankle by the ankle's lowest
height when planted) and its toe joint. A foot is on the ground where
:func:`engine.cleanup.planted_frames` says so (low *and* still: better than the
paper's height test alone). A planted foot is raised by the highest terrain under
its points (every point keeps its captured clearance, the binding one lands on H); the skeleton is displaced by the lower planted foot's rise (bending a leg is
always possible, stretching it may not be), interpolated between plants. The
off-ground foot moves with the skeleton (a plant's extra height easing in and
out over FADE_SECONDS so it does not pop), and where one of its points would come
closer to H than ``e`` it is lifted to clear it by e (appendix B). The
legs are then solved for the ankles by the learnt model (trained on the walk
itself) with a CCD finish; the feet keep their captured orientation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import distance_transform_edt, maximum_filter1d, uniform_filter1d

from . import ccd, learnt_ik as L, quat
from .cleanup import planted_frames, planted_runs
from .profiles import SIDES
from .skeleton import Clip, pose_fk

CLEARANCE = 1.0          # cm: e, the least height of an off-ground foot's points above the terrain
WALK_PLANT_SPEED = 50.0  # cm/s: a walking ankle rolls through its stance (cleanup's 15 is for a batsman's)
MIN_PLANT_SECONDS = 0.1  # a foot must stay planted this long to count as on the ground
FADE_SECONDS = 0.15     # a planted foot's extra height eases out (and in) over this
MAX_HEIGHT_CM = 1000.0   # terrain parameters beyond 10 m are a typo
MAX_MAP_CELLS = 4_000_000


@dataclass
class Terrain:
    kind: str
    params: dict
    grid: np.ndarray | None = None          # npy: heights (nz, nx) cm
    origin: np.ndarray | None = None        # steps: a point of step 0's middle (x, z)
    direction: np.ndarray | None = None     # steps: unit walking direction (x, z)

    def height(self, x, z) -> np.ndarray:
        """H(x, z) cm for arrays of ground coordinates (cm)."""
        x, z = np.asarray(x, float), np.asarray(z, float)
        p = self.params
        if self.kind == "sine":
            k = 2 * math.pi / p["wavelength"]
            return p["amp"] * np.sin(k * x) * np.cos(k * z)
        if self.kind == "steps":
            s = (x - self.origin[0]) * self.direction[0] + (z - self.origin[1]) * self.direction[1]
            return p["rise"] * np.floor(s / p["run"] + 0.5)
        return _bilinear(self.grid, (x - p["x0"]) / (p["x1"] - p["x0"]), (z - p["z0"]) / (p["z1"] - p["z0"]))


def _bilinear(grid: np.ndarray, u, v) -> np.ndarray:
    """Grid (nz, nx) at fractions u (along x), v (along z) in [0, 1], clamped."""
    nz, nx = grid.shape
    fx, fz = np.clip(u, 0, 1) * (nx - 1), np.clip(v, 0, 1) * (nz - 1)
    ix, iz = np.minimum(fx.astype(int), nx - 2 if nx > 1 else 0), np.minimum(fz.astype(int), nz - 2 if nz > 1 else 0)
    tx, tz = fx - ix, fz - iz
    g = lambda a, b: grid[np.minimum(a, nz - 1), np.minimum(b, nx - 1)]  # noqa: E731
    top = g(iz, ix) * (1 - tx) + g(iz, ix + 1) * tx
    bottom = g(iz + 1, ix) * (1 - tx) + g(iz + 1, ix + 1) * tx
    return top * (1 - tz) + bottom * tz


_KEYS = {"sine": ("amp", "wavelength"), "steps": ("rise", "run"), "npy": ("file", "x0", "x1", "z0", "z1")}


def parse_spec(spec: str) -> Terrain:
    """A Terrain from its SPEC text (see the module's doc); ValueError names the problem."""
    kind, _, rest = spec.partition(":")
    if kind not in _KEYS:
        raise ValueError(f"terrain: unknown kind {kind!r} (use sine:amp=A,wavelength=L, steps:rise=R,run=D "
                         "or npy:file=PATH,x0=..,x1=..,z0=..,z1=..)")
    params = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        if not eq or key not in _KEYS[kind] or key in params:
            raise ValueError(f"terrain {kind}: {item!r} is not one of {', '.join(k + '=' for k in _KEYS[kind])} (once each)")
        params[key] = value if key == "file" else _number(kind, key, value)
    missing = [k for k in _KEYS[kind] if k not in params]
    if missing:
        raise ValueError(f"terrain {kind}: missing {missing[0]}=")
    for key in ("wavelength", "run"):
        if key in params and params[key] <= 0:
            raise ValueError(f"terrain {kind}: {key} must be > 0")
    if kind == "npy":
        return _height_map(params)
    return Terrain(kind, params)


def _number(kind: str, key: str, text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise ValueError(f"terrain {kind}: {key}={text[:40]!r} is not a number") from None
    if not math.isfinite(v) or abs(v) > MAX_HEIGHT_CM * 100:
        raise ValueError(f"terrain {kind}: {key} must be a finite number of cm, got {text[:40]}")
    return v


def _height_map(params: dict) -> Terrain:
    if params["x1"] <= params["x0"] or params["z1"] <= params["z0"]:
        raise ValueError("terrain npy: the extent needs x0 < x1 and z0 < z1")
    path = Path(params["file"])
    try:
        grid = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise ValueError(f"terrain npy: cannot read {path} as a plain .npy array ({e.__class__.__name__})") from None
    if grid.ndim != 2 or min(grid.shape) < 1 or grid.size > MAX_MAP_CELLS or grid.dtype.kind not in "iuf":
        raise ValueError(f"terrain npy: {path} must hold a 2-D array of numbers (nz, nx), at most {MAX_MAP_CELLS} cells")
    grid = grid.astype(float)
    if not np.all(np.isfinite(grid)) or np.abs(grid).max() > MAX_HEIGHT_CM:
        raise ValueError(f"terrain npy: heights must be finite and within {MAX_HEIGHT_CM:g} cm")
    return Terrain("npy", params, grid=grid)


def place_steps(terrain: Terrain, root_positions: np.ndarray) -> None:
    """Steps run along the walk (first to last frame's hips), step 0 under the first frame."""
    if terrain.kind != "steps":
        return
    d = (root_positions[-1] - root_positions[0])[[0, 2]]
    n = np.linalg.norm(d)
    if n < 1.0:
        raise ValueError("terrain steps: the capture does not travel (its hips move < 1 cm), no direction for stairs")
    terrain.origin, terrain.direction = root_positions[0, [0, 2]].copy(), d / n


@dataclass
class TerrainResult:
    clip: Clip                   # the retargeted walk (rig joints, cm)
    rise: np.ndarray             # (F,) cm the skeleton is displaced by
    lift: np.ndarray             # (2, F) cm each foot (left, right) is raised by
    planted: np.ndarray          # (2, F) bool: the foot is on the ground
    ankle_error: np.ndarray      # (2, F) cm: ankle vs its target after the legs' IK
    ankle_rest: tuple            # (left, right) cm: the heel is this far below the ankle

    def summary(self) -> dict:
        out = {"rise_cm": [round(float(self.rise.min()), 2), round(float(self.rise.max()), 2)]}
        for k, side in enumerate(SIDES):
            out[f"{side}_planted_frames"] = int(self.planted[k].sum())
            out[f"{side}_ankle_error_cm_max"] = round(float(self.ankle_error[k].max()), 3)
        return out


def ankle_rest(rig, global_positions: np.ndarray, planted: np.ndarray, side: str) -> float:
    """The ankle's resting height (cm above the floor): its lowest over the planted
    frames ``(F,)`` (over all frames if none)."""
    y = global_positions[:, rig.chains[f"{side}_leg"].effector, 1]
    return float(y[planted].min() if planted.any() else y.min())


def foot_points(rig, global_positions: np.ndarray, side: str, rest: float) -> np.ndarray:
    """The foot's contact points ``(F, P, 3)``: the heel (``rest`` cm below the ankle)
    and the last toe joint of ``rig.feet[side]``, if any."""
    ankle = rig.chains[f"{side}_leg"].effector
    pts = [global_positions[:, ankle] - np.array([0.0, rest, 0.0])]
    toes = [j for j in rig.feet.get(side, []) if j != ankle]
    pts += [global_positions[:, toes[-1]]] if toes else []
    return np.stack(pts, axis=1)


def between_plants(planted: np.ndarray, lift: np.ndarray) -> np.ndarray:
    """(F,) ``lift (F,)`` where ``planted (F,)``, linear in between, held before the
    first and after the last planted frame."""
    if not planted.any():
        raise ValueError("terrain: no foot is ever planted (low and still) in this capture: not a walk?")
    f = np.arange(len(planted))
    return np.interp(f, f[planted], lift[planted])


def fade_from_plants(planted: np.ndarray, value: np.ndarray, frames: float) -> np.ndarray:
    """(F,) ``value (F,)`` where ``planted (F,)``; elsewhere the nearest planted frame's
    value eased (smoothstep) to 0 over ``frames`` frames; 0 with no plant."""
    if not planted.any():
        return np.zeros(len(planted))
    dist, (near,) = distance_transform_edt(~planted, return_indices=True)
    x = np.clip(1 - dist / max(frames, 1.0), 0, 1)
    return value[near] * x * x * (3 - 2 * x)


def plant_lifts(terrain: Terrain, points: np.ndarray, runs: list) -> np.ndarray:
    """(F,) in each planted run ``[a, b)`` the highest terrain under the foot's ``points
    (F, P, 3)`` (a toe rolling over a step's edge lifts the foot by the step at once:
    the foot stays on H rather than easing early); NaN off the runs."""
    # a point the capture has below its floor (y < 0) is brought up to H, not kept under it
    under = (terrain.height(points[..., 0], points[..., 2]) - np.minimum(points[..., 1], 0.0)).max(axis=1)
    lift = np.full(len(points), np.nan)
    for a, b in runs:
        lift[a:b] = under[a:b]
    return lift


def ahead(need: np.ndarray, frames: float) -> np.ndarray:
    """(F,) a smooth curve never below ``need (F,)``: the running maximum over +-frames,
    then its running mean over +-frames (each mean's window holds a maximum that covers
    the frame), so a foot rises before a step's edge instead of popping over it."""
    w = 2 * int(round(frames)) + 1
    return uniform_filter1d(maximum_filter1d(need, w, mode="nearest"), w, mode="nearest")


def below(limit: np.ndarray, frames: float) -> np.ndarray:
    """(F,) a smooth curve never above ``limit (F,)`` (the mirror of :func:`ahead`)."""
    return -ahead(-limit, frames)


def foot_lifts(terrain: Terrain, points: list, runs: list, e: float, fade: float) -> tuple:
    """(rise (F,), lift (2, F), planted (2, F)): a planted foot raised by the highest
    terrain under it; the skeleton by the lower planted foot's lift
    (interpolated between plants, eased, never above it), so a planted leg only ever bends; an off-ground foot
    with the skeleton (appendix B), its plant's extra height easing out over ``fade``
    frames, and lifted where one of its points would come within ``e`` of the terrain."""
    plift = np.stack([plant_lifts(terrain, p, r) for p, r in zip(points, runs)])
    planted = np.isfinite(plift)
    lower = np.where(planted, plift, np.inf).min(axis=0)
    rise = below(between_plants(np.isfinite(lower), lower), fade)
    clear = np.stack([ahead((terrain.height(p[..., 0], p[..., 2]) + e - p[..., 1]).max(axis=1), fade / 3)
                      for p in points])
    extra = np.stack([fade_from_plants(planted[k], np.nan_to_num(plift[k] - rise), fade) for k in range(len(points))])
    return rise, np.where(planted, plift, np.maximum(rise + extra, clear)), planted


def _solve_legs(rig, root, local, ankle_targets, src_global_rot, training_local, settings) -> np.ndarray:
    """Legs toward ``ankle_targets (2, F, 3)`` in place: learnt model, CCD finish, the feet
    turned back to their captured world orientation. Returns the ankle errors (2, F)."""
    skel = rig.skeleton
    names = tuple(f"{side}_leg" for side in SIDES)
    models = L.train_chains(rig, [training_local], settings, names=names)
    err = np.zeros(ankle_targets.shape[:2])
    for k, name in enumerate(names):
        m, ch = models[name], ccd.chain_arrays(rig, name)
        g_rot, g_pos = pose_fk(skel, root, local)
        x = L.constraints(m.limb, g_rot, g_pos, ankle_targets[k][:, None])
        local[:, m.limb.joints] = L.lookup(m, x)[0]
        g_rot, g_pos = pose_fk(skel, root, local)
        local[:, ch.joints], err[k], _ = ccd.solve(ch, g_rot[:, ch.parent], g_pos[:, ch.parent],
                                                  local[:, ch.joints], ankle_targets[k])
        foot = ch.effector
        g_rot, _ = pose_fk(skel, root, local)
        local[:, foot] = quat.mul(quat.conjugate(g_rot[:, skel.parents[foot]]), src_global_rot[:, foot])
    return err


def retarget(rig, shot, terrain: Terrain, e: float = CLEARANCE,
             settings: L.LearntSettings | None = None) -> TerrainResult:
    """``shot`` (a walk on the flat floor y = 0, cm) walked over ``terrain``."""
    if not (math.isfinite(e) and 0 <= e <= 100):
        raise ValueError(f"terrain: clearance e must be between 0 and 100 cm, got {e}")
    g_rot, g_pos = shot.fk
    place_steps(terrain, shot.clip.root_positions)
    ankles = [rig.chains[f"{side}_leg"].effector for side in SIDES]
    least = max(3, int(round(MIN_PLANT_SECONDS * shot.clip.fps)))     # shorter 'plants' are flicker
    fps = shot.clip.fps
    runs = [planted_runs(g_pos[:, a], fps, speed_tol=WALK_PLANT_SPEED, min_frames=least) for a in ankles]
    rest = [ankle_rest(rig, g_pos, planted_frames(g_pos[:, a], fps, speed_tol=WALK_PLANT_SPEED), side)
            for a, side in zip(ankles, SIDES)]
    points = [foot_points(rig, g_pos, side, rest[k]) for k, side in enumerate(SIDES)]
    rise, lift, planted = foot_lifts(terrain, points, runs, e, FADE_SECONDS * fps)
    root = shot.clip.root_positions + rise[:, None] * [0.0, 1.0, 0.0]
    local = shot.clip.local_rotations.copy()
    targets = np.stack([g_pos[:, a] for a in ankles]) + lift[..., None] * [0.0, 1.0, 0.0]
    err = _solve_legs(rig, root, local, targets, g_rot, shot.clip.local_rotations, settings)
    return TerrainResult(Clip(root, local, shot.clip.fps), rise, lift, planted, err, tuple(rest))


def clearances(rig, result: TerrainResult, terrain: Terrain) -> np.ndarray:
    """(2, F) cm: each foot's lowest contact point above the terrain in the result
    (negative: sunk into it)."""
    _, g_pos = pose_fk(rig.skeleton, result.clip.root_positions, result.clip.local_rotations)
    out = []
    for k, side in enumerate(SIDES):
        p = foot_points(rig, g_pos, side, result.ankle_rest[k])
        out.append((p[..., 1] - terrain.height(p[..., 0], p[..., 2])).min(axis=1))
    return np.stack(out)


def terrain_mesh(terrain: Terrain, x_range, z_range, cell: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """A triangle mesh of the terrain over ``x_range``, ``z_range`` (cm) for drawing:
    vertices ``(N, 3)`` on H every ``cell`` cm and triangles ``(M, 3)`` (counter-clockwise
    seen from above, so their normals point up)."""
    if not (cell > 0 and x_range[1] > x_range[0] and z_range[1] > z_range[0]):
        raise ValueError("terrain mesh: needs cell > 0 and non-empty ranges")
    xs = np.linspace(x_range[0], x_range[1], max(2, int(math.ceil((x_range[1] - x_range[0]) / cell)) + 1))
    zs = np.linspace(z_range[0], z_range[1], max(2, int(math.ceil((z_range[1] - z_range[0]) / cell)) + 1))
    X, Z = np.meshgrid(xs, zs)                      # (nz, nx)
    verts = np.stack([X, terrain.height(X, Z), Z], axis=-1).reshape(-1, 3)
    nx = len(xs)
    i = (np.arange(len(zs) - 1)[:, None] * nx + np.arange(nx - 1)[None, :]).reshape(-1)
    tris = np.concatenate([np.stack([i, i + nx, i + 1], -1), np.stack([i + 1, i + nx, i + nx + 1], -1)])
    return verts, tris
