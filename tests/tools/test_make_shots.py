"""tools.make_shots: the shared stance and rest keys are within the arms' reach."""
import numpy as np
import pytest

from engine.rig import default_rig
from tools import make_shots, shots_defs
from tools.shots_ik import PoseSolver


def test_shared_keys_within_reach():
    make_shots.shared_reach(PoseSolver(default_rig()))


def test_a_stance_with_a_locked_arm_is_refused(monkeypatch):
    """The stance before the fix (left wrist 53.5 cm from its shoulder, of 54)
    popped the bat 26 cm in the first frames of every shot: it must be refused."""
    locked = dict(shots_defs.STANCE, hips_pos=np.array([27.0, 83, 117]), chest_ypr=np.array([-88.0, 16, 18]),
                  toe=np.array([-7.0, 1.5, 102]))
    monkeypatch.setattr(make_shots, "STANCE", locked)
    with pytest.raises(ValueError, match="STANCE: left wrist 53.5 cm"):
        make_shots.shared_reach(PoseSolver(default_rig()))
