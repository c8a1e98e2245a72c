"""``hitpoint bench``: engine timings as JSON (IK per frame and per shot, skinning, ikpy)."""
from __future__ import annotations

import json
import os
import time

import warnings
import numpy as np
import typer

from app.errors import cli_errors, number
from engine.library import load_library
from engine.rig import default_rig
from engine.skeleton import bind_positions, skinning_matrices

MIN_REPS, MAX_REPS = 10, 100_000   # below 10 the p95 means nothing; above, a run takes hours


def _stats(samples, scale: float) -> dict:
    a = np.asarray(samples) * scale
    return {"median": round(float(np.median(a)), 3), "p95": round(float(np.percentile(a, 95)), 3),
            "n": len(a)}


def _time(fn, reps: int, warmup: int = 3) -> list[float]:
    for _ in range(warmup):
        fn()
    out = []
    for _ in range(reps):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def ikpy_chain(rig, chain, parent_rot, start_euler_rad, lo, hi):
    """An ikpy chain equal to one of our chains for one frame: the base is the
    chain's parent joint frame, each Euler column is a revolute link (free) or
    a fixed turn by its source angle (locked), the effector a fixed link."""
    from ikpy.chain import Chain      # the bench extra: only for the comparison
    from ikpy.link import OriginLink, URDFLink
    links = [OriginLink()]
    mask = [False]
    axes = ((0, 0, 1), (0, 1, 0), (1, 0, 0))
    for k, j in enumerate(chain.joints):
        for c in range(3):
            trans = chain.offsets[k] if c == 0 else np.zeros(3)
            name = f"{rig.skeleton.names[j]}_{'zyx'[c]}"
            if chain.free[k, c]:
                links.append(URDFLink(name, trans, np.zeros(3), rotation=np.array(axes[c], float),
                                      bounds=(lo[k, c], hi[k, c])))
                mask.append(True)
            else:
                rpy = np.zeros(3)
                rpy[2 - c] = start_euler_rad[k, c]      # rpy = (x, y, z) angles
                links.append(URDFLink(name, trans, rpy, joint_type="fixed"))
                mask.append(False)
    links.append(URDFLink("effector", chain.eff_off, np.zeros(3), joint_type="fixed"))
    mask.append(False)
    ch = Chain(links, active_links_mask=mask)
    init = np.zeros(len(links))
    i = 1
    for k in range(len(chain.joints)):
        for c in range(3):
            if chain.free[k, c]:
                init[i] = start_euler_rad[k, c]
            i += 1
    return ch, init


def _slowest_shot(rig, settings, reps: int, rng) -> tuple:
    """Every bundled shot adapted whole to random hit points: the slowest shot's figures (ms),
    its Adapter and its targets."""
    from engine.adapt import Adapter
    worst = None
    for shot in load_library(rig=rig):
        adapter = Adapter(rig, shot)
        targets = shot.hit_point + rng.uniform(-20, 20, size=(8, 3))
        it = iter(range(10 ** 9))
        st = _stats(_time(lambda: adapter.adapt(targets[next(it) % len(targets)], settings), reps), 1e3)
        if worst is None or st["median"] > worst[0]["median"]:
            worst = (dict(st, shot=shot.name, frames=shot.num_frames), adapter, targets)
    return worst


def _paired(ways: dict, call, reps: int, setup=None) -> tuple[dict, float]:
    """``call(way, k)`` for each of two ``ways`` (name -> way) call by call in turn, ``setup(way)``
    untimed before each: the medians (ms) by name and the median of the paired ratios, the
    first way's over the second's (alternating cancels most of a shared machine's drift)."""
    times = {name: [] for name in ways}
    for k in range(reps + 3):
        for name, way in ways.items():
            if setup is not None:
                setup(way)
            t = time.perf_counter()
            call(way, k)
            if k >= 3:      # the first calls warm up
                times[name].append(time.perf_counter() - t)
    first, second = (np.asarray(v) for v in times.values())
    medians = {name: _stats(v, 1e3)["median"] for name, v in times.items()}
    return medians, round(float(np.median(first / second)), 3)


