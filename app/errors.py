"""One-line errors and exit status 2 for the command line, and the one check
every numeric option goes through (finite, in range, an integer where one is
meant)."""
from __future__ import annotations

import functools
import json
import math
import sys
import warnings

import typer

# Sane limits of the numeric options (the messages name them).
MAX_POSITION_CM = 10_000.0      # a hit point / ball target: 100 m is beyond any ground
MAX_FALLOFF_CM = 10_000.0       # importance falloff: further than that blends everything
MIN_FALLOFF_CM = 0.1            # ... and below a millimetre blends nothing
MIN_FPS, MAX_FPS = 1.0, 1000.0  # animation frame rate
MAX_TOKEN_CHARS = 40            # a user's value is echoed up to this many characters
MAX_LINE_CHARS = 400            # an error line longer than this is cut
MAX_HELD_WARNINGS = 20          # warnings held back while a command runs (see cli_errors)


class UserError(Exception):
    """Bad input from the user: reported as one line, exit status 2."""


def shorten(text, limit: int = MAX_TOKEN_CHARS) -> str:
    """``text`` as given, or its first ``limit`` characters and '…' (a huge token is never echoed)."""
    text = str(text)
    return text if len(text) <= limit else text[:limit] + "…"


def one_line(message) -> str:
    """The message as one line: line breaks become spaces, and it is cut at MAX_LINE_CHARS."""
    text = " ".join(str(message).split())
    return shorten(text, MAX_LINE_CHARS) if text else "error"


def number(option: str, value, low: float | None = None, high: float | None = None,
           integer: bool = False, choices: tuple | None = None):
    """``value`` (a number, or the text of one) checked for ``option``: finite,
    ``low <= value <= high``, a whole number with ``integer``, one of ``choices``.
    UserError names the option, the value (shortened) and what was expected."""
    given = shorten(str(value).strip())     # float() takes surrounding white space (and newlines)
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise UserError(f"{option}: {given!r} is not a number") from None
    except OverflowError:       # an integer past a float's range
        raise UserError(f"{option} must be a finite number, got {given}") from None
    if not math.isfinite(x):
        raise UserError(f"{option} must be a finite number, got {given}")
    if choices is not None and x not in choices:
        raise UserError(f"{option} must be {' or '.join(map(str, choices))}, got {given}")
    if integer or choices is not None:
        if x != int(x):
            raise UserError(f"{option} must be a whole number, got {given}")
        x = int(x)
    if (low is not None and x < low) or (high is not None and x > high):
        raise UserError(f"{option} must be between {_plain(low)} and {_plain(high)}, got {given}")
    return x


def _plain(limit: float) -> str:
    """A limit as people write it: 1000000, 0.1 (not 1e+06)."""
    return str(int(limit)) if float(limit).is_integer() else f"{limit:g}"


def numbers(option: str, values, low: float | None = None, high: float | None = None) -> list[float]:
    """Every value of a multi-value option checked by :func:`number`."""
    return [number(option, v, low, high) for v in values]


def position(option: str, values) -> list[float]:
    """An X Y Z point in cm, each coordinate within +-MAX_POSITION_CM."""
    if len(values) != 3:
        raise UserError(f"{option} needs 3 numbers (X Y Z cm), got {len(values)}")
    return numbers(option, values, -MAX_POSITION_CM, MAX_POSITION_CM)


def falloff(option: str, value) -> float:
    return number(option, value, MIN_FALLOFF_CM, MAX_FALLOFF_CM)


def trunk_reach(option: str, value) -> float:
    """Degrees a spine joint may turn from the source's (engine.adapt.AdaptSettings.trunk_reach)."""
    return number(option, value, 0.0, 180.0)


# Exceptions that mean "bad input", never a bug worth a traceback.
def _input_errors():
    from engine.bvh import BvhError      # the engine (numpy) only when an error is described
    return (UserError, BvhError, KeyError, ValueError, json.JSONDecodeError)


def describe_os_error(e: OSError) -> str:
    """``FILE: reason`` for a failed read or write (full disk, read-only folder, ...)."""
    if not e.strerror:
        return str(e)
    return f"{e.filename}: {e.strerror}" if e.filename else e.strerror


def fail(message: str) -> None:
    """Print ``error: message`` on stderr and exit with status 2."""
    print(f"error: {one_line(message)}", file=sys.stderr)
    raise typer.Exit(code=2)


def cli_errors(func):
    """Decorator for CLI commands: bad input or a failed read/write -> one line
    on stderr, exit 2. Warnings (numpy's on odd input, say) are held back while
    the command runs: shown after it if it succeeds, dropped if it refuses the
    input, so the error stays the only line."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        held: list = []
        with warnings.catch_warnings():
            warnings.showwarning = lambda *w, **k: held.append(w) if len(held) < MAX_HELD_WARNINGS else None
            try:
                result = func(*args, **kwargs)
            except typer.Exit:
                raise
            except _input_errors() as e:
                text = e.args[0] if isinstance(e, KeyError) and e.args else e
                fail(str(text))
            except OSError as e:
                fail(describe_os_error(e))
        for w in held:
            warnings.showwarning(*w)
        return result
    return wrapper
