"""The ``hitpoint`` command. Each sub-command lives in its own ``app.cmd_*``
module exposing ``register(cli)``; modules import heavy libraries lazily."""
from __future__ import annotations

import importlib
import sys

import typer

from app.errors import one_line

cli = typer.Typer(add_completion=False, no_args_is_help=False,
                  help="Hitpoint: adapt motion-captured cricket shots to any hit point.")

COMMAND_MODULES = [
    "app.cmd_view", "app.cmd_shots", "app.cmd_render", "app.cmd_adapt",
    "app.cmd_bench", "app.cmd_analyse", "app.cmd_synth",
]

for _name in COMMAND_MODULES:
    try:
        _mod = importlib.import_module(_name)
    except ModuleNotFoundError as _e:  # a command not built yet
        if _e.name != _name:
            raise
        continue
    _mod.register(cli)


@cli.callback(invoke_without_command=True)
def _default(ctx: typer.Context):
    """With no sub-command, open the viewer on the bundled library."""
    if ctx.invoked_subcommand is None:
        try:
            from app.cmd_view import view
        except ModuleNotFoundError:
            typer.echo(ctx.get_help())
            raise typer.Exit(0)
        ctx.invoke(view)


def run(argv=None) -> int:
    """Run the command line ``argv`` (default: ``sys.argv[1:]``); its exit status.
    Click's usage errors (unknown or missing option, a value of the wrong type)
    become one ``error:`` line and status 2 like every other bad input, instead of
    the several-line box typer prints; ``--help`` is untouched."""
    command = typer.main.get_command(cli)
    try:
        status = command.main(args=argv, prog_name="hitpoint", standalone_mode=False)
    except typer.TyperException as e:        # click's UsageError, BadParameter, NoSuchOption, ...
        ctx = getattr(e, "ctx", None)
        where = ctx.command_path if ctx is not None else _command_path(command, argv)
        print(f"error: {where}: {one_line(e.format_message())}", file=sys.stderr)
        return 2
    except typer.Abort:                      # end of input at a prompt
        print("error: aborted", file=sys.stderr)
        return 2
    return status if isinstance(status, int) else 0


def _command_path(command, argv) -> str:
    """``hitpoint SUB`` for an error click raised before it made the sub-command's context."""
    args = sys.argv[1:] if argv is None else list(argv)
    sub = args[0] if args and args[0] in getattr(command, "commands", {}) else None
    return f"hitpoint {sub}" if sub else "hitpoint"


def main(argv=None):
    sys.exit(run(argv))
