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

from .shots_maths import perp, turn, unit

V = lambda *a: np.array(a, float)
FPS_KEYS = 30.0                   # the frame rate the keys near impact are placed on


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
    # knees slightly bent, hips and shoulders side-on, CoM over the balls of the feet;
    # crouched enough (chest pitch 24) that the hanging arms are not locked: both
    # wrists 47 cm from their shoulders, inside make_shots.unfold's 48 of 54 cm
    "hips_pos": V(27, 80, 117), "hips_ypr": V(-90, 12, 0), "chest_ypr": V(-88, 24, 12),
    "look": BOWLER, "head_tilt": 0.0,
    # bat grounded just in front of the back foot's toes, hands at the front thigh
    "toe": V(-3, 1.5, 106), "bat_d": bat_d(-4, -80, -8), "bat_n": V(-0.3, 0, 1),
    "wrist_pref": 50.0,
    **STANCE_FEET,
}

REST = {
    # relaxed and taller, shoulders a little open, bat held just off the ground
    "hips_pos": V(28, 86, 117), "hips_ypr": V(-86, 8, 0), "chest_ypr": V(-84, 12, 14),
    "look": BOWLER, "head_tilt": 0.0,
    "grip": V(-2, 94, 112), "bat_d": bat_d(-0.15, -1, -0.1), "bat_n": V(-0.3, 0, 1),
    "wrist_pref": 30.0,
    **STANCE_FEET,
}


# ------------------------------------------------------------- composing a stroke
class Feet:
    """Key lists for one foot, built from events in time order; the toe
    (ball of the foot) only moves during a step or a short drag."""

    def __init__(self, side: str, t0: float):
        self.s = side
        self.toe = STANCE_FEET[side + "_toe"].copy()
        self.yaw = STANCE_FEET[side + "_yaw"]
        self.heel = 0.0
        self.keys = [(t0, self._state())]

    def _state(self, **kw):
        st = {self.s + "_toe": self.toe.copy(), self.s + "_yaw": self.yaw, self.s + "_heel": self.heel}
        st.update({self.s + "_" + k: v for k, v in kw.items()})
        return st

    def step(self, t_lift, t_land, toe, yaw, height=9.0, heel_lift=14.0):
        """Lift (heel first), swing with the toe ``height`` cm up, land flat."""
        toe = np.asarray(toe, float)
        self.keys.append((t_lift - 0.07, self._state()))
        self.heel = heel_lift
        self.keys.append((t_lift, self._state()))
        mid = (self.toe + toe) / 2 + V(0, height, 0)
        self.keys.append(((t_lift + t_land) / 2, self._state(toe=mid, yaw=(self.yaw + yaw) / 2, heel=heel_lift / 2)))
        self.toe, self.yaw, self.heel = toe, yaw, 0.0
        self.keys.append((t_land, self._state()))

    def pivot(self, t0, t1, heel, yaw=None, drag=None):
        """Raise/lower the heel and turn about the ball of the foot; ``drag``
        moves the ball forward, just clear of the ground (a back-foot drag)."""
        self.keys.append((t0, self._state()))
        yaw = self.yaw if yaw is None else yaw
        if drag is not None:
            mid = self.toe + np.asarray(drag, float) / 2 + V(0, 1.5, 0)
            self.keys.append(((t0 + t1) / 2, self._state(toe=mid, heel=(self.heel + heel) / 2,
                                                         yaw=(self.yaw + yaw) / 2)))
            self.toe = self.toe + np.asarray(drag, float)
        self.heel, self.yaw = heel, yaw
        self.keys.append((t1, self._state()))

    def home(self, t_lift, t_land, height=7.0):
        """Step back to the stance spot (flat)."""
        self.step(t_lift, t_land, STANCE_FEET[self.s + "_toe"], STANCE_FEET[self.s + "_yaw"], height, 8.0)


