"""Author the bundled shot library: assets/shots/<name>.bvh and library.json.

Run ``python -m tools.make_shots`` (deterministic: fixed seeds, no clocks).
``--check`` prints diagnostics only; ``--only NAME`` builds one shot.

Route: key poses for pelvis, chest, head target, feet and bat (tools/shots_defs,
with the measured figures they follow cited there) -> monotone cubic
interpolation at 30 fps (tools/shots_keys) -> low-amplitude smooth noise on the
upper body and bat, so no two shots move alike -> analytic IK for legs and
arms with every joint built from its allowed DOFs (tools/shots_ik) -> BVH via
engine.bvh.write. Every shot starts in the same stance frame and ends in the
same rest frame: the noise fades out at both ends and the end frames are the
shared key values exactly.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from engine import bvh, cleanup, quat
from engine.library import Shot
from engine.rig import assets_dir, default_rig, rig_from_dict
from engine.skeleton import Clip, clip_fk

from . import shots_check as chk
from .grips import GRIPS, bat_keys, grip_of, refit, regrip, reshape
from .make_rig import rig as rig_dict
from .shots_defs import REST, SHOTS, STANCE
from .shots_ik import PoseSolver, fit_torso, shoulder_positions
from .shots_keys import FPS, targets, tracks
from .shots_lean import choose_lean
from .shots_roll import HELD_WEIGHT

# noise amplitude per channel (cm or degrees): a captured batsman never
# repeats a key pose exactly; feet are left alone so planted feet stay planted
NOISE = {"hips_pos": 0.5, "hips_ypr": 0.8, "chest_ypr": 1.2, "look": 4.0, "grip": 0.5,
         "bat_d": 0.006, "bat_n": 0.01, "head_tilt": 1.5}
SEED = 20240611


def smooth_noise(rng: np.random.Generator, n: int, dims: int, cutoff_frames: float = 9.0) -> np.ndarray:
    """Band-limited noise ``(n, dims)`` with unit standard deviation."""
    white = rng.standard_normal((n + 60, dims))
    k = np.exp(-0.5 * (np.arange(-30, 31) / (cutoff_frames / 2.0)) ** 2)
    out = np.stack([np.convolve(white[:, d], k / k.sum(), "valid") for d in range(dims)], -1)[:n]
    return out / np.maximum(out.std(axis=0), 1e-9)


def envelope(n: int, ramp: int = 8) -> np.ndarray:
    """0 on the first and last frame, 1 in the middle, smooth ramps ``(n,)``."""
    x = np.ones(n)
    r = np.arange(ramp) / ramp
    s = r * r * (3 - 2 * r)
    x[:ramp] = s
    x[-ramp:] = s[::-1]
    return x


def unfold(solver, T, times, d_min: float = 27.0, d_max: float = 48.0, held_s: float = 0.0) -> np.ndarray:
    """Grip offsets ``(F, 3)`` keeping each wrist between ``d_min`` and ``d_max``
    from its shoulder (full reach is 54 cm); none at the contact nor ``held_s`` after it."""
    sh = shoulder_positions(solver, T["hips_pos"], T["hips_rot"], T["chest_rot"])
    l_wrist, _, r_wrist, _ = solver.hand_targets(T["grip"], T["bat_rot"])
    push = np.zeros_like(l_wrist)
    for k, w in ((0, l_wrist), (1, r_wrist)):
        v = w - sh[:, k]
        dist = np.linalg.norm(v, axis=-1, keepdims=True)
        push += (np.maximum(0.0, d_min - dist) - np.maximum(0.0, dist - d_max)) * v / np.maximum(dist, 1e-9)
    k = np.exp(-0.5 * (np.arange(-8, 9) / 2.5) ** 2)
    pad = np.pad(push, ((8, 8), (0, 0)), mode="edge")
    smooth = np.stack([np.convolve(pad[:, i], k, "valid") for i in range(3)], -1)
    # the stroke's contact is never moved
    # (a defence's bat is held where it met the ball: tests/assets/test_shots.test_hit_frame_is_the_contact)
    away = np.where(times > 0.0, np.maximum(0.0, times - held_s), times)
    return 0.8 * smooth * (1.0 - np.exp(-0.5 * (away / 0.1) ** 2))[:, None] * envelope(len(times), 6)[:, None]


def shared_reach(solver, d_min: float = 27.0, d_max: float = 48.0) -> None:
    """Raise unless the shared stance and rest keys hold both wrists between
    ``d_min`` and ``d_max`` of their shoulders: ``unfold`` and ``fit_torso`` fade
    out at the first and last frames (they are the shared keys exactly), so a
    key out of that reach is corrected on every frame but its own and the
    bat jumps between them (the stance's left wrist at 53.5 cm of 54 lifted
    the bat 26 cm over frames 0-3 of every shot)."""
    grip = grip_of(solver.rig)
    for pose_name, pose in (("STANCE", STANCE), ("REST", REST)):
        pose = regrip([(0.0, pose)], grip, STANCE, REST)[0][1]
        tr = tracks([(0.0, dict(pose)), (1.0, dict(pose))], np.zeros(1), solver)
        T = targets(tr)
        sh = shoulder_positions(solver, T["hips_pos"], T["hips_rot"], T["chest_rot"])[0]
        l_wrist, _, r_wrist, _ = solver.hand_targets(T["grip"], T["bat_rot"])
        for side, w, s in (("left", l_wrist[0], sh[0]), ("right", r_wrist[0], sh[1])):
            dist = float(np.linalg.norm(w - s))
            if not d_min <= dist <= d_max:
                raise ValueError(f"{pose_name}: {side} wrist {dist:.1f} cm from its shoulder, "
                                 f"outside [{d_min}, {d_max}]")


def build(name: str, rig=None, noise: bool = True, keyed=None, fitted=None):
    """(skeleton, clip, hit_frame, description, info) for one shot; ``keyed``: its
    (keys, description) in place of ``SHOTS[name]()``; ``fitted``: its re-fitted bat keys
    (tools/grips.refit) in place of the grip's."""
    rig = rig or default_rig()
    solver, T, n_pre, description, info = planned(name, rig, noise, keyed, fitted)
    root, local, solved = solver.solve(T)
    info.update(solved)
    clip, clamped = into_limits(rig, Clip(root, local, FPS))
    clamped = max(clamped, info["top_arm_clamped_deg"])       # the solver clamps the top arm itself
    return rig.skeleton, clip, n_pre, description, {"clamped_deg": clamped, **info}


