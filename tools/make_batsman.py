"""Write assets/batsman.glb: the bundled skinned batsman, his bat and a ball.

Deterministic; run ``python -m tools.make_batsman``. Everything is built from
primitives (lofted tubes, superellipsoids, trimesh icospheres) in the rig's
T-pose (cm, Y up, facing +Z, left side +X, arms along +-X palms down) and bound
to ``engine.rig.default_rig().skeleton`` with computed weights:

* limbs get weights from keys along the bone (smoothstep between keys), so the
  elbows, knees, shoulders and spine bend smoothly and the arm twist is spread
  over Arm -> ArmRoll and ForeArm -> ForeArmRoll (no candy wrapper);
* at most 4 influences per vertex, summing to 1;
* the bat (geometry from ``rig.bat``) is bound 100 % to LeftHand.

The glTF 2.0 binary holds one skinned mesh ``Batsman`` (node ``Batsman_body``; vertex
colours COLOR_0, a per-vertex gloss ``_GLOSS``), a coarse skinned copy ``BatsmanShadow``
(the same shapes at a lower ``detail``: the renderer's shadow caster), two levels of
detail ``BatsmanLod1``/``BatsmanLod2``, the joint nodes (names as in the rig, rest
frames world-aligned, so each inverse bind matrix is a translation by the
negated bind position) and an unskinned ``Ball`` mesh. Units are cm; the joints hang
under the character's root node ``Batsman`` whose scale 0.01 shows him 1.8 m tall in
glTF tools (metres). The default scene holds only him (root and body); the ball, the
shadow caster and the levels of detail are in a second scene, so a user opening the
file sees one batsman. (Exports, engine.gltf_export, are in metres with no scale.)
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from engine.rig import Rig, assets_dir, default_rig
from engine.skeleton import bind_positions

# sRGB colours
SHIRT = (0.93, 0.91, 0.84)
TROUSERS = (0.89, 0.87, 0.79)
PAD = (0.97, 0.97, 0.95)
STRAP = (0.78, 0.79, 0.80)
GLOVE = (0.96, 0.96, 0.95)
GLOVE_BAND = (0.10, 0.16, 0.40)
HELMET = (0.07, 0.11, 0.30)
LINING = (0.05, 0.06, 0.09)
GRILLE = (0.62, 0.64, 0.68)
SKIN = (0.80, 0.60, 0.47)
SHOE = (0.95, 0.95, 0.95)
SOLE = (0.20, 0.20, 0.22)
WILLOW = (0.88, 0.77, 0.56)
GRIP = (0.55, 0.09, 0.12)
BALL_RED = (0.62, 0.04, 0.05)
SEAM = (0.93, 0.90, 0.80)


@dataclass
class Part:
    vertices: np.ndarray   # (V, 3)
    faces: np.ndarray      # (T, 3)
    normals: np.ndarray    # (V, 3)
    colors: np.ndarray     # (V, 3) sRGB
    gloss: float
    weights: np.ndarray | None = None  # (V, J)


# ----------------------------------------------------------------- detail
# Tessellation level: 1.0 is the reference; the primitives scale their ring counts, steps
# along paths and subdivisions by it. Set only through ``build(detail=...)``.
BODY_DETAIL = 0.65      # the drawn mesh (~20k triangles: llvmpipe pays per triangle)
SHADOW_DETAIL = 0.4     # the shadow caster (only its outline matters) ...
SHADOW_TRIANGLES = 2000 # ... decimated to about this many triangles (the map has ~1 cm texels)
LOD1_DETAIL = 0.5       # drawn when he is smaller on screen: half the triangles, the same silhouette
LOD2_DETAIL = 0.3       # smaller still: a third of the triangles
_detail = 1.0


def ring(n: int, low: int = 4) -> int:
    """Segments round a section at the current detail (even, at least ``low``)."""
    return n if _detail == 1.0 else max(low, 2 * int(round(n * _detail / 2)))


def count(n: int, low: int = 2) -> int:
    """Samples along a path at the current detail."""
    return n if _detail == 1.0 else max(low, int(round(n * _detail)))


def subdiv(s: int) -> int:
    """Icosphere subdivisions at the current detail (the finest level goes first)."""
    return max(1, s - (1 if _detail < 0.6 or (_detail < 0.7 and s >= 3) else 0))


# ----------------------------------------------------------------- geometry
def smoothstep(e0, e1, x):
    t = np.clip((np.asarray(x, float) - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3 - 2 * t)


def loft(rings: np.ndarray, cap_start: bool = False, cap_end: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Tube through ``rings (K, M, 3)`` (closed loops); optional fan caps to the ring centroids.

    Returns vertices and faces; winding is fixed outward later by ``finish``.
    """
    K, M, _ = rings.shape
    verts = rings.reshape(-1, 3)
    i = np.arange(K - 1)[:, None] * M
    j = np.arange(M)[None, :]
    a, b = i + j, i + (j + 1) % M
    c, d = a + M, b + M
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    extra = []
    for cap, k, flip in ((cap_start, 0, True), (cap_end, K - 1, False)):
        if not cap:
            continue
        centre_index = len(verts) + sum(len(e) for e in extra)
        extra.append(rings[k].mean(0)[None])
        ring = k * M + np.arange(M)
        f = np.stack([np.full(M, centre_index), ring, np.roll(ring, -1)], -1)
        faces = np.concatenate([faces, f[:, ::-1] if flip else f])
    if extra:
        verts = np.concatenate([verts] + extra)
    return verts, faces