def bat(grip=None, d=None, n=None, hit=None, x=None):
    """A bat key: axis ``d`` (handle -> toe) and either the face normal ``n``
    or ``x``, the way the forearms point (elbow -> wrist, the LeftHand X
    axis), from which the face normal follows; then the left grip point or,
    with ``hit``, the Bat joint position."""
    d = bat_d(*d)
    k = {"bat_d": d}
    if n is not None:
        k["bat_n"] = V(*n)
    elif x is not None:
        k["bat_x"] = V(*x)        # the face follows in shots_keys.resolve_bat_keys, for the rig's grip
    else:
        k["bat_auto"] = True      # forearms point from the shoulders to the hands
    if hit is not None:
        k["hit"] = V(*hit)
    else:
        k["grip"] = V(*grip)
    return k


def swing(hit, d, n, v, peak, pivot, frames=(-3, 3), widths=(2.6, 2.0)) -> list:
    """Bat keys on every frame of ``frames`` around impact (t = 0): arms and bat turn as
    one unit (Stuelcken et al. 2005) about an axis through ``pivot`` (near the shoulders),
    so at the hit the Bat joint is at ``hit`` with axis ``d`` and face normal ``n``,
    moving along ``v`` (made square to the radius) at ``peak`` m/s, the fastest of the
    stroke (Stretch et al. 1998: peak bat speed just before impact). The speed falls
    off as a Gaussian of ``widths`` frames before and after the hit."""
    hit, d, n, pivot = V(*hit), bat_d(*d), unit(V(*n)), V(*pivot)
    r = hit - pivot
    radius = float(np.linalg.norm(r))
    v = unit(perp(V(*v), r / radius))
    w = unit(np.cross(r, v))                     # w x r = radius v
    fine = np.linspace(frames[0], frames[1], 40 * (frames[1] - frames[0]) + 1)
    width = np.where(fine < 0, widths[0], widths[1])
    rate = peak * 100.0 / FPS_KEYS / radius * np.exp(-0.5 * (fine / width) ** 2)   # rad per frame
    angle = np.degrees(np.concatenate([[0.0], np.cumsum((rate[1:] + rate[:-1]) / 2 * np.diff(fine))]))
    angle -= np.interp(0.0, fine, angle)
    keys = []
    for k in range(frames[0], frames[1] + 1):
        a = float(np.interp(k, fine, angle))
        keys.append((k / FPS_KEYS, bat(hit=pivot + turn(w, a, r), d=turn(w, a, d), n=turn(w, a, n))))
    return keys


def body(hips=None, hips_ypr=None, chest=None):
    k = {}
    if hips is not None:
        k["hips_pos"] = V(*hips)
    if hips_ypr is not None:
        k["hips_ypr"] = V(*hips_ypr)
    if chest is not None:
        k["chest_ypr"] = V(*chest)
    return k


def compose(t_start, t_end, bat_keys, body_keys, look_keys, feet: list, hold=0.15) -> list:
    """Key list: stance (held) -> the stroke -> rest (held)."""
    keys = [(t, dict(k)) for t, k in bat_keys] + [(t, dict(k)) for t, k in body_keys]
    keys += [(t, {"look": V(*p)}) for t, p in look_keys]
    for f in feet:
        keys += [(t, k) for t, k in f.keys[1:]]
    merged = {}
    for t, k in keys:
        t = round(t, 4)
        for c, v in k.items():
            if c in merged.setdefault(t, {}):
                raise ValueError(f"channel {c} keyed twice at t={t}")
            merged[t][c] = v
    body = sorted(merged.items())
    if body[0][0] <= t_start + hold or body[-1][0] >= t_end - hold:
        raise ValueError("stroke keys must lie between the stance and rest holds")
    return ([(t_start, dict(STANCE)), (t_start + hold, dict(STANCE))] + body +
            [(t_end - hold, dict(REST)), (t_end, dict(REST))])


# ------------------------------------------------------------- the shots
STANCE_BAT = {k: STANCE[k] for k in ("toe", "bat_d", "bat_n")}


