"""BVH reader under fuzzing: every input gives either a valid, finite
(skeleton, clip) or one short line of BvhError; valid files round-trip."""
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from engine import bvh, quat
from engine.skeleton import Clip, Skeleton

from tests.conftest import MOCAP
from tests.engine.test_bvh import SMALL

# test_core_bvh's two-joint file, grown: a joint without channels under Chest
# (holding the End Site), a rotation-only leg, three frames.
HEAD = ("\t\tJOINT Head\n\t\t{\n\t\t\tOFFSET 0 10 0\n\t\t\tCHANNELS 0\n"
        "\t\t\tEnd Site\n\t\t\t{\n\t\t\t\tOFFSET 0 1.5e1 0\n\t\t\t}\n\t\t}\n")
LEG = "\tJOINT Leg\n\t{\n\t\tOFFSET 5 -40 0\n\t\tCHANNELS 3 Xrotation Zrotation Yrotation\n\t}\n"
FRAMES = ("Frames: 3\nFrame Time: 0.0333333\n"
          "1 90 2 10 20 30 0 20 0 -5 4 3 7 8 9\n"
          "1.5 91 2.5 11 21 31 0.5 20 0 -6 5 2 7 8 9\n"
          "2 92 3 12 22 32 1 20 0 -7 6 1 -7 -8 -9\n")
BASE = (SMALL[:SMALL.index("\t\tEnd Site")] + HEAD + "\t}\n" + LEG + "}\nMOTION\n" + FRAMES)
PATH = "fuzz.bvh"
SMALL_CHUNK = bvh.MAX_TOKEN + 16   # chunks this small cut nearly every frame line


def outcome(text: str, path: str = PATH):
    """(skeleton, clip) for a valid text, else the BvhError's message; asserts the contract."""
    try:
        skel, clip = bvh.parse(text, path)
    except bvh.BvhError as e:
        msg = str(e)
        assert "\n" not in msg and len(msg) < 300 and msg.startswith(path), msg
        result = msg
    else:
        assert_valid(skel, clip)
        result = skel, clip
    return result


def assert_valid(skel: Skeleton, clip: Clip) -> None:
    J, F = skel.num_joints, clip.num_frames
    assert 1 <= J <= bvh.MAX_JOINTS and 1 <= F <= bvh.MAX_FRAMES
    assert math.isfinite(clip.fps) and 1 / bvh.MAX_FRAME_TIME <= clip.fps <= 1 / bvh.MIN_FRAME_TIME
    assert clip.local_rotations.shape == (F, J, 4) and clip.root_positions.shape == (F, 3)
    arrays = [skel.offsets, clip.root_positions, clip.local_rotations, *skel.end_sites.values()]
    if clip.local_positions is not None:
        arrays.append(clip.local_positions)
    assert all(np.isfinite(a).all() for a in arrays)
    assert np.abs(skel.offsets).max() <= bvh.MAX_OFFSET


def same(a, b) -> bool:
    """Identical outcomes: the same message, or bit-identical arrays."""
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    (s1, c1), (s2, c2) = a, b
    lp = (c1.local_positions is None and c2.local_positions is None) or \
        (c1.local_positions is not None and c2.local_positions is not None
         and np.array_equal(c1.local_positions, c2.local_positions))
    return (s1.names == s2.names and np.array_equal(s1.parents, s2.parents)
            and np.array_equal(s1.offsets, s2.offsets) and s1.channel_orders == s2.channel_orders
            and s1.position_channels == s2.position_channels
            and s1.end_sites.keys() == s2.end_sites.keys()
            and all(np.array_equal(s1.end_sites[k], s2.end_sites[k]) for k in s1.end_sites)
            and np.array_equal(c1.root_positions, c2.root_positions)
            and np.array_equal(c1.local_rotations, c2.local_rotations) and c1.fps == c2.fps and lp)


@pytest.fixture
def small_chunks(monkeypatch):
    monkeypatch.setattr(bvh, "_CHUNK_CHARS", SMALL_CHUNK)


