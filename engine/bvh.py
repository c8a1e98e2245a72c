"""BVH reader and writer.

Reads any rotation channel order per joint, End Sites, root-only or per-joint
translation channels, CRLF or LF, tabs, exponent notation, a UTF-8 byte-order
mark. Malformed files raise :class:`BvhError`: one line naming the file, the
line and what was expected. Sizes and magnitudes have the named limits below,
so a hostile file fails fast with a clear message instead of exhausting memory
or the stack, or giving non-finite poses.
"""
from __future__ import annotations

import math
import os
import re
from itertools import islice
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import atomic, euler as euler_angles, quat
from .skeleton import Clip, Skeleton

MAX_FILE_BYTES = 512 * 1024 * 1024   # refused before reading
MAX_TOKEN = 64                       # characters in a name or number
MAX_DEPTH = 64                       # nested joints (the root is level 1)
MAX_JOINTS = 1024
MAX_FRAMES = 1_000_000
MAX_JOINT_FRAMES = 5_000_000         # frames x joints: bounds the pose arrays (~150 bytes each)
MAX_VALUES = 20_000_000              # frames x channels: the motion data (8 bytes each)
MAX_OFFSET = 1e6                     # |offset| and |position channel|, file units
MAX_ANGLE = 1e5                      # |rotation channel|, degrees
MIN_FRAME_TIME, MAX_FRAME_TIME = 1e-4, 10.0   # s: 10 kHz .. 0.1 Hz
MAX_QUOTE = 40                       # characters of a token repeated in a message
MAX_PATH_SHOWN = 120                 # characters of a path repeated in a message

_ROT = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}
_POS = ("Xposition", "Yposition", "Zposition")
# One token longer than MAX_TOKEN is seen as a MAX_TOKEN + 1 prefix: a 200 MB
# blob without whitespace is never copied whole.
_TOKEN = re.compile(r"\S{1,%d}" % (MAX_TOKEN + 1))
_INTEGER = re.compile(r"[+-]?[0-9]+")
_CHUNK_CHARS = 1 << 22   # motion data is converted 4 MB at a time: junk fails in its first chunk
_EXACT_COUNT_CHARS = 1 << 22   # a frame line longer than this is not split to count its values


def _printable(text: str, limit: int) -> str:
    """``text`` cut to ``limit`` characters (+ '…'), control characters escaped."""
    shown = text if len(text) <= limit else text[:limit] + "…"
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in shown)


def quoted(token: str) -> str:
    """A token for a message: in quotes, cut to MAX_QUOTE characters, escaped."""
    return f"'{_printable(token, MAX_QUOTE)}'"


def shown_path(path: str) -> str:
    """A path for a message: its last MAX_PATH_SHOWN characters, escaped."""
    path = _printable(path, 10 ** 9)
    return path if len(path) <= MAX_PATH_SHOWN else "…" + path[-(MAX_PATH_SHOWN - 1):]


class BvhError(ValueError):
    """A malformed BVH file; ``str(err)`` is one line: path, line number, problem."""

    def __init__(self, message: str, line: int | None = None, path: str | None = None):
        self.line = line
        where = shown_path(path) if path else "BVH"
        where += f", line {line}" if line else ""
        super().__init__(f"{where}: {message}")


def _line_at(text: str, pos: int) -> int:
    """1-based line of character ``pos`` (files with lone CR line ends count CRs)."""
    lf = text.count("\n", 0, pos)
    return lf + 1 if lf or "\n" in text else text.count("\r", 0, pos) + 1