def t_frames(n: int) -> float:
    return -n / 30.0


def forward_defence():
    """Front-foot block: stride 0.72 m to the pitch, bat angled down beside the pad, dead hands."""
    t0, t1 = t_frames(30), 1.25
    hit = V(0, 33, 200)
    L, R = Feet("l", t0), Feet("r", t0)
    L.step(-0.64, -0.14, (13, 1, 210), -60.0, 10.0)          # FD: stride starts 0.64 s, lands 0.14 s before
    R.pivot(-0.05, 0.10, heel=18.0, yaw=-78.0)
    R.pivot(0.15, 0.35, heel=24.0, yaw=-72.0, drag=(0, 0, 5))  # FD back-foot drag 0.05 m
    L.home(0.58, 0.92)
    R.pivot(0.70, 0.95, heel=0.0, yaw=-90.0, drag=(0, 0, -5))
    bats = [(-0.80, dict(STANCE_BAT)),
            # the hands in front of the body (x 8 and below: at 16-20 they sat under and behind the
            # front shoulder, and the top arm hung back behind the trunk, turned 120 deg in)
            (-0.62, bat(grip=(8, 96, 118), d=(-0.15, -0.7, -0.7), x=(0.14, -1, 0.04))),
            # a compact backlift, its top (toe ~0.65 m up) carried forward by the stride, so
            # that the bat never exceeds the measured FD peak of 3.5 m/s (Stretch et al.)
            (-0.45, bat(grip=(8, 110, 140), d=(-0.61, -0.63, -0.47))),          # picked up toward gully
            (-0.30, bat(grip=(6, 103, 158), d=(-0.12, -0.78, -0.62))),
            (-0.16, bat(grip=(6, 94, 182), d=(-0.05, -0.93, -0.36), x=(0.2, -0.9, 0.4))),
            (-0.07, bat(hit=(1, 40, 185), d=(-0.02, -1, -0.32), n=(0, 0, 1))),
            (0.0, bat(hit=hit, d=(0, -1, -0.4), n=(0, 0, 1))),
            (0.12, bat(hit=hit + V(-1, -1, 2), d=(0, -1, -0.42), n=(0, 0, 1))),
            (0.45, bat(hit=hit + V(-1, 3, 3), d=(-0.03, -1, -0.35), n=(0, 0, 1))),
            # recovered by 0.81 s (0.75 took the blade to 3.58 m/s there, past the FD's 3.5, and
            # 0.78 to 3.6 once the humerus's axial range was charged harder); the forearms
            # pointing down and forward (x z +0.3): pointed back (-0.3) the bottom elbow swung
            # round its arm twice on the way up (28 and 35 cm in a frame, at 0.6 and 0.9 s)
            (0.81, bat(grip=(8, 92, 140), d=(-0.2, -1, -0.15), x=(0, -1, 0.3)))]
    bodies = [(-0.70, body(hips=(29, 83, 113))),
              (-0.38, body(hips=(28, 82, 124), hips_ypr=(-90, 12, 0), chest=(-93, 18, 20))),
              (-0.14, body(hips=(26, 78, 150))),
              (0.0, body(hips=(24, 75, 157), hips_ypr=(-80, 18, -4), chest=(-72, 38, -5))),
              (0.45, body(hips=(24, 76, 158), hips_ypr=(-80, 17, -4), chest=(-73, 36, -4))),
              (0.78, body(hips=(27, 80, 134), hips_ypr=(-86, 12, 0), chest=(-85, 20, 12)))]
    looks = [(-0.55, BOWLER), (-0.30, (0, 80, 700)), (0.0, hit + V(0, 0, 10)), (0.45, hit + V(0, 0, 80)),
             (0.85, BOWLER)]
    return compose(t0, t1, bats, bodies, looks, [L, R]), "Forward defence: front-foot stride to the pitch, bat angled down beside the pad."