def planned(name: str, rig, noise: bool = True, keyed=None, fitted=None):
    """What ``build`` hands the pose solver: (the PoseSolver, its world targets ``T`` with
    the bat's ``roll_weight``, the hit frame, the description, info: ``tracks``, ``unfold_cm``)."""
    keys, description = keyed or SHOTS[name]()
    grip = grip_of(rig)
    keys = reshape(name, regrip(keys, grip, STANCE, REST), grip)
    keys = refit(keys, bat_keys(name, grip) if fitted is None else fitted)
    t0, t1 = keys[0][0], keys[-1][0]
    n_pre, n_post = int(round(-t0 * FPS)), int(round(t1 * FPS))
    times = np.arange(-n_pre, n_post + 1) / FPS
    solver = PoseSolver(rig)
    shared_reach(solver)
    tr = tracks(keys, times, solver)
    if noise:
        rng = np.random.default_rng([SEED, sorted(SHOTS).index(name)])
        env = envelope(len(times))[:, None]
        for ch, amp in NOISE.items():
            if ch in tr:
                tr[ch] = tr[ch] + amp * env * smooth_noise(rng, len(times), tr[ch].shape[1])
    T = targets(tr)
    # lean the chest where the keyed torso would leave an arm locked or folded
    tr["chest_ypr"] = tr["chest_ypr"] + fit_torso(solver, T, tr["chest_ypr"], envelope(len(times), 4))
    T = targets(tr)
    # never fold an elbow shut nor pull an arm out of its socket: where a
    # hand comes within 27 cm of its shoulder (elbow past ~135 degrees) or
    # beyond 48 cm (of 54), carry the bat to where the arms can hold it
    keyed_grip = tr["grip"]
    held_s = grip.get("dead_bat_s", 0.0) if name in chk.DEAD_BATS else 0.0
    for _ in range(8):
        tr["grip"] = tr["grip"] + unfold(solver, T, times, held_s=held_s)
        T = targets(tr)
    info = {"tracks": tr, "unfold_cm": float(np.linalg.norm(tr["grip"] - keyed_grip, axis=-1).max())}
    # the face may turn about the bat's axis except near impact and at the
    # shared first and last frames
    near_hit = np.exp(-0.5 * (times / 0.06) ** 2)
    T["roll_weight"] = 0.05 + 200.0 * near_hit + 200.0 * (1.0 - envelope(len(times), 6))
    T["roll_weight"][n_pre] = np.inf          # the face meets the ball as keyed
    # ... and a defence or glance holds it there (grips: dead_bat_s)
    T["roll_weight"][n_pre + 1:n_pre + int(round(held_s * FPS)) + 1] = HELD_WEIGHT
    if grip.get("lean_pass"):
        turn, info["lean"] = choose_lean(solver, T, n_pre)
        T["bat_rot"] = T["bat_rot"] @ turn
    return solver, T, n_pre, description, info


