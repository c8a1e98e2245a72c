"""Principal component analysis of a shot (dissertation 2.5.4, 3.1, 3.2.1).

A shot's parameters per frame are the root translation (3) and the quaternion
(w, x, y, z) of every animated joint, made sign-continuous over time (P = 107
for the bundled rig). They are standardised by their mean M and standard
deviation D and decomposed by SVD. A pose comes back from scores S as
``P = (L S)^T * D + M`` with each quaternion renormalised.

Everything is plain arrays so that :meth:`ShotPCA.pose_from_scores` costs a few
microseconds (it runs every time the PC-pad marker moves).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from . import quat

# A parameter whose SD is below this is treated as constant (D = 1), so it
# standardises to exactly 0 instead of to noise / 0.
CONSTANT_SD = 1e-4   # a quaternion component varying by less (~0.01 deg) is constant: capture noise, not motion


@dataclass
class ShotPCA:
    """PCA of one shot (or several shots together).

    ``K = min(frames, parameters)`` components, best first.
    """
    mean: np.ndarray            # (P,) M
    sd: np.ndarray              # (P,) D (1 where a parameter is constant)
    loadings: np.ndarray        # (P, K) L, orthonormal columns
    scores: np.ndarray          # (F, K) scores of the fitted frames
    explained: np.ndarray       # (K,) fraction of the total variance per component
    joints: np.ndarray          # (A,) joint indices whose quaternions are parameters
    include_root: bool          # root translation is parameters 0..2
    base_root: np.ndarray       # (3,) root position when it is not a parameter
    base_rotations: np.ndarray  # (J, 4) rotations of joints that are not parameters
    _ld_t: np.ndarray = field(init=False, repr=False)        # (K, P) (L * D)^T

    def __post_init__(self):
        self.joints = np.ascontiguousarray(self.joints, dtype=np.int64)
        self.mean = np.ascontiguousarray(self.mean, dtype=np.float64)
        self.base_rotations = np.ascontiguousarray(self.base_rotations, dtype=np.float64)
        self.base_root = np.ascontiguousarray(self.base_root, dtype=np.float64)
        # Folding D into the loadings leaves one matmul and one add per pose.
        self._ld_t = np.ascontiguousarray((self.loadings * self.sd[:, None]).T)

    # ------------------------------------------------------------------ sizes
    @property
    def num_params(self) -> int:
        return self.mean.shape[0]

    @property
    def num_components(self) -> int:
        return self.loadings.shape[1]

    @property
    def cumulative(self) -> np.ndarray:
        """(K,) cumulative fraction of the variance captured by the first k PCs."""
        return np.cumsum(self.explained)

    @property
    def score_sd(self) -> np.ndarray:
        """(K,) standard deviation of the observed scores per component."""
        F = self.scores.shape[0]
        return self.scores.std(axis=0, ddof=1) if F > 1 else np.zeros(self.num_components)

    # ------------------------------------------------------------- transforms
    def standardise(self, params: np.ndarray) -> np.ndarray:
        return (np.asarray(params, float) - self.mean) / self.sd

    def project(self, params: np.ndarray, k: int | None = None) -> np.ndarray:
        """Scores ``(..., k)`` of parameter vectors ``(..., P)`` (all PCs by default)."""
        L = self.loadings if k is None else self.loadings[:, :k]
        return self.standardise(params) @ L

    def reconstruct(self, scores: np.ndarray, k: int | None = None) -> np.ndarray:
        """Parameters ``(..., P)`` from the first ``k`` scores ``(..., >=k)``.

        Quaternions are NOT renormalised here (raw ``(L S)^T * D + M``); use
        :meth:`pose_from_scores` for a pose.
        """
        scores = np.asarray(scores, float)
        k = scores.shape[-1] if k is None else k
        return scores[..., :k] @ self._ld_t[:k] + self.mean

    def pose_from_scores(self, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pose from scores ``(..., k)`` for the first k PCs.

        Returns ``root_positions (..., 3)`` and ``local_rotations (..., J, 4)``
        with unit quaternions; joints that are not parameters (the Bat) keep
        ``base_rotations``. One compiled pass: a few microseconds per pose.
        """
        s = np.asarray(scores, dtype=np.float64)
        k = s.shape[-1]
        if k > self.num_components:
            raise ValueError(f"{k} scores given, the PCA has {self.num_components} components")
        lead = s.shape[:-1]
        flat = np.ascontiguousarray(s.reshape(-1, k))
        N = flat.shape[0]
        root = np.empty((N, 3))
        rot = np.empty((N,) + self.base_rotations.shape)
        _pose_kernel(flat, self._ld_t, self.mean, self.joints, self.base_rotations, self.base_root,
                     self.include_root, root, rot)
        return root.reshape(lead + (3,)), rot.reshape(lead + self.base_rotations.shape)

    def params_from_pose(self, root_positions: np.ndarray, local_rotations: np.ndarray,
                         continuous: bool = True) -> np.ndarray:
        """Parameters ``(..., P)`` of poses, quaternion signs aligned with this PCA.

        With ``continuous`` (for a clip ``(F, 3)``, ``(F, J, 4)``) the signs are
        first made continuous over frames and then each joint's whole track is
        flipped to agree with the mean; otherwise each pose is aligned on its own.
        """
        root_positions = np.asarray(root_positions, float)
        q = np.asarray(local_rotations, float)[..., self.joints, :]
        if continuous and q.ndim == 3:
            q = quat.make_continuous(q, axis=0)
        mq = self.mean_quaternions
        d = np.einsum("...ji,ji->...j", q, mq)
        if continuous and q.ndim == 3:
            flip = d.sum(axis=0) < 0          # per joint, whole track
            q = np.where(flip[None, :, None], -q, q)
        else:
            q = np.where((d < 0)[..., None], -q, q)
        parts = [q.reshape(q.shape[:-2] + (-1,))]
        if self.include_root:
            parts.insert(0, root_positions)
        return np.concatenate(parts, axis=-1)

    def project_pose(self, root_positions, local_rotations, k: int | None = None,
                     continuous: bool = True) -> np.ndarray:
        """Scores ``(..., k)`` of poses or of a clip (see :meth:`params_from_pose`)."""
        return self.project(self.params_from_pose(root_positions, local_rotations, continuous), k)

    @property
    def mean_quaternions(self) -> np.ndarray:
        """(A, 4) mean quaternion parameters (not unit) per parameter joint."""
        start = 3 if self.include_root else 0
        return self.mean[start:].reshape(-1, 4)


