"""The CLI's promise, command by command: a bad command line gets exactly one
``error:`` line on stderr and exit status 2, never a traceback, and leaves no
output (or temporary) file and no new folder behind. Run in-process through
``app.cli.run`` (a subprocess costs a second of imports); a handful of
end-to-end cases run ``hitpoint`` for real."""
from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given, settings, strategies as st

from app.cli import run
from app.errors import MAX_TOKEN_CHARS, UserError, number

SHOT = "forward_defence"
HIT = ["--hit", "10", "100", "250"]
BROKEN_BVH = {
    "truncated": "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition",
    "empty": "",
    "garbage": "\x00\x01 not a bvh at all \xff",
    "bad_number": "HIERARCHY\nROOT Hips\n{\n OFFSET 0 x 0\n CHANNELS 3 Xrotation Yrotation Zrotation\n"
                  " End Site\n {\n  OFFSET 0 1 0\n }\n}\nMOTION\nFrames: 1\nFrame Time: 0.033\n0 0 0\n",
}


@pytest.fixture
def place(tmp_path):
    return make_place(tmp_path)


def make_place(tmp_path: Path) -> Path:
    """Input files (good and bad) in ``tmp_path``; outputs go to ``tmp_path/out``."""
    (tmp_path / "out").mkdir()
    (tmp_path / "dir.png").mkdir()
    (tmp_path / "dir.bvh").mkdir()
    (tmp_path / "bad.json").write_text("{not json")
    (tmp_path / "binary.json").write_bytes(b"\xff\xfe\x00garbage")
    (tmp_path / "path.json").write_text(json.dumps({"preset": "exaggerated", "amount": 0.2}))
    (tmp_path / "nan_path.json").write_text('[[NaN, 0], [1, 1]]')
    for kind, text in BROKEN_BVH.items():
        (tmp_path / f"{kind}.bvh").write_text(text, encoding="latin-1")
        (tmp_path / f"lib_{kind}.json").write_text(json.dumps(
            [{"name": "broken", "file": f"{kind}.bvh", "hit_frame": 0}]))
    (tmp_path / "lib_not_list.json").write_text('{"name": "x"}')
    (tmp_path / "lib_missing_file.json").write_text(json.dumps([{"name": "x", "file": "none.bvh", "hit_frame": 1}]))
    return tmp_path


def tree(folder: Path) -> set:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def assert_refused(place, capsys, argv):
    before = tree(place)
    code = run([a.format(d=place) for a in argv])
    out, err = capsys.readouterr()
    assert code == 2, (argv, out, err)
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and lines[0][6:].strip(), (argv, err)
    assert "Traceback" not in err and "Warning" not in err, err
    assert list((place / "out").iterdir()) == [], argv
    assert tree(place) == before, argv             # no folder (tree) made, no temp file left
    return lines[0]


