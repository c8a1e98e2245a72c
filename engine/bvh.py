"""BVH reader and writer.

Reads any rotation channel order per joint, End Sites, root-only or per-joint
translation channels, CRLF or LF, tabs, exponent notation. Malformed files
raise :class:`BvhError` whose message names the line and what was expected.
"""
from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from . import atomic, quat
from .skeleton import Clip, Skeleton

_ROT = {"Xrotation": "X", "Yrotation": "Y", "Zrotation": "Z"}
_POS = ("Xposition", "Yposition", "Zposition")


class BvhError(ValueError):
    """A malformed BVH file; ``str(err)`` is one line: path, line number, problem."""

    def __init__(self, message: str, line: int | None = None, path: str | None = None):
        self.line = line
        where = f"{path or 'BVH'}" + (f", line {line}" if line else "")
        super().__init__(f"{where}: {message}")


class _Tokens:
    def __init__(self, text: str, path: str | None):
        self.path = path
        self.toks: list[tuple[str, int]] = []
        for n, raw in enumerate(text.splitlines(), start=1):
            for t in raw.split():
                self.toks.append((t, n))
        self.i = 0

    def error(self, msg: str) -> BvhError:
        line = self.toks[min(self.i, len(self.toks) - 1)][1] if self.toks else 1
        return BvhError(msg, line, self.path)

    def peek(self) -> str | None:
        return self.toks[self.i][0] if self.i < len(self.toks) else None

    def next(self, what: str) -> str:
        if self.i >= len(self.toks):
            raise BvhError(f"unexpected end of file, expected {what}", self.toks[-1][1] if self.toks else 1, self.path)
        t = self.toks[self.i][0]
        self.i += 1
        return t

    def expect(self, word: str) -> None:
        t = self.next(f"'{word}'")
        if t != word:
            self.i -= 1
            raise self.error(f"expected '{word}', found '{t}'")

    def number(self, what: str) -> float:
        t = self.next(what)
        try:
            v = float(t)
        except ValueError:
            self.i -= 1
            raise self.error(f"expected {what} (a number), found '{t}'") from None
        if not math.isfinite(v):
            self.i -= 1
            raise self.error(f"expected {what} (a finite number), found '{t}'")
        return v

    def integer(self, what: str) -> int:
        t = self.next(what)
        if not re.fullmatch(r"[+-]?\d+", t):
            self.i -= 1
            raise self.error(f"expected {what} (an integer), found '{t}'")
        return int(t)


def _parse_joint(tk: _Tokens, parent: int, names, parents, offsets, channels, end_sites):
    name = tk.next("a joint name")
    if name in ("{", "}"):
        tk.i -= 1
        raise tk.error(f"expected a joint name, found '{name}'")
    if name in names:
        tk.i -= 1
        raise tk.error(f"duplicate joint name '{name}'")
    j = len(names)
    names.append(name)
    parents.append(parent)
    tk.expect("{")
    tk.expect("OFFSET")
    offsets.append([tk.number("OFFSET x"), tk.number("OFFSET y"), tk.number("OFFSET z")])
    tk.expect("CHANNELS")
    n = tk.integer("a channel count")
    if n < 0 or n > 6:
        tk.i -= 1
        raise tk.error(f"channel count must be 0..6, found {n}")
    chans = []
    for _ in range(n):
        c = tk.next("a channel name")
        if c not in _ROT and c not in _POS:
            tk.i -= 1
            raise tk.error(f"expected a channel name (Xposition..Zrotation), found '{c}'")
        if c in chans:
            tk.i -= 1
            raise tk.error(f"channel '{c}' repeated in joint '{name}'")
        chans.append(c)
    rot = [c for c in chans if c in _ROT]
    if len(rot) not in (0, 3):
        raise tk.error(f"joint '{name}' needs 0 or 3 rotation channels, has {len(rot)}")
    channels.append(chans)
    while True:
        t = tk.next("'JOINT', 'End Site' or '}'")
        if t == "}":
            return
        if t == "JOINT":
            _parse_joint(tk, j, names, parents, offsets, channels, end_sites)
        elif t == "End":
            tk.expect("Site")
            tk.expect("{")
            tk.expect("OFFSET")
            end_sites[j] = np.array([tk.number("OFFSET x"), tk.number("OFFSET y"), tk.number("OFFSET z")])
            tk.expect("}")
        else:
            tk.i -= 1
            raise tk.error(f"expected 'JOINT', 'End Site' or '}}', found '{t}'")


