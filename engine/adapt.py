"""Adapt a whole shot so the bat meets the ball at a new hit point (dissertation 2.2).

At the hit frame h the offset from the FK bat joint to the desired point P is
taken into bat-joint space (2.2.4): ``offset_local = R(h)^T (P - b(h))``. Every
frame is fully IK, with the handle ``b(f) + blend(f) R(f) offset_local`` and
``blend(f) = clamp(1 - |b(f) - b(h)| / falloff, 0, 1)`` (2.2.5), so blend 0
gives back the source pose exactly. The left-arm chain (Spine .. LeftHand,
effector Bat) is solved for position; the right hand is put back on its source
grip relative to the new left hand (2.2.2) by solving the right-arm chain for
the wrist position, then turning the trailing joints that do not move the wrist
(forearm twist, hand) for its orientation.

All frames are solved by one compiled call (:func:`adapt_frames`); a single
frame for scrubbing uses the same call with one frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import quat
from .ccd import ITERATIONS, KIND_NONE, TOLERANCE, ChainArrays, chain_arrays, limit_euler
from .dls import DAMPING, default_stiffness
from .carry import CARRY_REACH_DEG, carried_start, hit_run, served
from .arms_nb import TORSO_WEIGHT
from .frames_parallel import run_frames
from .skeleton import local_translations, relative_pose

ORIENT_TOL = 1e-4       # rad: the right hand's orientation is "there"
FACES = ("keep", "free")
SOLVERS = ("ccd", "dls")
TWISTS = ("follow", "lead")
TRUNK_WIDER = 3.0       # the held trunk's reach widened this much where the bat needs it (trunk_reach)
TWIST_COLUMN = 2        # ZYX Euler columns z, y, x: x is the twist about the bone in the arms


def face_weights(n: int, torso: int) -> np.ndarray:
    """Weights (1 / stiffness) of the chain's joints, root-most first, in the face-keeping
    solve (dissertation 1.10, 4.2): rising toward the hand (squared), so the roll joints
    turn the face first, and a tenth of that for the ``torso`` joints at the chain's root
    (up to the one the right arm hangs from), which turn only where the arm's limits cannot.
    Measured over the 135 offsets of ``analyse --directions``: the spine's largest angle
    change at the hit frame median 4.2 deg (position only 4.1; the torso at the arm's
    weights 5.7, the arm alone then the torso 4.3 at 1.4x the time)."""
    w = np.linspace(0.25, 1.0, n) ** 2
    w[:torso] *= TORSO_WEIGHT
    return np.ascontiguousarray(w)


def trunk_reach(n: int, torso: int, degrees: float) -> np.ndarray:
    """Bounds ``(3, n)`` rad, on each Euler axis, of how far each of the left chain's ``n``
    joints may turn from the pose the adaptation starts from: the ``torso`` joints at the
    chain's root ``degrees`` each (inf: as far as their limits), then, where the bat cannot
    reach its handle so, TRUNK_WIDER times that, then as far as their limits; the arm's
    joints always as far as theirs."""
    reach = np.full((3, n), np.inf)
    reach[0, :torso] = math.radians(degrees)
    reach[1, :torso] = math.radians(degrees * TRUNK_WIDER)
    return reach


def _chest(rig) -> int | None:
    """The rig's thorax joint (``rig.humerus["chest"]``), or None."""
    return (getattr(rig, "humerus", None) or {}).get("chest")


def trunk_turn_deg(rig, source_rotations: np.ndarray, global_rotations: np.ndarray) -> float | None:
    """Degrees the chest (the rig's thorax, ``rig.humerus["chest"]``) of an adapted shot's
    ``global_rotations (F, J, 4)`` turns furthest from the source's ``source_rotations`` over
    the frames: what the adaptation costs the trunk's posture (None: a rig without a thorax)."""
    chest = _chest(rig)
    if chest is None:
        return None
    return float(quat.angle_between(global_rotations[:, chest], source_rotations[:, chest]).max())