class _Tokens:
    """The header's tokens, read lazily: the first bad token fails at once."""

    def __init__(self, text: str, path: str | None):
        self.text, self.path = text, path
        self._matches = _TOKEN.finditer(text)
        self.start = self.end = 0   # span of the last token read

    def error(self, msg: str) -> BvhError:
        """An error at the last token read."""
        return BvhError(msg, _line_at(self.text, self.start), self.path)

    def next(self, what: str) -> str:
        m = next(self._matches, None)
        if m is None:
            raise self.error(f"unexpected end of file, expected {what}")
        self.start, self.end = m.span()
        token = m.group()
        if len(token) > MAX_TOKEN:
            raise self.error(f"expected {what}, found a token longer than {MAX_TOKEN} characters "
                             f"(MAX_TOKEN) {quoted(token)}")
        return token

    def expect(self, word: str) -> None:
        t = self.next(f"'{word}'")
        if t != word:
            raise self.error(f"expected '{word}', found {quoted(t)}")

    def number(self, what: str, limit: float = math.inf, limit_name: str = "") -> float:
        t = self.next(what)
        try:
            v = float(t)
        except ValueError:
            raise self.error(f"expected {what} (a number), found {quoted(t)}") from None
        if not math.isfinite(v):
            raise self.error(f"expected {what} (a finite number), found {quoted(t)}")
        if abs(v) > limit:
            raise self.error(f"{what} {quoted(t)} is beyond the limit ±{limit:g} ({limit_name})")
        return v

    def integer(self, what: str) -> int:
        t = self.next(what)
        if not _INTEGER.fullmatch(t):
            raise self.error(f"expected {what} (an integer), found {quoted(t)}")
        return int(t)   # at most MAX_TOKEN digits: far below Python's int-digit limit

    def offset(self) -> list[float]:
        return [self.number(f"OFFSET {a}", MAX_OFFSET, "MAX_OFFSET") for a in "xyz"]


class _Hierarchy:
    """Joints in file (depth-first) order, as parsed."""

    def __init__(self):
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[list[str]] = []
        self.end_sites: dict[int, np.ndarray] = {}


def _channels(tk: _Tokens, name: str) -> list[str]:
    tk.expect("CHANNELS")
    n = tk.integer("a channel count")
    if n < 0 or n > 6:
        raise tk.error(f"channel count must be 0..6, found {n}")
    chans = []
    for _ in range(n):
        c = tk.next("a channel name")
        if c not in _ROT and c not in _POS:
            raise tk.error(f"expected a channel name (Xposition..Zrotation), found {quoted(c)}")
        if c in chans:
            raise tk.error(f"channel {quoted(c)} repeated in joint {quoted(name)}")
        chans.append(c)
    rot = [c for c in chans if c in _ROT]
    if len(rot) not in (0, 3):
        raise tk.error(f"joint {quoted(name)} needs 0 or 3 rotation channels, has {len(rot)}")
    return chans


def _open_joint(tk: _Tokens, h: _Hierarchy, parent: int) -> int:
    """Read a joint's name, '{', OFFSET and CHANNELS; its index."""
    name = tk.next("a joint name")
    if name in ("{", "}") or not name.isprintable():
        raise tk.error(f"expected a joint name, found {quoted(name)}")
    if name in h.names:
        raise tk.error(f"duplicate joint name {quoted(name)}")
    if len(h.names) >= MAX_JOINTS:
        raise tk.error(f"more than {MAX_JOINTS} joints (MAX_JOINTS)")
    h.names.append(name)
    h.parents.append(parent)
    tk.expect("{")
    tk.expect("OFFSET")
    h.offsets.append(tk.offset())
    h.channels.append(_channels(tk, name))
    return len(h.names) - 1


def _end_site(tk: _Tokens, h: _Hierarchy, joint: int) -> None:
    tk.expect("Site")
    tk.expect("{")
    tk.expect("OFFSET")
    h.end_sites[joint] = np.array(tk.offset())
    tk.expect("}")


def _parse_hierarchy(tk: _Tokens) -> _Hierarchy:
    """HIERARCHY and the joint tree, with an explicit stack (no recursion)."""
    tk.expect("HIERARCHY")
    tk.expect("ROOT")
    h = _Hierarchy()
    open_joints = [_open_joint(tk, h, -1)]
    while open_joints:
        t = tk.next("'JOINT', 'End Site' or '}'")
        if t == "}":
            open_joints.pop()
        elif t == "JOINT":
            if len(open_joints) >= MAX_DEPTH:
                raise tk.error(f"joints nested more than {MAX_DEPTH} levels deep (MAX_DEPTH)")
            open_joints.append(_open_joint(tk, h, open_joints[-1]))
        elif t == "End":
            _end_site(tk, h, open_joints[-1])
        else:
            raise tk.error(f"expected 'JOINT', 'End Site' or '}}', found {quoted(t)}")
    return h


