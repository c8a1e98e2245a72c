"""The ``hitpoint`` command. Each sub-command lives in its own ``app.cmd_*``
module exposing ``register(cli)``; modules import heavy libraries lazily."""
from __future__ import annotations

import importlib

import typer

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


def main():
    cli()