def trunk_jump_deg(rig, source_rotations: np.ndarray, global_rotations: np.ndarray) -> float | None:
    """Degrees the chest (as :func:`trunk_turn_deg`) of an adapted shot's ``global_rotations
    (F, J, 4)`` turns between two frames beyond the source's own turn there, at most over the
    frames: a pop the eye sees, where a turn held over the frames reads 0 (None: no thorax)."""
    chest = _chest(rig)
    if chest is None:
        return None
    if len(global_rotations) < 2:
        return 0.0
    src, out = source_rotations[:, chest], global_rotations[:, chest]
    extra = quat.angle_between(out[1:], out[:-1]) - quat.angle_between(src[1:], src[:-1])
    return float(max(extra.max(), 0.0))


def twist_only(free: np.ndarray) -> np.ndarray:
    """(n,) bool: the chain joints ``free (n, 3)`` whose one free axis is the twist."""
    return (free.sum(axis=1) == 1) & free[:, TWIST_COLUMN]


@dataclass
class AdaptSettings:
    falloff: float = 90.0        # cm
    wrist_dof: int = 0           # 0 (locked, default) or 2
    solver: str = "ccd"          # "ccd" | "dls"
    iterations: int = ITERATIONS
    tolerance: float = TOLERANCE     # cm
    fix_right_hand: bool = True
    # CCD only. "follow": the left arm's twist-only (roll) joints keep the source's twist
    # and the swing joints reach the ball; "lead": CCD turns them too, which spins the bat
    # about its handle (9 shots x 15 offsets, wrist locked: face turned up to 153 deg, p90
    # 30, against 40 and 25 when they follow). DLS spreads the motion by its stiffness
    # weights and keeps the face already (max 34 deg), and needs the twist to reach.
    twist: str = "follow"
    # "keep": after the position solve, damped Newton on the bat's position and face
    # normal turns the face back to the source's at the hit frame (the other adapted frames
    # toward it by the importance blend); "free": position only.
    face: str = "keep"
    # kept face: degrees it turns (about the vertical, carried by the blend) per cm the hit
    # point moves toward the off side, so the ball goes further that way (Fig. 2.6)
    face_turn: float = 0.1
    # kept face: degrees it tilts up (+) or down at the hit (carried by the blend): the
    # ball's elevation (engine.direction)
    face_tilt: float = 0.0
    # kept face: degrees it turns about the vertical at the hit (+ toward the off side,
    # carried by the blend), on top of face_turn: the ball's azimuth (engine.direction)
    face_yaw: float = 0.0
    # degrees each spine joint may turn from the source's on each axis (inf: as far as its
    # limits). Where the arm alone cannot keep the face or the right hand's grip, the trunk
    # turns, up to 176 deg from the source's over the +-30 cm grid; held within 10 deg a
    # joint, up to 102 (where the bat cannot reach its handle so: only there does the trunk
    # go further), and the face gives instead (up to 30 deg off at the cover drive's and
    # square cut's far off-side corners). README: "Holding the trunk".
    trunk_reach: float = math.inf
    # the hit frame solved first and its trunk's turn carried to the other frames by their
    # blend (engine.carry; not with a held trunk): the body leans into the hit instead of
    # turning at it alone. Over the +-30 cm grid (122 offsets above the ground), wrist locked
    # / 2 DOF, against every frame alone: the chest popping >20 deg a frame beyond the
    # source's in 13 -> 5 / 8 -> 2 adaptations, the worst pop 36.5 -> 25.5 / 29.3 -> 20.2 deg;
    # the right hand on its grip where alone it is (README, "Two mends and a default").
    # False: every frame alone, as the dissertation
    carry_lean: bool = True


