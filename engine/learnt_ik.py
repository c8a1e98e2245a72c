"""Learnt inverse kinematics (Ong & Hilton 2005, reference 002): the dual-layer
constraint-cluster model of one limb, trained on motion capture, and its lookup.

A *limb* is a set of joints under one parent joint (a rig chain, or the whole
body under the world). Its *constraint vector* x (3N,) holds the positions of
its N effectors relative to the limb's root joint, expressed in the frame of the
root's parent (cm) — a pure function of the limb's local rotations, so a model
learnt in one place answers anywhere on the pitch and under any torso pose. Its
*joint-angle vector* holds the limb's local rotations: quaternions ``(n, 4)``
(w, x, y, z), distances and smoothing in exponential maps (radians), so the
paper's Euler wrap-around never arises.

First layer (paper 3.3-3.4): k-means over x (scipy's ``kmeans2``, fixed seed),
each cluster a mean and a diagonal spread d (the members' standard deviation).
Second layer (appendix A): under each first-layer cluster, the nearest-neighbour
clustering of its members' joint angles with tolerance D. Lookup (section 4):
candidate clusters by eq. 10, ``|x_k - mu_k| <= spread * d_k`` for every k, plus
the nearest cluster (the paper's fallback when none encompasses; kept always so
a training constraint finds its own k-means cluster); the angle cluster
minimising ``G |x - Q(mu)| + F z`` (eqs. 11-12, z the distance from the
previous frame's limb skeleton); exponential-map smoothing
``e = A e_prev + B e`` (eq. 13). Q(mu) and the cluster skeletons are computed
once at training; the lookup is one compiled loop over frames.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.cluster.vq import kmeans2, vq

from . import quat
from .fk_nb import tree_fk
from .skeleton import forward_kinematics


@dataclass(frozen=True)
class LearntSettings:
    """The model's parameters, with the paper's names and meaning."""
    clusters: int = 24          # C_N: first-layer (constraint-position) clusters, k-means
    tolerance: float = 0.15     # D (rad): appendix A distance-to-cluster tolerance, joint-angle space
    spread: float = 2.0         # eq. 10: a cluster encompasses x within spread * d_k in every dim
    G: float = 1.0              # eq. 11: weight of the constraint mismatch |x - Q(mu)| (cm)
    F: float = 0.02             # eq. 11: weight of z, the distance from the previous frame's skeleton (cm)
    A: float = 0.1              # eq. 13: weight of the previous frame's exponential map
    B: float = 0.9              # eq. 13: weight of the current frame's
    kmeans_iterations: int = 40
    seed: int = 0               # k-means initialisation: the same model every run

    def check(self) -> None:
        if self.clusters < 1 or self.kmeans_iterations < 1:
            raise ValueError("learnt IK: clusters and kmeans_iterations must be >= 1")
        for name in ("tolerance", "spread", "G", "F", "A", "B"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"learnt IK: {name} must be a finite number >= 0, got {v}")


@dataclass
class Limb:
    """Joints ``(n,)`` (skeleton indices, parents first) under ``parent`` (a skeleton
    index, -1: the world); ``local_parents (n,)`` index into the limb (-1: the limb's
    root, exactly one); ``offsets (n, 3)`` cm; ``effectors (N,)`` index into the limb."""
    name: str
    joints: np.ndarray
    local_parents: np.ndarray
    offsets: np.ndarray
    effectors: np.ndarray
    parent: int

    @property
    def effector_joints(self) -> np.ndarray:
        """Skeleton indices of the effectors ``(N,)``."""
        return self.joints[self.effectors]


def make_limb(name: str, skeleton, joints, effectors, parent: int) -> Limb:
    """A limb of ``skeleton`` from skeleton indices (``effectors`` among ``joints``)."""
    joints = np.asarray(joints, np.int64)
    pos = {int(j): k for k, j in enumerate(joints)}
    lp = np.array([pos.get(int(skeleton.parents[j]), -1) for j in joints], np.int64)
    if (lp < 0).sum() != 1 or np.any(lp >= np.arange(len(joints))):
        raise ValueError(f"limb {name!r}: joints must form one tree, parents first")
    root = int(joints[lp < 0][0])
    if int(skeleton.parents[root]) != parent:
        raise ValueError(f"limb {name!r}: the root's parent is not joint {parent}")
    missing = [int(e) for e in effectors if int(e) not in pos]
    if missing:
        raise ValueError(f"limb {name!r}: effector {skeleton.names[missing[0]]!r} is not one of its joints")
    eff = np.array([pos[int(e)] for e in effectors], np.int64)
    return Limb(name, joints, lp, skeleton.offsets[joints].astype(float), eff, int(parent))


def chain_limb(rig, name: str, effectors=None) -> Limb:
    """The rig chain ``name`` as a limb; effectors default to the chain's effector
    (its last joint, or that joint's fixed child — then part of the limb)."""
    ch = rig.chains[name]
    effectors = [ch.effector] if effectors is None else list(effectors)
    joints = list(ch.joints) + [e for e in effectors if e not in ch.joints]
    parent = int(rig.skeleton.parents[ch.joints[0]])
    return make_limb(name, rig.skeleton, joints, effectors, parent)


def body_limb(skeleton, effectors, name: str = "body") -> Limb:
    """Every joint under the world: constraint = effectors relative to the root
    joint in world axes; used to guess the root's orientation (and joints no chain has)."""
    return make_limb(name, skeleton, np.arange(skeleton.num_joints), effectors, -1)


def limb_fk(limb: Limb, local_rotations: np.ndarray) -> np.ndarray:
    """Positions ``(..., n, 3)`` cm of the limb's joints relative to its root joint,
    in the root's parent frame, from ``local_rotations (..., n, 4)``."""
    return forward_kinematics(limb.local_parents, _root_at_origin(limb), np.asarray(local_rotations, float))[1]


def _root_at_origin(limb: Limb) -> np.ndarray:
    """The limb's offsets ``(n, 3)`` with its root's zeroed (positions relative to the root)."""
    t = limb.offsets.astype(float)
    t[limb.local_parents < 0] = 0.0
    return t


def constraints(limb: Limb, global_rotations: np.ndarray, global_positions: np.ndarray,
                targets: np.ndarray | None = None) -> np.ndarray:
    """Constraint vectors ``(F, 3N)`` of world ``targets (F, N, 3)`` (default: the
    effectors' own positions in ``global_positions (F, J, 3)``), relative to the limb's
    root joint, in its parent's frame ``global_rotations (F, J, 4)`` (world: axes kept)."""
    root = int(limb.joints[limb.local_parents < 0][0])
    t = global_positions[:, limb.effector_joints] if targets is None else np.asarray(targets, float)
    rel = t - global_positions[:, root, None, :]
    if limb.parent >= 0:
        inv = quat.conjugate(global_rotations[:, limb.parent, None, :])
        rel = quat.rotate(np.broadcast_to(inv, rel.shape[:-1] + (4,)), rel)
    return rel.reshape(len(rel), -1)


@dataclass
class LimbModel:
    """A trained dual-layer model. First layer: ``p_mu, p_d (C, 3N)`` cm. Second layer
    (K angle clusters, those of cluster i at ``a_start[i]:a_start[i+1]``): mean local
    rotations ``a_quat (K, n, 4)``, their exponential maps' spread ``a_d (K, 3n)`` rad,
    member counts ``a_count (K,)``, Q(mu) = the effectors ``a_eff (K, 3N)`` and the
    limb skeleton ``a_pos (K, 3n)`` (cm, root-relative, parent frame)."""
    limb: Limb
    settings: LearntSettings
    p_mu: np.ndarray
    p_d: np.ndarray
    a_start: np.ndarray
    a_quat: np.ndarray
    a_d: np.ndarray
    a_count: np.ndarray
    a_eff: np.ndarray
    a_pos: np.ndarray

    @property
    def angle_clusters(self) -> int:
        return len(self.a_quat)


@njit(cache=True)
def nearest_neighbour_labels(dist, tolerance):
    """Appendix A on a distance matrix ``(m, m)``: each point in turn joins the cluster
    of its nearest earlier point if that is closer than ``tolerance``, else starts one.
    Returns labels ``(m,)`` 0..C-1."""
    m = dist.shape[0]
    labels = np.zeros(m, np.int64)
    count = 1
    for n in range(1, m):
        best, where = np.inf, 0
        for j in range(n):
            if dist[n, j] < best:
                best, where = dist[n, j], j
        if best < tolerance:
            labels[n] = labels[where]
        else:
            labels[n] = count
            count += 1
    return labels


def mean_rotations(q: np.ndarray) -> np.ndarray:
    """Per-joint mean ``(n, 4)`` of rotations ``(m, n, 4)``: signs aligned to the first
    member, averaged, normalised (the chordal mean: close rotations in a cluster)."""
    s = np.where(np.sum(q * q[:1], axis=-1, keepdims=True) < 0, -1.0, 1.0)
    return quat.normalize((q * s).mean(axis=0))


def _first_layer(x: np.ndarray, s: LearntSettings) -> tuple[np.ndarray, np.ndarray]:
    """k-means centroids ``(C, 3N)`` and every frame's cluster ``(F,)`` (its nearest
    centroid; clusters left empty are dropped)."""
    k = min(s.clusters, len(np.unique(x, axis=0)))
    centroids, _ = kmeans2(x, k, iter=s.kmeans_iterations, minit="++", rng=np.random.default_rng(s.seed))
    labels, _ = vq(x, centroids)
    used = np.unique(labels)
    centroids = centroids[used]
    return centroids, np.searchsorted(used, labels)


def train(limb: Limb, local_rotations: np.ndarray, settings: LearntSettings | None = None) -> LimbModel:
    """Train the limb's model on training poses ``local_rotations (F, n, 4)``."""
    s = settings or LearntSettings()
    s.check()
    q = quat.normalize(np.asarray(local_rotations, float))
    if q.ndim != 3 or q.shape[1:] != (len(limb.joints), 4) or len(q) == 0:
        raise ValueError(f"learnt IK: training poses for limb {limb.name!r} must be (F, {len(limb.joints)}, 4)")
    x = limb_fk(limb, q)[:, limb.effectors].reshape(len(q), -1)
    e = quat.log(q).reshape(len(q), -1)
    centroids, labels = _first_layer(x, s)
    p_d, starts, means, spreads, counts = [], [0], [], [], []
    for i in range(len(centroids)):
        idx = np.flatnonzero(labels == i)
        p_d.append(x[idx].std(axis=0))
        dist = np.linalg.norm(e[idx, None] - e[None, idx], axis=-1)
        sub = nearest_neighbour_labels(dist, float(s.tolerance))
        for j in range(sub.max() + 1):
            members = idx[sub == j]
            means.append(mean_rotations(q[members]))
            spreads.append(e[members].std(axis=0))
            counts.append(len(members))
        starts.append(len(means))
    a_quat = np.array(means)
    a_pos = limb_fk(limb, a_quat)
    return LimbModel(limb, s, centroids, np.array(p_d), np.array(starts, np.int64), a_quat, np.array(spreads),
                     np.array(counts, np.int64), np.ascontiguousarray(a_pos[:, limb.effectors].reshape(len(a_quat), -1)),
                     np.ascontiguousarray(a_pos.reshape(len(a_quat), -1)))


# ------------------------------------------------------------------ lookup (compiled)
@njit(cache=True)
def _qlog(q):
    """Unit quaternion tuple -> rotation vector (w >= 0 hemisphere), as quat.log."""
    w, x, y, z = q
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 if s < 1e-12 else 2.0 * math.atan2(s, w) / s
    return (x * k, y * k, z * k)


@njit(cache=True)
def _qexp(r):
    a = math.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
    k = 0.5 if a < 1e-12 else math.sin(a / 2) / a
    return (math.cos(a / 2), r[0] * k, r[1] * k, r[2] * k)


@njit(cache=True)
def _dist(a, b):
    d = 0.0
    for k in range(a.shape[0]):
        r = a[k] - b[k]
        d += r * r
    return math.sqrt(d)


@njit(cache=True)
def _best_angle(i, x, prev_pos, has_prev, a_start, a_eff, a_pos, G, F, best, best_cost):
    """The angle cluster of first-layer cluster i with the lowest eq. 11 cost, if lower."""
    for j in range(a_start[i], a_start[i + 1]):
        c = G * _dist(x, a_eff[j])
        if has_prev:
            c += F * _dist(prev_pos, a_pos[j])
        if c < best_cost:
            best, best_cost = j, c
    return best, best_cost


@njit(cache=True)
def _choose(x, prev_pos, has_prev, p_mu, p_half, a_start, a_eff, a_pos, G, F):
    """Eq. 10 candidates (plus the nearest cluster), then eqs. 11-12: the angle cluster."""
    nearest, near_d = 0, np.inf
    best, best_cost = -1, np.inf
    for i in range(p_mu.shape[0]):
        inside = True
        d2 = 0.0
        for k in range(x.shape[0]):
            r = x[k] - p_mu[i, k]
            d2 += r * r
            if abs(r) > p_half[i, k]:
                inside = False
        if d2 < near_d:
            nearest, near_d = i, d2
        if inside:
            best, best_cost = _best_angle(i, x, prev_pos, has_prev, a_start, a_eff, a_pos, G, F, best, best_cost)
    best, best_cost = _best_angle(nearest, x, prev_pos, has_prev, a_start, a_eff, a_pos, G, F, best, best_cost)
    return best


@njit(cache=True)
def _smooth(mu, prev_q, has_prev, A, B, out_q):
    """Eq. 13 per joint on exponential maps: out_q (n, 4) from the cluster pose mu (n, 4)."""
    for m in range(mu.shape[0]):
        q = (mu[m, 0], mu[m, 1], mu[m, 2], mu[m, 3])
        if has_prev:
            e0 = _qlog((prev_q[m, 0], prev_q[m, 1], prev_q[m, 2], prev_q[m, 3]))
            e1 = _qlog(q)
            q = _qexp((A * e0[0] + B * e1[0], A * e0[1] + B * e1[1], A * e0[2] + B * e1[2]))
        out_q[m, 0], out_q[m, 1], out_q[m, 2], out_q[m, 3] = q


@njit(cache=True)
def _lookup_frames(xs, prev_q, has_prev, p_mu, p_half, a_start, a_quat, a_eff, a_pos,
                   lparents, offsets, weights, out_q, out_k):
    """Every frame of xs (T, 3N) in order, each one's previous the frame before it
    (the first's: prev_q (n, 4) when has_prev). ``weights``: (G, F, A, B) of eqs. 11-13;
    ``offsets (n, 3)`` with the root's zeroed (positions relative to the limb's root)."""
    G, F, A, B = weights
    n = a_quat.shape[1]
    g_rot = np.empty((n, 4))
    pos = np.empty((n, 3))
    every = np.ones(n, np.bool_)
    pq = prev_q.copy()
    tree_fk(lparents, offsets, pq, every, g_rot, pos)       # FK of the previous pose
    pp = pos.reshape(-1).copy()
    hp = has_prev
    for t in range(xs.shape[0]):
        k = _choose(xs[t], pp, hp, p_mu, p_half, a_start, a_eff, a_pos, G, F)
        out_k[t] = k
        _smooth(a_quat[k], pq, hp, A, B, out_q[t])
        tree_fk(lparents, offsets, out_q[t], every, g_rot, pos)
        pq[:, :] = out_q[t]
        pp[:] = pos.reshape(-1)
        hp = True


def lookup(model: LimbModel, x: np.ndarray, previous: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Local rotations ``(T, n, 4)`` for constraint vectors ``x (T, 3N)`` (cm, see
    :func:`constraints`), frame after frame; ``previous (n, 4)``: the pose before the
    first frame (None: the first frame has no F term and no smoothing). Also returns
    the chosen angle clusters ``(T,)``."""
    x = np.ascontiguousarray(np.asarray(x, float).reshape(len(x), -1))
    if x.shape[1] != model.p_mu.shape[1] or not np.all(np.isfinite(x)):
        raise ValueError(f"learnt IK: limb {model.limb.name!r} needs finite constraint vectors of "
                         f"{model.p_mu.shape[1]} numbers")
    n = len(model.limb.joints)
    s = model.settings
    has_prev = previous is not None
    prev_q = np.ascontiguousarray(previous if has_prev else quat.identity((n,)), float)
    out = np.empty((len(x), n, 4))
    chosen = np.empty(len(x), np.int64)
    _lookup_frames(x, prev_q, has_prev, model.p_mu, np.ascontiguousarray(s.spread * model.p_d),
                   model.a_start, model.a_quat, model.a_eff, model.a_pos, model.limb.local_parents,
                   _root_at_origin(model.limb), (float(s.G), float(s.F), float(s.A), float(s.B)), out, chosen)
    return out, chosen


def solve_limb(model: LimbModel, target: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """One frame of learnt IK: the limb's local rotations ``(n, 4)`` for its effectors'
    ``target (N, 3)`` cm relative to the limb's root joint, in the root's parent frame
    (:func:`constraints` makes it from world positions), given the previous frame's
    limb pose ``previous (n, 4)`` (None: none)."""
    return lookup(model, np.asarray(target, float).reshape(1, -1), previous)[0][0]


def lookup_world(model: LimbModel, parent_rotations: np.ndarray, parent_positions: np.ndarray,
                 targets: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """Learnt IK for frames in world space: the limb's local rotations ``(F, n, 4)`` (in
    ``model.limb.joints`` order) putting its effectors on world ``targets (F, N, 3)`` cm,
    given the global rotation ``(F, 4)`` and position ``(F, 3)`` of the limb root's
    parent joint each frame (see :func:`lookup` for ``previous``). For a solver's
    start pose (learnt+ccd), pass the result's chain joints to ``engine.ccd.solve``."""
    limb = model.limb
    q = np.asarray(parent_rotations, float)
    root_offset = limb.offsets[limb.local_parents < 0][0]
    root = np.asarray(parent_positions, float) + quat.rotate(q, np.broadcast_to(root_offset, q.shape[:-1] + (3,)))
    rel = np.asarray(targets, float).reshape(len(q), -1, 3) - root[:, None]
    x = quat.rotate(np.broadcast_to(quat.conjugate(q)[:, None], rel.shape[:-1] + (4,)), rel)
    return lookup(model, x.reshape(len(q), -1), previous)[0]


def train_chains(rig, clips, settings: LearntSettings | None = None, names=None, effectors=None) -> dict:
    """One model per rig chain (default: left_arm, right_arm, left_leg, right_leg),
    trained on the local rotations ``(F, J, 4)`` of every clip in ``clips`` (rig
    joint order). ``effectors``: chain name -> skeleton joints (default the chain's)."""
    names = names or ("left_arm", "right_arm", "left_leg", "right_leg")
    local = np.concatenate([np.asarray(c, float) for c in clips])
    models = {}
    for name in names:
        limb = chain_limb(rig, name, None if effectors is None else effectors.get(name))
        models[name] = train(limb, local[:, limb.joints], settings)
    return models
