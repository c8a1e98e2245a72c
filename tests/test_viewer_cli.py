"""``hitpoint view --headless`` end to end (subprocess, own Xvfb if needed),
and its one-line errors for bad input."""
import json
import os
import subprocess
import sys

import pytest

from conftest import ROOT

HITPOINT = [sys.executable, "-c", "from app.cli import main; main()"]


def hitpoint(*args, timeout=120):
    env = dict(os.environ)
    return subprocess.run(HITPOINT + list(args), cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)


def test_headless_run_writes_screenshot_and_stats(tmp_path):
    script = tmp_path / "drag.json"
    script.write_text(json.dumps([
        {"type": "set", "frame": 0, "key": "falloff", "value": 100},
        {"type": "drag_target_path", "frame": 1, "circle": {"center": [-20, 70], "radius": 25}, "frames": 12},
        {"type": "scrub", "frame": 16, "to": 5},
        {"type": "key", "frame": 17, "key": "h"},
        {"type": "key", "frame": 18, "key": "f12"},
    ]))
    png, stats = tmp_path / "shot.png", tmp_path / "stats.json"
    r = hitpoint("view", "--headless", "--frames", "24", "--script", str(script), "--screenshot", str(png),
                 "--stats", str(stats), "--size", "640", "400")
    assert r.returncode == 0, r.stderr
    from PIL import Image
    assert Image.open(png).size == (640, 400)
    data = json.loads(stats.read_text())
    assert data["frames"] == 24 and data["size"] == [640, 400]
    for phase in ("frame_ms", "engine_ms", "render_ms"):
        assert set(data[phase]) >= {"median", "p95", "p99"}
        assert data[phase]["median"] >= 0
    assert data["time_to_first_frame_s"] > 0 and data["errors"] == 0, data["messages"]
    assert data["engine_solves"] >= 5          # re-solved while the target moved


@pytest.mark.parametrize("content, needle", [
    ("{not json", "not valid JSON"),
    ('{"type": "key"}', "JSON list"),
    ('[{"type": "warp", "frame": 1}]', "unknown type"),
    ('[{"type": "key", "frame": 1, "key": "nope"}]', "unknown key"),
    ('[{"type": "drag_target", "frame": 1}]', "drag_target"),
])
def test_bad_script_is_one_line_exit_2(tmp_path, content, needle):
    script = tmp_path / "bad.json"
    script.write_text(content)
    r = hitpoint("view", "--headless", "--frames", "2", "--script", str(script))
    assert r.returncode == 2
    assert r.stderr.startswith("error:") and needle in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_bad_options_are_one_line_exit_2(tmp_path):
    for args, needle in [(["--headless", "--size", "10", "10"], "--size"),
                         (["--headless", "--script", str(tmp_path / "missing.json")], "missing.json"),
                         (["--frames", "3"], "--headless"),
                         (["--headless", "--library", str(tmp_path / "none.json")], "none.json"),
                         (["--headless", "--stats", str(tmp_path / "no" / "s.json")], "folder")]:
        r = hitpoint("view", *args)
        assert r.returncode == 2, (args, r.stderr)
        assert r.stderr.startswith("error:") and needle in r.stderr, r.stderr


def test_view_is_callable_without_arguments():
    """Plain ``hitpoint`` invokes ``view()`` directly: every default must be a real value."""
    import inspect
    from app.cmd_view import view
    for name, p in inspect.signature(view).parameters.items():
        assert p.default is not inspect.Parameter.empty, name
        assert not type(p.default).__name__.endswith("Info"), name
