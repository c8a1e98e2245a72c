"""``hitpoint shots``: list the bundled library or a user's."""
from __future__ import annotations

import json
from pathlib import Path

import typer

from app.errors import cli_errors
from engine.userlib import load_shots


def register(cli: typer.Typer) -> None:
    @cli.command("shots")
    @cli_errors
    def shots(as_json: bool = typer.Option(False, "--json", help="Print a JSON list of objects."),
              library: Path = typer.Option(None, "--library", help="A shot library: a folder with library.json, "
                                           "or the manifest (default: the bundled library).")):
        """List the shot library: name, file, frames, hit frame, FK hit point (cm)."""
        _, lib = load_shots(library)
        rows = [{"name": s.name, "file": s.file, "frames": s.num_frames, "hit_frame": s.hit_frame,
                 "hit_point": [round(float(v), 3) for v in s.hit_point]} for s in lib]
        if as_json:
            print(json.dumps(rows, indent=1))
            return
        print(f"{'name':<18}{'file':<26}{'frames':>7}{'hit':>5}  hit point (x, y, z) cm")
        for r in rows:
            x, y, z = r["hit_point"]
            print(f"{r['name']:<18}{r['file']:<26}{r['frames']:>7}{r['hit_frame']:>5}  ({x:7.1f}, {y:6.1f}, {z:6.1f})")