@njit(cache=True)
def _pose_kernel(scores, ld_t, mean, joints, base_rotations, base_root, include_root, root_out, rot_out):
    """P = S (L*D)^T + M per row of ``scores (N, k)``, quaternions renormalised,
    written into ``root_out (N, 3)`` and ``rot_out (N, J, 4)``."""
    N, k = scores.shape
    start = 3 if include_root else 0
    for n in range(N):
        for j in range(base_rotations.shape[0]):
            for c in range(4):
                rot_out[n, j, c] = base_rotations[j, c]
        for c in range(3):
            if include_root:
                v = mean[c]
                for i in range(k):
                    v += scores[n, i] * ld_t[i, c]
                root_out[n, c] = v
            else:
                root_out[n, c] = base_root[c]
        for a in range(joints.shape[0]):
            q = np.empty(4)
            for c in range(4):
                p = start + 4 * a + c
                v = mean[p]
                for i in range(k):
                    v += scores[n, i] * ld_t[i, p]
                q[c] = v
            norm = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
            if norm < 1e-12:   # degenerate extrapolation: identity rather than NaN
                q[0], q[1], q[2], q[3], norm = 1.0, 0.0, 0.0, 0.0, 1.0
            for c in range(4):
                rot_out[n, joints[a], c] = q[c] / norm


def shot_parameters(root_positions: np.ndarray, local_rotations: np.ndarray,
                    joints, include_root: bool = True) -> np.ndarray:
    """Parameters ``(F, P)`` of a clip: root translation and sign-continuous quaternions.

    Each joint's track is flipped as a whole so that its mean has w >= 0, which
    makes the parameters of a clip independent of the signs it was stored with.
    """
    q = quat.make_continuous(np.asarray(local_rotations, float)[:, joints], axis=0)
    flip = q[..., 0].sum(axis=0) < 0
    q = np.where(flip[None, :, None], -q, q)
    parts = [q.reshape(q.shape[0], -1)]
    if include_root:
        parts.insert(0, np.asarray(root_positions, float))
    return np.concatenate(parts, axis=1)


