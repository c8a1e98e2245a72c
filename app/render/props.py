"""Static scene geometry built once: stumps and bails, the target disc, unit cross.

Meshes are dicts of flat arrays (positions, normals, colors, gloss, indices),
the same layout as ``app.mesh.Mesh`` for the static program.
"""
from __future__ import annotations

import functools

import numpy as np

from app.render.mesh import Mesh

STUMP_HEIGHT = 71.1         # cm above the ground (law 8)
STUMP_DIAMETER = 3.65
WICKET_WIDTH = 22.86
BAIL_LENGTH = 10.95
PITCH_LENGTH = 2012.0
WOOD = (0.93, 0.88, 0.74)


def cylinder(p0, p1, radius, color, n=16, gloss=0.35) -> Mesh:
    """Closed cylinder with flat caps (split normals) from ``p0`` to ``p1``."""
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    axis = p1 - p0
    h = np.linalg.norm(axis)
    a = axis / h
    ref = np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(a, ref)
    u /= np.linalg.norm(u)
    v = np.cross(a, u)
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ring = np.cos(th)[:, None] * u + np.sin(th)[:, None] * v
    side_pos = np.concatenate([p0 + radius * ring, p1 + radius * ring])
    side_nrm = np.concatenate([ring, ring])
    i = np.arange(n)
    j = (i + 1) % n
    side_idx = np.concatenate([np.stack([i, j, n + j], 1), np.stack([i, n + j, n + i], 1)])
    cap0 = np.concatenate([[p0], p0 + radius * ring])
    cap1 = np.concatenate([[p1], p1 + radius * ring])
    base0, base1 = 2 * n, 3 * n + 1
    cap0_idx = np.stack([np.full(n, base0), base0 + 1 + j, base0 + 1 + i], 1)
    cap1_idx = np.stack([np.full(n, base1), base1 + 1 + i, base1 + 1 + j], 1)
    pos = np.concatenate([side_pos, cap0, cap1])
    nrm = np.concatenate([side_nrm, np.tile(-a, (n + 1, 1)), np.tile(a, (n + 1, 1))])
    idx = np.concatenate([side_idx, cap0_idx, cap1_idx])
    return _mesh(pos, nrm, idx, color, gloss)


def _mesh(pos, nrm, idx, color, gloss) -> Mesh:
    V = len(pos)
    col = np.ones((V, 4), np.float32)
    col[:, :3] = np.asarray(color, np.float32)[..., :3] if np.ndim(color) == 1 else color
    return Mesh(pos.astype(np.float32), nrm.astype(np.float32), col, np.full(V, gloss, np.float32),
                idx.astype(np.uint32))


def merge(meshes: list[Mesh]) -> Mesh:
    offs = np.cumsum([0] + [len(m.positions) for m in meshes])[:-1]
    return Mesh(np.concatenate([m.positions for m in meshes]), np.concatenate([m.normals for m in meshes]),
                np.concatenate([m.colors for m in meshes]), np.concatenate([m.gloss for m in meshes]),
                np.concatenate([m.indices + o for m, o in zip(meshes, offs)]).astype(np.uint32))


def wickets() -> Mesh:
    """Three stumps and two bails at each end; middle stump of the batting end at the origin."""
    parts = []
    r = STUMP_DIAMETER / 2
    gap = (WICKET_WIDTH - STUMP_DIAMETER) / 2
    for z in (0.0, PITCH_LENGTH):
        for x in (-gap, 0.0, gap):
            parts.append(cylinder((x, 0.0, z), (x, STUMP_HEIGHT - 0.6, z), r, WOOD, 14))
            parts.append(cylinder((x, STUMP_HEIGHT - 0.6, z), (x, STUMP_HEIGHT, z), r * 0.8, WOOD, 14))
        for x0, x1 in ((-gap, 0.0), (0.0, gap)):
            mid = (x0 + x1) / 2
            parts.append(cylinder((mid - BAIL_LENGTH / 2, STUMP_HEIGHT + 0.6, z),
                                  (mid + BAIL_LENGTH / 2, STUMP_HEIGHT + 0.6, z), 0.75, WOOD, 10))
    return merge(parts)