def into_limits(rig, clip: Clip) -> tuple[Clip, float]:
    """(the solved clip with every joint angle clamped into the rig's limits, the largest
    clamp in degrees); the right hand is then put back on the handle where the clamp moved
    it (engine.cleanup, which keeps the limits). The solver's costs leave a few frames a
    few degrees out where the keyed bat cannot be held otherwise."""
    local, largest = chk.clamp_into_limits(rig, clip.local_rotations)
    fixed = Clip(clip.root_positions.copy(), local.copy(), clip.fps)
    src_rot, src_pos = clip_fk(rig.skeleton, clip)
    have, want = chk.right_in_left(rig, *clip_fk(rig.skeleton, fixed)), chk.right_in_left(rig, src_rot, src_pos)
    off = (np.linalg.norm(have[0] - want[0], axis=-1) > 0.3) | (quat.angle_between(have[1], want[1]) > 1.5)
    if off.any():
        # the re-grip solves every frame (its elbows may differ): kept where the grip was lost;
        # forward in time only, as the library was built (both passes re-key the leg glance's
        # clamped frames: not yet checked against the shots' measures)
        cleanup.reattach_right_hand(rig, rig.skeleton, fixed, src_rot, src_pos, passes=(1,))
        # ... and where its elbow does not go through the trunk
        inside = chk.elbow_to_spine(rig, clip_fk(rig.skeleton, fixed)[1], "Right") < chk.TRUNK_INSIDE_CM
        fixed.local_rotations[~off | inside] = local[~off | inside]
    return fixed, largest