def frames_along(centres: np.ndarray, up) -> tuple[np.ndarray, np.ndarray]:
    """Per-section unit vectors (u near ``up``, v = tangent x u) along a path (K,3)."""
    t = np.gradient(centres, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    up = np.broadcast_to(np.asarray(up, float), t.shape)
    u = up - np.sum(up * t, 1, keepdims=True) * t
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(t, u)
    return u, v


def resample(centres, ru, rv, step):
    """Sections every ``step`` cm along the path (linear in arc length), so joints bend over many rings."""
    seg = np.linalg.norm(np.diff(centres, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    t = np.linspace(0, s[-1], max(int(np.ceil(s[-1] / step)), 1) + 1)
    c = np.stack([np.interp(t, s, centres[:, k]) for k in range(3)], 1)
    return c, np.interp(t, s, ru), np.interp(t, s, rv)


def tube(centres, ru, rv, up, n=24, power=2.0, dome_start=0.0, dome_end=0.0, step=None):
    """Superelliptic tube along ``centres (K,3)`` with radii ``ru`` (along ``up``) and ``rv``.

    ``dome_*`` > 0 closes that end with a half-ellipsoid of that depth (cm); ``step``
    resamples the sections every ``step`` cm.
    """
    # along the path only the coarse caster thins out: joints bend over many rings
    n, step = ring(n), (step / _detail if step and _detail < 0.6 else step)
    centres = np.asarray(centres, float)
    ru, rv = np.broadcast_to(np.asarray(ru, float), len(centres)), np.broadcast_to(np.asarray(rv, float), len(centres))
    if step:
        centres, ru, rv = resample(centres, ru, rv, step)
    u, v = frames_along(centres, up)
    tangent = np.gradient(centres, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    sections = [(c, a, b, uu, vv) for c, a, b, uu, vv in zip(centres, ru, rv, u, v)]
    for end, depth in ((0, dome_start), (-1, dome_end)):
        if depth <= 0:
            continue
        c, a, b, uu, vv = sections[end]
        sign = -1 if end == 0 else 1
        dome = []
        for ang in np.radians([22.5, 45, 67.5, 82] if _detail >= 0.6 else [40, 75]):
            dome.append((c + sign * np.sin(ang) * depth * tangent[end], a * np.cos(ang), b * np.cos(ang), uu, vv))
        sections = (dome[::-1] + sections) if end == 0 else (sections + dome)
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    cu, sv = np.cos(th), np.sin(th)
    e = 2.0 / power
    fu, fv = np.sign(cu) * np.abs(cu) ** e, np.sign(sv) * np.abs(sv) ** e
    rings = np.array([c + a * fu[:, None] * uu + b * fv[:, None] * vv for c, a, b, uu, vv in sections])
    return loft(rings, cap_start=dome_start > 0, cap_end=dome_end > 0)


def superellipsoid(centre, radii, power=2.0, subdivisions=3):
    """Rounded box / ellipsoid from an icosphere (vertices, faces)."""
    s = trimesh.creation.icosphere(subdivisions=subdiv(subdivisions))
    n = np.asarray(s.vertices)
    e = 2.0 / power
    p = np.sign(n) * np.abs(n) ** e
    return np.asarray(centre, float) + p * np.asarray(radii, float), np.asarray(s.faces)


def capsule(p0, p1, radius, count=(12, 16)):
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    h = np.linalg.norm(p1 - p0)
    m = trimesh.creation.capsule(height=h, radius=radius, count=[ring(c, 4) for c in count])
    z = np.array([0, 0, 1.0])
    d = (p1 - p0) / h
    R = trimesh.geometry.align_vectors(z, d)
    m.apply_transform(R)
    m.apply_translation((p0 + p1) / 2)
    return np.asarray(m.vertices), np.asarray(m.faces)


def finish(verts, faces, color, gloss, smooth_angle: float | None = None, inward: bool = False) -> Part:
    """Outward (or ``inward``) winding, smooth normals (split at edges sharper than ``smooth_angle`` deg)."""
    m = trimesh.Trimesh(np.asarray(verts, float), np.asarray(faces, np.int64), process=False)
    # Orient outward: positive signed volume about the centroid (works for nearly closed shells too).
    tri = m.triangles - m.vertices.mean(0)
    if (np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() < 0) != inward:
        m = trimesh.Trimesh(m.vertices, m.faces[:, ::-1], process=False)
    if smooth_angle is not None:
        m = trimesh.graph.smooth_shade(m, angle=np.radians(smooth_angle), facet_minarea=1e9)
    normals = np.asarray(m.vertex_normals, float)
    col = np.broadcast_to(np.asarray(color, float), (len(m.vertices), 3)).copy()
    return Part(np.asarray(m.vertices, float), np.asarray(m.faces, np.int64), normals, col, gloss)


# ----------------------------------------------------------------- weights
class Weigher:
    """Builds dense (V, J) weight arrays from joint names."""

    def __init__(self, rig: Rig):
        self.names = rig.skeleton.names
        self.J = len(self.names)

    def one(self, n, name) -> np.ndarray:
        w = np.zeros((n, self.J))
        w[:, self.names.index(name)] = 1.0
        return w

    def keys(self, s: np.ndarray, keys: list[tuple[float, dict]]) -> np.ndarray:
        """Weights from ``keys`` [(s, {joint: w})] at coordinates ``s (V,)``, smoothstep between keys."""
        table = np.zeros((len(keys), self.J))
        for k, (_, d) in enumerate(keys):
            for name, w in d.items():
                table[k, self.names.index(name)] = w
        pos = np.array([k[0] for k in keys])
        idx = np.clip(np.searchsorted(pos, s) - 1, 0, len(keys) - 2)
        t = smoothstep(0.0, 1.0, (s - pos[idx]) / (pos[idx + 1] - pos[idx]))[:, None]
        return (1 - t) * table[idx] + t * table[idx + 1]


def mix(wa, wb, t):
    t = np.asarray(t, float)[:, None]
    return (1 - t) * wa + t * wb


def arm_keys(side: str) -> list:
    """Along the arm (|x| in cm): shoulder blend, twist spread, elbow, twist spread, wrist."""
    L = side
    return [(8.0, {"Spine2": 1}), (13.0, {"Spine2": 0.5, f"{L}Shoulder": 0.5}),
            (17.0, {f"{L}Shoulder": 0.6, f"{L}Arm": 0.4}), (22.0, {f"{L}Arm": 1}),
            (25.0, {f"{L}Arm": 1}), (40.0, {f"{L}ArmRoll": 1}),       # upper-arm twist spread
            (43.0, {f"{L}ArmRoll": 1}), (46.0, {f"{L}ArmRoll": 0.5, f"{L}ForeArm": 0.5}),
            (49.5, {f"{L}ForeArm": 1}),
            (51.0, {f"{L}ForeArm": 1}), (67.0, {f"{L}ForeArmRoll": 1}),  # forearm twist spread
            (69.5, {f"{L}ForeArmRoll": 1}), (72.0, {f"{L}ForeArmRoll": 0.5, f"{L}Hand": 0.5}),
            (74.5, {f"{L}Hand": 1})]


def leg_keys(side: str) -> list:
    """Down the leg (-y in cm): hip, knee and ankle blends."""
    L = side
    return [(-101.0, {"Hips": 1}), (-92.0, {"Hips": 0.45, f"{L}UpLeg": 0.55}), (-85.0, {f"{L}UpLeg": 1}),
            (-52.0, {f"{L}UpLeg": 1}), (-47.0, {f"{L}UpLeg": 0.5, f"{L}Leg": 0.5}), (-42.0, {f"{L}Leg": 1}),
            (-11.0, {f"{L}Leg": 1}), (-6.5, {f"{L}Leg": 0.4, f"{L}Foot": 0.6}), (-3.0, {f"{L}Foot": 1})]


SPINE_KEYS = [(90.0, {"Hips": 1}), (97.0, {"Hips": 1}), (107.0, {"Spine": 1}), (119.0, {"Spine1": 1}),
              (131.0, {"Spine2": 1}), (144.0, {"Spine2": 1}), (150.0, {"Neck": 1}),
              (155.0, {"Neck": 1}), (160.0, {"Head": 1})]


# ----------------------------------------------------------------- body parts
def torso(rig, W) -> list[Part]:
    parts = []
    # pelvis / trousers
    # the pelvis stops above the crotch so nothing hangs between spread legs
    ys = np.array([85, 89, 94, 100, 106.0])
    wx = np.array([12.5, 15.0, 16.2, 15.5, 14.5])
    dz = np.array([9.5, 10.5, 11, 10.5, 10])
    v, f = tube(np.stack([np.zeros(5), ys, np.zeros(5)], 1), dz, wx, up=(0, 0, 1), n=28, power=2.3,
                dome_start=2.5, dome_end=2, step=2.5)
    p = finish(v, f, TROUSERS, 0.15)
    w = W.keys(p.vertices[:, 1], SPINE_KEYS)
    for L, s in (("Left", 1), ("Right", -1)):
        legw = W.keys(-p.vertices[:, 1], leg_keys(L))
        t = smoothstep(3, 9, s * p.vertices[:, 0]) * smoothstep(92, 84, p.vertices[:, 1])
        w = mix(w, legw, t)
    p.weights = w
    parts.append(p)
    # shirt
    ys = np.array([100, 106, 114, 124, 134, 141, 146, 149.5])
    wx = np.array([15.7, 15.0, 15.5, 17.0, 18.0, 17.5, 14.0, 8.0])
    dz = np.array([10.8, 10.4, 10.6, 11.2, 11.0, 9.5, 8.0, 6.2])
    zc = np.array([0, 0, 0.2, 0.6, 0.6, 0.2, 0, 0.5])
    v, f = tube(np.stack([np.zeros(8), ys, zc], 1), dz, wx, up=(0, 0, 1), n=32, power=2.4, dome_end=1.5, step=2.5)
    p = finish(v, f, SHIRT, 0.12)
    w = W.keys(p.vertices[:, 1], SPINE_KEYS)
    for L, s in (("Left", 1), ("Right", -1)):
        armw = W.keys(s * p.vertices[:, 0], arm_keys(L))
        t = smoothstep(9, 15, s * p.vertices[:, 0]) * smoothstep(128, 138, p.vertices[:, 1])
        w = mix(w, armw, t)
    p.weights = w
    parts.append(p)
    # neck and face
    v, f = tube([[0, 143, -0.5], [0, 150, 0], [0, 157, 1], [0, 162, 1.5]], [5.6, 5.4, 5.2, 5.2],
                [5.8, 5.6, 5.4, 5.4], up=(0, 0, 1), n=16, step=2.0)
    p = finish(v, f, SKIN, 0.2)
    p.weights = W.keys(p.vertices[:, 1], SPINE_KEYS)
    parts.append(p)
    v, f = superellipsoid([0, 164.5, 3], [7.4, 10.2, 8.6], 2.0, 3)
    p = finish(v, f, SKIN, 0.25)
    p.weights = W.one(len(p.vertices), "Head")
    parts.append(p)
    v, f = superellipsoid([0, 164.0, 11.3], [1.1, 2.2, 1.6], 2.0, 2)
    p = finish(v, f, SKIN, 0.25)
    p.weights = W.one(len(p.vertices), "Head")
    parts.append(p)
    return parts


def helmet(W) -> list[Part]:
    parts = []
    c, r = np.array([0, 168.5, 1.0]), np.array([12.3, 12.8, 13.6])
    s = trimesh.creation.icosphere(subdivisions=3 if _detail >= 0.6 else 2)   # keeps a round highlight
    n = np.asarray(s.vertices)
    fc = n[s.faces].mean(1)
    keep = (fc[:, 1] > 0.30) | ((fc[:, 2] < 0.42) & (fc[:, 1] > -0.55 + 0.5 * np.maximum(fc[:, 2], 0)))
    faces = np.asarray(s.faces)[keep]
    used = np.unique(faces)
    remap = np.full(len(n), -1)
    remap[used] = np.arange(len(used))
    v = c + n[used] * r
    p = finish(v, remap[faces], HELMET, 0.8)
    p.weights = W.one(len(p.vertices), "Head")
    parts.append(p)
    # lining: the same shell 0.8 cm inside, facing the head, so every part is closed
    # towards the viewer and the renderer can cull back faces
    p = finish(c + n[used] * (r - 0.8), remap[faces], LINING, 0.1, inward=True)
    p.weights = W.one(len(p.vertices), "Head")
    parts.append(p)
    # peak: a thin curved lip along the front rim
    th = np.radians(np.linspace(-70, 70, count(17, 5)))
    ring_c = np.stack([np.sin(th) * 12.6, np.full_like(th, 172.4), 1.0 + np.cos(th) * 13.4 + 2.2], 1)
    ring_c[:, 1] -= 0.9 * np.cos(th)  # droops a little at the front
    v, f = tube(ring_c, 0.45, 2.8, up=(0, 1, 0), n=8, power=3.0, dome_start=0.5, dome_end=0.5)
    p = finish(v, f, HELMET, 0.8)
    p.weights = W.one(len(p.vertices), "Head")
    parts.append(p)
    # grille: horizontal arcs and two uprights
    bars = []
    for y, rad, span in ((167.0, 14.2, 62), (162.0, 14.6, 60), (157.0, 14.2, 55)):
        th = np.radians(np.linspace(-span, span, count(13, 5)))
        bars.append(np.stack([np.sin(th) * rad * 0.92, np.full_like(th, y), 1.0 + np.cos(th) * rad], 1))
    for x in (-4.0, 4.0):
        ys = np.linspace(156.5, 171.5, 5)
        z = 1.0 + np.sqrt(np.maximum(14.4 ** 2 - (x / 0.92) ** 2, 0)) + 0.05 * (ys - 164) ** 2 * 0.05
        bars.append(np.stack([np.full_like(ys, x), ys, z], 1))
    for path in bars:
        v, f = tube(path, 0.42, 0.42, up=(0, 0, 1) if abs(path[0, 1] - path[-1, 1]) > 1 else (0, 1, 0),
                    n=6, dome_start=0.4, dome_end=0.4)
        p = finish(v, f, GRILLE, 0.9)
        p.weights = W.one(len(p.vertices), "Head")
        parts.append(p)
    return parts


def arm(W, L, s) -> list[Part]:
    parts = []
    xs = np.array([12, 18, 24, 32, 40, 46, 52, 58, 64, 69.0])
    ry = np.array([6.0, 6.2, 5.6, 5.0, 4.5, 4.2, 4.4, 4.0, 3.4, 3.3])
    rz = np.array([6.0, 6.2, 5.8, 5.2, 4.7, 4.3, 4.2, 3.8, 3.3, 3.2])
    cy = 143.0 - np.array([0, 0, 0.3, 0.4, 0.4, 0.3, 0.4, 0.3, 0.2, 0])
    v, f = tube(np.stack([s * xs, cy, np.zeros_like(xs)], 1), ry, rz, up=(0, 1, 0), n=20,
                dome_start=3, dome_end=2, step=1.8)
    p = finish(v, f, SHIRT, 0.12)
    p.weights = W.keys(s * p.vertices[:, 0], arm_keys(L))
    parts.append(p)
    v, f = superellipsoid([s * 19.0, 143.4, 0], [5.4, 5.9, 5.9], 2.0, 2)  # deltoid
    p = finish(v, f, SHIRT, 0.12)
    p.weights = W.keys(s * p.vertices[:, 0], arm_keys(L))
    parts.append(p)
    parts += glove(W, L, s)
    return parts


def glove(W, L, s) -> list[Part]:
    parts = []
    hand = f"{L}Hand"
    # gauntlet cuff, weighted like the forearm/wrist it covers
    xs = np.array([63.5, 65, 68, 71, 72.5])
    v, f = tube(np.stack([s * xs, np.full(5, 143.0), np.zeros(5)], 1), [4.0, 4.6, 4.5, 4.3, 3.8],
                [3.9, 4.5, 4.4, 4.2, 3.7], up=(0, 1, 0), n=16, dome_start=0.6, dome_end=0.6)
    p = finish(v, f, GLOVE, 0.3)
    band = (np.abs(s * p.vertices[:, 0] - 66.0) < 1.0)
    p.colors[band] = GLOVE_BAND
    p.weights = W.keys(s * p.vertices[:, 0], arm_keys(L))
    parts.append(p)
    # fist around the handle, finger rolls, thumb
    pieces = [superellipsoid([s * 77.5, 142.3, 0], [5.6, 3.8, 4.9], 3.0, 2)]
    for z in (-3.6, -1.2, 1.2, 3.6):
        pieces.append(capsule([s * 74.5, 145.2, z], [s * 82.0, 144.8, z], 1.25, (5, 7)))
        pieces.append(capsule([s * 82.6, 144.0, z], [s * 82.8, 139.8, z * 0.95], 1.2, (5, 7)))
    pieces.append(capsule([s * 73.5, 140.5, 4.6], [s * 80.0, 138.6, 3.2], 1.5, (5, 8)))
    for v, f in pieces:
        p = finish(v, f, GLOVE, 0.3)
        w = W.keys(s * p.vertices[:, 0], arm_keys(L))
        p.weights = w if s * v[:, 0].min() < 72 else W.one(len(p.vertices), hand)
        parts.append(p)
    return parts


def leg(W, L, s) -> list[Part]:
    parts = []
    ys = np.array([99, 90, 75, 60, 50, 46, 41, 33, 22, 12, 6.0])
    rx = np.array([8.5, 8.8, 7.8, 6.5, 5.6, 5.4, 5.4, 5.6, 4.5, 4.0, 4.0])
    rz = np.array([9.5, 9.5, 8.3, 7.0, 6.2, 6.0, 6.1, 6.4, 5.0, 4.3, 4.3])
    zc = np.array([-0.5, 0, 0.4, 0.4, 0.4, 0.4, 0, -0.6, -0.2, 0, 0])
    xc = s * np.array([8.0, 9.5, 9.3, 9.1, 9.0, 9.0, 9.0, 9.0, 9.0, 9.0, 9.0])
    v, f = tube(np.stack([xc, ys, zc], 1), rz, rx, up=(0, 0, 1), n=20, dome_start=2, dome_end=2, step=2.5)
    p = finish(v, f, TROUSERS, 0.15)
    p.weights = W.keys(-p.vertices[:, 1], leg_keys(L))
    parts.append(p)
    parts += pad(W, L, s)
    parts += shoe(W, L, s)
    return parts


def leg_radius(y):
    return np.interp(y, [6, 12, 22, 33, 41, 46, 50, 60, 70], [4.3, 4.3, 5.0, 6.4, 6.1, 6.0, 6.2, 7.0, 7.6])


def pad(W, L, s) -> list[Part]:
    """Batting pad: three vertical bolsters, knee roll, side wings, straps."""
    parts = []
    ys = np.concatenate([[7.5, 7.7, 8.2, 9.0], np.linspace(10, 62, count(22, 6)), [63.5, 64.5, 65.0, 65.2]])
    fade = smoothstep(7.5, 10.0, ys) * smoothstep(65.2, 62.0, ys)
    M = ring(22, 8)
    u = np.linspace(-1, 1, M)
    rings = []
    for y, fd in zip(ys, fade):
        r_in = leg_radius(y) + 0.7
        top = smoothstep(52, 64, y)
        th_max = np.radians(118 - 25 * top)
        bolster = np.where(np.abs(u) < 0.6, 0.9 * np.cos(np.pi * u * 2.5) ** 2, 0.0)
        wing = 1.0 - 0.55 * smoothstep(0.6, 1.0, np.abs(u))
        knee = 1.6 * np.exp(-((y - 51.0) / 3.2) ** 2)
        thick = (3.6 + bolster + knee * (np.abs(u) < 0.75)) * wing
        mid_r = r_in + 0.5 * thick
        half = 0.5 * thick * fd + 0.05
        th = u * th_max
        out = mid_r + half
        inn = mid_r - half
        cx, cz = s * 9.0, 0.6
        ring_out = np.stack([cx + np.sin(th) * out * 1.12, np.full(M, y), cz + np.cos(th) * out], 1)
        ring_in = np.stack([cx + np.sin(th) * inn * 1.12, np.full(M, y), cz + np.cos(th) * inn], 1)[::-1]
        rings.append(np.concatenate([ring_out, ring_in]))
    v, f = loft(np.array(rings))
    p = finish(v, f, PAD, 0.35)
    yv = p.vertices[:, 1]
    p.weights = mix(W.one(len(yv), f"{L}Leg"), W.keys(-yv, leg_keys(L)), smoothstep(54, 60, yv) * 0.8)
    parts.append(p)
    # straps round the back of the calf
    for y in (18.0, 36.0):
        th = np.radians(np.linspace(100, 260, count(11, 4)))
        r = leg_radius(y) + 0.5
        path = np.stack([s * 9.0 + np.sin(th) * r * 1.05, np.full_like(th, y), 0.6 + np.cos(th) * r], 1)
        v, f = tube(path, 1.5, 0.35, up=(0, 1, 0), n=8, power=4, dome_start=0.3, dome_end=0.3)
        p = finish(v, f, STRAP, 0.3)
        p.weights = W.one(len(p.vertices), f"{L}Leg")
        parts.append(p)
    return parts


def shoe(W, L, s) -> list[Part]:
    parts = []
    v, f = superellipsoid([s * 9.0, 4.6, 7.6], [5.0, 4.6, 13.0], 3.0, 3)
    v[:, 1] = np.maximum(v[:, 1], 1.4 + 0 * v[:, 1])
    # lower the upper at the toes
    toe = smoothstep(8, 20, v[:, 2])
    v[:, 1] = 1.4 + (v[:, 1] - 1.4) * (1 - 0.45 * toe)
    p = finish(v, f, SHOE, 0.35)
    parts.append(p)
    v, f = superellipsoid([s * 9.0, 0.8, 7.6], [5.4, 0.9, 13.5], 4.0, 2)
    parts.append(finish(v, f, SOLE, 0.1))
    v, f = tube([[s * 9.0, 6.0, -0.2], [s * 9.0, 9.5, 0.0], [s * 9.0, 11.5, 0.0]], [4.8, 4.6, 4.4],
                [4.6, 4.4, 4.2], up=(0, 0, 1), n=14, dome_start=0.5, dome_end=0.3)
    parts.append(finish(v, f, SHOE, 0.35))
    for p in parts:
        zk = [(9.0, {f"{L}Foot": 1}), (13.0, {f"{L}Foot": 0.5, f"{L}ToeBase": 0.5}), (16.0, {f"{L}ToeBase": 1})]
        w = W.keys(p.vertices[:, 2], zk)
        p.weights = mix(w, W.keys(-p.vertices[:, 1], leg_keys(L)), smoothstep(7, 11, p.vertices[:, 1]))
    return parts


def bat(rig: Rig, W, bind) -> list[Part]:
    """Handle (grip + splice) and blade from ``rig.bat``, in LeftHand's rest frame, 100 % LeftHand."""
    b = rig.bat
    hand = rig.skeleton.index("LeftHand")
    axis = np.asarray(b["axis"], float)
    normal = np.asarray(b["face_normal"], float)
    across = np.cross(normal, axis)
    grip = bind[hand] + np.asarray(b["left_grip"], float)
    top = grip - axis * b["grip_to_top"]

    def to_world(a, x, y):
        """a: distance from the handle top along the axis; x: across; y: along the face normal."""
        return top + np.multiply.outer(a, axis) + np.multiply.outer(x, across) + np.multiply.outer(y, normal)

    parts = []
    L, H, Wd = b["length"], b["handle_length"], b["blade_width"]
    T, E = b["blade_thickness"], b["edge_thickness"]
    # handle: rubber grip with ribs, then the cane splice into the blade
    a = np.linspace(0.0, H + 2.0, count(40, 4))
    r = 1.65 + 0.12 * (np.cos(a * 2.4) > 0.3) * (a < H - 6) * (_detail >= 0.6)
    m = ring(12, 6)
    th = np.linspace(0, 2 * np.pi, m, endpoint=False)
    rings = np.array([to_world(np.full(m, ai), np.cos(th) * ri * 1.05, np.sin(th) * ri) for ai, ri in zip(a, r)])
    v, f = loft(rings, cap_start=True, cap_end=True)
    p = finish(v, f, WILLOW, 0.5)
    along = (v - top) @ axis
    p.colors[along[:len(p.colors)] < H - 6] = GRIP
    parts.append(p)
    # blade cross-section: flat face, ridged back (spine); edges E, centre T thick
    M = ring(28, 8)
    xs = np.linspace(-1, 1, M // 2)
    face = np.stack([xs * 0.97, np.full_like(xs, 1.0)], 1)
    back = np.stack([xs[::-1] * 0.97, np.full_like(xs, -1.0)], 1)
    a_blade = np.concatenate([[H - 4.0, H - 2.5, H - 1.2], np.linspace(H, L - 1.2, count(18, 4)), [L - 0.4, L]])
    rings = []
    for ai in a_blade:
        shoulder = smoothstep(H - 4.5, H + 1.0, ai)
        halfw = (0.5 * Wd * (0.35 + 0.65 * shoulder)) * (1 - 0.04 * smoothstep(L - 3, L, ai))
        spine = smoothstep(H - 2, H + 18, ai) * (1 - 0.5 * smoothstep(L - 8, L, ai))
        face_y = T / 2
        edge_back = face_y - E * (0.6 + 0.4 * shoulder)
        centre_back = face_y - (E + (T - E) * spine) * (0.6 + 0.4 * shoulder)
        x = np.concatenate([face[:, 0], back[:, 0]]) * halfw
        prof = (1 - (x / max(halfw, 1e-6)) ** 2) ** 0.8
        y = np.concatenate([np.full(M // 2, face_y), edge_back + (centre_back - edge_back) * prof[M // 2:]])
        y[M // 2:] = np.minimum(y[M // 2:], face_y - 0.4)
        # the handle axis runs through the middle of the blade's thickness (face at +T/2)
        rings.append(to_world(np.full(M, ai), x, y))
    v, f = loft(np.array(rings), cap_start=True, cap_end=True)
    p = finish(v, f, WILLOW, 0.55, smooth_angle=40)
    parts.append(p)
    for p in parts:
        p.weights = W.one(len(p.vertices), "LeftHand")
    return parts


def ball(radius: float) -> Part:
    s = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    body = finish(np.asarray(s.vertices), np.asarray(s.faces), BALL_RED, 0.9)
    th = np.linspace(0, 2 * np.pi, 32, endpoint=False)
    path = np.stack([np.cos(th), np.zeros_like(th), np.sin(th)], 1) * radius
    path = np.concatenate([path, path[:1]])
    v, f = tube(path, 0.22, 0.12, up=(0, 1, 0), n=5)
    seam = finish(v, f, SEAM, 0.4)
    return merge([body, seam])


def merge(parts: list[Part]) -> Part:
    offs = np.cumsum([0] + [len(p.vertices) for p in parts])[:-1]
    w = None if parts[0].weights is None else np.concatenate([p.weights for p in parts])
    return Part(np.concatenate([p.vertices for p in parts]),
                np.concatenate([p.faces + o for p, o in zip(parts, offs)]),
                np.concatenate([p.normals for p in parts]),
                np.concatenate([p.colors for p in parts]),
                0.0, w), np.concatenate([np.full(len(p.vertices), p.gloss) for p in parts])


def top4(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Four largest influences per vertex ``(V,4)`` joint indices and weights summing to 1."""
    idx = np.argsort(-weights, axis=1)[:, :4]
    w = np.take_along_axis(weights, idx, 1)
    w[w < 1e-3] = 0.0
    w = (w / w.sum(1, keepdims=True)).astype(np.float32)
    w[:, 0] += 1.0 - w.sum(1)  # exact in float32
    idx = np.where(w > 0, idx, 0)
    return idx.astype(np.uint8), w


def body_at(rig: Rig, detail: float, decimate_to: int | None = None) -> tuple[Part, np.ndarray, np.ndarray, np.ndarray]:
    """The whole batsman at ``detail``: merged part, per-vertex gloss, top-4 joints and weights.
    With ``decimate_to``, the body (not the bat: thin, it would collapse) is simplified to
    about that many triangles."""
    global _detail
    previous, _detail = _detail, float(detail)
    try:
        bind = bind_positions(rig.skeleton)
        W = Weigher(rig)
        parts = torso(rig, W) + helmet(W)
        for L, s in (("Left", 1), ("Right", -1)):
            parts += arm(W, L, s) + leg(W, L, s)
        bat_parts = bat(rig, W, bind)
        if decimate_to is None:
            body, gloss = merge(parts + bat_parts)
        else:
            body, gloss = decimated(*merge(parts), decimate_to)
            bat_body, bat_gloss = merge(bat_parts)
            body, gloss = merge([body, bat_body]), np.concatenate([gloss, bat_gloss])
            body = body[0]
    finally:
        _detail = previous
    joints, weights = top4(body.weights)
    return body, gloss, joints, weights


def build(rig: Rig | None = None, detail: float = BODY_DETAIL, shadow_detail: float | None = SHADOW_DETAIL,
          lod1_detail: float | None = LOD1_DETAIL, lod2_detail: float | None = LOD2_DETAIL) -> dict:
    rig = rig or default_rig()
    body, gloss, joints, weights = body_at(rig, detail)
    ballp, ball_gloss = ball(rig.ball_radius)
    model = {"body": body, "body_gloss": gloss, "joints": joints, "weights": weights,
             "ball": ballp, "ball_gloss": ball_gloss, "bind": bind_positions(rig.skeleton), "rig": rig}
    if shadow_detail is not None:
        model["shadow"], model["shadow_gloss"], model["shadow_joints"], model["shadow_weights"] = \
            body_at(rig, shadow_detail, decimate_to=SHADOW_TRIANGLES)
    if lod1_detail is not None:
        model["lod1"], model["lod1_gloss"], model["lod1_joints"], model["lod1_weights"] = body_at(rig, lod1_detail)
    if lod2_detail is not None:
        model["lod2"], model["lod2_gloss"], model["lod2_joints"], model["lod2_weights"] = body_at(rig, lod2_detail)
    return model


def decimated(part: Part, gloss: np.ndarray, triangles: int) -> tuple[Part, np.ndarray]:
    """``part`` (with dense weights) simplified (quadric error metric, fast-simplification)
    to about ``triangles`` faces; each new vertex takes the colour, gloss and weights of the
    nearest old one (the shadow caster: only its outline matters, and it moves with its bones)."""
    import fast_simplification

    reduction = max(0.0, 1.0 - triangles / len(part.faces))
    verts, faces = fast_simplification.simplify(part.vertices.astype(np.float32),
                                                part.faces.astype(np.int64), target_reduction=reduction)
    used, faces = np.unique(faces, return_inverse=True)          # drop vertices no face uses
    verts, faces = verts[used], faces.reshape(-1, 3)
    d2 = ((verts[:, None, :].astype(float) - part.vertices[None]) ** 2).sum(-1)   # (V', V): a few million
    nearest = d2.argmin(1)
    normals = np.zeros_like(verts, dtype=float)
    tri = verts[faces]
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    for k in range(3):
        np.add.at(normals, faces[:, k], face_n)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(length > 1e-9, normals / np.maximum(length, 1e-12), part.normals[nearest])  # degenerate fans
    out = Part(vertices=verts.astype(float), faces=faces.astype(np.int64), normals=normals,
               colors=part.colors[nearest], gloss=0.0, weights=part.weights[nearest])
    return out, gloss[nearest]


# ----------------------------------------------------------------- glTF
def write_glb(model: dict, path: Path) -> None:
    """The model as ``path`` (.glb, atomically): the skinned batsman (and its shadow caster and
    levels of detail) and the ball, the data in cm under one 0.01 scale."""
    import pygltflib as g

    from engine.atomic import atomic_output
    from engine.gltf_export import GltfBuffer

    skel = model["rig"].skeleton
    gltf = g.GLTF2(asset=g.Asset(version="2.0", generator="hitpoint tools/make_batsman.py"), scene=0)
    out = GltfBuffer(gltf)

    def prim(part: Part, gloss: np.ndarray, joints=None, weights=None) -> g.Primitive:
        col = np.concatenate([part.colors, np.ones((len(part.colors), 1))], 1)
        attrs = g.Attributes(
            POSITION=out.accessor(part.vertices, g.VEC3, target=g.ARRAY_BUFFER, minmax=True),
            NORMAL=out.accessor(part.normals, g.VEC3, target=g.ARRAY_BUFFER),
            COLOR_0=out.accessor(np.round(col * 255).astype(np.uint8), g.VEC4, target=g.ARRAY_BUFFER,
                                 normalized=True),
        )
        attrs._GLOSS = out.accessor(gloss, g.SCALAR, target=g.ARRAY_BUFFER)
        if joints is not None:
            attrs.JOINTS_0 = out.accessor(joints.astype(np.uint8), g.VEC4, target=g.ARRAY_BUFFER)
            attrs.WEIGHTS_0 = out.accessor(weights, g.VEC4, target=g.ARRAY_BUFFER)
        ind = out.accessor(part.faces.astype(np.uint32).reshape(-1), g.SCALAR, target=g.ELEMENT_ARRAY_BUFFER)
        return g.Primitive(attributes=attrs, indices=ind, material=0)

    gltf.meshes = [g.Mesh(name="Batsman", primitives=[prim(model["body"], model["body_gloss"], model["joints"],
                                                             model["weights"])]),
                   g.Mesh(name="Ball", primitives=[prim(model["ball"], model["ball_gloss"])])]
    for key, name in (("shadow", "BatsmanShadow"), ("lod1", "BatsmanLod1"), ("lod2", "BatsmanLod2")):
        if key in model:
            gltf.meshes.append(g.Mesh(name=name, primitives=[
                prim(model[key], model[f"{key}_gloss"], model[f"{key}_joints"], model[f"{key}_weights"])]))
    J = skel.num_joints
    ibm = np.tile(np.eye(4, dtype=np.float32), (J, 1, 1))
    ibm[:, :3, 3] = -model["bind"]
    ibm_acc = out.accessor(ibm.transpose(0, 2, 1).reshape(J, 16), g.MAT4)     # glTF: column-major
    _glb_nodes(gltf, skel)
    gltf.skins = [g.Skin(name="rig", joints=list(range(J)), inverseBindMatrices=ibm_acc, skeleton=len(gltf.nodes) - 1)]
    gltf.materials = [g.Material(name="vertex_colour", doubleSided=True, pbrMetallicRoughness=g.PbrMetallicRoughness(
        baseColorFactor=[1, 1, 1, 1], metallicFactor=0.0, roughnessFactor=0.7))]
    gltf.buffers = [g.Buffer(byteLength=len(out.blob))]
    gltf.set_binary_blob(bytes(out.blob))
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_output(path) as tmp:
        gltf.save_binary(str(tmp))


def _glb_nodes(gltf, skel) -> None:
    """The joints (skeleton order), the meshes' nodes and the character's root (last) into
    ``gltf.nodes``, and the two scenes."""
    import pygltflib as g
    J = skel.num_joints
    gltf.nodes = [g.Node(name=name, translation=[float(x) for x in skel.offsets[i]],
                         children=[int(c) for c in skel.children(i)] or None) for i, name in enumerate(skel.names)]
    gltf.nodes.append(g.Node(name="Batsman_body", mesh=0, skin=0))
    gltf.nodes.append(g.Node(name="Ball", mesh=1))
    for mi in range(2, len(gltf.meshes)):
        gltf.nodes.append(g.Node(name=gltf.meshes[mi].name, mesh=mi, skin=0))
    roots = [i for i in range(J) if skel.parents[i] < 0]
    # The character's root: the data stay in cm (the viewer's unit), the one scale
    # here makes glTF tools (metres) show him 1.8 m tall.
    gltf.nodes.append(g.Node(name="Batsman", scale=[0.01] * 3, children=roots))
    character = len(gltf.nodes) - 1
    # what a user opening the file sees: the batsman; the renderer's extra meshes (ball, shadow
    # caster, levels of detail) in a second scene of their own
    gltf.scenes = [g.Scene(name="Batsman", nodes=[character, J]),
                   g.Scene(name="Hitpoint renderer meshes (ball, shadow caster, levels of detail)",
                           nodes=[character] + list(range(J + 1, character)))]


def main() -> None:
    model = build()
    out = assets_dir() / "batsman.glb"
    write_glb(model, out)
    print(f"wrote {out}: {len(model['body'].vertices)} vertices, {len(model['body'].faces)} triangles "
          f"(+ shadow caster {len(model['shadow'].faces)}, LOD1 {len(model['lod1'].faces)}, "
          f"LOD2 {len(model['lod2'].faces)}, "
          f"ball {len(model['ball'].faces)})")


if __name__ == "__main__":
    main()
