"""render-strip on an adapted shot, through the command line."""
import subprocess
import sys

import numpy as np
from PIL import Image


def hitpoint(*args):
    return subprocess.run([sys.executable, "-c", "from app.cli import main; main()", *args],
                          capture_output=True, text=True, timeout=300)


def test_adapted_strip_differs_from_the_source_strip(tmp_path):
    src, ada = tmp_path / "src.png", tmp_path / "ada.png"
    common = ["render-strip", "--shot", "cover_drive", "--frames", "3", "--size", "160x200"]
    assert hitpoint(*common, "--out", str(src)).returncode == 0
    r = hitpoint(*common, "--hit", "-70", "45", "215", "--out", str(ada))
    assert r.returncode == 0, r.stderr
    a, b = (np.asarray(Image.open(p), int) for p in (src, ada))
    assert a.shape == b.shape
    # top row (meshes): frames 0 and last are the source pose (blend 0, the
    # ghost coincides), the hit frame reaches for the new point
    from app.cli.render import TITLE_H
    W, H = 160, 200
    top = slice(TITLE_H, TITLE_H + H)
    cells = [np.abs(a[top, k * W:(k + 1) * W] - b[top, k * W:(k + 1) * W]).sum(-1) > 30 for k in range(3)]
    assert cells[1].sum() > 300
    assert cells[1].sum() > 5 * max(cells[0].sum(), cells[2].sum())


def test_bad_hit_is_one_line_exit_2(tmp_path):
    out = tmp_path / "x.png"
    r = hitpoint("render-strip", "--shot", "cover_drive", "--hit", "1", "nan", "3", "--out", str(out))
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0 and "--hit" in r.stderr
    assert not out.exists()
