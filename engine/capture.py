"""A real capture on its own skeleton, made ready for the engine and written back.

``load_capture`` reads a BVH, places its joints by a rig profile
(:mod:`engine.profiles`), scales it to centimetres and builds a :class:`Rig`
for it: DOFs and anatomical limits per role (taken from the bundled rig's
joint of the same role, so every limit is written once, in ``assets/rig.json``),
the lead-arm chain from the first spine joint to the lead hand with the
implement's hit point as its effector (a fixed joint appended under the lead
hand, placed at the hit frame), and the trail arm kept on the grip. The
result goes back with :meth:`Capture.to_file`: the input's hierarchy, joint
order, channels and units, the appended joint dropped.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from . import bvh, quat
from .capture_facing import check_facing, choose_facing, turn_clip
from .hitframe import HitFrame, find_hit_frame, motion_start
from .library import Shot
from .profiles import Profile, ProfileError, detect, load_profile, resolve
from .rig import Chain, Rig, default_rig
from .skeleton import Clip, Skeleton, clip_fk

IMPLEMENT_JOINT = "HitpointImplement"   # appended under the lead hand; never written out
KNOWN_UNITS_CM = (0.1, 1.0, 2.54, 5.6444, 100.0)   # mm, cm, inch, CMU's unit, m
STANDING_HEIGHT_CM = 170.0             # a typical adult, to guess a file's unit
BALL_DIAMETER_CM = 7.2
HELD_SPAN_CM = 30.0                    # hands further apart at the hit hold no implement (golf swing: 16.5 cm)


@dataclass
class Capture:
    path: Path
    profile: Profile
    roles: dict
    scale: float                 # cm per file unit
    file_skeleton: Skeleton      # as read (file units)
    file_clip: Clip
    rig: Rig                     # in cm, with the implement joint when appended
    shot: Shot
    hit: HitFrame
    appended: bool               # an implement joint was appended (dropped on writing)
    first_frame: int = 0         # frames before it (a conversion's T-pose) hold the motion's first pose
    facing_deg: int = 0          # turned this much about the vertical to face the ball (engine.capture_facing)
    pivot: np.ndarray | None = None   # (3,) cm: the vertical it turned about

    @property
    def lead_hand(self) -> int:
        return self.roles[f"{self.profile.lead}_hand"]

    @property
    def trail_hand(self) -> int:
        return self.roles[f"{self.profile.trail}_hand"]

    def write(self, out: str | Path, local_rotations: np.ndarray, root_positions: np.ndarray,
              blend: np.ndarray | None = None, name: str | None = None) -> None:
        """Write an engine result on the file's own skeleton (format by extension)."""
        from .export import write_take
        name = name or f"{self.shot.name}_adapted"
        if Path(out).suffix.lower() in (".glb", ".gltf"):
            from .gltf_export import write_gltf   # no batsman mesh on a foreign skeleton
            write_gltf(out, *self.to_file_cm(local_rotations, root_positions), with_mesh=False, name=name)
            return
        skel, clip = self.to_file(local_rotations, root_positions)
        # the file's own numbers wherever a rotation is unchanged (legs, untouched frames)
        write_take(out, skel, clip, name=name, blend=blend, reference=getattr(self.file_clip, "file_euler", None))

    def to_file_cm(self, local_rotations: np.ndarray, root_positions: np.ndarray) -> tuple[Skeleton, Clip]:
        """:meth:`to_file` in centimetres: the file's joints at their real size, for a glTF (in
        metres; the file's own units there made a CMU golfer 32 cm tall)."""
        return scaled(*self.to_file(local_rotations, root_positions), self.scale)

    def to_file(self, local_rotations: np.ndarray, root_positions: np.ndarray) -> tuple[Skeleton, Clip]:
        """An engine result (cm, rig joints) as a take on the file's own skeleton and units."""
        J = self.file_skeleton.num_joints
        clip = Clip(np.array(root_positions, float), np.array(local_rotations[:, :J], copy=True), self.file_clip.fps,
                    None if self.file_clip.local_positions is None else self.file_clip.local_positions.copy())
        if self.facing_deg:                 # back to the capture's own frame
            turn_clip(clip, -self.facing_deg, self.pivot)
        clip.root_positions = clip.root_positions / self.scale
        if clip.local_positions is not None:
            clip.local_positions[:, 0] = clip.root_positions
        f, src = self.first_frame, self.file_clip
        if f and clip.num_frames == src.num_frames:      # the file's own T-pose back in front
            clip.local_rotations[:f], clip.root_positions[:f] = src.local_rotations[:f], src.root_positions[:f]
            if clip.local_positions is not None:
                clip.local_positions[:f] = src.local_positions[:f]
        return self.file_skeleton, clip


