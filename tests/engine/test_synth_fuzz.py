"""Fuzzing the score-path loader of ``hitpoint synth``: every path description,
well-formed or not, gives either a bounded, finite per-frame path or a one-line
ValueError / UserError, never another exception, a hang or a huge allocation."""
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.errors import UserError
from app.jsonfile import MAX_JSON_DEPTH, read_json
from tests.conftest import ROOT
from engine import synth
from engine import pca as pcam
from engine.skeleton import clip_fk
from tests.motion_kit import smooth_random_clip

FUZZ = settings(max_examples=500, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# Numbers a path file may hold, from ordinary to absurd (JSON itself has no NaN,
# but a caller of parse_path_spec may pass one).
extreme_floats = st.sampled_from([0.0, -0.0, 1e-300, 5e-324, 1e3, 1e5, 1e9, 1e15, 1e300, 1.7e308, -1e308,
                                  math.inf, -math.inf, math.nan])
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10 ** 30, 10 ** 30),
                    st.integers().map(lambda i: i * 10 ** 400), extreme_floats,
                    st.floats(-20, 20), st.floats(0, 700))
scalars = st.one_of(numbers, st.booleans(), st.none(), st.text(max_size=60),
                    st.sampled_from(list(synth.PRESETS) + ["points", "times", "fps", "preset"]))
json_like = st.recursive(scalars, lambda inner: st.one_of(
    st.lists(inner, max_size=5),
    st.dictionaries(st.sampled_from(["points", "times", "fps", "preset", "amount", "abort_frame", "x"]),
                    inner, max_size=4)), max_leaves=30)
point = st.lists(numbers, min_size=2, max_size=3)
path_like = st.one_of(
    st.lists(point, min_size=0, max_size=30),
    st.fixed_dictionaries({"points": st.lists(point, max_size=10)},
                          optional={"times": st.lists(numbers, max_size=10), "fps": numbers}),
    st.fixed_dictionaries({"preset": st.sampled_from(list(synth.PRESETS) + ["huge", ""])},
                          optional={"amount": numbers, "abort_frame": numbers}),
    json_like)
rates = st.one_of(st.floats(0.1, 2000), st.sampled_from([30.0, 60.0, 1000.0]))


@pytest.fixture(scope="module")
def shot(rig):
    clip = smooth_random_clip(rig, 60, seed=5)
    _, pos = clip_fk(rig.skeleton, clip)
    return pcam.fit_clip(rig, clip, "body"), synth.shot_sections(pos[:, rig.bat_joint], 35)


def one_line(err: Exception) -> str:
    text = str(err)
    assert text and "\n" not in text and len(text) < 400, text
    return text


def bounded_frames(spec, space, sections, fps) -> np.ndarray | None:
    """What ``hitpoint synth`` does with a parsed spec, up to the poses: a finite
    per-frame path within the bounds, or None after a one-line ValueError."""
    try:
        points = synth.path_from_spec(spec, space, sections)
        frames = None if spec.times is not None else space.scores.shape[0]
        per_frame = synth.resample_path(points, frames, spec.times, fps)
    except ValueError as e:
        one_line(e)
        return None
    assert 1 <= len(per_frame) <= synth.MAX_SYNTH_FRAMES
    assert np.isfinite(per_frame).all() and np.abs(per_frame).max() <= synth.MAX_ABS_SCORE * (1 + 1e-12)  # interp rounding
    return per_frame


@FUZZ
@given(obj=path_like, fps=rates)
def test_any_path_spec_is_bounded_or_one_line_error(shot, obj, fps):
    try:
        spec = synth.parse_path_spec(obj)
    except ValueError as e:
        one_line(e)
        return
    bounded_frames(spec, *shot, fps)


valid_points = st.lists(st.tuples(st.floats(-synth.MAX_ABS_SCORE, synth.MAX_ABS_SCORE),
                                  st.floats(-synth.MAX_ABS_SCORE, synth.MAX_ABS_SCORE)), min_size=1, max_size=50)


@FUZZ
@given(points=valid_points, steps=st.lists(st.floats(0, 5), min_size=50, max_size=50),
       timed=st.booleans(), fps=st.floats(1, 120))
