"""``hitpoint analyse``: PCA of the shots (variance, style error, components strip,
batting space). Dissertation 2.5.4-2.5.5, 3.1, 4.2."""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw
import typer

from app.cli.render import check_png_out, save_png_atomic
from app.errors import MAX_POSITION_CM, UserError, cli_errors, numbers, shorten
from app.errors import falloff as falloff_cm
from app.errors import trunk_reach as trunk_reach_deg
from engine import choice
from engine.library import find_shot
from engine.userlib import load_shots
from engine.skeleton import Clip, bind_positions, clip_fk, skinning_matrices

DISSERTATION = {"dof0": 0.307, "dof2": 0.398, "source": "Table 2.1"}
PARTS = ("body", "upper")


def register(cli: typer.Typer) -> None:
    @cli.command("analyse")
    @cli_errors
    def analyse(
        shot: list[str] = typer.Option(None, "--shot", help="Only these shots (repeatable). Default: all."),
        as_json: bool = typer.Option(False, "--json", help="Variance as JSON instead of a table."),
        components: int = typer.Option(5, "--components", min=1, help="PCs listed in the variance table."),
        style: bool = typer.Option(False, "--style", help="Style RMSE (2.5.5) of adapted shots, 0-DOF vs 2-DOF wrist, as JSON."),
        offsets: str = typer.Option("15,30", "--offsets", help="--style: hit-point offsets in cm, applied off/leg/up/down."),
        falloff: float = typer.Option(90.0, "--falloff", help="--style: importance falloff (cm)."),
        solver: str = typer.Option("ccd", "--solver", help="--style: ccd or dls."),
        pcs: int = typer.Option(3, "--pcs", min=1, help="--style: PCs of the source the adapted shot is compared in (2.5.5 uses 3)."),
        strip: Path = typer.Option(None, "--components-strip", help="Write a PNG of poses along PC1..3 from -3 to +3 SD (Figure 3.2)."),
        part: str = typer.Option("upper", "--part", help="--components-strip: upper (as in Figure 3.2) or body."),
        directions: bool = typer.Option(False, "--directions", help="Face angle and ball direction over a grid of hit-point offsets, wrist 0 vs 2 DOF (Fig. 2.6); --json for JSON."),
        multi: bool = typer.Option(False, "--multi", help="The 'batting space' of all shots together (4.2): variance of 2 and 3 PCs."),
        solvers: bool = typer.Option(False, "--solvers", help="ccd, dls, learnt and learnt+ccd side by side over the --offsets distances along +-x, +-y, +-z: bat error, grip error, joint-limit hits, us a frame, style RMSE, face angle (medians); --json for JSON."),
        leave_out: bool = typer.Option(False, "--leave-out", help="--solvers: the learnt model of each shot trained without it."),
        library: Path = typer.Option(None, "--library", help="A shot library: a folder with library.json, or the manifest (default: the bundled library)."),
        trunk_reach: float = typer.Option(None, "--trunk-reach", help="--directions, --style: hold each spine joint within this many degrees of the source's (default: free)."),
    ):
        """PCA of each shot: explained variance per component and cumulative (first 5 PCs).

        The parameters per frame are the root translation and every animated
        joint's quaternion (3 + 26 x 4 = 107), sign-continuous and standardised.
        "upper" uses the spine, neck, head and arm quaternions only.
        """

        if strip is not None:
            check_png_out(strip, "--components-strip")
            if part not in PARTS:
                raise UserError(f"--part must be one of {', '.join(PARTS)}, got {shorten(part)!r}")
        if style or directions or solvers:
            from engine.adapt import AdaptSettings, check_settings  # numba (0.25 s): when the command runs
            offsets_cm = _parse_offsets(offsets) if style or solvers else None
            falloff = falloff_cm("--falloff", falloff)
            reach = math.inf if trunk_reach is None else trunk_reach_deg("--trunk-reach", trunk_reach)
            check_settings(AdaptSettings(falloff=falloff, solver=solver, trunk_reach=reach))
        rig, shots = load_shots(library)
        if not shots:
            raise UserError("the shot library is empty")
        if shot:
            shots = [find_shot(shots, n) for n in shot]
        if solvers:
            from app.cli.solvers_report import print_solvers, solvers_report
            if leave_out and len(shots) < 2:
                raise UserError("--leave-out needs a library of at least 2 shots (the learnt model trains on the others)")
            report = solvers_report(rig, shots, offsets_cm, falloff, 0, leave_out)
            if as_json:
                print(json.dumps(report, indent=1))
            else:
                print_solvers(report)
            return
        if directions:
            report = directions_report(rig, shots, falloff_cm("--falloff", falloff), solver, reach)
            if as_json:
                print(json.dumps(report, indent=1))
            else:
                print_directions(report)
            return
        if style:
            print(json.dumps(style_report(rig, shots, offsets_cm, falloff, solver, pcs, reach), indent=1))
            return
        if strip is not None:
            info = write_components_strip(rig, shots[0], strip, part)
            print(json.dumps(info, indent=1))
            return
        if multi:
            print(json.dumps(multi_report(rig, shots), indent=1))
            return
        rows = variance_rows(rig, shots, components)
        if as_json:
            print(json.dumps(rows, indent=1))
        else:
            print_variance_table(rows, components)


