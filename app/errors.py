"""One-line errors and exit status 2 for the command line."""
from __future__ import annotations

import functools
import sys

import typer


class UserError(Exception):
    """Bad input from the user: reported as one line, exit status 2."""


# Exceptions that mean "bad input", never a bug worth a traceback.
def _input_errors():
    from engine.bvh import BvhError
    import json
    return (UserError, BvhError, FileNotFoundError, KeyError, ValueError,
            json.JSONDecodeError, IsADirectoryError, PermissionError)


def fail(message: str) -> None:
    """Print ``error: message`` on stderr and exit with status 2."""
    msg = str(message).strip().splitlines()[0] if str(message).strip() else "error"
    print(f"error: {msg}", file=sys.stderr)
    raise typer.Exit(code=2)


def cli_errors(func):
    """Decorator for CLI commands: bad input -> one line on stderr, exit 2."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except typer.Exit:
            raise
        except _input_errors() as e:
            text = e.args[0] if isinstance(e, KeyError) and e.args else e
            fail(str(text))
    return wrapper