def _frame_count(tk: _Tokens, num_joints: int, num_channels: int) -> int:
    tk.expect("MOTION")
    tk.expect("Frames:")
    F = tk.integer("the frame count")
    if F < 1:
        raise tk.error(f"frame count must be at least 1, found {F}")
    if F > MAX_FRAMES:
        raise tk.error(f"frame count {F} is beyond {MAX_FRAMES} (MAX_FRAMES)")
    if F * num_joints > MAX_JOINT_FRAMES:
        raise tk.error(f"{F} frames of {num_joints} joints is beyond {MAX_JOINT_FRAMES} "
                       "joint-frames (MAX_JOINT_FRAMES)")
    if F * num_channels > MAX_VALUES:
        raise tk.error(f"{F} frames of {num_channels} channels is beyond {MAX_VALUES} "
                       "values (MAX_VALUES)")
    return F


def _frame_time(tk: _Tokens) -> float:
    tk.expect("Frame")
    tk.expect("Time:")
    dt = tk.number("the frame time")
    if not MIN_FRAME_TIME <= dt <= MAX_FRAME_TIME:
        raise tk.error(f"frame time must be {MIN_FRAME_TIME:g}..{MAX_FRAME_TIME:g} s "
                       f"(MIN_FRAME_TIME..MAX_FRAME_TIME), found {quoted(str(dt))}")
    return dt


def _chunk_end(text: str, start: int) -> int:
    """End of the chunk from ``start``: at whitespace, so no token is cut (a token
    longer than MAX_TOKEN may be: it is refused either way)."""
    cut = start + _CHUNK_CHARS
    if cut >= len(text):
        return len(text)
    for k in range(cut, max(start, cut - MAX_TOKEN - 1), -1):
        if text[k].isspace():
            return k
    return cut