# ------------------------------------------------------------------- variance
def variance_rows(rig, shots, components: int = 5) -> list[dict]:
    from engine import pca as pcam  # numba (0.25 s): when the command runs
    rows = []
    for s in shots:
        row = {"name": s.name, "frames": s.num_frames}
        for part in PARTS:
            p = pcam.fit_clip(rig, s.clip, part)
            k = min(components, p.num_components)
            row[part] = {
                "parameters": p.num_params,
                "explained": [round(float(v), 4) for v in p.explained[:k]],
                "cumulative": [round(float(v), 4) for v in p.cumulative[:k]],
                "pcs_for_70_percent": int(np.searchsorted(p.cumulative, 0.7 - 1e-12) + 1),
            }
        rows.append(row)
    return rows


def print_variance_table(rows: list[dict], components: int) -> None:
    k = components
    head = "".join(f"{'PC' + str(i + 1):>7}" for i in range(k))
    print(f"{'shot':<18}{'part':<6}{'P':>4}  explained % per PC{' ' * max(0, 7 * k - 18)}  cumulative %")
    print(f"{'':<18}{'':<6}{'':>4}  {head}  {head}  PCs for 70%")
    for r in rows:
        for part in PARTS:
            d = r[part]
            e = "".join(f"{100 * v:7.1f}" for v in d["explained"]) + " " * 7 * (k - len(d["explained"]))
            c = "".join(f"{100 * v:7.1f}" for v in d["cumulative"]) + " " * 7 * (k - len(d["cumulative"]))
            name = r["name"] if part == PARTS[0] else ""
            print(f"{name:<18}{part:<6}{d['parameters']:>4}  {e}  {c}  {d['pcs_for_70_percent']:>6}")


def multi_report(rig, shots) -> dict:
    from engine import pca as pcam  # numba (0.25 s): when the command runs
    out = {"shots": [s.name for s in shots], "frames": int(sum(s.num_frames for s in shots))}
    for part in PARTS:
        p = pcam.fit_clips(rig, [s.clip for s in shots], part)
        single = [float(pcam.fit_clip(rig, s.clip, part).cumulative[min(2, s.num_frames - 1)]) for s in shots]
        out[part] = {
            "parameters": p.num_params,
            "explained": [round(float(v), 4) for v in p.explained[:5]],
            "variance_2pcs": round(float(p.cumulative[min(1, p.num_components - 1)]), 4),
            "variance_3pcs": round(float(p.cumulative[min(2, p.num_components - 1)]), 4),
            "pcs_for_70_percent": int(np.searchsorted(p.cumulative, 0.7 - 1e-12) + 1),
            "single_shot_mean_variance_3pcs": round(float(np.mean(single)), 4),
        }
    return out


# ---------------------------------------------------------------- style error
def _parse_offsets(text: str) -> list[float]:
    """``--offsets`` "15,30": hit-point offsets in cm, each in (0, MAX_POSITION_CM]."""
    vals = [v for v in text.split(",") if v.strip()]
    if not vals:
        raise UserError(f"--offsets must be comma-separated numbers in cm, got {shorten(text)!r}")
    vals = numbers("--offsets", vals, 0.0, MAX_POSITION_CM)
    if 0.0 in vals:
        raise UserError("--offsets must be positive (cm), got 0")
    return vals


# off side is -X for the bundled right-handed batsman (he faces -X in stance)
DIRECTIONS = {"off": (-1.0, 0.0, 0.0), "leg": (1.0, 0.0, 0.0), "up": (0.0, 1.0, 0.0), "down": (0.0, -1.0, 0.0)}