DRIVE_PEAK = 12.4    # m/s along the arc: ~11.8 horizontally at the hit (Stretch et al. 1998)
RECOVER_BODY = body(hips=(27, 81, 130), hips_ypr=(-87, 11, 0), chest=(-86, 18, 12))


def front_foot_drive(name, t0, t1, toe, yaw, hit, d_hit, n_hit, v_hit, pivot, follow, hit_body, finish_body,
                     desc, backlift_face, tilts=()):
    """Drives share the measured drive timing (Stretch et al. 1998, D): stride
    starts 0.58 s and the downswing 0.36 s before impact, the front foot lands
    0.06 s before it, the back foot drags 0.10 m after."""
    hit = V(*hit)
    L, R = Feet("l", t0), Feet("r", t0)
    L.step(-0.58, -0.06, toe, yaw, 11.0)
    R.pivot(-0.02, 0.12, heel=22.0, yaw=-72.0)
    R.pivot(0.15, 0.40, heel=34.0, yaw=-58.0, drag=(0, 0, 10))
    L.home(0.66, 1.0)
    R.pivot(0.80, 1.08, heel=0.0, yaw=-90.0, drag=(0, 0, -10))
    bats = [(-0.80, dict(STANCE_BAT)),
            (-0.58, bat(grip=(18, 95, 108), d=(-0.15, -0.6, -0.8))),
            # top of the backlift at the downswing start, toe 0.74 m up (D), the face open
            # toward gully (``backlift_face``). Left to the forearms it faced the ground and
            # the leg side, and turned ~200 deg about the handle in the next 0.2 s: both
            # elbows swung round their arms (8 pops over 20 cm in the three drives)
            (-0.36, bat(grip=(27, 106, 86), d=(-0.35, -0.44, -0.83), n=backlift_face)),
            ] + swing(hit, d_hit, n_hit, v_hit, DRIVE_PEAK, pivot, frames=(-6, 3), widths=(3.4, 2.0)) + follow
    bodies = [(-0.65, body(hips=(29, 83, 114))),
              (-0.36, body(hips=(28, 82, 126), hips_ypr=(-90, 12, 0), chest=(-95, 16, 22))),
              (-0.06, body(hips=(25, 76, 152))),
              (0.0, hit_body), (0.40, finish_body), (0.85, RECOVER_BODY)]
    bodies += [(t, {"head_tilt": a}) for t, a in tilts]      # keeps the neck inside its limits
    looks = [(-0.55, BOWLER), (-0.30, (0, 80, 700)), (0.0, hit + V(0, 0, 15)), (0.30, (hit + V(0, 30, 400))),
             (0.95, BOWLER)]
    return compose(t0, t1, bats, bodies, looks, [L, R]), desc


def straight_drive():
    return front_foot_drive(
        "straight_drive", t_frames(31), 1.3, (14, 1, 205), -62.0,
        hit=(-2, 30, 212), d_hit=(0, -1, -0.08), n_hit=(0, 0, 1), v_hit=(0, 0.2, 1), pivot=(15, 125, 180),
        follow=[(0.20, bat(grip=(-5, 125, 205), d=(0.1, 0.3, 0.95))),
                (0.42, bat(grip=(5, 150, 175), d=(0.3, 0.8, -0.5))),
                (0.58, bat(grip=(10, 128, 168), d=(-0.08, -0.41, -0.91))),
                (0.72, bat(grip=(0, 104, 152), d=(0.04, -0.71, -0.7)))],
        hit_body=body(hips=(23, 74, 160), hips_ypr=(-78, 16, -4), chest=(-70, 32, -8)),
        finish_body=body(hips=(23, 77, 165), hips_ypr=(-70, 12, -3), chest=(-55, 18, -10)),
        backlift_face=(-0.7, 0.2, -0.6),
        desc="Straight drive: front-foot stride 0.68 m, full swing, face to the bowler, high finish.")