def _threads_vs_one(adapter, targets, settings, reps: int) -> dict:
    """A whole shot on engine.frames_parallel's threads and on one (``HITPOINT_THREADS=1``),
    call by call in turn: the two medians (ms), the threads and the median of the paired ratios."""
    from engine.frames_parallel import worker_count
    threads = worker_count()
    saved = os.environ.get("HITPOINT_THREADS")
    try:
        medians, ratio = _paired({"threads": threads, "one": 1},
                                 lambda n, k: adapter.adapt(targets[k % len(targets)], settings), reps,
                                 setup=lambda n: os.environ.__setitem__("HITPOINT_THREADS", str(n)))
    finally:
        if saved is None:
            os.environ.pop("HITPOINT_THREADS", None)
        else:
            os.environ["HITPOINT_THREADS"] = saved
    return {"threads": threads, "median_ms": medians["threads"], "one_thread_median_ms": medians["one"],
            "paired_ratio": ratio}


def _carried_vs_alone(adapter, targets, settings, reps: int) -> dict:
    """A whole shot with the hit's lean carried (engine.carry: the hit frame solved first,
    frames it does not serve again) and with every frame alone, call by call in turn, to
    the same targets: the two medians (ms) and the median of the paired ratios."""
    from dataclasses import replace
    medians, ratio = _paired({"carried": replace(settings, carry_lean=True),
                              "alone": replace(settings, carry_lean=False)},
                             lambda s, k: adapter.adapt(targets[k % len(targets)], s), reps)
    return {"carried_median_ms": medians["carried"], "alone_median_ms": medians["alone"], "paired_ratio": ratio}