def style_report(rig, shots, offsets: list[float], falloff: float, solver: str, pcs: int = 3,
                 trunk_reach: float = math.inf) -> dict:
    """Style RMSE (2.5.5) of every shot adapted to hit points around its own, with
    the left wrist at 0 and at 2 DOF; upper-body and whole-body PC spaces, the
    first ``pcs`` components of the source."""
    from engine import pca as pcam
    from engine.adapt import AdaptSettings, Adapter  # numba (0.25 s): when the command runs

    results, all_rmse = [], {(p, d): [] for p in PARTS for d in (0, 2)}
    for s in shots:
        adapter = Adapter(rig, s)
        spaces = {p: pcam.fit_clip(rig, s.clip, p) for p in PARTS}
        per = []
        for name, direction in DIRECTIONS.items():
            for dist in offsets:
                d = np.asarray(direction) * dist
                entry = {"offset": f"{name} {dist:g}", "offset_cm": [float(v) for v in d]}
                for dof in (0, 2):
                    a = adapter.adapt(s.hit_point + d, AdaptSettings(falloff=falloff, wrist_dof=dof, solver=solver,
                                                                     trunk_reach=trunk_reach))
                    for p in PARTS:
                        e = pcam.style_error(spaces[p], a.root_positions, a.local_rotations, pcs)
                        entry[f"{p}_dof{dof}"] = round(e, 4)
                        all_rmse[(p, dof)].append(e)
                    entry[f"bat_error_cm_dof{dof}"] = round(float(a.bat_error_cm), 3)
                per.append(entry)
        summary = {}
        for p in PARTS:
            r0 = float(np.sqrt(np.mean([e[f"{p}_dof0"] ** 2 for e in per])))
            r2 = float(np.sqrt(np.mean([e[f"{p}_dof2"] ** 2 for e in per])))
            summary[p] = {"dof0": round(r0, 4), "dof2": round(r2, 4),
                          "dof0_better": bool(r0 < r2),
                          "offsets_dof0_better": f"{sum(e[f'{p}_dof0'] < e[f'{p}_dof2'] for e in per)}/{len(per)}",
                          "difference_percent": round(100 * (r2 - r0) / r0, 1) if r0 > 0 else None}
        results.append({"name": s.name, **summary,
                        "agrees_with_dissertation": summary["upper"]["dof0_better"],
                        "offsets": per})
    overall = {}
    for p in PARTS:
        r0 = float(np.sqrt(np.mean(np.square(all_rmse[(p, 0)]))))
        r2 = float(np.sqrt(np.mean(np.square(all_rmse[(p, 2)]))))
        overall[p] = {"dof0": round(r0, 4), "dof2": round(r2, 4), "dof0_better": bool(r0 < r2),
                      "difference_percent": round(100 * (r2 - r0) / r0, 1) if r0 > 0 else None,
                      "shots_dof0_better": int(sum(r[p]["dof0_better"] for r in results))}
    return {
        "method": f"project each adapted shot into its source's first {pcs} PCs; RMSE over frames of "
                  "the Euclidean score distance; per shot and overall the quadratic mean over offsets",
        "offsets_cm": offsets, "directions": list(DIRECTIONS),
        "settings": {"falloff": falloff, "solver": solver, "pcs": pcs,
                     "trunk_reach_deg": None if math.isinf(trunk_reach) else trunk_reach},
        "dissertation": DISSERTATION,
        "overall": overall,
        "agrees_with_dissertation": overall["upper"]["dof0_better"],
        "shots": results,
    }


# ----------------------------------------------------------------- directions
GRID_X = (-30.0, -15.0, 0.0, 15.0, 30.0)    # cm, across the ball's line (-X: off side)
GRID_Y = (-15.0, 0.0, 15.0)                 # cm, up
REACHED_CM = 0.01                           # bat error below which an offset counts as reached


def _ranks(v) -> np.ndarray:
    """Ranks of ``v`` (1..n), ties averaged."""
    v = np.asarray(v, float)
    order = np.argsort(v, kind="stable")
    r = np.empty(len(v))
    r[order] = np.arange(1, len(v) + 1)
    for u in np.unique(v):
        same = v == u
        r[same] = r[same].mean()
    return r