def test_valid_paths_round_trip(shot, points, steps, timed, fps):
    times = np.cumsum(steps[:len(points)]) - steps[0]
    rows = [[a, b, float(t)] if timed else [a, b] for (a, b), t in zip(points, times)]
    spec = synth.parse_path_spec(json.loads(json.dumps(rows)))
    assert np.array_equal(spec.points, np.array(points).reshape(-1, 2))
    assert (spec.times is not None) == timed
    if timed:
        assert np.array_equal(spec.times, np.array([r[2] for r in rows]))
    per_frame = bounded_frames(spec, *shot, fps)
    expected_frames = int(round((times[-1] - times[0]) * fps)) + 1 if timed else shot[0].scores.shape[0]
    assert per_frame is not None and len(per_frame) == expected_frames


@FUZZ
@given(preset=st.sampled_from(synth.PRESETS), amount=st.one_of(st.none(), st.floats(0, 0.99)))
def test_valid_presets_give_finite_paths(shot, preset, amount):
    spec = synth.parse_path_spec({"preset": preset} if amount is None else {"preset": preset, "amount": amount})
    assert bounded_frames(spec, *shot, 30.0) is not None


@pytest.mark.parametrize("obj, needle", [
    ([[0, 0, 0], [1, 1, 1e5]], "MAX_PATH_SECONDS"),
    ([[0, 0, 0], [1, 1, 1e9]], "MAX_PATH_SECONDS"),
    ([[0, 0, -1e308], [1, 1, 1e308]], "MAX_PATH_SECONDS"),      # a span that overflows to inf
    ([[1e308, 0]], "MAX_ABS_SCORE"),
    ([[0, 1e4]], "MAX_ABS_SCORE"),
    ([[0, 10 ** 400]], "point 0"),
    ([[0, 0]] * (synth.MAX_PATH_POINTS + 1), "MAX_PATH_POINTS"),
    ([[0, 0, 1], [0, 0, 0]], "must not decrease"),
    ({"points": {"points": [[0, 0]]}}, "'points' must be a list"),
    ({"points": [[0, 0]], "times": [0, 1]}, "one timestamp per point"),
    ({"points": [[0, 0]], "fps": 1e9}, "'fps'"),
    ({"points": [[0, 0]], "speed": 2}, "unknown key"),
    ({"preset": "exaggerated", "amount": 1e300}, "MAX_EXAGGERATION"),
    ({"preset": "toned_down", "amount": 1}, "below 1"),
    ({"preset": "aborted", "abort_frame": 2.5}, "whole frame"),
    ({"preset": "aborted", "abort_frame": 10 ** 20}, "whole frame"),
    ({"preset": "exaggerated", "abort_frame": 3}, "aborted preset only"),
    ({"preset": ["x" * 10_000]}, "unknown preset"),
])
def test_seen_bad_paths_are_refused(obj, needle):
    with pytest.raises(ValueError) as e:
        synth.parse_path_spec(obj)
    assert needle in one_line(e.value)


def test_deep_python_nesting_does_not_recurse():
    deep: list = [[0, 0]]
    for _ in range(100_000):
        deep = [deep]
    with pytest.raises(ValueError) as e:
        synth.parse_path_spec(deep)
    one_line(e.value)
    nested: dict = {"points": [[0, 0]]}
    for _ in range(100_000):
        nested = {"points": nested}
    with pytest.raises(ValueError):
        synth.parse_path_spec(nested)


def test_resample_refuses_more_than_max_frames():
    with pytest.raises(ValueError, match="MAX_SYNTH_FRAMES"):
        synth.resample_path(np.zeros((2, 2)), times=np.array([0.0, 600.0]), fps=1000.0)
    with pytest.raises(ValueError, match="fps"):
        synth.resample_path(np.zeros((2, 2)), times=np.array([0.0, 1.0]), fps=0.0)
    longest = synth.resample_path(np.zeros((2, 2)), times=np.array([0.0, synth.MAX_PATH_SECONDS]), fps=60.0)
    assert len(longest) == synth.MAX_SYNTH_FRAMES          # ten minutes at 60 fps fit exactly