def fit_params(params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Standardise and decompose ``params (F, P)``.

    Returns mean (P,), sd (P,), loadings (P, K), scores (F, K), explained (K,).
    """
    X = np.asarray(params, float)
    if X.ndim != 2 or X.shape[0] < 1:
        raise ValueError("PCA needs a (frames, parameters) array with at least one frame")
    if not np.all(np.isfinite(X)):
        raise ValueError("PCA parameters contain NaN or infinity")
    F = X.shape[0]
    mean = X.mean(axis=0)
    sd = X.std(axis=0, ddof=1) if F > 1 else np.zeros(X.shape[1])
    sd = np.where(sd < CONSTANT_SD, 1.0, sd)
    Z = (X - mean) / sd
    U, S, Vt = np.linalg.svd(Z, full_matrices=False)
    loadings = Vt.T
    # Deterministic signs: the largest-magnitude loading of each PC is positive.
    big = np.argmax(np.abs(loadings), axis=0)
    signs = np.where(loadings[big, np.arange(loadings.shape[1])] < 0, -1.0, 1.0)
    loadings = loadings * signs
    scores = U * (S * signs)
    var = S ** 2
    total = var.sum()
    explained = var / total if total > 0 else np.zeros_like(var)
    return mean, sd, loadings, scores, explained


def fit(root_positions: np.ndarray, local_rotations: np.ndarray, joints=None,
        include_root: bool = True) -> ShotPCA:
    """PCA of a clip given as ``root_positions (F, 3)``, ``local_rotations (F, J, 4)``.

    ``joints``: the joints whose quaternions are parameters (default all).
    Joints left out keep their (normalised) mean rotation in poses built from
    scores; the root keeps its mean position when ``include_root`` is False.
    """
    local_rotations = np.asarray(local_rotations, float)
    root_positions = np.asarray(root_positions, float)
    J = local_rotations.shape[1]
    joints = np.arange(J) if joints is None else np.asarray(joints, dtype=np.int64)
    X = shot_parameters(root_positions, local_rotations, joints, include_root)
    mean, sd, loadings, scores, explained = fit_params(X)
    base = quat.normalize(quat.make_continuous(local_rotations, axis=0).mean(axis=0))
    return ShotPCA(mean, sd, loadings, scores, explained, joints, include_root,
                   root_positions.mean(axis=0), base)


# --------------------------------------------------------------------- rig parts
def body_joints(rig) -> np.ndarray:
    """Animated joints of the rig (every joint that carries PCA parameters)."""
    return np.arange(rig.animated_joints)


def upper_body_joints(rig) -> np.ndarray:
    """Animated joints from the first left-arm-chain joint (Spine) downwards:
    spine, neck, head, both arms; not the hips or the legs."""
    s = rig.skeleton
    top = rig.chains["left_arm"].joints[0]
    below = [top]
    for j in range(top + 1, s.num_joints):
        if int(s.parents[j]) in below:
            below.append(j)
    return np.array([j for j in below if j < rig.animated_joints])


def fit_clip(rig, clip, part: str = "body") -> ShotPCA:
    """PCA of a rig clip: ``part`` "body" (107 parameters for the bundled rig)
    or "upper" (upper-body quaternions only, no root translation)."""
    if part == "body":
        pca = fit(clip.root_positions, clip.local_rotations, body_joints(rig), True)
    elif part == "upper":
        pca = fit(clip.root_positions, clip.local_rotations, upper_body_joints(rig), False)
    else:
        raise ValueError(f"unknown body part {part!r} (body or upper)")
    # joints that are never animated (the Bat) stay exactly as rigged
    pca.base_rotations[rig.animated_joints:] = quat.identity((rig.skeleton.num_joints - rig.animated_joints,))
    return pca


def fit_clips(rig, clips, part: str = "body") -> ShotPCA:
    """One PCA over the frames of several clips together (the "batting space")."""
    joints = body_joints(rig) if part == "body" else upper_body_joints(rig)
    include_root = part == "body"
    X = np.concatenate([shot_parameters(c.root_positions, c.local_rotations, joints, include_root)
                        for c in clips], axis=0)
    mean, sd, loadings, scores, explained = fit_params(X)
    rots = np.concatenate([quat.make_continuous(c.local_rotations, axis=0) for c in clips])
    base = quat.normalize(rots.mean(axis=0))
    base[rig.animated_joints:] = quat.identity((rig.skeleton.num_joints - rig.animated_joints,))
    roots = np.concatenate([c.root_positions for c in clips])
    return ShotPCA(mean, sd, loadings, scores, explained, joints, include_root, roots.mean(axis=0), base)


# ------------------------------------------------------------------ style error
def style_rmse(source_scores: np.ndarray, target_scores: np.ndarray) -> float:
    """RMSE over frames of the Euclidean distance between two score tracks ``(F, m)``
    (dissertation 2.5.5)."""
    a = np.asarray(source_scores, float)
    b = np.asarray(target_scores, float)
    if a.shape != b.shape:
        raise ValueError(f"score tracks differ in shape: {a.shape} vs {b.shape}")
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1))))


def style_error(pca: ShotPCA, root_positions: np.ndarray, local_rotations: np.ndarray,
                k: int = 3) -> float:
    """Style error of a clip (e.g. an adapted shot) against the shot ``pca`` was fitted on:
    project it into the first ``k`` PCs and compare with the source's own scores."""
    t = pca.project_pose(root_positions, local_rotations, k)
    return style_rmse(pca.scores[:, :k], t)