def cover_drive():
    return front_foot_drive(
        "cover_drive", t_frames(30), 1.3, (0, 1, 198), -45.0,
        hit=(-42, 30, 205), d_hit=(-0.15, -1, -0.1), n_hit=(-0.55, 0, 0.85), v_hit=(-0.45, 0.2, 0.9),
        pivot=(5, 125, 172),
        # the finish's face keyed over the head and down the back (left to the forearms: the
        # elbows popped at frames 38, 46, 53, the humeri 14 frames past their axial range)
        follow=[(0.20, bat(grip=(-30, 120, 195), d=(-0.3, 0.4, 0.85))),
                (0.42, bat(grip=(-10, 148, 170), d=(0.2, 0.8, -0.5), n=(0.93, 0, 0.37))),
                (0.58, bat(grip=(10, 128, 168), d=(-0.09, -0.18, -0.98), n=(0.02, -0.98, 0.18))),
                (0.72, bat(grip=(-4, 104, 152), d=(0.05, -0.5, -0.85)))],
        hit_body=body(hips=(18, 74, 156), hips_ypr=(-72, 18, -4), chest=(-62, 36, -6)),
        finish_body=body(hips=(18, 77, 160), hips_ypr=(-66, 12, -3), chest=(-50, 20, -8)),
        tilts=[(-0.42, 0.0), (-0.23, 12.0), (-0.05, 0.0)], backlift_face=(-0.65, 0.3, -0.7),
        desc="Cover drive: front foot to the off side, bat through the line of a wide half-volley toward cover.")


def on_drive():
    return front_foot_drive(
        "on_drive", t_frames(29), 1.27, (24, 1, 200), -80.0,
        hit=(16, 30, 207), d_hit=(0.05, -1, -0.1), n_hit=(0.35, 0, 0.94), v_hit=(0.3, 0.2, 0.95),
        pivot=(20, 125, 175),       # at x = 25 the right hand passed 21 cm from its shoulder 0.23 s out
        follow=[(0.20, bat(grip=(18, 122, 200), d=(0.3, 0.3, 0.9))),
                (0.42, bat(grip=(20, 148, 172), d=(0.5, 0.7, -0.5))),
                (0.52, bat(grip=(-4, 134, 178), d=(0.65, 0.5, -0.55))),
                (0.58, bat(grip=(-6, 120, 168), d=(0.77, 0.34, -0.55))),
                (0.72, bat(grip=(4, 104, 152), d=(0.05, -0.5, -0.85)))],
        hit_body=body(hips=(28, 74, 156), hips_ypr=(-70, 16, -4), chest=(-58, 30, -8)),
        finish_body=body(hips=(28, 77, 160), hips_ypr=(-60, 12, -3), chest=(-42, 16, -10)),
        backlift_face=(-0.65, 0.3, -0.7),
        desc="On drive: front foot straight up the pitch, hips open, bat through mid-on.")


def back_foot(t0, t1, r_toe, r_yaw, l_toe, l_yaw, bats, hit_body, finish_body, looks, tilts=()):
    """Back-foot strokes: the back foot goes back and across while the bat is
    at the top (no measured figures; the downswing keeps the ~0.36 s timing)."""
    L, R = Feet("l", t0), Feet("r", t0)
    R.step(-0.50, -0.24, r_toe, r_yaw, 8.0)
    L.step(-0.28, -0.06, l_toe, l_yaw, 5.0)
    R.home(0.62, 0.92)
    L.home(0.72, 1.02)
    bodies = [(-0.60, body(hips=(28, 83, 118))),
              (-0.36, body(hips=(26, 83, 108), hips_ypr=(-92, 10, 2), chest=(-96, 16, 20))),
              (0.0, hit_body), (0.40, finish_body), (0.85, RECOVER_BODY)]
    bodies += [(t, {"head_tilt": a}) for t, a in tilts]      # keeps the neck inside its limits
    return compose(t0, t1, bats, bodies, looks, [L, R])


