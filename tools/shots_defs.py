"""The nine bundled shots as key poses (see shots_keys for the channels).

World: cm, Y up, middle stump at the origin, bowler along +Z, popping crease
at z = 122. The right-handed batsman stands side-on, left shoulder toward
+Z, facing -X (the off side). t is seconds relative to impact.

Timing and distances follow measured batting (shared/DESIGN.md, "Figures for
authoring believable shots"):
  Stretch, Buys, Du Toit & Viljoen 1998, drive (D) vs forward defence (FD):
    backlift height D 0.74 m, FD 0.65 m (read here as the bat toe's height at
    the top of the backlift); stride starts D 0.58 s, FD 0.64 s before impact;
    downswing starts D 0.36 s, FD 0.38 s before impact; front-foot stride
    D 0.68 m, FD 0.72 m; front foot lands D 0.06 s, FD 0.14 s before impact;
    back foot drags forward D 0.10 m, FD 0.05 m; peak horizontal bat speed
    0.02 s before impact, D 11.8 m/s, FD 3.5 m/s.
  Stance: centre of mass ~0.08 m forward of the feet's midpoint (read as
    toward the toes, -X), feet about shoulder width apart, knees slightly
    bent, head still and level.
  Stuelcken, Portus & Mason 2005: looped bat path, backswing flowing into
    the downswing without a pause, front upper limb as one unit, front foot
    placed just before impact inside the line of the ball.
  The stroke is committed 180-200 ms before impact: no key changes the bat's
    course inside that window except the swing itself.
Back-foot strokes (cut, pull, back defence, glance) and the sweep have no
figures there; they reuse the downswing timing (~0.36 s) with the back foot
moving back and across instead of the front-foot stride.
"""
from __future__ import annotations

import numpy as np

from .shots_ik import unit

V = lambda *a: np.array(a, float)


def bat_d(*a):
    return unit(V(*a))


# ------------------------------------------------------------- shared poses
# Feet: ball of the back (right) foot at z = 97, front (left) at z = 138,
# 41 cm apart (shoulder width) either side of the popping crease (z = 122),
# balls of the feet 21 cm to the leg side of middle stump. Back foot parallel to the
# crease, front foot opened 15 degrees toward the bowler.
STANCE_FEET = {"l_toe": V(21, 1, 138), "l_yaw": -75.0, "l_heel": 0.0,
               "r_toe": V(21, 1, 97), "r_yaw": -90.0, "r_heel": 0.0}

BOWLER = V(0, 210, 1900)          # where a batsman watches the ball come from

STANCE = {
    # knees slightly bent, hips and shoulders side-on, CoM over the balls of the feet
    "hips_pos": V(27, 83, 117), "hips_ypr": V(-90, 12, 0), "chest_ypr": V(-88, 16, 18),
    "look": BOWLER, "head_tilt": 0.0,
    # bat grounded just in front of the back foot's toes, hands at the front thigh
    "toe": V(-7, 1.5, 102), "bat_d": bat_d(-4, -80, -8), "bat_n": V(-0.3, 0, 1),
    "wrist_pref": 50.0,
    **STANCE_FEET,
}

REST = {
    # relaxed and taller, shoulders a little open, bat held just off the ground
    "hips_pos": V(28, 86, 117), "hips_ypr": V(-86, 8, 0), "chest_ypr": V(-84, 12, 14),
    "look": BOWLER, "head_tilt": 0.0,
    "grip": V(-3, 89, 113), "bat_d": bat_d(-0.15, -1, -0.1), "bat_n": V(-0.3, 0, 1),
    "wrist_pref": 30.0,
    **STANCE_FEET,
}


def frame_span(t_start: float, t_end: float) -> tuple[int, int]:
    """Frames before and after impact for a key span in seconds."""
    return int(round(-t_start * 30)), int(round(t_end * 30))


def with_ends(t_start: float, t_end: float, body: list, hold: float = 0.15) -> list:
    """Stance at the start (held), rest at the end (held), the stroke between."""
    return ([(t_start, dict(STANCE)), (t_start + hold, dict(STANCE))] + body +
            [(t_end - hold, dict(REST)), (t_end, dict(REST))])


# ------------------------------------------------------------- the shots
def forward_defence():
    """Front-foot block: short stride to the pitch of the ball, bat angled, dead hands."""
    hit = V(0, 33, 200)
    land = V(12, 1, 212)             # front-foot stride 0.72 m (Stretch FD)
    body = [
        (-0.78, {"l_heel": 0.0}),
        (-0.70, {"hips_pos": V(32, 88, 113)}),        # weight rocks back before the stride
        (-0.64, {"l_toe": STANCE_FEET["l_toe"], "l_heel": 14.0}),   # stride starts 0.64 s before
        (-0.58, {"grip": V(16, 90, 112), "bat_d": bat_d(-0.15, -0.8, -0.6), "bat_n": V(-1, 0.3, 0.2)}),
        (-0.40, {"l_toe": V(14, 9, 178), "l_heel": 6.0, "l_yaw": -65.0}),
        # top of a modest backlift: downswing starts 0.38 s before impact, toe ~0.65 m up
        (-0.38, {"grip": V(17, 100, 112), "bat_d": bat_d(-0.35, -0.44, -0.85), "bat_n": V(-0.8, 0.7, 0),
                 "chest_ypr": V(-93, 30, 4), "hips_ypr": V(-90, 14, 0), "look": V(0, 60, 600)}),
        (-0.20, {"grip": V(11, 96, 160), "bat_d": bat_d(-0.15, -0.9, -0.45), "bat_n": V(-0.3, 0.2, 1)}),
        (-0.14, {"l_toe": land, "l_heel": 0.0, "l_yaw": -62.0,      # lands 0.14 s before impact
                 "hips_pos": V(29, 81, 150)}),
        (0.0, {"hit": hit, "bat_d": bat_d(0, -1, -0.4), "bat_n": V(0, 0, 1),
               "hips_pos": V(28, 78, 156), "hips_ypr": V(-80, 18, -4), "chest_ypr": V(-72, 42, -14),
               "look": hit, "r_toe": STANCE_FEET["r_toe"], "r_heel": 0.0}),
        (0.06, {"r_heel": 18.0}),
        (0.15, {"hit": hit + V(-1, -1, 3), "bat_d": bat_d(0, -1, -0.42), "bat_n": V(0, 0, 1)}),
        (0.25, {"r_toe": V(17, 2.5, 100)}),
        (0.32, {"r_toe": V(17, 1, 102), "r_heel": 22.0}),      # back foot drags 5 cm (FD)
        (0.45, {"hit": hit + V(-1, 2, 4), "bat_d": bat_d(-0.05, -1, -0.35), "bat_n": V(0, 0, 1),
                "hips_pos": V(28, 79, 157), "hips_ypr": V(-80, 17, -4), "chest_ypr": V(-72, 40, -12),
                "look": hit + V(0, 0, 60), "l_toe": land, "l_heel": 0.0, "l_yaw": -62.0}),
        (0.62, {"r_toe": V(17, 1, 102), "r_heel": 22.0}),
        (0.75, {"l_toe": V(15, 9, 175), "l_heel": 8.0, "l_yaw": -70.0,
                "grip": V(12, 92, 140), "bat_d": bat_d(-0.2, -1, -0.2), "bat_n": V(-1, 0, 0.6)}),
        (0.90, {"r_toe": STANCE_FEET["r_toe"], "r_heel": 0.0}),
    ]
    return with_ends(-1.0, 1.25, body), "Forward defence: front-foot stride to the pitch, bat angled down beside the pad."


SHOTS = {
    "forward_defence": forward_defence,
}