BAD = {
    # global
    "unknown command": ["nosuch"],
    "unknown global option": ["--foo"],
    # shots
    "shots unknown option": ["shots", "--foo"],
    "shots extra argument": ["shots", "--json", "x"],
    # view (all refused before a window or context opens)
    "view size small": ["view", "--headless", "--size", "10", "10"],
    "view size huge": ["view", "--headless", "--size", "100000", "720"],
    "view size text": ["view", "--size", "x", "720"],
    "view size one": ["view", "--size", "1280"],
    "view frames negative": ["view", "--headless", "--frames", "-1"],
    "view frames fraction": ["view", "--frames", "2.5"],
    "view frames nan": ["view", "--frames", "nan"],
    "view frames absurd": ["view", "--headless", "--frames", "99999999999"],
    "view script missing": ["view", "--headless", "--script", "{d}/missing.json"],
    "view script folder": ["view", "--headless", "--script", "{d}"],
    "view script malformed": ["view", "--headless", "--script", "{d}/bad.json"],
    "view script binary": ["view", "--headless", "--script", "{d}/binary.json"],
    "view library missing": ["view", "--headless", "--library", "{d}/none.json"],
    "view library folder": ["view", "--headless", "--library", "{d}"],
    "view screenshot no folder": ["view", "--headless", "--screenshot", "{d}/no/such/s.png"],
    "view screenshot suffix": ["view", "--headless", "--screenshot", "{d}/out/s.jpg"],
    "view screenshot folder": ["view", "--headless", "--screenshot", "{d}/dir.png"],
    "view stats no folder": ["view", "--headless", "--stats", "{d}/no/s.json"],
    "view stats folder": ["view", "--headless", "--stats", "{d}/out"],
    "view unknown option": ["view", "--bogus"],
    # render-strip
    "strip no shot": ["render-strip", "--out", "{d}/out/r.png"],
    "strip no out": ["render-strip", "--shot", SHOT],
    "strip hit nan": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--hit", "nan", "nan", "nan"],
    "strip hit inf": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--hit", "inf", "0", "0"],
    "strip hit two": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--hit", "1", "2"],
    "strip hit absurd": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--hit", "1e9", "0", "0"],
    "strip hit text": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--hit", "a", "b", "c"],
    "strip falloff nan": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", *HIT, "--falloff", "nan"],
    "strip falloff negative": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", *HIT, "--falloff", "-5"],
    "strip falloff zero": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", *HIT, "--falloff", "0"],
    "strip wrist fraction": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", *HIT, "--wrist-dof", "2.5"],
    "strip wrist one": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", *HIT, "--wrist-dof", "1"],
    "strip frames zero": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--frames", "0"],
    "strip frames many": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--frames", "65"],
    "strip frames text": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--frames", "x"],
    "strip size small": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--size", "10x10"],
    "strip size text": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--size", "axb"],
    "strip size three": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--size", "100x100x100"],
    "strip out suffix": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.jpg"],
    "strip out no folder": ["render-strip", "--shot", SHOT, "--out", "{d}/no/r.png"],
    "strip out folder": ["render-strip", "--shot", SHOT, "--out", "{d}/dir.png"],
    "strip sheet huge": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--frames", "64", "--size", "4096x4096"],
    "strip unknown shot": ["render-strip", "--shot", "nosuch", "--out", "{d}/out/r.png"],
    "strip unknown option": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--bogus"],
    # adapt
    "adapt nothing": ["adapt"],
    "adapt target nan": ["adapt", "--target", "nan", "100", "300"],
    "adapt target two": ["adapt", "--target", "1", "2"],
    "adapt target inf": ["adapt", "--target", "inf", "0", "0"],
    "adapt hit absurd": ["adapt", "--shot", SHOT, "--hit", "1e300", "0", "0"],
    "adapt hit text": ["adapt", "--shot", SHOT, "--hit", "x", "0", "0"],
    "adapt wrist fraction": ["adapt", "--shot", SHOT, *HIT, "--wrist-dof", "2.5"],
    "adapt wrist one": ["adapt", "--shot", SHOT, *HIT, "--wrist-dof", "1"],
    "adapt wrist nan": ["adapt", "--shot", SHOT, *HIT, "--wrist-dof", "nan"],
    "adapt falloff zero": ["adapt", "--shot", SHOT, *HIT, "--falloff", "0"],
    "adapt falloff -inf": ["adapt", "--shot", SHOT, *HIT, "--falloff", "-inf"],
    "adapt solver": ["adapt", "--shot", SHOT, *HIT, "--solver", "nope"],
    "adapt trunk reach negative": ["adapt", "--shot", SHOT, *HIT, "--trunk-reach", "-1"],
    "adapt trunk reach nan": ["adapt", "--shot", SHOT, *HIT, "--trunk-reach", "nan"],
    "adapt trunk reach text": ["adapt", "--shot", SHOT, *HIT, "--trunk-reach", "stiff"],
    "adapt out suffix": ["adapt", "--shot", SHOT, *HIT, "--out", "{d}/out/a.fbx"],
    "adapt out no folder": ["adapt", "--shot", SHOT, *HIT, "--out", "{d}/no/a.bvh"],
    "adapt out folder": ["adapt", "--shot", SHOT, *HIT, "--out", "{d}/dir.bvh"],
    "adapt both": ["adapt", "--target", "0", "100", "300", "--shot", SHOT, *HIT],
    "adapt unknown shot": ["adapt", "--shot", "nosuch", *HIT],
    "adapt unknown option": ["adapt", "--bogus"],
    "adapt missing value": ["adapt", "--shot"],
    "adapt huge token": ["adapt", "--" + "x" * 5000],
    # bench
    "bench reps few": ["bench", "--reps", "2"],
    "bench reps huge": ["bench", "--reps", "10000000000"],
    "bench reps text": ["bench", "--reps", "x"],
    "bench unknown option": ["bench", "--bogus"],
    # analyse
    "analyse components zero": ["analyse", "--components", "0"],
    "analyse components text": ["analyse", "--components", "x"],
    "analyse pcs zero": ["analyse", "--pcs", "0"],
    "analyse unknown shot": ["analyse", "--shot", "nosuch"],
    "analyse library missing": ["analyse", "--library", "{d}/none.json"],
    "analyse library folder": ["analyse", "--library", "{d}"],
    "analyse library malformed": ["analyse", "--library", "{d}/bad.json"],
    "analyse library not list": ["analyse", "--library", "{d}/lib_not_list.json"],
    "analyse library bvh missing": ["analyse", "--library", "{d}/lib_missing_file.json"],
    **{f"analyse library bvh {k}": ["analyse", "--library", f"{{d}}/lib_{k}.json"] for k in BROKEN_BVH},
    "analyse offsets text": ["analyse", "--style", "--offsets", "a,b"],
    "analyse offsets nan": ["analyse", "--style", "--offsets", "nan"],
    "analyse offsets zero": ["analyse", "--style", "--offsets", "0"],
    "analyse offsets negative": ["analyse", "--style", "--offsets", "-5"],
    "analyse offsets empty": ["analyse", "--style", "--offsets", ","],
    "analyse offsets absurd": ["analyse", "--style", "--offsets", "1e308"],
    "analyse falloff nan": ["analyse", "--style", "--falloff", "nan"],
    "analyse solver": ["analyse", "--style", "--solver", "nope"],
    "analyse strip suffix": ["analyse", "--components-strip", "{d}/out/c.jpg"],
    "analyse strip no folder": ["analyse", "--components-strip", "{d}/no/c.png"],
    "analyse strip folder": ["analyse", "--components-strip", "{d}/dir.png"],
    "analyse strip part": ["analyse", "--components-strip", "{d}/out/c.png", "--part", "nope"],
    # synth
    "synth nothing": ["synth"],
    "synth path missing": ["synth", "--shot", SHOT, "--path", "{d}/missing.json", "--out", "{d}/out/s.bvh"],
    "synth path folder": ["synth", "--shot", SHOT, "--path", "{d}", "--out", "{d}/out/s.bvh"],
    "synth path malformed": ["synth", "--shot", SHOT, "--path", "{d}/bad.json", "--out", "{d}/out/s.bvh"],
    "synth path binary": ["synth", "--shot", SHOT, "--path", "{d}/binary.json", "--out", "{d}/out/s.bvh"],
    "synth path nan": ["synth", "--shot", SHOT, "--path", "{d}/nan_path.json", "--out", "{d}/out/s.bvh"],
    "synth out suffix": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/out/s.txt"],
    "synth out no folder": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/no/s.bvh"],
    "synth out folder": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/dir.bvh"],
    "synth fps nan": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/out/s.bvh", "--fps", "nan"],
    "synth fps zero": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/out/s.bvh", "--fps", "0"],
    "synth fps absurd": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/out/s.bvh", "--fps", "1e9"],
    "synth fps text": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/out/s.bvh", "--fps", "x"],
    "synth unknown shot": ["synth", "--shot", "nosuch", "--path", "{d}/path.json", "--out", "{d}/out/s.bvh"],
    **{f"synth library bvh {k}": ["synth", "--shot", "broken", "--path", "{d}/path.json", "--out",
                                  "{d}/out/s.bvh", "--library", f"{{d}}/lib_{k}.json"] for k in BROKEN_BVH},
}