def back_foot_defence():
    hit = V(-4, 72, 126)
    bats = [(-0.80, dict(STANCE_BAT)),
            # the face opening up as the bat lifts (left to the forearms, the bottom elbow
            # swung 45 cm round its arm in one frame at the top of the backlift)
            (-0.58, bat(grip=(8, 92, 110), d=(-0.1, -0.8, -0.6), n=(-0.13, 0.6, -0.79))),
            # a short, early backlift: the bat stays under 3.5 m/s (Stretch et al.'s FD peak)
            (-0.42, bat(grip=(22, 112, 102), d=(-0.4, -0.5, -0.77))),
            (-0.22, bat(grip=(12, 118, 118), d=(-0.22, -0.85, -0.48))),
            (-0.07, bat(hit=hit + V(1, 4, -12), d=(-0.3, -0.92, -0.22), n=(0, 0, 1))),
            (0.0, bat(hit=hit, d=(-0.24, -0.94, -0.28), n=(0, 0, 1))),
            # the dead bat after the ball: the face eases open toward point (held square, the
            # bottom hand needs more supination than its 90, Kapandji)
            (0.12, bat(hit=hit + V(-1, -1, 2), d=(-0.34, -0.9, -0.3), n=(-0.3, 0, 1))),
            (0.40, bat(hit=hit + V(0, 2, 1), d=(-0.3, -0.92, -0.26), n=(-0.3, 0, 1))),
            (0.72, bat(grip=(6, 104, 125), d=(-0.1, -1, -0.2)))]
    looks = [(-0.55, BOWLER), (-0.30, (0, 120, 600)), (0.0, hit + V(0, 0, 10)), (0.40, hit + V(0, -20, 60)),
             (0.95, BOWLER)]
    keys = back_foot(t_frames(30), 1.25, (16, 1, 84), -92.0, (19, 1, 124), -80.0, bats,
                     # tall on the back foot (chest pitch 16, the stance's 24): crouched, the
                     # bottom elbow tucks into the trunk at the hit
                     body(hips=(26, 84, 104), hips_ypr=(-86, 10, 0), chest=(-80, 16, 4)),
                     body(hips=(26, 84, 105), hips_ypr=(-86, 10, 0), chest=(-80, 16, 4)), looks,
                     tilts=[(-0.25, 0.0), (0.0, 10.0), (0.25, 0.0)])
    return keys, "Back-foot defence: back and across, high left elbow, bat angled down over a rising ball."


def square_cut():
    hit = V(-70, 85, 85)
    # played late, beside the back foot: the bat comes down from a high backlift
    # across the line, toe toward gully, face open toward point
    bats = [(-0.80, dict(STANCE_BAT)),
            # the face open to the off side and up as the bat goes up (tools/face_keys; left
            # to the forearms, the top elbow popped twice over 20 cm in the backlift)
            (-0.58, bat(grip=(22, 100, 96), d=(0.19, 0.05, -0.98), n=(-0.7, 0.71, -0.1))),
            (-0.36, bat(grip=(24, 128, 84), d=(-0.2, 0.65, -0.75))),           # high backlift
            (-0.20, bat(grip=(-14, 136, 80), d=(-0.25, 0.5, -0.85)))]
    bats += swing(hit, d=(-0.7, -0.2, -0.7), n=(-0.7, -0.1, 0.7), v=(0, -0.7, 0.7), peak=10.0,
                  pivot=(15, 135, 110))
    bats += [(0.25, bat(grip=(8, 92, 150), d=(-0.55, -0.8, 0.2))),
             (0.45, bat(grip=(10, 100, 140), d=(-0.2, -0.9, 0.3))),
             (0.65, bat(grip=(4, 110, 130), d=(0.1, -0.6, -0.8)))]
    looks = [(-0.55, BOWLER), (-0.30, (-20, 140, 600)), (0.0, hit + V(0, 0, 10)), (0.30, (-300, 60, 60)),
             (0.95, BOWLER)]
    keys = back_foot(t_frames(31), 1.3, (4, 1, 88), -100.0, (12, 1, 130), -88.0, bats,
                     body(hips=(20, 80, 100), hips_ypr=(-96, 14, 4), chest=(-100, 30, -2)),
                     body(hips=(20, 81, 102), hips_ypr=(-90, 12, 2), chest=(-90, 22, 0)), looks)
    return keys, "Square cut: back and across to a short wide ball, arms extended, bat coming down on it toward point."


