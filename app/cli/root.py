"""The ``hitpoint`` command. Each sub-command lives in its own ``app.cli.*``
module exposing ``register(cli)``; they import heavy libraries (numba, GL, imgui) only
when they run, so that ``--help`` and a bad option answer at once."""
from __future__ import annotations

import sys

import typer

from app.cli import adapt as cmd_adapt, analyse as cmd_analyse, bench as cmd_bench, render as cmd_render
from app.cli import shots as cmd_shots, synth as cmd_synth, view as cmd_view, library as cmd_library
from app.cli import reconstruct as cmd_reconstruct, terrain as cmd_terrain
from app.errors import one_line

cli = typer.Typer(add_completion=False, no_args_is_help=False,
                  help="Hitpoint: adapt motion-captured cricket shots to any hit point.")

for _module in (cmd_view, cmd_shots, cmd_render, cmd_adapt, cmd_bench, cmd_analyse, cmd_synth, cmd_library):
    _module.register(cli)
cmd_reconstruct.register(cli)          # learnt IK (issue 17)
cmd_terrain.register(cli)
NO_ENGINE_COMMANDS = ("shots",)     # commands that run no compiled engine code


@cli.callback(invoke_without_command=True)
def _default(ctx: typer.Context):
    """With no sub-command, open the viewer on the bundled library. Before any command
    that runs the engine: a note on stderr if its kernels compile for more than a moment."""
    if ctx.invoked_subcommand not in NO_ENGINE_COMMANDS:
        from app.cli import compile_note  # imports numba (~0.25 s): not for --help or `shots`
        compile_note.install()
    if ctx.invoked_subcommand is None:
        ctx.invoke(cmd_view.view)


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