def run_bench(reps: int = 200) -> dict:
    """The engine's figures (medians, p95; see ``_stats``) on the first bundled shot at its
    hit frame, targets within 20 cm of its hit point; ikpy on the same left-arm chain."""
    from engine.adapt import Adapter, AdaptSettings  # numba (0.25 s): when the command runs

    rig = default_rig()
    shot = load_library(rig=rig)[0]
    adapter = Adapter(rig, shot)
    settings = AdaptSettings()
    h = shot.hit_frame
    rng = np.random.default_rng(1)
    targets = shot.hit_point + rng.uniform(-20, 20, size=(16, 3))
    it = iter(range(10 ** 9))

    def one_frame():
        adapter.adapt_frame(h, targets[next(it) % len(targets)], settings)

    def whole_shot():
        adapter.adapt(targets[next(it) % len(targets)], settings)

    res = {"shot": shot.name, "frames": shot.num_frames, "hit_frame": h, "solver": "ccd",
           "targets": "hit point + uniform(-20, 20) cm"}
    res["one_frame_both_arms_us"] = _stats(_time(one_frame, reps), 1e6)
    res["whole_shot_ms"] = _stats(_time(whole_shot, max(reps // 4, 20)), 1e3)
    slowest, slow_adapter, slow_targets = _slowest_shot(rig, settings, max(reps // 10, 10), rng)
    res["whole_shot_threads_vs_one"] = dict(_threads_vs_one(slow_adapter, slow_targets, settings, max(reps // 10, 10)),
                                            shot=slowest["shot"])
    res["whole_shot_ms_slowest_shot"] = slowest
    res["whole_shot_carried_vs_alone"] = dict(_carried_vs_alone(slow_adapter, slow_targets, settings,
                                                                max(reps // 10, 10)), shot=slowest["shot"])
    res["solvers"] = solver_figures(rig)
    grot, gpos = shot.fk
    bind = bind_positions(rig.skeleton)
    res["skinning_one_frame_us"] = _stats(_time(lambda: skinning_matrices(grot[h], gpos[h], bind), reps), 1e6)
    res["synthesised_take_ms"] = _take_figures(rig, shot, max(reps // 10, 10))
    res.update(_left_arm_vs_ikpy(rig, shot, targets, reps))
    return res


def _take_figures(rig, shot, reps: int) -> dict:
    """A PC-pad take (what a click on a preset waits for): the exaggerated preset (0.4) synthesised
    with the source's detail and cleaned up (hand, feet, the bat to the hit point with the face)."""
    from engine import cleanup, synth, synth_detail
    from engine import pca as pcam
    space = pcam.fit_clip(rig, shot.clip, "body")
    sections = synth.shot_sections(shot.fk[1][:, rig.bat_joint], shot.hit_frame)
    path = synth.preset_path(synth.source_path(space), "exaggerated", 0.4, sections)

    def take():
        anim = synth.synthesise(space, path, frames=shot.num_frames,
                                detail=synth_detail.source_detail(space, path, "time"))
        cleanup.cleanup(rig, shot.skeleton, anim, shot.clip, source_hit_frame=shot.hit_frame)
    return {**_stats(_time(take, reps), 1e3), "preset": "exaggerated 0.4, source detail, full clean-up"}


def _left_arm_vs_ikpy(rig, shot, targets: np.ndarray, reps: int) -> dict:
    """The left-arm chain alone, ours vs ikpy, from the same start pose to the same targets."""
    from engine import ccd, quat

    res = {}
    h = shot.hit_frame
    grot, gpos = shot.fk
    it = iter(range(10 ** 9))
    chain = ccd.chain_arrays(rig, "left_arm", 0)
    lim = np.radians(rig.limits[chain.joints])
    src = np.radians(ccd.limit_euler(shot.clip.local_rotations[h, chain.joints], rig.limits[chain.joints]))
    lo = np.minimum(lim[..., 0], src)
    hi = np.maximum(lim[..., 1], src)
    pr, pp = grot[h, chain.parent], gpos[h, chain.parent]
    start = shot.clip.local_rotations[h:h + 1, chain.joints]
    ours_err = []

    def ours():
        k = next(it) % len(targets)
        _, e, _ = ccd.solve(chain, pr[None], pp[None], start, targets[k][None])
        ours_err.append(float(e[0]))

    t_ours = _time(ours, reps)
    try:
        ch, init = ikpy_chain(rig, chain, pr, src, lo, hi)
        local_targets = quat.rotate(quat.conjugate(pr), targets - pp)
        fk0 = ch.forward_kinematics(init)[:3, 3]
        bat0 = quat.rotate(quat.conjugate(pr), gpos[h, rig.bat_joint] - pp)
        ik_err = []

        def theirs():
            k = next(it) % len(targets)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sol = ch.inverse_kinematics(local_targets[k], initial_position=init)
            ik_err.append(float(np.linalg.norm(ch.forward_kinematics(sol)[:3, 3] - local_targets[k])))

        t_ik = _time(theirs, max(reps // 10, 10), warmup=1)
        ik = _stats(t_ik, 1e3)
        res["ikpy_left_arm_ms"] = ik
        res["ours_left_arm_us"] = _stats(t_ours, 1e6)
        res["ikpy_over_ours"] = round(float(np.median(t_ik) / np.median(t_ours)), 1)
        res["ikpy_median_error_cm"] = round(float(np.median(ik_err)), 4)
        res["ours_median_error_cm"] = round(float(np.median(ours_err)), 6)
        res["ikpy_start_matches_cm"] = round(float(np.linalg.norm(fk0 - bat0)), 6)
    except ImportError:
        res["ikpy_left_arm_ms"] = None
        res["ours_left_arm_us"] = _stats(t_ours, 1e6)
    return res


def solver_figures(rig) -> dict:
    """ccd, dls, learnt, learnt+ccd on every bundled shot over offsets of 15 and 30 cm along
    +-x, +-y, +-z (engine.solver_compare; 3 timed runs each): the medians over shots."""
    from app.cli.solvers_report import clean
    from engine.solver_compare import compare
    report = compare(rig, load_library(rig=rig), (15.0, 30.0), reps=3)
    return clean({"offsets": "15 and 30 cm along +-x, +-y, +-z", "median_over_shots": report["overall"]})


def register(cli: typer.Typer) -> None:
    @cli.command("bench")
    @cli_errors
    def bench(as_json: bool = typer.Option(False, "--json", help="Print JSON only."),
              reps: int = typer.Option(200, "--reps", help="Timed repetitions per figure (10..100000).")):
        """Engine timings: one frame adapted (both arms), a whole shot, the four solvers
        side by side (ccd, dls, learnt, learnt+ccd: us a frame, bat and grip error, limit
        hits, style RMSE, face angle; medians over shots), skinning matrices for one
        frame, a synthesised take (a PC-pad preset made and cleaned up), and ikpy on the
        same left-arm chain (median, p95)."""
        reps = number("--reps", reps, MIN_REPS, MAX_REPS, integer=True)
        res = run_bench(reps)
        if as_json:
            print(json.dumps(res))
            return
        for k, v in res.items():
            print(f"{k:<28}{v}")