@pytest.mark.parametrize("argv", list(BAD.values()), ids=list(BAD))
def test_bad_command_line_is_one_line_exit_2_nothing_written(place, capsys, argv):
    assert_refused(place, capsys, argv)


def test_usage_errors_name_the_command_and_click_message(place, capsys):
    line = assert_refused(place, capsys, ["render-strip", "--shot", SHOT, "--out", "x.png", "--foo"])
    assert "hitpoint render-strip" in line and "No such option: --foo" in line
    line = assert_refused(place, capsys, ["render-strip", "--shot", SHOT])
    assert "Missing option '--out'" in line
    line = assert_refused(place, capsys, ["render-strip", "--out", "x.png"])     # --shot or --bvh
    assert "--shot" in line and "--bvh" in line


def test_refusals_say_what_was_expected(place, capsys):
    assert "0 or 2" in assert_refused(place, capsys, BAD["adapt wrist fraction"])
    assert "0 or 2" in assert_refused(place, capsys, BAD["strip wrist one"])
    assert "--hit" in assert_refused(place, capsys, BAD["strip hit nan"])
    assert "10000" in assert_refused(place, capsys, BAD["adapt hit absurd"])   # the limit is named
    assert len(assert_refused(place, capsys, BAD["adapt huge token"])) < 200    # never echoed in full