class _Motion:
    """Where the motion data lies in the text, to place an error by value index."""

    def __init__(self, text: str, start: int, num_channels: int, path: str | None):
        self.text, self.start, self.path = text, start, path
        self.num_channels = num_channels
        self.chunks: list[tuple[int, int]] = []   # (text position, index of its first value)

    def error_at(self, k: int, msg: str) -> BvhError:
        """An error at value ``k`` of the data (0-based over all frames)."""
        pos, first = next((p, f) for p, f in reversed(self.chunks) if f <= k)
        m = next(islice(_TOKEN.finditer(self.text, pos), k - first, None))
        frame = k // max(self.num_channels, 1)
        return BvhError(f"expected a channel value of frame {frame} {msg}, found "
                        f"{quoted(m.group())}",
                        _line_at(self.text, m.start()), self.path)

    def count_error(self, num_frames: int, stop: int) -> BvhError:
        """Why the values do not fill ``num_frames`` lines: the first line (before
        ``stop``) with a wrong count, else the first line beyond the count, else
        how many lines there are. Stops early, so junk costs one chunk."""
        lines, pos = 0, self.start
        while pos < stop:
            end = self.text.find("\n", pos, stop)
            end = stop if end < 0 else end
            count, exact = self._count_values(pos, end)
            if count and count != self.num_channels:
                shown = count if exact else f"more than {self.num_channels}"
                return BvhError(f"frame {lines} has {shown} values, expected {self.num_channels} "
                                "(one per channel)", _line_at(self.text, pos), self.path)
            if count and lines == num_frames:
                return BvhError(f"more than {num_frames} frame lines (the 'Frames:' count)",
                                _line_at(self.text, pos), self.path)
            lines, pos = lines + (count > 0), end + 1
        return BvhError(f"found {lines} frame lines, expected {num_frames} (the 'Frames:' count)",
                        _line_at(self.text, max(stop - 1, self.start)), self.path)

    def _count_values(self, start: int, end: int) -> tuple[int, bool]:
        """Tokens in ``text[start:end]`` and whether that is exact: a long line
        stops counting at one too many."""
        if end - start <= _EXACT_COUNT_CHARS:
            return len(self.text[start:end].split()), True
        limit = self.num_channels + 1
        count = sum(1 for _ in islice(_TOKEN.finditer(self.text, start, end), limit))
        return count, count < limit

    def values(self, num_frames: int) -> np.ndarray:
        """All ``num_frames * num_channels`` numbers, converted a chunk at a time."""
        expected = num_frames * self.num_channels
        parts, n, pos = [], 0, self.start
        while pos < len(self.text):
            end = _chunk_end(self.text, pos)
            tokens = self.text[pos:end].split()
            room = expected - n   # a bad value within the count comes first, then a count error
            self.chunks.append((pos, n))
            parts.append(self._convert(tokens if len(tokens) <= room else tokens[:room], n))
            if len(tokens) > room:   # the scan covers the whole line the chunk ends in
                line_end = self.text.find("\n", end)
                raise self.count_error(num_frames, len(self.text) if line_end < 0 else line_end)
            n, pos = n + len(tokens), end
        if n != expected:
            raise self.count_error(num_frames, len(self.text))
        return np.concatenate(parts) if parts else np.empty(0)

    def _convert(self, tokens: list[str], first: int) -> np.ndarray:
        if tokens and max(map(len, tokens)) > MAX_TOKEN:
            k = next(i for i, t in enumerate(tokens) if len(t) > MAX_TOKEN)
            raise self.error_at(first + k, f"(at most {MAX_TOKEN} characters, MAX_TOKEN)")
        try:
            return np.fromiter(map(float, tokens), float, len(tokens))
        except ValueError:
            k = next(i for i, t in enumerate(tokens) if not _is_float(t))
            raise self.error_at(first + k, "(a number)") from None

    def check(self, data: np.ndarray, channels: list[list[str]]) -> None:
        """Every value finite and within its channel's limit."""
        limits = np.array([MAX_ANGLE if c in _ROT else MAX_OFFSET for chans in channels for c in chans])
        bad = np.flatnonzero(~(np.abs(data) <= limits).ravel())   # NaN compares False
        if bad.size == 0:
            return
        k = int(bad[0])
        if not math.isfinite(data.flat[k]):
            raise self.error_at(k, "(a finite number)")
        limit = limits[k % len(limits)]
        bound = f"±{MAX_ANGLE:g} degrees, MAX_ANGLE" if limit == MAX_ANGLE else f"±{MAX_OFFSET:g}, MAX_OFFSET"
        raise self.error_at(k, f"(within {bound})")