# ---- mutations of a valid file ---------------------------------------------------------

KEYWORDS = ["{", "}", "HIERARCHY", "ROOT", "JOINT", "End", "Site", "OFFSET", "CHANNELS",
            "MOTION", "Frames:", "Frame", "Time:", "Xposition", "Zrotation", "0", "3", "6", "7"]
NUMBERS = ["-0", "1e308", "-1e308", "1e6", "1000001", "1e5", "100001", "nan", "inf", "-Infinity",
           "5e-324", "1e-4", "9.99e-5", "10", "10.5", "1e8", "100000000", "10000000000000000000",
           "9" * 5000, "0." + "0" * 5000 + "1", "1_0", "0x10", "+3", "--3", "3.", ".5", "1e", "e5"]
token = st.one_of(st.sampled_from(KEYWORDS), st.sampled_from(NUMBERS),
                  st.text(min_size=1, max_size=8).filter(lambda s: not s.isspace()),
                  st.integers(-10 ** 20, 10 ** 20).map(str),
                  st.floats(allow_nan=True, allow_infinity=True).map(repr))


def pieces(text: str) -> list[str]:
    """Tokens and the whitespace between them, so edits keep the layout."""
    import re
    return re.findall(r"\s+|\S+", text)


@st.composite
def mutated(draw, base: str = BASE) -> str:
    parts = pieces(base)
    for _ in range(draw(st.integers(1, 3))):
        k = draw(st.integers(0, len(parts) - 1))
        kind = draw(st.sampled_from(["replace", "delete", "duplicate", "insert", "cut"]))
        if kind == "replace":
            parts[k] = draw(token)
        elif kind == "delete":
            del parts[k:k + draw(st.integers(1, 8))]
        elif kind == "duplicate":
            n = draw(st.integers(1, 12))
            parts[k:k] = parts[k:k + n] * draw(st.integers(1, 3))
        elif kind == "insert":
            parts[k:k] = [" ", draw(token), " "]
        else:
            del parts[k:]
        if not parts:
            break
    return "".join(parts)


@settings(max_examples=700, deadline=None)
@given(mutated())
def test_mutated_files_give_a_valid_clip_or_one_short_line(text):
    outcome(text)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=mutated())
def test_small_chunks_read_and_fail_exactly_like_one_chunk(text, monkeypatch):
    whole = outcome(text)
    with monkeypatch.context() as m:
        m.setattr(bvh, "_CHUNK_CHARS", SMALL_CHUNK)
        assert same(whole, outcome(text))


def nested(depth: int, channels: str = "CHANNELS 0") -> str:
    joints = "".join(f"JOINT j{i}\n{{\nOFFSET 0 1 0\n{channels}\n" for i in range(depth - 1))
    return ("HIERARCHY\nROOT r\n{\nOFFSET 0 0 0\nCHANNELS 3 Xposition Yposition Zposition\n" + joints
            + "}\n" * depth + "MOTION\nFrames: 2\nFrame Time: 0.01\n1 2 3\n4 5 6\n")


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 3000), st.sampled_from(["CHANNELS 0", "CHANNELS 3 Zrotation Xrotation Yrotation"]))
def test_any_nesting_depth_is_read_or_refused_by_name(depth, channels):
    text = nested(depth, channels)
    if channels != "CHANNELS 0":   # rotation columns for every joint
        text = text.replace("1 2 3\n4 5 6\n", ("1 2 3" + " 0 0 0" * (depth - 1) + "\n") * 2)
    result = outcome(text)
    if depth <= bvh.MAX_DEPTH:
        assert not isinstance(result, str), result
        assert result[0].num_joints == depth
    else:
        assert "MAX_DEPTH" in result and str(bvh.MAX_DEPTH) in result


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=64), st.integers(0, len(BASE.encode())), st.integers(0, 64))
def test_random_bytes_anywhere_in_a_file(tmp_path_factory, blob, at, cut):
    raw = BASE.encode()
    data = raw[:at] + blob + raw[at + cut:]
    path = tmp_path_factory.getbasetemp() / "bytes.bvh"
    path.write_bytes(data)
    try:
        skel, clip = bvh.read(path)
    except bvh.BvhError as e:
        msg = str(e)
        assert "\n" not in msg and len(msg) < 300 and str(path) in msg, msg
        if "not UTF-8" in msg:
            assert "line " in msg and "column " in msg
    else:
        assert_valid(skel, clip)


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(["\n", "\r\n", "\r"]), st.sampled_from(["\t", " ", "  \t "]),
       st.booleans(), st.text(" \t\n", max_size=4))