def test_non_finite_clip_is_refused(shot):
    clip = synth.synthesise(shot[0], np.zeros((3, 2)), frames=4)
    synth.check_finite_clip(clip)
    clip.root_positions[2, 1] = np.inf
    with pytest.raises(ValueError, match="non-finite"):
        synth.check_finite_clip(clip)


# ---------------------------------------------------------------- the file
json_texts = st.one_of(
    st.text(max_size=200),
    st.sampled_from(["[" * 5000 + "]" * 5000, "[[0, Infinity]]", "[[0, NaN]]", "[[0, -Infinity]]",
                     "[[0, 1e400]]", "[[0, " + "9" * 5000 + "]]", '{"points": [[0,0]]', "\ufeff[[0,0]]", ""]),
    json_like.map(lambda o: json.dumps(o, allow_nan=True)))


@FUZZ
@given(text=json_texts)
def test_any_path_file_reads_or_one_line_error(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("p") / "path.json"
    path.write_text(text, encoding="utf-8")
    try:
        obj = read_json(path, "path file", 1_000_000)
    except UserError as e:
        assert str(path) in one_line(e)
        return
    assert _finite_everywhere(obj)
    try:
        synth.parse_path_spec(obj)
    except ValueError as e:
        one_line(e)


def _finite_everywhere(obj) -> bool:
    stack = [obj]
    while stack:
        o = stack.pop()
        if isinstance(o, float) and not math.isfinite(o):
            return False
        if isinstance(o, dict):
            stack.extend(o.values())
        elif isinstance(o, list):
            stack.extend(o)
    return True


def test_read_json_limits(tmp_path):
    big = tmp_path / "big.json"
    big.write_bytes(b" " * 2001)
    with pytest.raises(UserError, match="larger than"):
        read_json(big, "path file", 2000)
    bad = tmp_path / "bad.json"
    bad.write_bytes(b'[[0, 1],\n [2, \xff]]')
    with pytest.raises(UserError, match="line 2, byte 14"):
        read_json(bad, "path file", 2000)
    bad.write_text('[[0, 1],\n [2, ]]')
    with pytest.raises(UserError, match="line 2, column 6"):
        read_json(bad, "path file", 2000)
    bad.write_text("[" * (MAX_JSON_DEPTH + 1) + "]" * (MAX_JSON_DEPTH + 1))
    with pytest.raises(UserError, match="nested deeper"):
        read_json(bad, "path file", 2000)
    with pytest.raises(UserError, match="folder"):
        read_json(tmp_path, "path file", 2000)


# ---------------------------------------------------------------- the command
@pytest.mark.parametrize("content", [
    "[[0, 0, 0], [1, 1, 1e9]]",                 # a hang / MemoryError before
    "[[1e308, 0], [0, 0]]",                     # inf in the BVH before
    "[" * 100_000 + "]" * 100_000,              # RecursionError before
    b"[[0, 0], [\xff]]",
])
def test_cli_refuses_bad_paths_with_one_line(tmp_path, content):
    path, out = tmp_path / "path.json", tmp_path / "out.bvh"
    (path.write_bytes if isinstance(content, bytes) else path.write_text)(content)
    r = subprocess.run([sys.executable, "-c", "from app.cli import main; main()", "synth", "--shot", "cover_drive", "--path", str(path),
                        "--out", str(out)], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and str(path) in lines[0], r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["path.json"]      # no output, no temp file


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 5), st.integers(1, 6), st.integers(0, 10_000))
def test_the_alignment_is_the_cheapest_forward_map(frames, guide_frames, seed):
    """engine.synth_detail.align_to_guide against every non-decreasing map of a few frames: never
    going back, and no map is cheaper (summed squared distance of the scores)."""
    import itertools
    from engine.synth_detail import align_to_guide
    rng = np.random.default_rng(seed)
    scores, guide = rng.normal(size=(frames, 2)), rng.normal(size=(guide_frames, 2))
    m = align_to_guide(scores, guide)
    assert m.shape == (frames,) and np.all(np.diff(m) >= 0) and m.min() >= 0 and m.max() < guide_frames

    def cost(mm):
        return float(np.sum((scores - guide[list(mm)]) ** 2))
    best = min(cost(mm) for mm in itertools.combinations_with_replacement(range(guide_frames), frames))
    assert cost(m) <= best + 1e-9