def target_disc(radius: float = 30.0, rings: int = 5, thickness: float = 1.5) -> Mesh:
    """Red-and-white archery-style disc facing +Z, centred at the origin, both faces ringed."""
    n = 40      # the rim deviates < 0.5 px from a circle even 300 px across
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    cs = np.stack([np.cos(th), np.sin(th), np.zeros(n)], 1)
    red, white = (0.80, 0.06, 0.06), (0.97, 0.97, 0.97)
    parts = []
    for face_z, sign in ((thickness / 2, 1.0), (-thickness / 2, -1.0)):
        for k in range(rings):
            r0, r1 = radius * k / rings, radius * (k + 1) / rings
            color = red if (rings - 1 - k) % 2 == 0 else white
            inner = cs * r0 + (0, 0, face_z)
            outer = cs * r1 + (0, 0, face_z)
            pos = np.concatenate([inner, outer])
            i = np.arange(n)
            j = (i + 1) % n
            idx = np.concatenate([np.stack([i, j, n + j], 1), np.stack([i, n + j, n + i], 1)])
            if k == 0:      # the centre ring is a fan (no zero-area triangles)
                idx = idx[n:]
            if sign > 0:   # counter-clockwise seen from the side the face looks at
                idx = idx[:, ::-1]
            parts.append(_mesh(pos, np.tile((0, 0, sign), (2 * n, 1)), idx, color, 0.3))
    rim = cylinder((0, 0, -thickness / 2 + 0.1), (0, 0, thickness / 2 - 0.1), radius + 0.6, (0.08, 0.10, 0.20), n, 0.5)
    parts.append(rim)
    return merge(parts)


def target_model(position, normal) -> np.ndarray:
    """Model matrix ``(4,4)`` placing the disc's +Z on ``normal`` at ``position``."""
    m = _disc_axes(tuple(float(v) for v in np.ravel(normal))).copy()
    m[:3, 3] = position
    return m


