"""Can the arms hold a shot's keyed bat with a given grip? Per frame and arm, the least
excess over the rig's joint limits and the shoulder's ranges (degrees, summed over the arm's
joints, the horizontal and the axial range: tools/shots_arms ArmSolver.excess and
shoulder_excess) that any elbow on its circle allows, with the bat's roll free where the
authoring lets it turn (tools/shots_roll) and the bottom hand's turns and slides on the handle
(tools/shots_grips). A frame no elbow can hold is one the keys must change for that grip;
the arms' solve would clamp it, and the bat would jump there.

Run ``python -m tools.grip_feasibility --grip anatomical [--shot NAME]``: it reads the keys as
``tools.make_shots`` plans them (noise, the trunk's fit, the hands' unfold and, for a grip with
``lean_pass``, the bat's lean included), and solves nothing, so the whole library takes seconds
(about 40 s a shot with the lean) where a build takes minutes.
"""
from __future__ import annotations

import argparse
import sys

import numpy as np

from .grips import GRIPS
from .make_rig import grip_rig
from .make_shots import planned
from .shots_defs import SHOTS
from .shots_maths import rot_axis
from .shots_roll import FREE_ROLLS, FREE_WEIGHT

ELBOW_STEP_DEG = 10.0   # the elbow circle's sampling
OVER_DEG = 5.0          # a frame with more excess than this needs re-keying for the grip


def least_excess(solver, T: dict) -> dict:
    """``{"Left": (F,), "Right": (F,)}``: per frame the least limit excess (deg) of each arm
    over its elbow circle, the free rolls of the bat (where ``T["roll_weight"]`` <
    FREE_WEIGHT; elsewhere as keyed) and, for the bottom hand, its candidate grips."""
    arms = solver.arms
    F = len(T["grip"])
    psi = np.radians(np.arange(0.0, 360.0, ELBOW_STEP_DEG))[None]
    _, g_rot, g_pos = solver.body_pose(T)
    free = T["roll_weight"] < FREE_WEIGHT
    best = {"Left": np.full(F, np.inf), "Right": np.full(F, np.inf)}
    for roll in FREE_ROLLS:
        lw, lr, rw, rr = solver.hand_targets(T["grip"], T["bat_rot"] @ rot_axis(2, np.full(F, roll)))
        wrists, rots = solver.bottom_hand.grips(rw, rr)[:2]
        for pre, side, hands in (("Left", 1.0, [(lw, lr)]), ("Right", -1.0, zip(wrists, rots))):
            for w, r in hands:
                ang = arms.arm_angles(pre, w, r, g_rot, g_pos, side, psi)
                least = arms.all_excess(ang, pre, g_rot[:, arms.ix["Spine2"]]).min(1)
                best[pre] = np.minimum(best[pre], np.where(free | (roll == 0.0), least, np.inf))
    return best


def report(rig, names) -> dict:
    """Print, per shot and arm, the frames over OVER_DEG, the worst and the hit's excess;
    return ``{name: least_excess}``."""
    out = {}
    totals = {"Left": 0, "Right": 0}
    for name in names:
        solver, T, hit, _, _ = planned(name, rig)
        out[name] = least = least_excess(solver, T)
        parts = []
        for pre, e in least.items():
            over = np.flatnonzero(e > OVER_DEG)
            totals[pre] += len(over)
            parts.append(f"{pre.lower()} arm {len(over):2d} frames over {OVER_DEG:.0f} deg "
                         f"(worst {e.max():5.1f} at {int(e.argmax()):2d}, hit {e[hit]:4.1f})")
        print(f"{name:18s} " + "; ".join(parts))
    print(f"frames over {OVER_DEG:.0f} deg: left arm {totals['Left']}, right arm {totals['Right']}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grip", choices=sorted(GRIPS), default="anatomical")
    ap.add_argument("--shot", choices=list(SHOTS), help="one shot (default: all)")
    a = ap.parse_args(argv)
    report(grip_rig(a.grip), [a.shot] if a.shot else list(SHOTS))
    return 0


if __name__ == "__main__":
    sys.exit(main())