def report(rig, name, clip, hit, clamped_deg=0.0):
    g_rot, g_pos = clip_fk(rig.skeleton, clip)
    sk = rig.skeleton
    bat = g_pos[:, rig.bat_joint]
    speed = np.linalg.norm(np.gradient(bat, axis=0), axis=-1) * FPS / 100
    off_handle, slide = chk.right_palm_on_handle(rig, g_rot, g_pos)
    rpos, _ = chk.right_in_left(rig, g_rot, g_pos)
    print(f"{name}: {clip.num_frames} frames, hit {hit}, hit point {np.round(bat[hit], 1)}, "
          f"bat speed at hit {speed[hit]:.1f} m/s (max {speed.max():.1f} at {int(speed.argmax())})")
    print(f"  right palm off the handle max {off_handle.max():.2f} cm, slid down it up to {slide.max():.1f} cm "
          f"({np.count_nonzero(slide > 1.0)} frames), right-in-left std {rpos.std(0).max():.2f}, "
          f"largest clamp into the limits {clamped_deg:.1f} deg")
    for foot in ("LeftFoot", "LeftToeBase", "RightFoot", "RightToeBase"):
        p = g_pos[:, sk.index(foot)]
        print(f"  {foot}: min y {p[:, 1].min():.2f}, drift {chk.foot_drift(p, FPS):.2f} cm, "
              f"runs {chk.planted_runs(p, FPS)}")
    for v in chk.limit_violations(rig, clip.local_rotations):
        print("  LIMIT", v)
    for v in chk.shoulder_problems(rig, g_rot):
        print("  SHOULDER", v)
    for v in chk.trunk_problems(rig, g_pos):
        print("  TRUNK", v)
    for v in chk.elbow_problems(rig, g_pos):
        print("  ELBOW", v)
    shot = Shot(name, f"{name}.bvh", hit, "", rig.skeleton, clip, rig.bat_joint)
    m = chk.hit_measures(rig, shot)
    print(f"  hit: {m['contact']} (face_to_ball {m['face_to_ball']:.2f}), azimuth {m['azimuth_deg']:.1f}, "
          f"elevation {m['elevation_deg']:.1f}, bat {m['speed_mps']:.1f} m/s (peak {m['peak_mps']:.1f}, "
          f"{m['peak_offset']:+d} frames), first lands {m['first_bounce_cm']:.0f} cm away")
    for problem in chk.hit_problems(name, m):
        print("  HIT", problem)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="diagnostics only, write nothing")
    ap.add_argument("--only", help="build one shot")
    ap.add_argument("--out", help="where the library goes (default: the bundled one)")
    ap.add_argument("--grip", choices=sorted(GRIPS), help="hold the bat with this grip (tools/grips); "
                    "the rig goes into --out beside the shots (default: the bundled rig's)")
    a = ap.parse_args(argv)
    if a.only and a.only not in SHOTS:
        ap.error(f"unknown shot {a.only!r} (known: {', '.join(SHOTS)})")
    rig = default_rig()
    if a.grip and GRIPS[a.grip] is not grip_of(rig):
        if not a.out:
            ap.error(f"--grip {a.grip} is not the bundled rig's grip: give --out")
        data = rig_dict(a.grip)
        rig = rig_from_dict(data)
        Path(a.out).mkdir(parents=True, exist_ok=True)
        bvh.atomic_write_text(Path(a.out) / "rig.json", json.dumps(data, indent=1) + "\n")
    out = Path(a.out or assets_dir() / "shots")
    out.mkdir(parents=True, exist_ok=True)
    names = [a.only] if a.only else list(SHOTS)
    manifest = []
    totals = dict.fromkeys(chk.ARM_FRAMES, 0)
    for name in names:
        skel, clip, hit, desc, info = build(name, rig)
        report(rig, name, clip, hit, info["clamped_deg"])
        for kind, n in chk.arm_figures(rig, *clip_fk(rig.skeleton, clip)).items():
            totals[kind] = totals.get(kind, 0) + n
        if not a.check:
            # engine.bvh.write, but with the Euler branch the rig's DOFs mean
            # (an elbow flexed past 90 degrees stays a pure y rotation)
            bvh.atomic_write_text(out / f"{name}.bvh",
                                  bvh.format_bvh(skel, clip, euler=chk.dof_euler(rig, clip.local_rotations)))
        manifest.append({"name": name, "file": f"{name}.bvh", "hit_frame": hit, "description": desc})
    if not a.check and not a.only:
        bvh.atomic_write_text(out / "library.json", json.dumps(manifest, indent=1) + "\n")
        print(f"wrote {len(manifest)} shots to {out}")
    # what tests/assets/test_shot_smoothness bounds over the whole library
    print("arm-frames: " + ", ".join(f"{k} {totals[k]}" for k in chk.ARM_FRAMES))


if __name__ == "__main__":
    sys.exit(main())
