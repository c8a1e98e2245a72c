"""Shot-library manifests under fuzzing: a valid manifest loads exactly its
entries; anything else raises LibraryError with one short line."""
import json
import math
import shutil

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from engine import bvh, library
from engine.library import LibraryError, load_library
from engine.rig import assets_dir

SHOTS = assets_dir() / "shots"
FILES = {name: bvh.read(SHOTS / name)[1].num_frames for name in ("pull.bvh", "sweep.bvh")}  # frames


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A library folder with two shot files (and one more in its parent, for '..')."""
    root = tmp_path_factory.mktemp("lib")
    (root / "shots").mkdir()
    for name in FILES:
        shutil.copy(SHOTS / name, root / "shots" / name)
    shutil.copy(SHOTS / "pull.bvh", root / "above.bvh")
    return root / "shots"


def write(folder, data, name="m.json"):
    path = folder / name
    path.write_bytes(data if isinstance(data, bytes) else json.dumps(data).encode())
    return path


def outcome(path, rig):
    """The shots, or the LibraryError's message; asserts the contract."""
    try:
        shots = load_library(path, rig)
    except LibraryError as e:
        msg = str(e)
        assert "\n" not in msg and len(msg) < 300 and str(path.name) in msg, msg
        return msg
    assert shots and all(np.isfinite(s.hit_point).all() for s in shots)
    return shots


def valid_entry(e) -> bool:
    """The manifest format, stated independently of the loader."""
    def text(v, limit, empty=False):
        return isinstance(v, str) and (empty or v) and len(v) <= limit and v.isprintable()
    return (isinstance(e, dict) and text(e.get("name"), library.MAX_NAME)
            and isinstance(e.get("file"), str) and e["file"] in FILES
            and type(e.get("hit_frame")) is int and 0 <= e["hit_frame"] < FILES[e["file"]]
            and ("description" not in e or text(e["description"], library.MAX_DESCRIPTION, True)))


def finite_json(v) -> bool:
    """No NaN or Infinity anywhere (plain JSON has neither; the loader refuses them)."""
    if isinstance(v, float):
        return math.isfinite(v)
    if isinstance(v, dict):
        return all(finite_json(x) for x in v.values())
    if isinstance(v, list):
        return all(finite_json(x) for x in v)
    return True


def valid(manifest) -> bool:
    if not isinstance(manifest, list) or not 1 <= len(manifest) <= library.MAX_SHOTS:
        return False
    if not finite_json(manifest):
        return False
    names = [e.get("name") for e in manifest if isinstance(e, dict)]
    return all(valid_entry(e) for e in manifest) and len(set(names)) == len(manifest)


# ---- strategies ----------------------------------------------------------------------------

json_value = st.recursive(
    st.none() | st.booleans() | st.integers(-10 ** 30, 10 ** 30)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=8)
good_entry = st.fixed_dictionaries(
    {"name": st.sampled_from(["pull", "sweep", "a", "pull2", "é"]),
     "file": st.sampled_from(sorted(FILES)),
     "hit_frame": st.integers(0, min(FILES.values()) - 1)},
    optional={"description": st.text(max_size=20), "extra": json_value})


@st.composite
def entry(draw):
    e = dict(draw(good_entry))
    kind = draw(st.sampled_from(["keep", "keep", "drop", "retype", "hit_edge", "not_object"]))
    key = draw(st.sampled_from(["name", "file", "hit_frame", "description"]))
    if kind == "drop":
        e.pop(key, None)
    elif kind == "retype":
        e[key] = draw(json_value)
    elif kind == "hit_edge":
        e["hit_frame"] = draw(st.sampled_from([-1, 69, 70, 73, 74, 10 ** 18, 10 ** 19, 3.0, True, None, "3"]))
    elif kind == "not_object":
        return draw(json_value)
    return e


manifests = st.one_of(st.lists(entry(), min_size=0, max_size=4), json_value)


@settings(max_examples=600, deadline=None)
@given(manifests)
def test_any_manifest_loads_exactly_or_fails_in_one_line(folder, rig, manifest):
    path = write(folder, json.dumps(manifest).encode())
    result = outcome(path, rig)
    if valid(manifest):
        assert not isinstance(result, str), result
        assert [s.name for s in result] == [e["name"] for e in manifest]
        assert [s.hit_frame for s in result] == [e["hit_frame"] for e in manifest]
        assert [s.description for s in result] == [e.get("description", "") for e in manifest]
    else:
        assert isinstance(result, str), manifest


GOOD = json.dumps([{"name": "pull", "file": "pull.bvh", "hit_frame": 30},
                   {"name": "sweep", "file": "sweep.bvh", "hit_frame": 31, "description": "low"}],
                  indent=1).encode()


@settings(max_examples=500, deadline=None)
@given(st.binary(max_size=24), st.integers(0, len(GOOD)), st.integers(0, 24))
def test_byte_level_damage_fails_in_one_line(folder, rig, blob, at, cut):
    outcome(write(folder, GOOD[:at] + blob + GOOD[at + cut:]), rig)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, len(GOOD)), st.sampled_from(["[", "{", "]", "}", ",", ":", '"', "NaN", "-Infinity",
                                                   "1e999", "9" * 40, "\\ud800", "\x00", "true"]))
def test_json_token_damage_fails_in_one_line(folder, rig, at, token):
    outcome(write(folder, GOOD[:at] + token.encode() + GOOD[at:]), rig)


# ---- regressions ---------------------------------------------------------------------------

E = {"name": "pull", "file": "pull.bvh", "hit_frame": 30}


