"""``hitpoint view`` (and plain ``hitpoint``): the interactive viewer, or a
headless replay of scripted input that writes a screenshot and frame stats."""
from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Optional, Tuple

import typer

from app.errors import UserError, cli_errors

HEADLESS_DT = 1.0 / 60.0   # headless playback advances a fixed 60 Hz step: reproducible runs


def register(cli: typer.Typer) -> None:
    cli.command("view")(view)


@cli_errors
def view(
    size: Annotated[Tuple[int, int], typer.Option("--size", help="Window size W H in pixels.")] = (1280, 720),
    headless: Annotated[bool, typer.Option("--headless", help="No window: an EGL context (or a hidden "
                                           "window, on a private Xvfb if there is no DISPLAY).")] = False,
    frames: Annotated[int, typer.Option("--frames", help="Frames to run, then exit (default headless: "
                                        "until the script ends, min 60; with a window: until closed).")] = 0,
    script: Annotated[Optional[Path], typer.Option("--script", help="JSON list of timed input events "
                                                   "(also in a window: benchmarks of the real present path).")] = None,
    screenshot: Annotated[Optional[Path], typer.Option("--screenshot", help="Write the last frame as PNG.")] = None,
    stats: Annotated[Optional[Path], typer.Option("--stats", help="Write frame-time statistics as JSON.")] = None,
    library: Annotated[Optional[Path], typer.Option("--library", help="Shot library manifest "
                                                    "(default: bundled).")] = None,
):
    """Open the viewer: drag the red-and-white target, the shot adapts every frame."""
    started = time.perf_counter()
    w, h = _parse_size(size)
    if frames < 0:
        raise UserError("--frames must be >= 0")
    player = None
    if script is not None:
        from app.script import ScriptPlayer, load_script
        player = ScriptPlayer(load_script(script), str(script))
    if library is not None and not library.is_file():
        raise UserError(f"{library}: shot library not found")
    for out in (screenshot, stats):
        if out is not None and not out.resolve().parent.is_dir():
            raise UserError(f"{out}: folder does not exist")
    from app.viewer import App
    from app.window import DisplayError
    try:
        app = App((w, h), headless=headless, manifest=library, started_at=started)
    except DisplayError as e:
        raise UserError(str(e)) from None
    try:
        if headless or frames or player is not None:
            run_headless(app, frames, player)
        else:
            app.run()
        if screenshot is not None:
            from app.capture import write_png
            write_png(screenshot, app.screenshot())
        if stats is not None:
            skip = min(10, app.frame_index // 10)
            data = app.stats.write(stats, skip=skip, size=[w, h], headless=headless,
                                   renderer=app.ctx.info.get("GL_RENDERER", "?"),
                                   engine_solves=app.state.solve_count, errors=app.state.errors,
                                   messages=[m for _, m in app.state.messages])
            f = data["frame_ms"]
            print(f"frames {data['frames']}: median {f['median']:.2f} ms, p95 {f['p95']:.2f}, "
                  f"p99 {f['p99']:.2f}; first frame {data.get('time_to_first_frame_s', 0):.2f} s")
    finally:
        app.close()


def run_headless(app, frames: int, player=None) -> None:
    """A fixed number of frames at a fixed 60 Hz step (also in a window, which closing ends early)."""
    n = frames or max((player.last_frame + 2) if player is not None else 0, 60)
    for i in range(n):
        if player is not None:
            player.apply(app, i)
        app.frame(dt=HEADLESS_DT)
        if app.window.should_close():
            break
    app.finish_frame()


def _parse_size(size) -> tuple[int, int]:
    w, h = size if size else (1280, 720)
    if not (200 <= w <= 8192 and 200 <= h <= 8192):
        raise UserError(f"--size {w} {h}: each side must be 200..8192 pixels")
    return int(w), int(h)