def test_layout_changes_keep_the_same_numbers(newline, indent, bom, trailing):
    text = BASE.replace("\t", indent).replace("\n", newline) + trailing
    assert same(outcome(("\ufeff" if bom else "") + text), outcome(BASE))


# ---- valid skeletons and clips round-trip -------------------------------------------------

ORDERS = ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX", ""]
name_chars = st.characters(min_codepoint=33, max_codepoint=0x2FF,
                           blacklist_categories=("Cc", "Cs", "Zs", "Zl", "Zp", "Cf"))
joint_name = st.text(name_chars, min_size=1, max_size=bvh.MAX_TOKEN).filter(lambda s: s not in ("{", "}"))
coordinate = st.floats(-1e4, 1e4, allow_nan=False, width=32)


@st.composite
def skeleton_and_clip(draw):
    J = draw(st.integers(1, 10))
    names = draw(st.lists(joint_name, min_size=J, max_size=J, unique=True))
    parents, chain = [-1], [0]     # depth-first order: a parent is on the open chain
    for j in range(1, J):
        parent = draw(st.sampled_from(chain))
        chain = chain[:chain.index(parent) + 1] + [j]
        parents.append(parent)
    orders = [draw(st.sampled_from(ORDERS)) for _ in range(J)]
    has_pos = [draw(st.booleans()) for _ in range(J)]
    offsets = np.array(draw(st.lists(coordinate, min_size=3 * J, max_size=3 * J))).reshape(J, 3)
    leaves = [j for j in range(J) if j not in parents]
    end_sites = {j: np.array(draw(st.lists(coordinate, min_size=3, max_size=3)))
                 for j in leaves if draw(st.booleans())}
    skel = Skeleton(names, parents, offsets, orders, has_pos, end_sites)
    F = draw(st.integers(1, 12))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    euler = rng.uniform(-180, 180, size=(F, J, 3))
    rotations = quat.from_euler(euler)
    rotations[:, [j for j in range(J) if not orders[j]]] = quat.identity()
    positions = np.broadcast_to(offsets, (F, J, 3)).copy()
    moved = [j for j in range(J) if has_pos[j]]
    positions[:, moved] = rng.uniform(-1e4, 1e4, size=(F, len(moved), 3))
    fps = draw(st.floats(1 / bvh.MAX_FRAME_TIME, 1000))
    animated = any(has_pos[1:])
    return skel, Clip(positions[:, 0].copy(), rotations, fps, positions if animated else None)


@settings(max_examples=300, deadline=None)
@given(skeleton_and_clip())
def test_random_valid_skeletons_and_clips_round_trip(pair):
    skel, clip = pair
    result = outcome(bvh.format_bvh(skel, clip))
    assert not isinstance(result, str), result
    skel2, clip2 = result
    assert skel2.names == skel.names and list(skel2.parents) == list(skel.parents)
    assert skel2.channel_orders == skel.channel_orders and skel2.position_channels == skel.position_channels
    assert np.allclose(skel2.offsets, skel.offsets, atol=1e-8)
    assert skel2.end_sites.keys() == skel.end_sites.keys()
    assert all(np.allclose(skel2.end_sites[j], skel.end_sites[j], atol=1e-8) for j in skel.end_sites)
    assert clip2.num_frames == clip.num_frames and math.isclose(clip2.fps, clip.fps, rel_tol=1e-5)
    assert np.all(quat.angle_between(clip.local_rotations, clip2.local_rotations) < 1e-5)
    assert np.allclose(clip2.root_positions, clip.root_positions, atol=1e-8)
    if clip.local_positions is not None:
        assert np.allclose(clip2.local_positions, clip.local_positions, atol=1e-8)