def refused(folder, rig, data, *words):
    msg = outcome(write(folder, data), rig)
    assert isinstance(msg, str), "accepted"
    assert all(w in msg for w in words), msg
    return msg


@pytest.mark.parametrize("data,words", [
    (b"[{", ("line 1", "not JSON")),
    (b'[{"name": "\xff"}]', ("line 1", "not UTF-8", "0xff")),
    (["pull", "sweep"], ("entry 0", "expected an object", "found text")),
    ({"name": "pull"}, ("expected a list", "found an object")),
    ("pull", ("expected a list",)),
    (None, ("expected a list", "null")),
    ([{**E, "hit_frame": None}], ("entry 0", "hit_frame", "found null")),
    ([{**E, "file": 3}], ("entry 0", "'file'", "found an integer")),
    ([{**E, "name": ["x"]}], ("entry 0", "'name'", "found a list")),
    ([{**E, "description": 5}], ("entry 0", "'description'", "found an integer")),
    ([{**E, "hit_frame": True}], ("entry 0", "hit_frame", "true/false")),
    ([{**E, "hit_frame": 3.0}], ("entry 0", "hit_frame", "found a number")),
    ([{**E, "hit_frame": -1}], ("entry 0", "hit_frame", "-1")),
    ([{**E, "hit_frame": 70}], ("entry 0", "hit_frame 70", "0..69")),
    ([{**E, "hit_frame": 10 ** 64}], ("65 digits", "MAX_INT_DIGITS")),
    ([{**E, "hit_frame": 10 ** 19}], ("entry 0", "hit_frame 10000000000000000000 outside")),
    (b'[{"name": "pull", "file": "pull.bvh", "hit_frame": NaN}]', ("NaN", "finite")),
    (b'[{"name": "pull", "file": "pull.bvh", "hit_frame": 1e999}]', ("1e999", "finite")),
    (b'[{"name": "pull", "file": "pull.bvh", "hit_frame": -Infinity}]', ("finite",)),
    ([E, {**E, "file": "sweep.bvh"}], ("entry 1", "'pull'", "entry 0")),
    ([{**E, "file": "missing.bvh"}], ("entry 0", "'missing.bvh' not found")),
    ([{**E, "file": "../missing.bvh"}], ("entry 0", "not found")),
    ([{**E, "file": "."}], ("entry 0", "not found")),
    ([{**E, "file": ""}], ("entry 0", "'file' must not be empty")),
    ([{**E, "name": ""}], ("entry 0", "'name' must not be empty")),
    ([{**E, "name": "x" * 10 ** 6}], ("entry 0", "at most 64 characters", "…")),
    ([{**E, "name": "a\nb"}], ("entry 0", "printable")),
    ([{"file": "pull.bvh", "hit_frame": 3}], ("entry 0", "missing 'name'")),
    ([{"name": "pull", "hit_frame": 3}], ("entry 0", "missing 'file'")),
    ([{"name": "pull", "file": "pull.bvh"}], ("entry 0", "missing 'hit_frame'")),
    ([], ("no shots",)),
    ([E] * (library.MAX_SHOTS + 1), ("MAX_SHOTS",)),
    (b"[" * 100_000 + b"]" * 100_000, ("nested too deeply",)),
    (b'[{"name": "pull", "name": "sweep", "file": "pull.bvh", "hit_frame": 3}]', ("'name' repeated",)),
    (b'[{"name": "pull", "file": "pull.bvh", "hit_frame": ' + b"9" * 5000 + b"}]", ("5000 digits",)),
])
def test_malformed_manifests_raise_one_line_library_errors(folder, rig, data, words):
    msg = refused(folder, rig, data, *words)
    assert "m.json" in msg and len(msg) < 300


def test_library_error_is_a_value_error():
    assert issubclass(LibraryError, ValueError)


def test_missing_unreadable_and_oversized_manifests(folder, rig, tmp_path):
    with pytest.raises(LibraryError, match="manifest not found"):
        load_library(tmp_path / "none.json", rig)
    with pytest.raises(LibraryError, match="cannot read"):
        load_library(tmp_path, rig)
    big = tmp_path / "big.json"
    with open(big, "wb") as f:
        f.truncate(library.MAX_MANIFEST_BYTES + 1)
    with pytest.raises(LibraryError, match="MAX_MANIFEST_BYTES"):
        load_library(big, rig)


def test_paths_outside_the_folder_and_absolute_paths_load_when_they_exist(folder, rig):
    shots = outcome(write(folder, [{**E, "file": "../above.bvh"},
                                   {**E, "name": "abs", "file": str(folder / "sweep.bvh")}]), rig)
    assert [s.name for s in shots] == ["pull", "abs"]


def test_byte_order_mark_and_extra_keys_are_accepted(folder, rig):
    shots = outcome(write(folder, b"\xef\xbb\xbf" + json.dumps([{**E, "tags": ["x"]}]).encode()), rig)
    assert [s.hit_frame for s in shots] == [30]


def test_a_broken_shot_file_names_the_file(folder, rig):
    (folder / "broken.bvh").write_text("HIERARCHY\nROOT\n")
    with pytest.raises(ValueError) as err:
        load_library(write(folder, [{**E, "file": "broken.bvh"}]), rig)
    assert "broken.bvh" in str(err.value) and "\n" not in str(err.value)


def test_bundled_library_loads_unchanged(rig):
    shots = load_library(rig=rig)
    entries = json.loads((SHOTS / "library.json").read_text())
    assert [(s.name, s.file, s.hit_frame, s.description) for s in shots] == \
        [(e["name"], e["file"], e["hit_frame"], e["description"]) for e in entries]
    assert all(math.isfinite(v) for s in shots for v in s.hit_point)
