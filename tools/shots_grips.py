"""The bottom (right) hand's grip on the handle for the shot authoring (tools/shots_ik)."""
from __future__ import annotations

import numpy as np

from .shots_maths import rot_axis
from .shots_roll import frames_from, held_frames, speed_charge


class BottomHand:
    """The bottom hand holds the handle loosely (the coaches' thumb-and-forefinger bottom hand):
    it may turn about the handle, and slide down it, which the top hand may not (the bat is
    the top hand's). Where the keyed bat turns the hands faster than the bottom arm's limits
    follow, the turn lets its elbow stay on its side instead of swinging round the arm; where
    the hands' keyed spacing would fold the bottom arm or swing its elbow round, the slide
    gives it room (library: elbow pops over 20 cm 15 -> 10, arms folded 14 -> 7).

    ``right_in_bat``: the right hand's keyed rotation in the bat's frame ``(3, 3)``;
    ``right_grip``: its palm centre in RightHand's frame ``(3,)`` cm."""

    TURNS = np.array([0.0, -15.0, 15.0, -30.0, 30.0])   # deg about the handle; the keyed grip first
    TURN_DEG = 15.0    # a turn this far costs as much as the wrist 20 deg off its preference
    STEP_WEIGHT = 5.0  # per (7.5 deg or SLIDE_STEP_CM)^2 the grip changes between frames
    STEP_DEG = 30.0    # and no faster than this a frame (900 deg/s): faster, the glove spins
    # cm down the handle from the keyed grip (11 cm below the top hand's): at 7.5 the glove's
    # edge is still 2 cm short of the blade (the handle is 30 cm)
    SLIDES = np.array([0.0, 2.5, 5.0, 7.5])
    SLIDE_CM = 1.0     # a slide of s cm costs (s / SLIDE_CM)^2 a frame: only where it buys that
    SLIDE_STEP_CM = 2.5    # and no faster than this a frame (75 cm/s)
    HELD_FRAMES = 3    # the first and last frames hold the shared stance's and rest's grip

    def __init__(self, right_in_bat: np.ndarray, right_grip: np.ndarray):
        self.right_in_bat = right_in_bat
        self.right_grip = right_grip

    def turned(self, wrist, hand_rot, turn: float):
        """The right wrist ``(F, 3)`` and hand rotation ``(F, 3, 3)`` turned ``turn`` degrees
        about the handle (the bat's Z) from ``wrist``, ``hand_rot``: the palm stays on it."""
        bat_rot = hand_rot @ self.right_in_bat.T
        turned = bat_rot @ rot_axis(2, turn) @ self.right_in_bat
        return wrist + (hand_rot - turned) @ self.right_grip, turned

    def grips(self, wrist, hand_rot):
        """The bottom hand's candidate grips on the handle for ArmSolver.solve, from its keyed ``wrist``
        ``(F, 3)`` and ``hand_rot`` ``(F, 3, 3)``: every TURNS x SLIDES. Returns (G
        wrists ``(F, 3)``, G hand rotations ``(F, 3, 3)``, costs ``(F, G)``, charges between
        them ``(G, G)``, turns ``(G,)`` deg, slides ``(G,)`` cm); the keyed grip first."""
        F = len(wrist)
        turns = np.tile(self.TURNS, len(self.SLIDES))
        slides = np.repeat(self.SLIDES, len(self.TURNS))
        down = -(hand_rot @ self.right_in_bat.T)[..., 2]          # the bat's Z points up the handle
        grips = [self.turned(wrist, hand_rot, t) for t in self.TURNS]
        wrists = [grips[g % len(grips)][0] + s * down for g, s in enumerate(slides)]
        rots = [grips[g % len(grips)][1] for g in range(len(slides))]
        costs = np.tile((turns / self.TURN_DEG) ** 2 + (slides / self.SLIDE_CM) ** 2, (F, 1))
        held = np.zeros(F, bool)
        held[:self.HELD_FRAMES] = held[-self.HELD_FRAMES:] = True
        costs[np.ix_(held, slides != 0.0)] = np.inf
        turn_step = np.abs(turns[:, None] - turns[None, :])
        slide_step = np.abs(slides[:, None] - slides[None, :])
        charges = (self.STEP_WEIGHT * ((turn_step / 7.5) ** 2 + (slide_step / self.SLIDE_STEP_CM) ** 2)
                   + 1e4 * (np.maximum(0.0, turn_step - self.STEP_DEG) ** 2
                            + np.maximum(0.0, slide_step - self.SLIDE_STEP_CM) ** 2))
        return wrists, rots, costs, charges, turns, slides