def spearman(a, b) -> float:
    """Spearman's rank correlation of two equal-length sequences (nan when one is constant)."""
    ra, rb = _ranks(a), _ranks(b)
    ra, rb = ra - ra.mean(), rb - rb.mean()
    d = float(np.sqrt((ra @ ra) * (rb @ rb)))
    return float(ra @ rb / d) if d > 0 else float("nan")


def source_direction(rig, shot) -> dict:
    """The source shot at its own hit point: face, ball direction and bat speed
    (central difference of the bat joint), and where the horizontal bat speed peaks."""
    from app.cli.adapt import hit_summary
    from engine import ballistics
    grot, gpos = shot.fk
    h, fps = shot.hit_frame, shot.clip.fps
    out = hit_summary(rig, shot, grot, gpos, choice.BALL_START, shot.hit_point)
    del out["face_angle_deg"]
    v = ballistics.bat_velocities(gpos, rig.bat_joint, fps)
    horiz = np.hypot(v[:, 0], v[:, 2])
    k = int(np.argmax(horiz[1:-1])) + 1                  # central differences only
    den = horiz[k - 1] - 2 * horiz[k] + horiz[k + 1]     # sub-frame peak: parabola through 3 samples
    peak = k + (0.5 * (horiz[k - 1] - horiz[k + 1]) / den if den < 0 else 0.0)
    out.update({"bat_speed_mps": round(float(np.linalg.norm(v[h])) / 100, 2),
                "bat_horizontal_speed_mps": round(float(horiz[h]) / 100, 2),
                "peak_horizontal_speed_mps": round(float(horiz[k]) / 100, 2),
                "peak_frames_after_hit": round(float(peak - h), 1)})
    return out


def directions_report(rig, shots, falloff: float = 90.0, solver: str = "ccd", trunk_reach: float = math.inf) -> dict:
    """Every shot adapted over the GRID_X x GRID_Y offsets (cm, on the plane facing
    the bowler) with the wrist at 0 and 2 DOF: face angle vs the source, face_to_ball,
    contact and the ball's azimuth/elevation (Fig. 2.6's data), a summary per shot
    and over all shots."""
    from engine import face
    from engine.adapt import Adapter  # numba (0.25 s): when the command runs

    results = []
    pooled = {d: {"angle": [], "cos": [], "trunk": [], "jump": []} for d in (0, 2)}
    for s in shots:
        adapter = Adapter(rig, s)
        src = source_direction(rig, s)
        grid, summary = [], {}
        for dof in (0, 2):
            rows = _direction_rows(rig, s, adapter, src, dof, falloff, solver, trunk_reach)
            grid += rows
            ok = [e for e in rows if e["bat_error_cm"] < REACHED_CM]
            pooled[dof]["angle"] += [e["face_angle_deg"] for e in ok]
            pooled[dof]["cos"] += [e["face_to_ball"] for e in ok]
            pooled[dof]["trunk"] += [e["trunk_turn_deg"] for e in ok]
            pooled[dof]["jump"] += [e["trunk_jump_deg"] for e in ok]
            summary[f"dof{dof}"] = _direction_summary(rows, ok)
        results.append({"name": s.name, "source": src, **summary, "grid": grid})
    overall = {}
    for dof, p in pooled.items():
        ang, cos = np.array(p["angle"]), np.array(p["cos"])
        overall[f"dof{dof}"] = {
            "offsets": int(len(ang)),
            "face_angle_median_deg": round(float(np.median(ang)), 2) if len(ang) else None,
            "face_angle_p90_deg": round(float(np.percentile(ang, 90)), 2) if len(ang) else None,
            "face_angle_max_deg": round(float(ang.max()), 2) if len(ang) else None,
            "turned_from_ball": int(np.sum(cos < 0)),
            "shots_azimuth_moves_with_hit_point": int(sum(r[f"dof{dof}"]["azimuth_moves_with_hit_point"]
                                                          for r in results)),
            **{f"trunk_turn_{k}_deg": v for k, v in _stats(p["trunk"], "median", "p90", "max").items()},
            **{f"trunk_jump_{k}_deg": v for k, v in _stats(p["jump"], "median", "p90", "max").items()},
        }
    return {
        "method": "hit point moved by offset_cm (x across the ball's line, -x the off side; y up) on the plane "
                  "facing the bowler; face angle = angle between the adapted and the source face normals at the "
                  "hit frame; face_to_ball = cosine of the face normal and the direction toward the incoming ball "
                  f"(contact: face >= {face.EDGE_COS}, back <= -{face.EDGE_COS}, edge between); ball direction "
                  "of the velocity just after the impact (0 deg straight back past the bowler, + toward the off "
                  f"side); statistics over offsets reached to {REACHED_CM} cm; Fig. 2.6 holds when Spearman's "
                  "rho of azimuth vs the off-side offset is positive; trunk turn = the chest's largest angle from "
                  "the source's over the frames (what keeping the face and the grip costs the posture); trunk jump = "
                  "its largest turn between two frames beyond the source's own turn there (a pop)",
        "grid_x_cm": list(GRID_X), "grid_y_cm": list(GRID_Y),
        "settings": {"falloff": falloff, "solver": solver,
                     "trunk_reach_deg": None if math.isinf(trunk_reach) else trunk_reach},
        "overall": overall,
        "shots": results,
    }


