"""``hitpoint library init DIR``: a manifest for a folder of the user's own captures."""
from __future__ import annotations

import json
from pathlib import Path

import typer

from app.errors import UserError, cli_errors, number


def register(cli: typer.Typer) -> None:
    lib = typer.Typer(help="A shot library of your own captures (a folder of BVH files on one skeleton).",
                      no_args_is_help=True)
    cli.add_typer(lib, name="library")

    @lib.command("init")
    @cli_errors
    def init(folder: Path = typer.Argument(..., help="Folder of BVH files (one skeleton)."),
             profile: str = typer.Option("auto", "--profile", help="Rig profile (cmu, mixamo, neuron, hitpoint, "
                                         "generic, a profile .json) or auto (from the joint names)."),
             hit_frame: str = typer.Option("auto", "--hit-frame", help="Hit frame of every file, or auto "
                                           "(found per file: see the description it writes)."),
             force: bool = typer.Option(False, "--force", help="Write library.json again if it exists."),
             facing: str = typer.Option("auto", "--facing", help="Turn every capture about the vertical by 0, 90, "
                                        "180 or 270 deg, or auto (each one turned to meet the ball with its face)."),
             as_json: bool = typer.Option(False, "--json", help="Print the entries as JSON.")):
        """Write FOLDER/library.json: each BVH file's name, hit frame (found or given),
        profile and a description. Every file must read and share one skeleton."""
        from engine.capture_facing import check_facing
        from engine.userlib import init_library
        if not folder.is_dir():
            raise UserError(f"{folder}: not a folder")
        hf = hit_frame if hit_frame == "auto" else number("--hit-frame", hit_frame, 0, None, integer=True)
        try:
            turn = check_facing(facing)
        except ValueError as e:
            raise UserError(f"--facing: {e}") from None
        out, entries = init_library(folder, profile, hf, force, turn)
        if as_json:
            print(json.dumps(entries, indent=1))
            return
        print(f"wrote {out}: {len(entries)} shot{'s' if len(entries) != 1 else ''}, profile {entries[0]['profile']}")
        for e in entries:
            print(f"  {e['name']:<24} hit frame {e['hit_frame']:>5}  ({e['description']})")