def guess_scale(skeleton: Skeleton, roles: dict) -> float:
    """cm per unit, the known unit nearest (in ratio) to a 170 cm rest height."""
    from .skeleton import bind_positions
    p = bind_positions(skeleton)
    top = roles.get("head", roles["spine"][-1])
    feet = [roles[k] for k in ("left_foot", "right_foot") if k in roles] or [0]
    height = float(p[top, 1] - min(p[f, 1] for f in feet))
    if not height > 0:
        raise ProfileError("cannot guess the file's units (the head is not above the feet); give --scale")
    ratios = [abs(np.log(u * height / STANDING_HEIGHT_CM)) for u in KNOWN_UNITS_CM]
    return KNOWN_UNITS_CM[int(np.argmin(ratios))]


def scaled(skeleton: Skeleton, clip: Clip, scale: float) -> tuple[Skeleton, Clip]:
    """Skeleton and clip with every length multiplied by ``scale`` (file units -> cm)."""
    sk = Skeleton(list(skeleton.names), skeleton.parents.copy(), skeleton.offsets * scale,
                  list(skeleton.channel_orders), list(skeleton.position_channels),
                  {j: o * scale for j, o in skeleton.end_sites.items()})
    cl = Clip(clip.root_positions * scale, clip.local_rotations.copy(), clip.fps,
              None if clip.local_positions is None else clip.local_positions * scale)
    return sk, cl


@lru_cache(maxsize=1)
def _template() -> tuple[Rig, dict]:
    """The bundled rig and its roles: where every role's DOFs and limits are written."""
    rig = default_rig()
    return rig, resolve(load_profile("hitpoint"), rig.skeleton)