def _direction_rows(rig, shot, adapter, src: dict, dof: int, falloff: float, solver: str,
                    trunk_reach: float = math.inf) -> list[dict]:
    """One row per grid offset: the adapted hit's bat error, face and ball direction."""
    from app.cli.adapt import hit_summary
    from engine import face
    from engine.adapt import AdaptSettings

    settings = AdaptSettings(falloff=falloff, wrist_dof=dof, solver=solver, trunk_reach=trunk_reach)
    rows = []
    for dy in GRID_Y:
        for dx in GRID_X:
            a = adapter.adapt(shot.hit_point + np.array([dx, dy, 0.0]), settings)
            e = {"wrist_dof": dof, "offset_cm": [dx, dy, 0.0], "bat_error_cm": round(a.bat_error_cm, 4),
                 **hit_summary(rig, shot, a.global_rotations, a.global_positions, choice.BALL_START,
                               a.desired_hit_point), **_trunk_figures(rig, shot, a.global_rotations)}
            # unwrapped around the source's direction, so a shot near +-180 deg stays continuous
            e["ball_azimuth_deg"] = round(float(src["ball_azimuth_deg"] + face.wrap_deg(
                e["ball_azimuth_deg"] - src["ball_azimuth_deg"])), 2)
            rows.append(e)
    return rows


def _trunk_figures(rig, shot, global_rotations) -> dict:
    """engine.adapt.trunk_turn_deg and trunk_jump_deg of an adapted ``shot``, rounded."""
    from engine.adapt import trunk_jump_deg, trunk_turn_deg
    turn = trunk_turn_deg(rig, shot.fk[0], global_rotations)
    jump = trunk_jump_deg(rig, shot.fk[0], global_rotations)
    return {"trunk_turn_deg": None if turn is None else round(turn, 2),
            "trunk_jump_deg": None if jump is None else round(jump, 2)}


def _stats(values: list, *which: str) -> dict:
    """``{which_deg: ...}`` (median, p90, max) of ``values`` rounded, None where there are none."""
    v = np.array([x for x in values if x is not None], float)
    fn = {"median": np.median, "p90": lambda a: np.percentile(a, 90), "max": np.max}
    return {w: round(float(fn[w](v)), 2) if len(v) else None for w in which}


def _direction_summary(rows: list[dict], ok: list[dict]) -> dict:
    """A shot's grid at one wrist DOF summed up: ``ok`` the rows reached."""
    ang = np.array([e["face_angle_deg"] for e in ok])
    cos = np.array([e["face_to_ball"] for e in ok])
    off = [-e["offset_cm"][0] for e in ok]           # toward the off side
    rho = spearman(off, [e["ball_azimuth_deg"] for e in ok]) if len(ok) > 2 else float("nan")
    rows_up = 0
    for dy in GRID_Y:
        az = [e["ball_azimuth_deg"] for e in sorted((e for e in ok if e["offset_cm"][1] == dy),
                                                      key=lambda e: -e["offset_cm"][0])]
        rows_up += int(len(az) == len(GRID_X) and bool(np.all(np.diff(az) > 0)))
    return {
        "reached": f"{len(ok)}/{len(rows)}",
        "face_angle_median_deg": round(float(np.median(ang)), 2) if len(ang) else None,
        "face_angle_max_deg": round(float(ang.max()), 2) if len(ang) else None,
        "face_share": round(float(np.mean([e["contact"] == "face" for e in ok])), 3) if ok else None,
        "turned_from_ball": int(np.sum(cos < 0)),
        "spearman_azimuth_vs_off_offset": None if np.isnan(rho) else round(rho, 3),
        "azimuth_moves_with_hit_point": bool(rho > 0),
        "rows_strictly_increasing": f"{rows_up}/{len(GRID_Y)}",
        **{f"trunk_turn_{k}_deg": v for k, v in _stats([e["trunk_turn_deg"] for e in ok], "median", "max").items()},
        **{f"trunk_jump_{k}_deg": v for k, v in _stats([e["trunk_jump_deg"] for e in ok], "median", "max").items()},
    }


