"""The shot library: a manifest of BVH source shots with their hit frames."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from . import bvh
from .rig import Rig, assets_dir, default_rig
from .skeleton import Clip, Skeleton, clip_fk, reorder_joints


@dataclass
class Shot:
    name: str
    file: str
    hit_frame: int
    description: str
    skeleton: Skeleton
    clip: Clip
    bat_joint: int
    capture: object = None      # the engine.capture.Capture a user's shot came from (to write it back)

    @cached_property
    def fk(self) -> tuple[np.ndarray, np.ndarray]:
        """Global rotations ``(F, J, 4)`` and positions ``(F, J, 3)`` of the source."""
        return clip_fk(self.skeleton, self.clip)

    @property
    def hit_point(self) -> np.ndarray:
        """FK position of the bat joint at the hit frame ``(3,)``."""
        return self.fk[1][self.hit_frame, self.bat_joint]

    @property
    def num_frames(self) -> int:
        return self.clip.num_frames


def conform_to_rig(rig: Rig, skeleton: Skeleton, clip: Clip, where: str) -> tuple[Skeleton, Clip]:
    """The clip with its joints in the rig's order; a clear error if they differ."""
    if sorted(skeleton.names) != sorted(rig.skeleton.names):
        missing = sorted(set(rig.skeleton.names) - set(skeleton.names))
        extra = sorted(set(skeleton.names) - set(rig.skeleton.names))
        detail = (f"missing {', '.join(missing[:3])}" if missing else f"unknown {', '.join(extra[:3])}")
        raise ValueError(f"{where}: joints do not match the rig ({detail})")
    if skeleton.names != rig.skeleton.names:
        skeleton, clip = reorder_joints(skeleton, clip, rig.skeleton.names)
    return skeleton, clip


MAX_MANIFEST_BYTES = 1024 * 1024   # a manifest is a short list, never megabytes
MAX_SHOTS = 1000
MAX_NAME = 64                      # characters in a shot name
MAX_DESCRIPTION = 2000             # characters in a description
MAX_FILE_NAME = 4096               # characters in an entry's file (a path)
MAX_INT_DIGITS = 64                # digits of a JSON integer (Python refuses int() past 4300)
_FIELDS = {"name": "a shot name (text)", "file": "a BVH file name (text)",
           "hit_frame": "a frame number (an integer)"}


class LibraryError(ValueError):
    """A malformed manifest; ``str(err)`` is one line: manifest, entry, what was expected."""

    def __init__(self, manifest: Path, message: str, entry: int | None = None, line: int | None = None):
        where = bvh.shown_path(str(manifest))
        where += f", line {line}" if line else ""
        where += f", entry {entry}" if entry is not None else ""
        super().__init__(f"{where}: {message}")


def _kind(value) -> str:
    """The JSON name of a value's type, for messages."""
    names = {bool: "true/false", int: "an integer", float: "a number", str: "text",
             list: "a list", dict: "an object", type(None): "null"}
    return names.get(type(value), type(value).__name__)


def _json_int(text: str) -> int:
    digits = len(text.lstrip("-"))
    if digits > MAX_INT_DIGITS:
        raise ValueError(f"integer of {digits} digits (at most {MAX_INT_DIGITS}, MAX_INT_DIGITS)")
    return int(text)


def _json_float(text: str) -> float:
    v = float(text)
    if not math.isfinite(v):
        raise ValueError(f"number {bvh.quoted(text)} is not finite")
    return v


def _json_constant(name: str):
    raise ValueError(f"{name} is not a finite number")


def _json_object(pairs: list) -> dict:
    # json keeps the last of repeated keys silently; a repeated key is a typo
    obj = dict(pairs)
    if len(obj) != len(pairs):
        seen = set()
        repeated = next(k for k, _ in pairs if k in seen or seen.add(k))
        raise ValueError(f"key {bvh.quoted(repeated)} repeated in one object")
    return obj