def pull():
    hit = V(-28, 125, 152)
    # body square to the bowler, the bat horizontal at chest height swung round
    # the body, face closing toward mid-wicket
    bats = [(-0.80, dict(STANCE_BAT)),
            # re-keyed with the crouched stance (was (20, 110, 106) and (31, 136, 84)):
            # the right forearm and wrist stay inside their limits
            # the face open to the sky as the bat goes up, and keyed through the finish: left
            # to the forearms (tools/shots_keys.face_for_forearm) the elbows popped 6 times
            # over 20 cm and the humeri turned 9 frames past their axial range, 25 past the
            # horizontal (the faces tools/face_keys found)
            (-0.58, bat(grip=(20, 110, 102), d=(-0.05, -0.4, -0.91), n=(-0.02, 0.92, -0.4))),
            (-0.36, bat(grip=(28, 128, 80), d=(-0.45, 0.65, -0.6))),          # high backlift
            (-0.20, bat(grip=(30, 136, 84), d=(-0.65, 0.4, -0.65)))]
    bats += swing(hit, d=(-0.78, 0.03, 0.62), n=(0.6, -0.2, 0.77), v=(0.55, 0, 0.85), peak=10.0,
                  pivot=(20, 140, 110))
    bats += [(0.27, bat(grip=(30, 120, 120), d=(0.5, 0.25, 0.85), n=(0.86, 0, -0.51))),
             (0.40, bat(grip=(30, 128, 120), d=(0.55, 0.6, 0.0), n=(-0.52, 0.48, 0.71))),
             (0.50, bat(grip=(38, 130, 100), d=(0.5, 0.5, -0.7), n=(0.81, 0, 0.58)))]
    looks = [(-0.55, BOWLER), (-0.30, (0, 160, 600)), (0.0, hit + V(0, 0, 10)), (0.30, (400, 80, 300)),
             (0.95, BOWLER)]
    keys = back_foot(t_frames(30), 1.3, (15, 1, 85), -100.0, (24, 1, 128), -50.0, bats,
                     body(hips=(22, 84, 95), hips_ypr=(-45, 8, 0), chest=(-12, 14, -5)),
                     body(hips=(24, 84, 96), hips_ypr=(-40, 8, 0), chest=(0, 12, -5)), looks)
    return keys, "Pull: back and across to a short ball, body swivels to face the bowler, horizontal bat at chest height to mid-wicket."