def test_help_still_works(capsys):
    for argv in (["--help"], ["adapt", "--help"], ["render-strip", "--help"]):
        assert run(argv) == 0
        out, err = capsys.readouterr()
        assert "Usage" in out and err == ""


# ------------------------------------------------------------ writes that fail
WRITERS = {
    "synth": ["synth", "--shot", SHOT, "--path", "{d}/path.json", "--out", "{d}/out/s.bvh", "--no-plant-feet"],
    "render-strip": ["render-strip", "--shot", SHOT, "--out", "{d}/out/r.png", "--frames", "2", "--size", "64x64"],
    "analyse strip": ["analyse", "--shot", SHOT, "--components-strip", "{d}/out/c.png"],
    "adapt bvh": ["adapt", "--shot", SHOT, *HIT, "--out", "{d}/out/a.bvh"],
    "adapt csv": ["adapt", "--shot", SHOT, *HIT, "--out", "{d}/out/a.csv"],
    "adapt glb": ["adapt", "--shot", SHOT, *HIT, "--out", "{d}/out/a.glb"],
    "view stats": ["view", "--headless", "--frames", "2", "--stats", "{d}/out/s.json"],
    "view screenshot": ["view", "--headless", "--frames", "2", "--screenshot", "{d}/out/s.png"],
}


def disk_full(monkeypatch):
    """Every write's data fails to reach the disk (ENOSPC, as a full disk reports at fsync)."""
    import engine.atomic

    def full(path, flags=os.O_RDONLY):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(engine.atomic, "_fsync", full)
    return "No space left on device"


def read_only(monkeypatch, folder: Path):
    """The output folder is read-only (chmod; as root, which writes anyway, the
    temporary file's creation fails as it would)."""
    folder.chmod(0o500)
    if os.geteuid() == 0:
        import engine.atomic

        def refuse(*a, dir=None, prefix="", suffix="", **k):
            name = os.path.join(dir, prefix + "xxxxxxxx" + suffix)
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), name)
        monkeypatch.setattr(engine.atomic.tempfile, "mkstemp", refuse)
    return "Permission denied"


@pytest.mark.parametrize("failure", ["disk full", "read-only"])
@pytest.mark.parametrize("argv", list(WRITERS.values()), ids=list(WRITERS))
def test_failed_write_is_one_line_naming_the_file(place, capsys, monkeypatch, argv, failure):
    out_dir = place / "out"
    reason = disk_full(monkeypatch) if failure == "disk full" else read_only(monkeypatch, out_dir)
    target = next(Path(a.format(d=place)) for a in argv if a.startswith("{d}/out/"))
    try:
        line = assert_refused(place, capsys, argv)
    finally:
        out_dir.chmod(0o755)
    assert reason in line and target.name in line, line
    assert ".tmp" not in line                      # the target is named, not its temporary file


def test_a_good_write_still_works(place, capsys):
    assert run(WRITERS["adapt csv"][:-2] + ["--out", f"{place}/out/a.csv"]) == 0
    capsys.readouterr()
    assert [p.name for p in (place / "out").iterdir()] == ["a.csv"]


# ------------------------------------------------------------ the shared check
@settings(max_examples=1500, deadline=None)
@given(st.one_of(st.text(max_size=80), st.floats(allow_nan=True, allow_infinity=True),
                 st.integers(-10 ** 30, 10 ** 30), st.sampled_from([10 ** 400, -10 ** 400])),
       st.booleans())
def test_number_is_a_finite_value_in_range_or_one_short_user_error(value, integer):
    try:
        x = number("--opt", value, -100.0, 100.0, integer=integer)
    except UserError as e:
        msg = str(e)
        # the value is echoed shortened (its repr may spell a character as \U0001xxxx)
        assert msg.startswith("--opt") and "\n" not in msg and len(msg) < 80 + 10 * MAX_TOKEN_CHARS
        return
    assert -100 <= x <= 100 and x == x
    assert not integer or isinstance(x, int)
    assert x == float(value)