@functools.lru_cache(maxsize=8)
def _disc_axes(normal: tuple) -> np.ndarray:
    """Rotation part (4,4) of ``target_model``: the plane's normal is fixed, so it is built once."""
    z = np.asarray(normal, float)
    z = z / (np.linalg.norm(z) or 1.0)
    up = np.array([0.0, 1.0, 0.0]) if abs(z[1]) < 0.95 else np.array([1.0, 0.0, 0.0])
    x = np.cross(up, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, y, z
    return m.astype(np.float32)


def translation(p) -> np.ndarray:
    m = np.eye(4, dtype=np.float32)
    m[:3, 3] = p
    return m


# ----------------------------------------------------------------- ground
GRASS = (0.27, 0.40, 0.18)
GRASS_STRIPE = (0.32, 0.46, 0.21)
PITCH = (0.80, 0.74, 0.56)
PITCH_WORN = (0.71, 0.63, 0.46)
LINE = (0.97, 0.97, 0.96)
PITCH_HALF_WIDTH = 152.5     # 3.05 m strip
PITCH_OVERRUN = 150.0        # strip beyond each bowling crease
CREASE_HALF = 2.5            # lines 5 cm wide


def _quad(x0, x1, z0, z1, colors) -> tuple[np.ndarray, np.ndarray]:
    """Ground quad (y=0) as 2 triangles; ``colors`` one rgb or 4 rgb (x0z0, x1z0, x1z1, x0z1)."""
    p = np.array([[x0, 0, z0], [x1, 0, z0], [x1, 0, z1], [x0, 0, z0], [x1, 0, z1], [x0, 0, z1]], np.float32)
    c = np.asarray(colors, np.float32).reshape(-1, 3)
    c = np.tile(c, (6, 1)) if len(c) == 1 else c[[0, 1, 2, 0, 2, 3]]
    return p, c


def crease_rects(z0: float, direction: float) -> list[tuple[float, float, float, float]]:
    """Crease lines of one end (law 7) as (x0, x1, z0, z1): bowling crease 2.64 m through the
    stumps, popping crease 1.22 m in front (drawn 1.83 m each side of the middle stump), return
    creases 1.32 m either side running 2.44 m back from the popping crease."""
    w = CREASE_HALF
    pop = z0 + direction * 122.0
    back = pop - direction * 244.0
    zlo, zhi = min(pop, back), max(pop, back)
    return [(-132.0 - w, 132.0 + w, z0 - w, z0 + w), (-183.0, 183.0, pop - w, pop + w),
            (-132.0 - w, -132.0 + w, zlo - w, zhi + w), (132.0 - w, 132.0 + w, zlo - w, zhi + w)]


def ground_layers() -> list[tuple]:
    """The ground as rectangles in painter's order (each over the ones before): outfield, mown
    stripes, pitch strip with worn ends, creases. Rows (x0, x1, z0, z1, colours (4,3) sRGB at
    (x0,z0), (x1,z0), (x1,z1), (x0,z1)), interpolated over the triangles of ``_quad``."""
    flat = lambda c: np.tile(np.asarray(c, float), (4, 1))
    layers = [(-40000.0, 40000.0, -40000.0, 40000.0, flat(GRASS))]
    for x in np.arange(-6000.0, 6000.0, 600.0):
        layers.append((x + 300.0, x + 600.0, -6000.0, 8000.0, flat(GRASS_STRIPE)))
    L, hw = PITCH_LENGTH, PITCH_HALF_WIDTH
    # strip in bands along z so the worn areas in front of each crease blend smoothly
    zs = np.array([-PITCH_OVERRUN, 0, 60, 120, 200, 300, 420, 600, L - 600, L - 420, L - 300, L - 200,
                   L - 120, L - 60, L, L + PITCH_OVERRUN])
    wear = np.exp(-((zs - 200.0) / 160.0) ** 2) + np.exp(-((zs - (L - 200.0)) / 160.0) ** 2)
    xs = np.array([-hw, -45.0, 0.0, 45.0, hw])
    xw = np.exp(-(xs / 60.0) ** 2)
    col = lambda zi, xi: np.asarray(PITCH) + (np.asarray(PITCH_WORN) - PITCH) * 0.7 * wear[zi] * xw[xi]
    for i in range(len(zs) - 1):
        for k in range(len(xs) - 1):
            layers.append((xs[k], xs[k + 1], zs[i], zs[i + 1],
                           np.array([col(i, k), col(i, k + 1), col(i + 1, k + 1), col(i + 1, k)])))
    for z0, d in ((0.0, 1.0), (L, -1.0)):
        for x0, x1, za, zb in crease_rects(z0, d):
            layers.append((x0, x1, za, zb, flat(LINE)))
    return layers


def layer_color(layer, x, z) -> np.ndarray:
    """sRGB colour ``(N,3)`` of ``layer`` at ground points ``x, z (N,)`` inside it: linear over
    each of its two triangles (split along (x0,z0)-(x1,z1)), as the rasteriser would."""
    x0, x1, z0, z1, c = layer
    u = (np.asarray(x, float) - x0) / (x1 - x0)
    v = (np.asarray(z, float) - z0) / (z1 - z0)
    u, v = u[:, None], v[:, None]
    lower = c[0] + u * (c[1] - c[0]) + v * (c[2] - c[1])       # triangle (x0z0, x1z0, x1z1)
    upper = c[0] + v * (c[3] - c[0]) + u * (c[2] - c[3])       # triangle (x0z0, x1z1, x0z1)
    return np.where(u >= v, lower, upper)


def ground() -> tuple[np.ndarray, np.ndarray]:
    """Ground triangles ``ground_layers`` cut into cells that do not overlap: every pixel of
    ground is shaded once (in painter's order the stripes, strip and creases drew over the
    outfield 3-5 times, which made redrawing the static scene - orbiting - slow). Each cell
    takes the colours of the topmost layer over it; runs of one flat colour along x are
    merged. Returns positions (N,3) and sRGB colours (N,3)."""
    layers = ground_layers()
    xs = np.unique(np.concatenate([[l[0], l[1]] for l in layers]))
    zs = np.unique(np.concatenate([[l[2], l[3]] for l in layers]))
    xc, zc = 0.5 * (xs[:-1] + xs[1:]), 0.5 * (zs[:-1] + zs[1:])
    owner = np.zeros((len(zc), len(xc)), int)
    for i, (x0, x1, z0, z1, _) in enumerate(layers):
        owner[np.ix_((zc > z0) & (zc < z1), (xc > x0) & (xc < x1))] = i
    flat = [bool(np.all(l[4] == l[4][0])) for l in layers]
    quads = []
    for j in range(len(zc)):
        k = 0
        while k < len(xc):
            i = owner[j, k]
            end = k + 1
            while flat[i] and end < len(xc) and owner[j, end] == i:
                end += 1
            x0, x1, z0, z1 = xs[k], xs[end], zs[j], zs[j + 1]
            corners = np.tile(layers[i][4][0], (4, 1)) if flat[i] else layer_color(
                layers[i], np.array([x0, x1, x1, x0]), np.array([z0, z0, z1, z1]))
            quads.append((x0, x1, z0, z1, corners))
            k = end
    # all quads at once, as _quad lays them out: (x0z0, x1z0, x1z1), (x0z0, x1z1, x0z1)
    q = np.array([r[:4] for r in quads])
    x = q[:, [0, 1, 1, 0, 1, 0]]
    z = q[:, [2, 2, 3, 2, 3, 3]]
    positions = np.stack([x, np.zeros_like(x), z], -1).reshape(-1, 3).astype(np.float32)
    colors = np.array([r[4] for r in quads])[:, [0, 1, 2, 0, 2, 3]].reshape(-1, 3).astype(np.float32)
    return positions, colors


# ----------------------------------------------------------------- stadium
BOUNDARY = (6300.0, 7000.0)     # boundary rope half-axes (x, z) around the pitch centre, cm
BOARD_COLORS = [(0.10, 0.18, 0.45), (0.80, 0.12, 0.12), (0.95, 0.80, 0.15), (0.10, 0.50, 0.30), (0.95, 0.95, 0.95)]
CROWD = [(0.62, 0.22, 0.20), (0.20, 0.30, 0.55), (0.80, 0.78, 0.70), (0.30, 0.45, 0.30), (0.75, 0.62, 0.25)]


def _ring(theta: np.ndarray, scale: float) -> np.ndarray:
    """Points (K,3) on the oval of the boundary scaled by ``scale``, around the pitch centre."""
    return np.stack([np.cos(theta) * BOUNDARY[0] * scale, np.zeros_like(theta),
                     PITCH_LENGTH / 2 + np.sin(theta) * BOUNDARY[1] * scale], 1)


def _band(a: np.ndarray, b: np.ndarray, ca, cb) -> tuple[np.ndarray, np.ndarray]:
    """Triangles joining polyline ``a`` to polyline ``b`` (both (K,3)); colours per vertex row."""
    ca, cb = np.broadcast_to(ca, a.shape), np.broadcast_to(cb, b.shape)
    i = np.arange(len(a) - 1)
    tri = np.stack([np.stack([a[i], a[i + 1], b[i + 1]], 1), np.stack([a[i], b[i + 1], b[i]], 1)], 1)
    col = np.stack([np.stack([ca[i], ca[i + 1], cb[i + 1]], 1), np.stack([ca[i], cb[i + 1], cb[i]], 1)], 1)
    return tri.reshape(-1, 3), col.reshape(-1, 3)


def stadium(segments: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """Boundary rope, advertising boards, sightscreens and tiered stands with a crowd, as
    flat-lit coloured triangles (positions (N,3), sRGB colours (N,3)); a few thousand triangles."""
    rng = np.random.default_rng(7)
    theta = np.linspace(0, 2 * np.pi, segments + 1)
    parts = []
    # rope: a low white ribbon just off the grass
    r0, r1 = _ring(theta, 1.0), _ring(theta, 1.0 + 10.0 / BOUNDARY[0])
    r0[:, 1] = r1[:, 1] = 4.0
    parts.append(_band(r0, r1, (0.97, 0.97, 0.97), (0.97, 0.97, 0.97)))
    # advertising boards: one colour per board (duplicated vertices for hard colour edges)
    lo, hi = _ring(theta, 1.06), _ring(theta, 1.06)
    hi[:, 1] = 90.0
    for k in range(segments):
        c = BOARD_COLORS[k % len(BOARD_COLORS)]
        parts.append(_band(lo[k:k + 2], hi[k:k + 2], c, np.minimum(np.asarray(c) * 1.15 + 0.05, 1.0)))
    # stands: tiers rising away from the field, seat sections in muted colours (flat per section)
    tiers = [(1.10, 1.10, 180.0), (1.10, 1.20, 520.0), (1.20, 1.30, 950.0), (1.30, 1.36, 1250.0)]
    for k, (s0, s1, h1) in enumerate(tiers):
        a = _ring(theta, s0)
        b = _ring(theta, s1)
        a[:, 1] = 0.0 if k == 0 else tiers[k - 1][2]
        b[:, 1] = h1
        if k == 0:   # the front wall below the first tier
            parts.append(_band(a, b, (0.34, 0.36, 0.40), (0.42, 0.44, 0.48)))
            continue
        for j in range(segments):
            c = np.asarray(CROWD[(j // 4 + k) % len(CROWD)]) * 0.45 + 0.25
            c = c * rng.uniform(0.85, 1.0)
            parts.append(_band(a[j:j + 2], b[j:j + 2], c * 0.8, c))
    top = _ring(theta, tiers[-1][1])
    top[:, 1] = tiers[-1][2]
    roof = _ring(theta, tiers[-1][1] + 0.03)
    roof[:, 1] = tiers[-1][2] + 300.0
    parts.append(_band(top, roof, (0.78, 0.80, 0.84), (0.90, 0.91, 0.93)))
    # sightscreens behind each wicket, in front of the stands
    for z, sign in ((PITCH_LENGTH / 2 - BOUNDARY[1] * 1.08, 1), (PITCH_LENGTH / 2 + BOUNDARY[1] * 1.08, -1)):
        a = np.array([[-700.0, 0.0, z], [700.0, 0.0, z]])
        b = a + (0.0, 700.0, 0.0)
        parts.append(_band(a, b, (0.96, 0.96, 0.96), (0.99, 0.99, 0.99)))
    return np.concatenate([p[0] for p in parts]).astype(np.float32), np.concatenate([p[1] for p in parts]).astype(np.float32)


TERRAIN_RGB = ((0.42, 0.36, 0.26), (0.58, 0.52, 0.38))     # low and high ground
TERRAIN_LINE_CM = 20.0      # a darker line every this many cm across, so the bumps read in a still


def terrain_prop(vertices: np.ndarray, triangles: np.ndarray) -> Mesh:
    """A drawable mesh of ``engine.terrain.terrain_mesh``'s vertices ``(N, 3)`` and triangles
    ``(M, 3)``: smooth normals, coloured by height, with grid lines every TERRAIN_LINE_CM."""
    v = np.asarray(vertices, float)
    t = np.asarray(triangles, np.int64)
    face = np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]])
    if face[:, 1].sum() < 0:
        face = -face                       # the terrain's normals point up
    nrm = np.zeros_like(v)
    for k in range(3):
        np.add.at(nrm, t[:, k], face)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-9)
    y = v[:, 1]
    a = (y - y.min()) / max(float(np.ptp(y)), 1e-9)
    lo, hi = (np.asarray(c) for c in TERRAIN_RGB)
    col = lo + a[:, None] * (hi - lo)
    line = (np.abs((v[:, 0] / TERRAIN_LINE_CM + 0.5) % 1 - 0.5) < 0.06) | \
        (np.abs((v[:, 2] / TERRAIN_LINE_CM + 0.5) % 1 - 0.5) < 0.06)
    col[line] *= 0.7
    return _mesh(v, nrm, t, col, 0.1)