def print_directions(report: dict) -> None:
    """The directions report as tables: per shot the source's direction, the grid
    (0 | 2 DOF side by side) and a summary line per wrist setting."""
    for r in report["shots"]:
        s = r["source"]
        print(f"{r['name']}: source az {s['ball_azimuth_deg']:+.1f} el {s['ball_elevation_deg']:+.1f} "
              f"face_to_ball {s['face_to_ball']:+.2f} ({s['contact']}), bat {s['bat_speed_mps']:.1f} m/s at the hit, "
              f"horizontal peak {s['peak_horizontal_speed_mps']:.1f} m/s {s['peak_frames_after_hit']:+.1f} frames from it")
        print(f"  {'dx':>5}{'dy':>5} | {'wrist 0 DOF: angle  cos contact    az    el trunk  jump':<56}"
              "| wrist 2 DOF: angle  cos contact    az    el trunk  jump")
        by = {(e["wrist_dof"], e["offset_cm"][0], e["offset_cm"][1]): e for e in r["grid"]}
        for dy in report["grid_y_cm"]:
            for dx in report["grid_x_cm"]:
                cells = []
                for dof in (0, 2):
                    e = by[(dof, dx, dy)]
                    mark = "" if e["bat_error_cm"] < REACHED_CM else "*"
                    trunk = "" if e["trunk_turn_deg"] is None else f"{e['trunk_turn_deg']:6.0f}"
                    jump = "" if e["trunk_jump_deg"] is None else f"{e['trunk_jump_deg']:6.0f}"
                    cells.append(f"{e['face_angle_deg']:12.1f}{e['face_to_ball']:+6.2f} {e['contact']:<5}"
                                 f"{e['ball_azimuth_deg']:+7.1f}{e['ball_elevation_deg']:+6.1f}{trunk:>6}{jump:>6}"
                                 f"{mark:<1}")
                print(f"  {dx:5.0f}{dy:5.0f} |{cells[0]:<57}|{cells[1]}")
        for dof in (0, 2):
            m = r[f"dof{dof}"]
            print(f"  {dof} DOF: face angle median {m['face_angle_median_deg']} max {m['face_angle_max_deg']} deg, "
                  f"face {m['face_share']}, turned from the ball {m['turned_from_ball']}, reached {m['reached']}, "
                  f"rho(az, off) {m['spearman_azimuth_vs_off_offset']} -> "
                  f"{'moves with the hit point' if m['azimuth_moves_with_hit_point'] else 'NOT monotonic'}, "
                  f"trunk turned median {m['trunk_turn_median_deg']} max {m['trunk_turn_max_deg']} deg, "
                  f"jumped a frame median {m['trunk_jump_median_deg']} max {m['trunk_jump_max_deg']} deg")
    for dof in (0, 2):
        o = report["overall"][f"dof{dof}"]
        print(f"all shots, {dof} DOF: face angle median {o['face_angle_median_deg']} p90 {o['face_angle_p90_deg']} "
              f"max {o['face_angle_max_deg']} deg over {o['offsets']} offsets, turned from the ball "
              f"{o['turned_from_ball']}, azimuth moves with the hit point in "
              f"{o['shots_azimuth_moves_with_hit_point']}/{len(report['shots'])} shots, trunk turned median "
              f"{o['trunk_turn_median_deg']} p90 {o['trunk_turn_p90_deg']} max {o['trunk_turn_max_deg']} deg, "
              f"jumped a frame median {o['trunk_jump_median_deg']} p90 {o['trunk_jump_p90_deg']} "
              f"max {o['trunk_jump_max_deg']} deg")
    reach = report["settings"].get("trunk_reach_deg")
    print("(* offset not reached: bat error >= %g cm; the trunk %s)" % (
        REACHED_CM, "free" if reach is None else f"held within {reach:g} deg a spine joint"))