def _is_float(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def parse(text: str, path: str | None = None) -> tuple[Skeleton, Clip]:
    """Parse BVH text into a skeleton and a clip."""
    text = text[1:] if text.startswith("\ufeff") else text
    if _TOKEN.search(text) is None:
        raise BvhError("empty file, expected 'HIERARCHY'", 1, path)
    tk = _Tokens(text, path)
    h = _parse_hierarchy(tk)
    num_channels = sum(len(c) for c in h.channels)
    F = _frame_count(tk, len(h.names), num_channels)
    dt = _frame_time(tk)
    motion = _Motion(text, tk.end, num_channels, path)
    data = motion.values(F).reshape(F, num_channels)
    motion.check(data, h.channels)
    return _build(h.names, h.parents, h.offsets, h.channels, h.end_sites, data, dt)


@dataclass
class FileClip(Clip):
    """A clip as read from a BVH file, with the file's own Euler numbers
    ``file_euler (F, J, 3)`` degrees (each joint's channel order; zeros for a joint
    without rotation channels): the writer keeps them wherever the rotation is
    unchanged, so a file read and written back has the same numbers."""
    file_euler: np.ndarray | None = None

    def copy(self) -> "FileClip":
        base = super().copy()
        return FileClip(base.root_positions, base.local_rotations, base.fps, base.local_positions,
                        None if self.file_euler is None else self.file_euler.copy())


def _build(names, parents, offsets, channels, end_sites, data, dt):
    J = len(names)
    F = data.shape[0]
    offsets = np.array(offsets, float)
    orders, has_pos = [], []
    euler = np.zeros((F, J, 3))
    local_positions = np.broadcast_to(offsets, (F, J, 3)).copy()
    animated_positions = False
    col = 0
    for j, chans in enumerate(channels):
        rot = "".join(_ROT[c] for c in chans if c in _ROT)  # "" = no rotation channels
        orders.append(rot)
        has_pos.append(any(c in _POS for c in chans))
        k_rot = 0
        for c in chans:
            if c in _ROT:
                euler[:, j, k_rot] = data[:, col]
                k_rot += 1
            else:
                local_positions[:, j, _POS.index(c)] = data[:, col]
                if j > 0:
                    animated_positions = True
            col += 1
    rotations = np.empty((F, J, 4))
    rotations[:] = (1.0, 0.0, 0.0, 0.0)
    for order in set(orders) - {""}:
        sel = [j for j in range(J) if orders[j] == order]
        rotations[:, sel] = quat.from_euler(euler[:, sel], order)
    skel = Skeleton(names, np.array(parents), offsets, orders, has_pos, end_sites)
    clip = FileClip(local_positions[:, 0].copy(), rotations, 1.0 / dt,
                    local_positions if animated_positions else None, euler)
    return skel, clip


def read(path: str | os.PathLike) -> tuple[Skeleton, Clip]:
    """Read a BVH file. Missing, unreadable, oversized or non-UTF-8 files raise
    :class:`BvhError` too."""
    p = Path(path)
    return parse(_decode(_read_bytes(p), str(p)), str(p))


def _read_bytes(p: Path) -> bytes:
    try:
        with open(p, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size > MAX_FILE_BYTES:
                raise BvhError(f"file of {size} bytes is beyond {MAX_FILE_BYTES} (MAX_FILE_BYTES)",
                               None, str(p))
            # read one byte more than allowed: a growing file or a device cannot exceed it
            data = f.read(MAX_FILE_BYTES + 1)
    except FileNotFoundError:
        raise BvhError("file not found", None, str(p)) from None
    except OSError as e:
        raise BvhError(f"cannot read file ({e.__class__.__name__})", None, str(p)) from None
    if len(data) > MAX_FILE_BYTES:
        raise BvhError(f"file is beyond {MAX_FILE_BYTES} bytes (MAX_FILE_BYTES)", None, str(p))
    return data


def _decode(data: bytes, path: str) -> str:
    """UTF-8 text (a byte-order mark is dropped); else where the first bad byte is."""
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise BvhError("cannot read file: UTF-16 text, expected UTF-8", 1, path)
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line_start = data.rfind(b"\n", 0, e.start) + 1
        raise BvhError(f"cannot read file: not UTF-8 text (byte 0x{data[e.start]:02x} at column "
                       f"{e.start - line_start + 1}, byte offset {e.start})",
                       data.count(b"\n", 0, e.start) + 1, path) from None


def _fmt(v: float) -> str:
    s = f"{v:.9f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


END_SITE_SHARE = 0.25    # a leaf joint without an End Site gets one this share of its bone on


def end_site(skeleton: Skeleton, j: int) -> np.ndarray:
    """The End Site offset written under leaf joint ``j``: its own, else one that
    carries its bone on (importers then make a bone of that length; without one,
    Blender makes a 1 mm bone and warns). Joints with children get none: an End
    Site beside a JOINT confuses importers."""
    if j in skeleton.end_sites:
        return np.asarray(skeleton.end_sites[j], float)
    offset = np.asarray(skeleton.offsets[j], float)
    length = float(np.linalg.norm(offset))
    return offset * END_SITE_SHARE if length > 1e-9 else np.array([0.0, 1.0, 0.0])


def file_euler(skeleton: Skeleton, clip: Clip, limits: np.ndarray | None = None,
               reference: np.ndarray | None = None) -> np.ndarray:
    """The Euler numbers ``(F, J, 3)`` degrees a BVH (or CSV) of ``clip`` holds, in
    each joint's channel order: continuous over frames (:mod:`engine.euler`), from
    the branch inside ``limits (J, 3, 2)`` (same order) at frame 0, and equal to
    ``reference (F, J, 3)`` -- by default the numbers of the file ``clip`` was read
    from -- wherever the rotation is the same."""
    F, J = clip.num_frames, skeleton.num_joints
    if reference is None:
        reference = getattr(clip, "file_euler", None)
    if reference is not None and np.shape(reference) != (F, J, 3):
        reference = None     # another skeleton or clip length: nothing to keep
    return euler_angles.continuous(clip.local_rotations, skeleton.channel_orders, limits, reference)


def format_bvh(skeleton: Skeleton, clip: Clip, euler: np.ndarray | None = None, *,
               limits: np.ndarray | None = None, reference: np.ndarray | None = None,
               leaf_ends: bool = False) -> str:
    """BVH text for a skeleton and clip (rotation channels in each joint's order).

    ``euler (F, J, 3)`` degrees are written as given; by default they are
    :func:`file_euler` (continuous, ``limits`` and ``reference`` as there).
    End Sites: never beside a JOINT; with ``leaf_ends`` every leaf joint has one
    (:func:`end_site`), as importers want."""
    if euler is None:
        euler = file_euler(skeleton, clip, limits, reference)
    J = skeleton.num_joints
    out = ["HIERARCHY"]
    children = {j: skeleton.children(j) for j in range(J)}

    def emit(j: int, depth: int):
        ind = "\t" * depth
        kw = "ROOT" if j == 0 else "JOINT"
        out.append(f"{ind}{kw} {skeleton.names[j]}")
        out.append(f"{ind}{{")
        out.append(f"{ind}\tOFFSET " + " ".join(_fmt(v) for v in skeleton.offsets[j]))
        chans = (list(_POS) if skeleton.position_channels[j] else []) + \
            [f"{a}rotation" for a in skeleton.channel_orders[j]]
        out.append(f"{ind}\tCHANNELS {len(chans)}" + "".join(f" {c}" for c in chans))
        for c in children[j]:
            emit(c, depth + 1)
        if not children[j] and (leaf_ends or j in skeleton.end_sites):
            out.append(f"{ind}\tEnd Site")
            out.append(f"{ind}\t{{")
            out.append(f"{ind}\t\tOFFSET " + " ".join(_fmt(v) for v in end_site(skeleton, j)))
            out.append(f"{ind}\t}}")
        out.append(f"{ind}}}")

    emit(0, 0)
    # columns follow the file's depth-first joint order, not the array order
    dfs = [skeleton.names.index(line.split()[1]) for line in out
           if line.lstrip().startswith(("ROOT ", "JOINT "))]
    F = clip.num_frames
    out += ["MOTION", f"Frames: {F}", f"Frame Time: {1.0 / clip.fps:.8f}"]
    cols = []
    translations = clip.local_positions
    if translations is None:
        translations = np.broadcast_to(skeleton.offsets, (F, J, 3)).copy()
    translations = translations.copy()
    translations[:, 0] = clip.root_positions
    for j in dfs:
        if skeleton.position_channels[j]:
            cols.append(translations[:, j])
        order = skeleton.channel_orders[j]
        if not order:
            continue
        cols.append(euler[:, j])
    data = np.concatenate(cols, axis=1) if cols else np.zeros((F, 0))
    out += [" ".join(_fmt(v) for v in row) for row in data]
    return "\n".join(out) + "\n"


def write(path: str | os.PathLike, skeleton: Skeleton, clip: Clip, *, limits: np.ndarray | None = None,
          reference: np.ndarray | None = None) -> None:
    """Write atomically: a temporary file in the same folder, then a rename.
    Euler angles as :func:`file_euler` (``limits``, ``reference`` as there); an
    End Site on every leaf joint and none beside a JOINT (clean in Blender)."""
    text = format_bvh(skeleton, clip, limits=limits, reference=reference, leaf_ends=True)
    atomic_write_text(path, text)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write text atomically (see :mod:`engine.atomic`)."""
    atomic.write_text(path, text)