@settings(max_examples=1500, deadline=None)
@given(st.lists(st.one_of(st.sampled_from(["--target", "--hit", "--shot", "--falloff", "--wrist-dof",
                                           "--solver", "--out", "--bogus", "nan", "inf", "-1", "2.5", "0",
                                           "2", "1e400", "x.bvh"]),
                          st.text(max_size=12)), max_size=10))
def test_adapt_arguments_parse_or_fail_with_one_user_error(args):
    from app.cli.adapt import parse_args
    try:
        got = parse_args(args)
    except UserError as e:
        assert "\n" not in str(e)
        return
    for key in ("target", "hit"):
        assert got[key] is None or (len(got[key]) == 3 and all(abs(v) <= 1e4 for v in got[key]))
    assert got["wrist_dof"] in (0, 2) and 0 < got["falloff"] <= 1e4


# ------------------------------------------------------------ end to end
def hitpoint(*args):
    return subprocess.run([sys.executable, "-c", "from app.cli import main; main()", *map(str, args)],
                          capture_output=True, text=True, timeout=300)   # a hang guard (a cold cache compiles)


@pytest.mark.parametrize("argv", [BAD["unknown global option"], BAD["strip hit nan"], BAD["adapt wrist fraction"],
                                  BAD["view frames fraction"]], ids=["usage", "nan", "wrist", "view"])
def test_end_to_end_exit_2_one_line(place, argv):
    r = hitpoint(*[a.format(d=place) for a in argv])
    assert r.returncode == 2 and r.stdout == ""
    assert len(r.stderr.splitlines()) == 1 and r.stderr.startswith("error:"), r.stderr


def test_headless_view_on_a_broken_library_exits_2(place):
    r = hitpoint("view", "--headless", "--frames", "2", "--library", place / "lib_truncated.json",
                 "--stats", place / "out" / "s.json")
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and r.stderr.startswith("error: library"), r.stderr
    assert list((place / "out").iterdir()) == []


def test_headless_scripted_capture_into_a_missing_folder_exits_2(place):
    script = place / "s.json"
    script.write_text(json.dumps([{"type": "screenshot", "frame": 1, "path": str(place / "no" / "dir" / "s.png")}]))
    r = hitpoint("view", "--headless", "--script", script)
    assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "screenshot" in r.stderr, r.stderr
    assert not (place / "no").exists()


def test_headless_view_whose_renderer_failed_exits_2(place, capsys, monkeypatch):
    import app.viewer.loop

    def broken(*a, **k):
        raise ValueError("bad mesh asset")
    monkeypatch.setattr(app.viewer.loop, "SceneRenderer", broken)
    line = assert_refused(place, capsys, ["view", "--headless", "--frames", "2", "--stats", "{d}/out/s.json"])
    assert "renderer" in line and "bad mesh asset" in line


def test_warnings_before_a_refusal_are_dropped_after_success_shown(capsys):
    import warnings

    import numpy as np

    from app.errors import UserError, cli_errors

    @cli_errors
    def command(refuse):
        np.float64(1.0) / np.float64(0.0)          # RuntimeWarning: divide by zero
        warnings.warn("odd input", RuntimeWarning)
        if refuse:
            raise UserError("refused")

    shown = []
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = lambda message, *a, **k: shown.append(str(message))
        with pytest.raises(Exception):
            command(True)
        assert capsys.readouterr().err == "error: refused\n" and shown == []
        command(False)
    assert len(shown) == 2 and "odd input" in shown[1]


@pytest.mark.parametrize("event", [
    {"type": "screenshot", "frame": 1, "path": "{d}/no/dir/s.png"},
    {"type": "export", "frame": 1, "dir": "{d}/no/dir/e", "formats": ["bvh"]},
], ids=["screenshot", "export"])
def test_scripted_capture_into_a_missing_folder_is_refused(place, capsys, event):
    script = place / "script.json"
    script.write_text(json.dumps([{k: str(v).format(d=place) if isinstance(v, str) else v
                                   for k, v in event.items()}]))
    line = assert_refused(place, capsys, ["view", "--headless", "--script", "{d}/script.json"])
    assert event["type"] in line and "does not exist" in line


def test_scripted_export_makes_one_new_folder(place, capsys):
    script = place / "script.json"
    script.write_text(json.dumps([{"type": "export", "frame": 1, "dir": str(place / "out" / "e"), "formats": ["bvh"]}]))
    assert run(["view", "--headless", "--script", str(script)]) == 0, capsys.readouterr().err
    assert [p.suffix for p in (place / "out" / "e").iterdir()] == [".bvh"]