@dataclass
class Adaptation:                # whole adapted shot
    root_positions: np.ndarray   # (F,3)
    local_rotations: np.ndarray  # (F,J,4)
    global_rotations: np.ndarray  # (F,J,4)
    global_positions: np.ndarray  # (F,J,3)
    blend: np.ndarray            # (F,)
    handles: np.ndarray          # (F,3) IK handle per frame
    desired_hit_point: np.ndarray  # (3,)
    bat_error_cm: float          # |bat - desired| at the hit frame
    grip_error_cm: np.ndarray    # (F,) right hand position error vs source grip
    grip_error_deg: np.ndarray   # (F,)



def _subtree(parents: np.ndarray, root: int) -> np.ndarray:
    """(J,) bool: root and every joint below it."""
    m = np.zeros(len(parents), bool)
    m[root] = True
    for j in range(root + 1, len(parents)):
        if parents[j] >= 0 and m[parents[j]]:
            m[j] = True
    return m


def check_point(p, what: str = "target") -> np.ndarray:
    """A finite (3,) point, or ValueError with one clear line."""
    if isinstance(p, np.ndarray) and p.shape == (3,) and p.dtype == np.float64:
        x, y, z = p
        if math.isfinite(x) and math.isfinite(y) and math.isfinite(z):
            return p        # fast path (scrubbing calls this every frame)
    try:
        a = np.asarray(p, float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be three numbers (x, y, z) in cm") from None
    if a.shape != (3,):
        raise ValueError(f"{what} must be three numbers (x, y, z) in cm, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{what} must be finite numbers, got {a.tolist()}")
    return a


def check_settings(s: AdaptSettings) -> None:
    """ValueError with one clear line for settings the solvers cannot use."""
    if s.solver not in SOLVERS:
        raise ValueError(f"solver must be one of {', '.join(SOLVERS)}, got {s.solver!r}")
    if s.wrist_dof not in (0, 2):
        raise ValueError(f"wrist DOF must be 0 or 2, got {s.wrist_dof}")
    if s.face not in FACES:
        raise ValueError(f"face must be one of {', '.join(FACES)}, got {s.face!r}")
    if s.twist not in TWISTS:
        raise ValueError(f"twist must be one of {', '.join(TWISTS)}, got {s.twist!r}")
    if not (math.isfinite(s.falloff) and s.falloff > 0):
        raise ValueError(f"falloff must be a positive number of cm, got {s.falloff}")
    if not (math.isfinite(s.tolerance) and s.tolerance > 0):
        raise ValueError(f"tolerance must be a positive number of cm, got {s.tolerance}")
    if math.isnan(s.trunk_reach) or s.trunk_reach < 0:
        raise ValueError(f"trunk reach must be a number of degrees >= 0 (inf: free), got {s.trunk_reach}")
    if int(s.iterations) < 1:
        raise ValueError(f"iterations must be at least 1, got {s.iterations}")


END_GUARD_FRAMES = 8   # frames over which the blend fades to 0 at a shot's ends, where needed


class Adapter:
    """Per-shot precomputation (done once); :meth:`adapt` and :meth:`adapt_frame`
    then cost one compiled call each."""

    def __init__(self, rig, shot, end_guard: bool = True):
        """``end_guard``: keep the shot's first and last frames FK (:meth:`blend`); off for a
        synthesised take whose hit lies at one of its ends (engine.cleanup_hit)."""
        skel, clip = shot.skeleton, shot.clip
        if list(skel.names) != list(rig.skeleton.names):
            raise ValueError(f"shot {shot.name!r}: joints are not in the rig's order "
                             "(load it with engine.library.conform_to_rig)")
        self.rig = rig
        self.shot = shot
        self.end_guard = bool(end_guard)
        self.hit_frame = int(shot.hit_frame)
        self.num_frames = clip.num_frames
        self.parents = np.ascontiguousarray(skel.parents, np.int64)
        self.trans = np.ascontiguousarray(local_translations(skel, clip), float)
        self.src_local = np.ascontiguousarray(clip.local_rotations, float)
        grot, gpos = shot.fk
        self.src_grot = np.ascontiguousarray(grot, float)
        self.src_gpos = np.ascontiguousarray(gpos, float)
        self.src_euler = np.ascontiguousarray(np.radians(limit_euler(self.src_local, rig.limits)))
        self.bat = int(rig.bat_joint)
        left = rig.chains["left_arm"]
        right = rig.chains["right_arm"]
        self.lhand = int(left.joints[-1])
        self.rhand = int(right.joints[-1])
        self.subtree_l = _subtree(self.parents, int(left.joints[0]))
        # the right hand's source grip in the left hand's frame, per frame
        rel_pos, rel_rot = relative_pose(self.src_grot[:, self.lhand], self.src_gpos[:, self.lhand],
                                         self.src_grot[:, self.rhand], self.src_gpos[:, self.rhand])
        self.rel_pos, self.rel_rot = np.ascontiguousarray(rel_pos), np.ascontiguousarray(rel_rot)
        self._chains: dict[tuple, tuple] = {}
        self._blend_cache: tuple[float, np.ndarray] = (float("nan"), np.empty(0))
        self._reach_cache: dict[float, np.ndarray] = {}
        # where the right arm hangs off the left-arm chain (Spine2), for the two-arm solve
        rpar = int(self.parents[right.joints[0]])
        self.right_parent_in_left = list(left.joints).index(rpar) if rpar in list(left.joints) else -1
        self.face_w = face_weights(len(left.joints), self.right_parent_in_left + 1)
        self.trunk = np.asarray(left.joints[:self.right_parent_in_left + 1], np.int64)   # joints the arms share
        self.hit_point = self.src_gpos[self.hit_frame, self.bat].copy()
        self.bat_positions = self.src_gpos[:, self.bat]
        n = np.asarray(rig.bat["face_normal"], float)
        self.face_local = n / np.linalg.norm(n)
        self._shot_args = (self.parents, self.trans, self.subtree_l, self.src_grot, self.src_gpos, self.rel_pos,
                           self.rel_rot, self.hit_frame, self.bat, self.lhand, self.right_parent_in_left)

    @property
    def max_falloff(self) -> float:
        """Largest falloff (cm) that keeps the first and last frames fully FK
        (dissertation 2.2.5: the bat's distance from the hit point there)."""
        d = np.linalg.norm(self.bat_positions[[0, -1]] - self.hit_point, axis=-1)
        return float(d.min())

    def blend(self, falloff: float) -> np.ndarray:
        """Importance blend (F,) for a falloff in cm (2.2.5), with an end guard.

        The dissertation requires every shot to start and end fully FK (the
        shared stance and rest poses). Where the bat already lies within
        ``falloff`` of the hit point at the first or last frame (defensive
        shots whose hit point is near the stance), the blend is faded to 0 over
        the END_GUARD_FRAMES frames at that end; otherwise it is exactly
        ``clamp(1 - d / falloff, 0, 1)``.
        """
        d = np.linalg.norm(self.bat_positions - self.hit_point, axis=-1)
        blend = np.clip(1.0 - d / falloff, 0.0, 1.0)
        F = len(blend)
        frames = np.arange(F)
        for end, steps in ((0, frames), (F - 1, F - 1 - frames)):
            if blend[end] > 0.0 and self.end_guard:
                t = np.clip(steps / END_GUARD_FRAMES, 0.0, 1.0)
                blend = blend * (t * t * (3.0 - 2.0 * t))
        return blend

    def face_turn(self, desired: np.ndarray, settings: AdaptSettings) -> np.ndarray:
        """Rotation vector (3,) of the kept face at the hit frame against the source's:
        ``face_turn`` deg per cm of the hit point's move toward the off side (-x) plus
        ``face_yaw`` deg about the vertical, then ``face_tilt`` deg up about the horizontal
        across the face."""
        off_cm = -(float(desired[0]) - float(self.hit_point[0]))
        yaw = -math.radians(settings.face_turn * off_cm + settings.face_yaw)
        if settings.face_tilt == 0.0:
            return np.array([0.0, yaw, 0.0])        # the fast path: scrubbing calls this every frame
        across = np.cross(self.source_face(), [0.0, 1.0, 0.0])
        if np.linalg.norm(across) < 1e-9:
            return np.array([0.0, yaw, 0.0])
        tilt = quat.from_axis_angle(across / np.linalg.norm(across), math.radians(settings.face_tilt))
        q = quat.mul(tilt, quat.from_axis_angle(np.array([0.0, 1.0, 0.0]), yaw))
        return quat.log(q)

    def source_face(self) -> np.ndarray:
        """The source's world face normal (3,) at the hit frame."""
        return quat.rotate(self.src_grot[self.hit_frame, self.bat], self.face_local)

    def _blend_for(self, falloff: float) -> np.ndarray:
        # cached: scrubbing calls adapt_frame every frame with the same falloff
        if self._blend_cache[0] != falloff:
            self._blend_cache = (falloff, np.ascontiguousarray(self.blend(falloff)))
        return self._blend_cache[1]

    def _reach_for(self, degrees: float) -> np.ndarray:
        if degrees not in self._reach_cache:
            self._reach_cache[degrees] = trunk_reach(len(self.rig.chains["left_arm"].joints),
                                                     self.right_parent_in_left + 1, degrees)
        return self._reach_cache[degrees]

    def _chain_args(self, settings: AdaptSettings) -> tuple:
        key = (settings.wrist_dof, settings.solver, settings.twist)
        if key not in self._chains:
            out = []
            for name, wd in (("left_arm", settings.wrist_dof), ("right_arm", None)):
                ch: ChainArrays = chain_arrays(self.rig, name, wd)
                n = len(ch.joints)
                w = ch.polish_weight if settings.solver == "ccd" else 1.0 / default_stiffness(n)
                free, kind = ch.free, ch.kind
                if name == "left_arm" and settings.solver == "ccd" and settings.twist == "follow":
                    # locked, the source's twist is put back after every step
                    roll = twist_only(free)
                    free, kind = free & ~roll[:, None], np.where(roll, KIND_NONE, kind)
                out.append((ch.joints, ch.offsets, ch.eff_off, np.ascontiguousarray(free),
                            np.ascontiguousarray(kind), ch.lo, ch.hi, np.ascontiguousarray(w, float), ch.hold))
                if name == "left_arm":
                    face_free = np.ascontiguousarray(ch.free)     # the roll joints too
            self._chains[key] = (tuple(out), face_free)
        return self._chains[key]

    def _start_pose(self, start) -> tuple[np.ndarray, np.ndarray]:
        """Local rotations ``(F, J, 4)`` and their limit-branch Euler angles (rad) the
        chains start from: the source, or ``start`` (engine.learnt_solver's learnt pose,
        equal to the source wherever the blend is 0). The handles, the grip and the
        chain roots' transforms stay the source's."""
        if start is None:
            return self.src_local, self.src_euler
        start = np.ascontiguousarray(start, float)
        if start.shape != self.src_local.shape or not np.isfinite(start).all():
            raise ValueError(f"start pose must be finite local rotations {self.src_local.shape}")
        return start, np.ascontiguousarray(np.radians(limit_euler(start, self.rig.limits)))

    def _run(self, frames: np.ndarray, desired, settings: AdaptSettings, start=None, turn=None):
        check_settings(settings)
        p = check_point(desired, "desired hit point")
        start_local, start_euler = self._start_pose(start)
        chains, face_free = self._chain_args(settings)
        blend = self._blend_for(float(settings.falloff))
        rest = ((bool(settings.fix_right_hand), SOLVERS.index(settings.solver), float(settings.tolerance),
                 int(settings.iterations), DAMPING, ORIENT_TOL, self._reach_for(float(settings.trunk_reach)),
                 math.isfinite(settings.trunk_reach)),
                (settings.face == "keep", face_free, self.face_w, self.face_local,
                 self.face_turn(p, settings) if turn is None else np.asarray(turn, float)))
        J, h = self.parents.shape[0], self.hit_frame

        def solve(which, local, euler):
            return run_frames(which, J, (p, blend, self._shot_args, (local, euler)), chains, rest)

        held = settings.trunk_reach < 360.0        # (a reach past every limit holds nothing)
        if not settings.carry_lean or held or blend[h] == 0.0 or np.array_equal(frames, [h]):
            return solve(frames, start_local, start_euler), p
        hit = solve(np.array([h], np.int64), start_local, start_euler)
        carried = carried_start(start_local, start_euler, hit[0][0], self.trunk, blend, frames, h, self.rig.limits)
        at_hit = frames == h        # the hit frame keeps its own solve (not solved again)
        kept = np.zeros(len(frames), bool)
        if carried is not None:
            # the others held near the lean they start from, so their own solves do not turn
            # the trunk again on top of it
            held_rest = (rest[0][:6] + (self._reach_for(CARRY_REACH_DEG), True), rest[1])
            near = (hit_run(blend, frames, h) | (blend[frames] <= 0.0)) & ~at_hit
            ran = run_frames(frames[near], J, (p, blend, self._shot_args, carried), chains, held_rest)
            # a frame whose bat needed the trunk past that hold, or whose right hand it kept off
            # the grip, is solved alone: the hit's lean does not help it (the leg glance 30 cm
            # toward leg and 15 up: frame 32's chest 115 deg from the source's, alone 23); so is
            # one the blend adapts again after a gap (no part of the lean into the hit)
            kept[near] = served(ran[0], carried[1][frames[near]], ran[6], ran[7], self.trunk, self.rig.limits)
        out = tuple(np.empty((len(frames),) + a.shape[1:], a.dtype) for a in hit)

        def put(mask, outputs, rows):
            for mine, its in zip(out, outputs):
                mine[mask] = its[rows]
        put(at_hit, hit, slice(0, int(at_hit.any())))
        if carried is not None:
            put(kept, ran, kept[near])
        alone = ~kept & ~at_hit
        if alone.any():
            put(alone, solve(frames[alone], start_local, start_euler), slice(None))
        return out, p

    def adapt(self, desired_hit_point, settings: AdaptSettings | None = None, start=None,
              turn=None) -> Adaptation:
        """The whole shot adapted so the bat joint is at ``desired_hit_point`` at the hit frame;
        ``start``: the chains' start pose ``(F, J, 4)`` instead of the source's (learnt+ccd);
        ``turn``: the kept face's rotation vector ``(3,)`` rad at the hit frame against the
        shot's own, instead of the settings' (``face_turn``, ``face_yaw``, ``face_tilt``)."""
        settings = settings or AdaptSettings()
        frames = np.arange(self.num_frames, dtype=np.int64)
        (loc, grot, gpos, blend, handles, err, gcm, gdeg), p = self._run(frames, desired_hit_point, settings, start,
                                                                         turn)
        h = self.hit_frame
        return Adaptation(self.trans[:, 0].copy(), loc, grot, gpos, blend, handles, p,
                          float(np.linalg.norm(gpos[h, self.bat] - p)), gcm, gdeg)

    def adapt_frame(self, frame: int, desired_hit_point, settings: AdaptSettings | None = None):
        """(local_rotations (J,4), global_rotations (J,4), global_positions (J,3)) of one frame."""
        settings = settings or AdaptSettings()
        if not 0 <= int(frame) < self.num_frames:
            raise ValueError(f"frame {frame} outside 0..{self.num_frames - 1}")
        (loc, grot, gpos, *_), _ = self._run(np.array([int(frame)], np.int64), desired_hit_point, settings)
        return loc[0], grot[0], gpos[0]