class TopHand:
    """The top (left) hand's bat may lean about its face normal in the arms' pass, for a grip
    that asks (tools/grips: ``top_leans``): the elbow's Viterbi (tools/shots_arms) then picks the
    lean with its place on the circle, so a lean that keeps the elbow on its side is chosen where
    one exists. The face, and so the ball's direction, is kept; the lean is held at 0 at the
    shared ends and at the hit (the frames where the bat's roll is held: tools/shots_roll), where
    the blade meets the ball as keyed."""

    LEAN_DEG = 15.0    # a lean this far costs as much as the wrist 20 deg off its preference
    STEP_WEIGHT = 5.0  # per 7.5 deg^2 the lean changes between frames
    STEP_DEG = 10.0    # and no faster than this a frame (300 deg/s)
    END_FRAMES = 6     # the first and last frames: the shared stance and rest, held still (0.15 s, and
                       # the stance's bat key; at 3, a 10 deg lean in the hold moved the blade 9 cm a frame)
    CONTACT_FRAMES = 1  # frames either side of the hit
    BOTTOM_DEG = 10.0  # a lean the bottom arm holds no nearer its limits and ranges is charged (PoseSolver)

    def __init__(self, leans, hand_targets, bat_from_grip):
        self.leans = np.asarray(leans, float)
        if 0.0 not in self.leans:
            raise ValueError(f"top_leans {list(leans)} must hold 0: the keyed bat, held at the hit and the ends")
        self.hand_targets = hand_targets
        self.bat_from_grip = bat_from_grip

    def held(self, roll_weight):
        """``(F,)`` bool: where the lean is held at 0, from the roll pass's weights (tools/make_shots:
        infinite at the hit; shots_roll.HELD_WEIGHT where a defence's bat is held after it)."""
        F = len(roll_weight)
        near = frames_from(held_frames(roll_weight)) <= self.CONTACT_FRAMES
        ends = (np.arange(F) < self.END_FRAMES) | (np.arange(F) >= F - self.END_FRAMES)
        return near | ends

    def grips(self, grip, bat_rot, held):
        """The top hand's candidates for ArmSolver.solve from the bat's ``grip`` point ``(F, 3)``
        and frame ``bat_rot`` ``(F, 3, 3)``, the lean held at 0 where ``held`` ``(F,)``: (G wrists
        ``(F, 3)``, G hand rotations, costs ``(F, G)``, charges ``(F - 1, G, G)``, leans ``(G,)``
        deg); the keyed lean (0) first. A lean moves the blade: a step faster than the keyed
        shot's fastest is charged, so the defences stay slow."""
        F = len(grip)
        leans = self.leans[np.argsort(np.abs(self.leans), kind="stable")]
        turned = [bat_rot @ rot_axis(1, np.full(F, a)) for a in leans]
        hands = [self.hand_targets(grip, r)[:2] for r in turned]
        costs = np.tile((leans / self.LEAN_DEG) ** 2, (F, 1))
        costs[np.ix_(held, leans != 0.0)] = np.inf
        step = np.abs(leans[:, None] - leans[None, :])
        charges = self.STEP_WEIGHT * (step / 7.5) ** 2 + 1e4 * np.maximum(0.0, step - self.STEP_DEG) ** 2
        charges = charges + speed_charge(grip, bat_rot, self.bat_from_grip, rot_axis(1, leans), 0, at_peak=True)
        return [h[0] for h in hands], [h[1] for h in hands], costs, charges, leans