def parse(text: str, path: str | None = None) -> tuple[Skeleton, Clip]:
    """Parse BVH text into a skeleton and a clip."""
    tk = _Tokens(text, path)
    if not tk.toks:
        raise BvhError("empty file, expected 'HIERARCHY'", 1, path)
    tk.expect("HIERARCHY")
    tk.expect("ROOT")
    names, parents, offsets, channels, end_sites = [], [], [], [], {}
    _parse_joint(tk, -1, names, parents, offsets, channels, end_sites)
    tk.expect("MOTION")
    tk.expect("Frames:")
    F = tk.integer("the frame count")
    if F < 1:
        tk.i -= 1
        raise tk.error(f"frame count must be at least 1, found {F}")
    tk.expect("Frame")
    tk.expect("Time:")
    dt = tk.number("the frame time")
    if dt <= 0:
        tk.i -= 1
        raise tk.error(f"frame time must be positive, found {dt}")
    n_ch = sum(len(c) for c in channels)
    data_start = tk.i
    remaining = len(tk.toks) - data_start
    if remaining != F * n_ch:
        # Locate the first frame line with the wrong number of values.
        lines: dict[int, int] = {}
        for t, ln in tk.toks[data_start:]:
            lines[ln] = lines.get(ln, 0) + 1
        for k, (ln, count) in enumerate(sorted(lines.items())):
            if count != n_ch:
                raise BvhError(f"frame {k} has {count} values, expected {n_ch} (one per channel)", ln, path)
        raise BvhError(f"found {len(lines)} frame lines, expected {F} (the 'Frames:' count)",
                       tk.toks[-1][1], path)
    values = np.empty(F * n_ch)
    for k in range(F * n_ch):
        values[k] = tk.number(f"a channel value of frame {k // max(n_ch, 1)}")
    data = values.reshape(F, n_ch)
    return _build(names, parents, offsets, channels, end_sites, data, dt)


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
    clip = Clip(local_positions[:, 0].copy(), rotations, 1.0 / dt,
                local_positions if animated_positions else None)
    return skel, clip


def read(path: str | os.PathLike) -> tuple[Skeleton, Clip]:
    """Read a BVH file. Missing or unreadable files raise :class:`BvhError` too."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8", errors="strict")
    except FileNotFoundError:
        raise BvhError("file not found", None, str(p)) from None
    except (OSError, UnicodeDecodeError) as e:
        raise BvhError(f"cannot read file ({e.__class__.__name__})", None, str(p)) from None
    return parse(text, str(p))


def _fmt(v: float) -> str:
    s = f"{v:.9f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def format_bvh(skeleton: Skeleton, clip: Clip, euler: np.ndarray | None = None) -> str:
    """BVH text for a skeleton and clip (rotation channels in each joint's order)."""
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
        out.append(f"{ind}\tCHANNELS {len(chans)} " + " ".join(chans))
        for c in children[j]:
            emit(c, depth + 1)
        if j in skeleton.end_sites:
            out.append(f"{ind}\tEnd Site")
            out.append(f"{ind}\t{{")
            out.append(f"{ind}\t\tOFFSET " + " ".join(_fmt(v) for v in skeleton.end_sites[j]))
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
        e = quat.to_euler(clip.local_rotations[:, j], order) if euler is None else euler[:, j]
        cols.append(e)
    data = np.concatenate(cols, axis=1) if cols else np.zeros((F, 0))
    out += [" ".join(_fmt(v) for v in row) for row in data]
    return "\n".join(out) + "\n"


def write(path: str | os.PathLike, skeleton: Skeleton, clip: Clip) -> None:
    """Write atomically: a temporary file in the same folder, then a rename."""
    text = format_bvh(skeleton, clip)
    atomic_write_text(path, text)


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    """Write text atomically (see :mod:`engine.atomic`)."""
    atomic.write_text(path, text)
