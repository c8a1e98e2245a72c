"""Reading a user's JSON file with bounds: a size cap, a nesting cap, finite
numbers only. Every failure is one UserError line naming the file, the
position where there is one and the limit."""
from __future__ import annotations

import json
from pathlib import Path

from app.errors import UserError, shorten

MAX_JSON_DEPTH = 32          # nested lists/objects; our formats need 4 at most
MAX_INT_DIGITS = 30          # an integer literal longer than this is no frame, score or size of ours


def read_json(path: str | Path, what: str, max_bytes: int):
    """The JSON value in ``path`` (``what`` names the kind of file in messages),
    refused if the file is over ``max_bytes``, is not UTF-8, is not valid JSON,
    nests deeper than MAX_JSON_DEPTH or holds NaN, Infinity or an overflowing
    number."""
    path = Path(path)
    text = _read_text(path, what, max_bytes)
    try:
        obj = json.loads(text, parse_constant=_no_constant, parse_float=_finite_float, parse_int=_bounded_int)
    except json.JSONDecodeError as e:
        raise UserError(f"{path}: not valid JSON (line {e.lineno}, column {e.colno}: {e.msg})") from None
    except RecursionError:
        raise UserError(f"{path}: nested deeper than {MAX_JSON_DEPTH} levels") from None
    except ValueError as e:          # raised by the number hooks below
        raise UserError(f"{path}: {e}") from None
    if nesting_depth(obj) > MAX_JSON_DEPTH:
        raise UserError(f"{path}: nested deeper than {MAX_JSON_DEPTH} levels")
    return obj


def nesting_depth(obj) -> int:
    """Levels of lists/dicts in ``obj`` (0 for a scalar), without recursion."""
    deepest, stack = 0, [(obj, 1)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict):
            node = list(node.values())
        if isinstance(node, (list, tuple)):
            deepest = max(deepest, depth)
            if depth <= MAX_JSON_DEPTH:          # deeper is refused anyway: stop walking
                stack.extend((child, depth + 1) for child in node)
    return deepest


def _read_text(path: Path, what: str, max_bytes: int) -> str:
    try:
        with path.open("rb") as f:
            data = f.read(max_bytes + 1)     # a bounded read: /dev/zero or a huge file cannot fill memory
    except FileNotFoundError:
        raise UserError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise UserError(f"{path} is a folder, not a {what}") from None
    if len(data) > max_bytes:
        raise UserError(f"{path}: larger than the {max_bytes // 1_000_000} MB a {what} may be")
    try:
        return data.decode("utf-8-sig")         # a BOM (some Windows editors) is no error
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise UserError(f"{path}: not UTF-8 text (line {line}, byte {e.start}: {e.reason})") from None


def _no_constant(name: str):
    raise ValueError(f"{name} is not allowed: numbers must be finite")


def _finite_float(text: str) -> float:
    x = float(text)
    if x in (float("inf"), float("-inf")):
        raise ValueError(f"number {shorten(text)} is too large: numbers must be finite")
    return x


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INT_DIGITS:
        raise ValueError(f"integer {shorten(text)} has more than {MAX_INT_DIGITS} digits")
    return int(text)