def _read_json(manifest: Path):
    """The manifest's JSON value: plain data only, nothing executed."""
    try:
        with open(manifest, "rb") as f:
            data = f.read(MAX_MANIFEST_BYTES + 1)
    except FileNotFoundError:
        raise LibraryError(manifest, "manifest not found") from None
    except OSError as e:
        raise LibraryError(manifest, f"cannot read the manifest ({e.__class__.__name__})") from None
    if len(data) > MAX_MANIFEST_BYTES:
        raise LibraryError(manifest, f"manifest beyond {MAX_MANIFEST_BYTES} bytes (MAX_MANIFEST_BYTES)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        raise LibraryError(manifest, f"not UTF-8 text (byte 0x{data[e.start]:02x} at byte offset "
                           f"{e.start})", line=data.count(b"\n", 0, e.start) + 1) from None
    try:
        return json.loads(text, parse_int=_json_int, parse_float=_json_float,
                          parse_constant=_json_constant, object_pairs_hook=_json_object)
    except json.JSONDecodeError as e:
        raise LibraryError(manifest, f"not JSON ({e.msg} at column {e.colno})", line=e.lineno) from None
    except RecursionError:
        raise LibraryError(manifest, "not plain JSON data (nested too deeply)") from None
    except ValueError as e:   # from the parse hooks above
        raise LibraryError(manifest, f"not plain JSON data ({e})") from None


@dataclass
class ManifestEntry:
    """One checked manifest entry; ``path`` is its BVH file."""
    name: str
    file: str
    hit_frame: int
    description: str
    path: Path
    profile: str | None = None       # a rig profile (engine.profiles) for a capture on its own skeleton
    facing: int | str = "auto"       # a capture's turn to face the ball (engine.capture_facing)


def _check_text(manifest: Path, i: int, e: dict, key: str, limit: int) -> str:
    value = e[key]
    if not isinstance(value, str):
        raise LibraryError(manifest, f"{key!r} must be {_FIELDS.get(key, 'text')}, found {_kind(value)}", i)
    if not value and key in _FIELDS:
        raise LibraryError(manifest, f"{key!r} must not be empty (expected {_FIELDS[key]})", i)
    if len(value) > limit or not value.isprintable():
        raise LibraryError(manifest, f"{key!r} must be printable text of at most {limit} characters, "
                           f"found {bvh.quoted(value)}", i)
    return value


def _check_entry(manifest: Path, i: int, e) -> ManifestEntry:
    if not isinstance(e, dict):
        raise LibraryError(manifest, f"expected an object with name, file and hit_frame, found {_kind(e)}", i)
    for key, expected in _FIELDS.items():
        if key not in e:
            raise LibraryError(manifest, f"missing {key!r} (expected {expected})", i)
    name = _check_text(manifest, i, e, "name", MAX_NAME)
    file = _check_text(manifest, i, e, "file", MAX_FILE_NAME)
    description = _check_text(manifest, i, e, "description", MAX_DESCRIPTION) if "description" in e else ""
    profile = _check_text(manifest, i, e, "profile", MAX_NAME) if "profile" in e else None
    hit = e["hit_frame"]
    if type(hit) is not int or hit < 0:
        raise LibraryError(manifest, f"'hit_frame' must be a frame number (an integer >= 0), found "
                           f"{bvh.quoted(json.dumps(hit)) if type(hit) is int else _kind(hit)}", i)
    facing = e.get("facing", "auto")
    if facing != "auto" and (type(facing) is not int or facing % 90 or not 0 <= facing < 360):
        raise LibraryError(manifest, f"'facing' must be \"auto\" or 0, 90, 180 or 270 (degrees), found "
                           f"{bvh.quoted(json.dumps(facing)) if type(facing) is int else _kind(facing)}", i)
    path = manifest.parent / file
    if not path.is_file():
        raise LibraryError(manifest, f"file {bvh.quoted(file)} not found (expected a BVH file, "
                           "relative to the manifest's folder)", i)
    return ManifestEntry(name, file, hit, description, path, profile, facing)


def read_manifest(manifest: Path) -> list[ManifestEntry]:
    """The checked entries of a manifest (their BVH files exist, not yet read)."""
    entries = _read_json(manifest)
    if not isinstance(entries, list):
        raise LibraryError(manifest, f"expected a list of shot entries, found {_kind(entries)}")
    if not entries:
        raise LibraryError(manifest, "no shots (expected a list of at least one entry)")
    if len(entries) > MAX_SHOTS:
        raise LibraryError(manifest, f"{len(entries)} entries is beyond {MAX_SHOTS} (MAX_SHOTS)")
    checked, seen = [], {}
    for i, e in enumerate(entries):
        entry = _check_entry(manifest, i, e)
        if entry.name in seen:
            raise LibraryError(manifest, f"shot name {bvh.quoted(entry.name)} already used by "
                               f"entry {seen[entry.name]}", i)
        seen[entry.name] = i
        checked.append(entry)
    return checked


def load_library(manifest: str | Path | None = None, rig: Rig | None = None) -> list[Shot]:
    """Load every shot of a manifest (default: the bundled library).

    A malformed manifest raises :class:`LibraryError`, a malformed BVH file
    :class:`engine.bvh.BvhError` (both ValueErrors with one-line messages)."""
    rig = rig or default_rig()
    manifest = Path(manifest) if manifest else assets_dir() / "shots" / "library.json"
    shots = []
    for i, e in enumerate(read_manifest(manifest)):
        skel, clip = bvh.read(e.path)
        skel, clip = conform_to_rig(rig, skel, clip, str(e.path))
        if e.hit_frame >= clip.num_frames:
            raise LibraryError(manifest, f"hit_frame {e.hit_frame} outside the clip's frames "
                               f"0..{clip.num_frames - 1} ({bvh.quoted(e.file)})", i)
        shots.append(Shot(e.name, e.file, e.hit_frame, e.description, skel, clip, rig.bat_joint))
    return shots


def find_shot(shots: list[Shot], name: str) -> Shot:
    for s in shots:
        if s.name == name:
            return s
    raise KeyError(f"unknown shot {name!r} (known: {', '.join(s.name for s in shots)})")