# ------------------------------------------------------------ components strip
def components_poses(rig, clip, part: str = "upper", sds=(-3, -2, -1, 0, 1, 2, 3), pcs: int = 3):
    """Poses along each of the first ``pcs`` PCs (others 0) at ``sds`` standard
    deviations of the observed scores: ``root (pcs, n, 3)``, ``local (pcs, n, J, 4)``."""
    from engine import pca as pcam  # numba (0.25 s): when the command runs
    p = pcam.fit_clip(rig, clip, part)
    pcs = min(pcs, p.num_components)
    scores = np.zeros((pcs, len(sds), pcs))
    sd = p.score_sd
    for k in range(pcs):
        scores[k, :, k] = np.asarray(sds, float) * sd[k]
    root, rot = p.pose_from_scores(scores)
    return p, root, rot


def write_components_strip(rig, shot, path: Path, part: str = "upper", cell: int = 220) -> dict:
    """Figure 3.2: rows PC1..PC3, columns -3..+3 SD, the skinned batsman in each cell."""
    path = Path(path)
    check_png_out(path, "--components-strip")
    sds = (-3, -2, -1, 0, 1, 2, 3)
    p, root, rot = components_poses(rig, shot.clip, part, sds)
    img = _render_strip_gl(rig, root, rot, cell)
    img = _label_strip(img, shot.name, part, p, sds, cell)
    save_png_atomic(img, path)
    return {"shot": shot.name, "part": part, "file": str(path),
            "rows": [f"PC{k + 1}" for k in range(root.shape[0])], "columns_sd": list(sds),
            "variance_3pcs": round(float(p.cumulative[min(2, p.num_components - 1)]), 4)}


# The strip's camera looks from the off side, a little toward the bowler and above.
VIEW_FROM = np.array([-1.0, 0.35, 0.75]) / np.linalg.norm([-1.0, 0.35, 0.75])


def _render_strip_gl(rig, root, rot, cell: int):
    """Skinned batsman per cell through the render API (app.render)."""
    from app.render import scene as rs  # moderngl: when it renders
    J = rot.shape[-2]
    g_rot, g_pos = clip_fk(rig.skeleton, Clip(root.reshape(-1, 3), rot.reshape(-1, J, 4)))
    skin = skinning_matrices(g_rot, g_pos, bind_positions(rig.skeleton))
    ctx = rs.offscreen_context()
    try:
        return _render_cells(rs, rs.SceneRenderer(ctx, rig), root, skin, cell)
    finally:
        ctx.release()


def _render_cells(rs, renderer, root, skin, cell: int):
    rows, cols = root.shape[:2]
    centre = root.reshape(-1, 3).mean(axis=0)
    target = np.array([centre[0], 88.0, centre[2]])
    eye = target + VIEW_FROM * 600.0
    view = rs.look_at(eye, target)
    proj = rs.perspective(30.0, 1.0, 10.0, 5000.0)
    img = Image.new("RGB", (cols * cell, rows * cell + 46), (245, 245, 240))
    for i in range(rows * cols):
        sv = rs.SceneView(view=np.asarray(view, np.float32), proj=np.asarray(proj, np.float32),
                          size=(cell, cell), skin_matrices=skin[i], show_pitch=True)
        tile = rs.render_image(renderer, sv)
        r, c = divmod(i, cols)
        img.paste(Image.fromarray(np.asarray(tile, np.uint8)), (c * cell, 46 + r * cell))
    return img


def _label_strip(img, name, part, p, sds, cell):
    """Title and column labels in the top band; a boxed label on each row."""
    draw = ImageDraw.Draw(img)
    cum = p.cumulative
    draw.text((6, 6), f"{name}: {part} PCA, PC1..3 capture {100 * cum[min(2, len(cum) - 1)]:.1f}% of the variance; "
                      f"each row varies one PC from {sds[0]:+d} to {sds[-1]:+d} SD of its observed scores, others 0",
              fill=(20, 20, 20))
    for c, s in enumerate(sds):
        draw.text((c * cell + cell // 2 - 14, 28), f"{s:+d} SD" if s else "mean", fill=(60, 60, 60))
    for k in range((img.height - 46) // cell):
        y = 46 + k * cell + 4
        label = f"PC{k + 1} ({100 * p.explained[k]:.1f}%)"
        draw.rectangle([3, y - 1, 8 + 7 * len(label), y + 14], fill=(255, 255, 255))
        draw.text((6, y), label, fill=(20, 20, 20))
    return img