def leg_glance():
    hit = V(8, 62, 132)
    bats = [(-0.80, dict(STANCE_BAT)),
            (-0.55, bat(grip=(18, 98, 106), d=(-0.2, -0.6, -0.75))),
            (-0.36, bat(grip=(26, 104, 88), d=(-0.3, -0.45, -0.85))),
            (-0.16, bat(grip=(14, 102, 122), d=(-0.1, -0.85, -0.5))),
            (-0.06, bat(hit=hit + V(-2, 6, -12), d=(0, -1, -0.25), n=(0.3, 0, 1))),
            (0.0, bat(hit=hit, d=(-0.1, -1, -0.25), n=(0.8, 0, 0.6))),
            (0.12, bat(hit=hit + V(4, -1, -3), d=(0.2, -1, -0.3), n=(0.85, 0, 0.55))),
            # held there a moment, as a defence's is (tests/assets/test_shots.test_hit_frame_is_the_contact:
            # the anatomical grip's bat was still moving 1.8 m/s four frames after the ball)
            (0.16, bat(hit=hit + V(4, -1, -3), d=(0.2, -1, -0.3), n=(0.85, 0, 0.55))),
            (0.40, bat(grip=(14, 102, 122), d=(0.52, -0.83, 0.22))),
            (0.72, bat(grip=(6, 100, 122), d=(-0.1, -1, -0.2)))]
    looks = [(-0.55, BOWLER), (-0.30, (20, 90, 600)), (0.0, hit + V(0, 0, 10)), (0.35, (150, 40, 400)),
             (0.95, BOWLER)]
    keys = back_foot(t_frames(29), 1.22, (17, 1, 88), -95.0, (20, 1, 128), -76.0, bats,
                     body(hips=(28, 83, 106), hips_ypr=(-86, 12, 0), chest=(-80, 28, 6)),
                     body(hips=(28, 83, 107), hips_ypr=(-84, 12, 0), chest=(-76, 22, 6)), looks)
    return keys, "Leg glance: back foot, ball off the hip turned fine with a closing face and soft wrists."


def sweep():
    t0, t1 = t_frames(31), 1.4
    hit = V(-15, 35, 225)
    L, R = Feet("l", t0), Feet("r", t0)
    L.step(-0.60, -0.12, (2, 1, 195), -45.0, 8.0)
    R.pivot(-0.50, -0.15, heel=60.0, yaw=-70.0)               # back knee goes down to the turf
    R.pivot(0.60, 0.90, heel=0.0, yaw=-90.0)
    L.home(0.70, 1.05)
    bats = [(-0.80, dict(STANCE_BAT)),
            (-0.58, bat(grip=(20, 100, 108), d=(-0.3, -0.5, -0.8))),
            (-0.36, bat(grip=(16, 105, 112), d=(-0.6, -0.2, -0.75))),
            (-0.20, bat(grip=(-10, 72, 148), d=(-0.85, 0.05, -0.3)))]
    # the bat swept round low and flat from outside off, face toward square leg
    bats += swing(hit, d=(-0.5, -0.55, 0.67), n=(0.78, 0.1, 0.62), v=(0.8, 0, 0.4), peak=10.0,
                  pivot=(15, 100, 165))
    bats += [(0.22, bat(grip=(45, 58, 178), d=(0.3, -0.15, 0.95))),
             (0.40, bat(grip=(35, 78, 162), d=(0.71, -0.24, 0.66))),
             (0.62, bat(grip=(26, 90, 150), d=(0.55, -0.35, 0.75))),
             (0.85, bat(grip=(12, 95, 135), d=(-0.1, -0.9, -0.3)))]
    bodies = [(-0.60, body(hips=(29, 83, 116))),
              (-0.36, body(hips=(26, 72, 128), hips_ypr=(-85, 16, 0), chest=(-88, 28, 10))),
              (-0.12, body(hips=(21, 60, 140))),
              (0.0, body(hips=(20, 57, 142), hips_ypr=(-70, 25, -5), chest=(-60, 36, -8))),
              (0.40, body(hips=(20, 58, 142), hips_ypr=(-66, 20, -5), chest=(-50, 28, -8))),
              (0.90, RECOVER_BODY)]
    looks = [(-0.55, BOWLER), (-0.30, (-10, 40, 600)), (0.0, hit + V(0, 0, 10)), (0.35, (300, 20, 500)),
             (1.0, BOWLER)]
    return compose(t0, t1, bats, bodies, looks, [L, R]), "Sweep: long stride, back knee down, horizontal bat sweeping a full ball from outside off to square leg."


SHOTS = {
    "forward_defence": forward_defence,
    "back_foot_defence": back_foot_defence,
    "straight_drive": straight_drive,
    "cover_drive": cover_drive,
    "on_drive": on_drive,
    "square_cut": square_cut,
    "pull": pull,
    "leg_glance": leg_glance,
    "sweep": sweep,
}