def _template_joint(role: str, k: int, n: int, troles: dict) -> int:
    """The bundled rig's joint for ``role`` (the k-th of n for the spine and neck)."""
    t = troles[role]
    if isinstance(t, list):
        return t[min(len(t) - 1, (k * len(t)) // max(n, 1))]
    return t


def role_limits(roles: dict, num_joints: int) -> tuple[np.ndarray, np.ndarray]:
    """DOF mask (J, 3) and limits (J, 3, 2) degrees per joint from its role.

    Where a skeleton has no roll joints, the bundled rig's roll (twist) DOF and
    range move onto the arm or forearm above it."""
    trig, troles = _template()
    dof, limits = np.zeros((num_joints, 3), bool), np.zeros((num_joints, 3, 2))
    for role, j in roles.items():
        if role not in troles or role == "hips":   # the root is never solved
            continue
        joints = j if isinstance(j, list) else [j]
        for k, jj in enumerate(joints):
            t = _template_joint(role, k, len(joints), troles)
            dof[jj], limits[jj] = trig.dof[t], trig.limits[t]
    for side in ("left", "right"):
        for roll, host in (("arm_roll", "arm"), ("forearm_roll", "forearm")):
            if f"{side}_{roll}" in roles or f"{side}_{host}" not in roles:
                continue
            h, t = roles[f"{side}_{host}"], troles[f"{side}_{roll}"]
            dof[h, 2] = True
            limits[h, 2] = np.clip(limits[h, 2] + trig.limits[t, 2], -180.0, 180.0)
    return dof, limits


def implement_points(profile: Profile, roles: dict, global_positions: np.ndarray) -> np.ndarray:
    """The implement's hit point per frame ``(F, 3)`` cm, from the hands."""
    lead = global_positions[:, roles[f"{profile.lead}_hand"]]
    trail = global_positions[:, roles[f"{profile.trail}_hand"]]
    imp = profile.implement
    if imp.get("hit_point", "hands_midpoint") == "hands_midpoint":
        return 0.5 * (lead + trail)
    axis = trail - lead
    axis /= np.maximum(np.linalg.norm(axis, axis=-1, keepdims=True), 1e-9)
    return lead + float(imp["length_cm"]) * axis


def _with_implement(skel: Skeleton, hand: int, offset: np.ndarray) -> Skeleton:
    return Skeleton(skel.names + [IMPLEMENT_JOINT], np.append(skel.parents, hand),
                    np.vstack([skel.offsets, offset]), skel.channel_orders + [""],
                    skel.position_channels + [False], dict(skel.end_sites))


def build_rig(profile: Profile, roles: dict, skel: Skeleton, effector: int) -> Rig:
    """A Rig for a (cm) skeleton whose lead-arm effector is joint ``effector``."""
    J = skel.num_joints
    dof, limits = role_limits(roles, J)
    lead, trail = profile.lead, profile.trail
    trail_top = roles.get(f"{trail}_clavicle", roles[f"{trail}_arm"])
    chains = {"left_arm": Chain(skel.chain(skel.names[roles["spine"][0]], skel.names[roles[f"{lead}_hand"]]), effector),
              "right_arm": Chain(skel.chain(skel.names[trail_top], skel.names[roles[f"{trail}_hand"]]),
                                 roles[f"{trail}_hand"])}
    feet = {}
    for side in ("left", "right"):
        if all(f"{side}_{r}" in roles for r in ("upleg", "foot")):
            chains[f"{side}_leg"] = Chain(skel.chain(skel.names[roles[f"{side}_upleg"]],
                                                     skel.names[roles[f"{side}_foot"]]), roles[f"{side}_foot"])
            feet[side] = [roles[f"{side}_foot"]] + ([roles[f"{side}_toe"]] if f"{side}_toe" in roles else [])
    trig, _ = _template()
    bat = dict(trig.bat) if profile.implement.get("joint") else {"kind": profile.implement.get("kind", "bat")}
    animated = J
    while animated > 0 and not skel.channel_orders[animated - 1]:   # PCA: the animated joints come first
        animated -= 1
    return Rig(skel, dof, limits, chains, bat, BALL_DIAMETER_CM / 2, roles[f"{lead}_hand"], 0, feet, animated,
               dict(roles))


def load_capture(path: str | Path, profile: str | Profile = "auto", hit_frame: int | str = "auto",
                 handedness: str | None = None, scale: float | None = None, facing: int | str = "auto") -> Capture:
    """Read a BVH capture and make it ready for the engine (see the module's doc).

    ``profile``: a bundled name, a JSON path, a Profile or "auto"; ``hit_frame``:
    a frame number or "auto"; ``handedness`` overrides the profile's ("left":
    the right hand leads); ``scale`` overrides its units (cm per file unit); ``facing``: the
    turn about the vertical (deg: 0, 90, 180 or 270) or "auto" (engine.capture_facing).
    Raises ProfileError / BvhError / ValueError with one-line messages."""
    path = Path(path)
    file_skel, file_clip = bvh.read(path)
    if profile == "auto":
        prof, roles = detect(file_skel)
    else:
        prof = profile if isinstance(profile, Profile) else load_profile(profile)
        roles = resolve(prof, file_skel)
    if prof.up != "y":      # role limits assume Y-up rest frames (assets/rig.json); say so, never guess
        raise ProfileError(f"profile {prof.name!r}: up axis {prof.up!r} is not supported yet (re-export the "
                           "file Y-up)")
    if handedness is not None:
        if handedness not in ("right", "left"):
            raise ProfileError(f"handedness must be right or left, got {handedness!r}")
        prof = Profile(**{**prof.__dict__, "handedness": handedness})
    cm = float(scale) if scale is not None else (
        guess_scale(file_skel, roles) if prof.scale_cm == "auto" else float(prof.scale_cm))
    skel, clip = scaled(file_skel, file_clip, cm)
    # a T-pose the conversion put in front (CMU's frame 0) is no pose of the motion: it would
    # flash at each loop, pull a PC of its own and ask the clean-up for hands 130 cm apart
    first = motion_start(clip.local_rotations)
    _hold_first_pose(clip, first)
    grot, gpos = clip_fk(skel, clip)
    hit = _hit_frame(prof, roles, clip, gpos, hit_frame, first)
    skel, effector, appended = _implement(prof, roles, skel, grot[hit.frame], gpos[hit.frame])
    if appended:
        clip.local_rotations = np.concatenate(
            [clip.local_rotations, quat.identity((clip.num_frames, 1))], axis=1)
        if clip.local_positions is not None:
            clip.local_positions = np.concatenate(
                [clip.local_positions, np.broadcast_to(skel.offsets[-1], (clip.num_frames, 1, 3))], axis=1)
    rig = build_rig(prof, roles, skel, effector)
    if "axis" not in rig.bat:
        lead, trail = roles[f"{prof.lead}_hand"], roles[f"{prof.trail}_hand"]
        h = hit.frame
        span = gpos[h, trail] - gpos[h, lead]
        axis = quat.rotate(quat.conjugate(grot[h, lead]), _shaft(roles, gpos[h], lead, trail))
        rig.bat["axis"] = (axis / max(float(np.linalg.norm(axis)), 1e-9)).tolist()
        # Hands far apart at the hit (a walk: 57 cm) hold nothing: the effector stays, none is drawn.
        rig.bat["held"] = bool(np.linalg.norm(span) <= HELD_SPAN_CM)
    if "face_normal" not in rig.bat:
        rig.bat["face_normal"] = _leading_side(rig, clip, grot, gpos, hit.frame).tolist()
    turn, pivot = _facing(rig, skel, clip, hit.frame, facing)
    shot = Shot(path.stem, path.name, hit.frame, f"{prof.name} capture", skel, clip, effector)
    cap = Capture(path, prof, roles, cm, file_skel, file_clip, rig, shot, hit, appended, first, turn, pivot)
    shot.capture = cap
    return cap


def _facing(rig: Rig, skel: Skeleton, clip: Clip, h: int, facing) -> tuple[int, np.ndarray]:
    """Turn ``clip`` in place to face the ball (engine.capture_facing); (the turn in deg, the
    pivot (3,) cm: the hips over the ground at the hit)."""
    grot, gpos = clip_fk(skel, Clip(clip.root_positions[h:h + 1], clip.local_rotations[h:h + 1], clip.fps))
    pivot = np.array([gpos[0, 0, 0], 0.0, gpos[0, 0, 2]])
    if facing == "auto":
        if not rig.bat.get("held", True):
            return 0, pivot
        normal = quat.rotate(grot[0, rig.bat_joint], np.asarray(rig.bat["face_normal"], float))
        facing = choose_facing(normal, gpos[0, rig.bat_joint], pivot)
    try:
        turn = check_facing(facing)
    except ValueError as e:
        raise ProfileError(str(e)) from None
    turn_clip(clip, turn, pivot)
    return turn, pivot


def _hold_first_pose(clip: Clip, first: int) -> None:
    """Frames before ``first`` take frame ``first``'s pose, in place (the file keeps its own:
    :meth:`Capture.to_file` puts them back)."""
    if first:
        clip.local_rotations[:first] = clip.local_rotations[first]
        clip.root_positions[:first] = clip.root_positions[first]
        if clip.local_positions is not None:
            clip.local_positions[:first] = clip.local_positions[first]


def _hit_frame(prof: Profile, roles: dict, clip: Clip, gpos: np.ndarray, hit_frame, first: int) -> HitFrame:
    F = clip.num_frames
    if hit_frame == "auto":
        return find_hit_frame(implement_points(prof, roles, gpos), clip.fps, first)
    h = int(hit_frame)
    if not 0 <= h < F:
        raise ValueError(f"hit frame {h} outside the capture's frames 0..{F - 1}")
    return HitFrame(h, "given", h, float("nan"), 0)


def _implement(prof: Profile, roles: dict, skel: Skeleton, grot_hit: np.ndarray, gpos_hit: np.ndarray):
    """(skeleton, effector joint, appended): the profile's implement joint, or one
    appended under the lead hand at the hit point of the hit frame."""
    name = prof.implement.get("joint")
    if name:
        if name not in skel.names:
            raise ProfileError(f"profile {prof.name!r} names an implement joint the file lacks: {name}")
        return skel, skel.index(name), False
    hand = roles[f"{prof.lead}_hand"]
    point = implement_points(prof, roles, gpos_hit[None])[0]
    offset = quat.rotate(quat.conjugate(grot_hit[hand]), point - gpos_hit[hand])
    skel = _with_implement(skel, hand, offset)
    return skel, skel.num_joints - 1, True


def _shaft(roles: dict, gpos_hit: np.ndarray, lead: int, trail: int) -> np.ndarray:
    """The implement's shaft at the hit ``(3,)`` (world, unnormalised), when the file has none:
    arms and implement swing as one unit about the shoulders (Stuelcken et al. 2005; a club
    at impact lies along the lead arm), so the shaft runs along the swing's radius, from
    the shoulders' midpoint through the hands'. Without both shoulders: from the lead
    hand through the trail hand (the wrists of a grip lie across the shaft as much as along
    it: the CMU golfer's gave a shaft pointing at the keeper, and a face looking down)."""
    hands = 0.5 * (gpos_hit[lead] + gpos_hit[trail])
    if "left_arm" in roles and "right_arm" in roles:
        radius = hands - 0.5 * (gpos_hit[roles["left_arm"]] + gpos_hit[roles["right_arm"]])
        if np.linalg.norm(radius) > 1e-6:
            return radius
    return gpos_hit[trail] - gpos_hit[lead]


def _leading_side(rig: Rig, clip: Clip, grot: np.ndarray, gpos: np.ndarray, h: int) -> np.ndarray:
    """An implement's face when the file cannot say: the side that leads the swing at
    the hit frame (its velocity there, square to the shaft), in the lead hand's frame."""
    F, eff, hand = clip.num_frames, rig.bat_joint, int(rig.skeleton.parents[rig.bat_joint])
    a, b = max(h - 1, 0), min(h + 1, F - 1)
    off = rig.skeleton.offsets[eff]
    p = gpos[[a, b], hand] + quat.rotate(grot[[a, b], hand], np.broadcast_to(off, (2, 3)))
    v = p[1] - p[0]
    axis_w = quat.rotate(grot[h, hand], np.asarray(rig.bat["axis"], float))
    v = v - axis_w * float(v @ axis_w)
    n = np.linalg.norm(v)
    if n < 1e-9:        # a still implement: any side square to the shaft
        v = np.cross(axis_w, [0.0, 1.0, 0.0])
        n = max(float(np.linalg.norm(v)), 1e-9)
    return quat.rotate(quat.conjugate(grot[h, hand]), v / n)
