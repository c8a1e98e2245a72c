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
        # ... and the handle's red grip shows from at least one side (from above the hands hide it;
        # with the anatomical grip both hands cover most of it: 15 pixels at the forward defence's hit)
        assert max(reds) >= 10, (k, reds)

@pytest.mark.parametrize("args,says", [(["forward_defence", "{tmp}/a.png", "500"], "outside forward_defence"),
                                       (["no_such_shot", "{tmp}/a.png"], "unknown shot 'no_such_shot'"),
                                       (["pull", "{tmp}/no/such/folder/a.png", "30"], "does not exist")])
def test_bad_input_is_refused_in_one_line_and_writes_nothing(tmp_path, capsys, args, says):
    with pytest.raises(SystemExit) as e:
        closeup_shots.main([a.format(tmp=tmp_path) for a in args])
    err = capsys.readouterr().err
    assert e.value.code == 2 and says in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
