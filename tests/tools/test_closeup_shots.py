"""tools.closeup_shots: the authoring close-ups render the hands and bat, offscreen."""
import numpy as np
import pytest

from engine.library import find_shot, load_library
from tools import closeup_shots


def test_a_sheet_has_a_row_per_view_and_frames_the_hands_and_handle(rig):
    shot = find_shot(load_library(rig=rig), "forward_defence")
    frames = [shot.hit_frame, shot.hit_frame + 1]
    cell = (160, 160)
    sheet = np.asarray(closeup_sheet := closeup_shots.closeup_sheet(rig, shot, frames, cell=cell))
    assert closeup_sheet.size == (cell[0] * len(frames), cell[1] * len(closeup_shots.VIEWS) + 20)
    for k in range(len(frames)):
        reds = []
        for r in range(len(closeup_shots.VIEWS)):
            c = sheet[r * cell[1]:(r + 1) * cell[1], k * cell[0]:(k + 1) * cell[0]].astype(int)
            # the batsman's white fills part of every close-up ...
            assert (c.min(-1) > 200).mean() > 0.05, (r, k)
            reds.append(int(((c[..., 0] > 150) & (c[..., 1] < 80) & (c[..., 2] < 80)).sum()))
        # ... and the handle's red grip shows from at least one side (from above the hands hide it)
        assert max(reds) >= 20, (k, reds)

def test_frames_outside_the_shot_are_refused(capsys):
    with pytest.raises(SystemExit) as e:
        closeup_shots.main(["forward_defence", "/tmp/never.png", "500"])
    assert e.value.code == 2 and "outside forward_defence" in capsys.readouterr().err