@settings(max_examples=150, deadline=None)
@given(skeleton_and_clip(), st.data())
def test_mutations_of_random_valid_files(pair, data):
    outcome(data.draw(mutated(bvh.format_bvh(*pair))))


# ---- regressions: each case seen in the reader ---------------------------------------------

ZERO_CHANNELS = "HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 0\n}\nMOTION\nFrames: %s\nFrame Time: 0.1\n"


def refused(text: str, *words: str) -> str:
    result = outcome(text)
    assert isinstance(result, str), "accepted"
    assert all(w in result for w in words), result
    return result


def test_nesting_of_a_thousand_levels_is_refused_by_name():
    refused(nested(1000), "MAX_DEPTH", "64", "line ")
    assert not isinstance(outcome(nested(bvh.MAX_DEPTH)), str)


@pytest.mark.parametrize("frames", ["100000000", "1" + "0" * 19, str(bvh.MAX_FRAMES + 1)])
def test_absurd_frame_counts_are_refused_before_allocating(frames):
    refused(ZERO_CHANNELS % frames, "MAX_FRAMES", "line 8")


def test_frames_times_joints_and_values_are_capped():
    text = nested(60, "CHANNELS 0").replace("Frames: 2", f"Frames: {bvh.MAX_FRAMES}")
    refused(text, "MAX_JOINT_FRAMES")
    wide = nested(40, "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
    refused(wide.replace("Frames: 2", "Frames: 90000"), "MAX_VALUES")


def test_frame_count_is_checked_against_the_data():
    refused(ZERO_CHANNELS % "2" + "1 2 3\n", "frame 0 has 3 values, expected 0")
    refused(BASE.replace("Frames: 3", "Frames: 4"), "found 3 frame lines, expected 4")
    refused(BASE.replace("Frames: 3", "Frames: 2"), "more than 2 frame lines", "line 31")


@pytest.mark.parametrize("where", ["Frames: 3", "OFFSET 0 20 0", "-7 6 1"])
def test_numbers_of_five_thousand_digits_are_refused_by_length(where):
    digits = "9" * 5000
    text = BASE.replace(where, where.rsplit(" ", 1)[0] + " " + digits)
    msg = refused(text, "MAX_TOKEN", "64", "…")
    assert digits[:100] not in msg


def test_a_twenty_megabyte_token_is_truncated_in_the_message():
    for old in ("Chest", "-7"):
        msg = refused(BASE.replace(old, "C" * 20_000_000, 1), "…")
        assert len(msg) < 200


def test_denormal_frame_time_is_refused():
    refused(BASE.replace("0.0333333", "5e-324"), "frame time", "MIN_FRAME_TIME", "line 28")
    refused(BASE.replace("0.0333333", "11"), "frame time")
    assert not isinstance(outcome(BASE.replace("0.0333333", "1e-4")), str)


@pytest.mark.parametrize("old,new,limit", [
    ("OFFSET 0 20 0", "OFFSET 0 1e308 0", "MAX_OFFSET"),
    ("OFFSET 0 1.5e1 0", "OFFSET 0 -1.1e6 0", "MAX_OFFSET"),
    ("1.5 91 2.5", "1.5 9.1e6 2.5", "MAX_OFFSET"),
    ("-6 5 2", "-6 5 1e300", "MAX_ANGLE"),
    ("-6 5 2", "-6 5 -100001", "MAX_ANGLE"),
])
def test_magnitudes_beyond_the_limits_are_refused_by_name(old, new, limit):
    refused(BASE.replace(old, new), limit)


def test_limits_themselves_are_accepted():
    text = BASE.replace("OFFSET 0 20 0", "OFFSET 0 1e6 0").replace("-6 5 2", "-6 5 -1e5")
    skel, clip = outcome(text)
    assert skel.offsets[1, 1] == 1e6


def test_non_finite_values_are_refused_with_their_line():
    refused(BASE.replace("-6 5 2", "-6 nan 2"), "finite", "line 30")
    refused(BASE.replace("OFFSET 5 -40 0", "OFFSET 5 inf 0"), "finite", "line 22")


def test_utf8_byte_order_mark_is_accepted(tmp_path):
    path = tmp_path / "bom.bvh"
    path.write_bytes(b"\xef\xbb\xbf" + BASE.encode())
    assert same(bvh.read(path), outcome(BASE))
    assert same(outcome("\ufeff" + BASE), outcome(BASE))


def test_undecodable_bytes_give_line_and_column(tmp_path):
    path = tmp_path / "bad.bvh"
    path.write_bytes(BASE.encode().replace(b"Chest", b"Ch\xe9st"))
    with pytest.raises(bvh.BvhError) as err:
        bvh.read(path)
    msg = str(err.value)
    assert "line 6" in msg and "column 10" in msg and "0xe9" in msg and "\n" not in msg
    path.write_bytes(b"\xff\xfe" + "HIERARCHY".encode("utf-16-le"))
    with pytest.raises(bvh.BvhError, match="UTF-16"):
        bvh.read(path)


def test_a_file_of_absurd_size_is_refused_before_reading(tmp_path):
    path = tmp_path / "huge.bvh"
    with open(path, "wb") as f:
        f.truncate(bvh.MAX_FILE_BYTES + 1)   # sparse: no disk used, nothing read
    with pytest.raises(bvh.BvhError, match="MAX_FILE_BYTES"):
        bvh.read(path)


def test_hierarchy_without_motion():
    refused(BASE[:BASE.index("MOTION")], "unexpected end of file", "'MOTION'")
    refused(BASE[:BASE.index("Frame Time")], "unexpected end of file", "'Frame'")
    refused("HIERARCHY\n", "unexpected end of file", "'ROOT'")
    refused("\ufeff \n\t\n", "empty file")


def test_nul_bytes_are_refused_and_shown_escaped():
    msg = refused(BASE.replace("Chest", "Ch\x00est"), "joint name", "\\x00", "line 6")
    refused(BASE.replace("-6 5 2", "-6 5 \x00"), "\\x00", "line 30")
    refused("\x00" * 1000, "HIERARCHY")
    assert "\x00" not in msg


def test_joints_with_zero_rotation_channels_keep_identity_rotations():
    skel, clip = outcome(BASE)
    head = skel.index("Head")
    assert skel.channel_orders[head] == "" and not skel.position_channels[head]
    assert np.array_equal(clip.local_rotations[:, head], np.tile([1.0, 0, 0, 0], (3, 1)))
    skel, clip = outcome(ZERO_CHANNELS % "5")
    assert clip.num_frames == 5 and np.array_equal(clip.root_positions, np.zeros((5, 3)))


def test_two_hundred_megabytes_of_junk_fail_at_the_first_bad_token():
    header = BASE[:BASE.index("1 90 2")]
    for junk in ("x" * 200_000_000, header + "abc " * 50_000_000, header + "1 " * 100_000_000):
        refused(junk, "line ")   # speed is the bench's business; here: refused, one line
        del junk


def test_mocap_files_read_identically_in_small_chunks(monkeypatch):
    for path in sorted(MOCAP.glob("*.bvh")):
        whole = bvh.read(path)
        with monkeypatch.context() as m:
            m.setattr(bvh, "_CHUNK_CHARS", SMALL_CHUNK)
            assert same(whole, bvh.read(path))


def test_error_lines_are_right_in_small_chunks(small_chunks):
    refused(BASE.replace("-7 6 1", "-7 x 1"), "line 31", "frame 2")
    refused(BASE.replace("-7 6 1", "-7 1"), "line 31", "frame 2 has 14 values")
    refused(BASE.replace("Frames: 3", "Frames: 2"), "more than 2 frame lines", "line 31")
