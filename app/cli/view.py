"""``hitpoint view`` (and plain ``hitpoint``): the interactive viewer, or a
headless replay of scripted input that writes a screenshot and frame stats."""
from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated, Optional, Tuple

import typer

from app.errors import UserError, cli_errors, number

HEADLESS_DT = 1.0 / 60.0   # headless playback advances a fixed 60 Hz step: reproducible runs
MIN_SIDE_PX, MAX_SIDE_PX = 200, 8192    # window / framebuffer side
MAX_FRAMES = 1_000_000     # --frames: over four hours at 60 Hz


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
    library: Annotated[Optional[Path], typer.Option("--library", help="A shot library: a folder "
                                                    "with library.json, or the manifest (default: bundled).")] = None,
    fresh: Annotated[bool, typer.Option("--fresh", help="Start clean, not from the last session; that one "
                                        "is kept (renamed session.before-fresh-<time>.json) once this one "
                                        "changes.")] = False,
    session: Annotated[Optional[bool], typer.Option("--session/--no-session", help="Restore the last session "
                       "(settings, camera, every PC-pad take) and autosave it, to $HITPOINT_DATA_DIR or the "
                       "user data folder. Default: on with a window; off headless or with --script (runs stay "
                       "reproducible) unless HITPOINT_DATA_DIR is set.")] = None,
    software_gl: Annotated[str, typer.Option("--software-gl", help="The software-GL profile (cached layers, "
                           "partial redraws and presents): auto (on for llvmpipe/softpipe/swrast), on or off.")
                           ] = "auto",
    terrain: Annotated[Optional[str], typer.Option("--terrain", help="Draw this uneven ground (the SPEC given to "
                       "`hitpoint terrain`) instead of the pitch, e.g. with --library on a folder holding a "
                       "`hitpoint terrain` result.")] = None,
):
    """Open the viewer: drag the red-and-white target, the shot adapts every frame."""
    started = time.perf_counter()
    w, h = _parse_size(size)
    frames = number("--frames", frames, 0, MAX_FRAMES, integer=True)
    player = _checked_inputs(script, frames, library, screenshot, stats, terrain, software_gl)
    from app.viewer.loop import App
    from app.render.window import DisplayError
    try:
        from app.viewer.session import autosave_for
        app = App((w, h), headless=headless, manifest=library, started_at=started,
                  session=autosave_for(headless, script is not None, fresh, session))
    except DisplayError as e:
        raise UserError(str(e)) from None
    try:
        if terrain is not None:
            from app.viewer.terrain import show_terrain
            show_terrain(app.state, terrain)
        if headless or frames or player is not None:
            if headless:
                _refuse_failures(app)
            run_headless(app, frames, player)
            if headless:
                _refuse_failures(app)
        else:
            app.run()
        _write_outputs(app, screenshot, stats, (w, h), headless)
    finally:
        app.close()


def _checked_inputs(script, frames, library, screenshot, stats, terrain, software_gl):
    """Every input refused before a window opens (one line, exit 2); returns the script's
    player (None without --script) and sets the software-GL profile."""
    player = None
    if script is not None:
        from app.viewer.script import ScriptPlayer, load_script
        player = ScriptPlayer(load_script(script), str(script), frame_budget=frames or None)
    if library is not None and not (library.is_file() or (library / "library.json").is_file()):
        raise UserError(f"{library}: no shot library (a library.json, or a folder holding one: "
                        f"hitpoint library init FOLDER writes it)")
    _check_outputs(screenshot, stats)
    if terrain is not None:
        from app.cli.terrain_strip import load_terrain
        load_terrain(terrain)       # a bad SPEC is refused before a window opens
    from app import softgl
    if software_gl not in softgl.MODES:
        raise UserError(f"--software-gl {software_gl!r}: one of {', '.join(softgl.MODES)}")
    softgl.set_mode(software_gl)
    return player


def _write_outputs(app, screenshot, stats, size, headless) -> None:
    """The --screenshot PNG and the --stats JSON (and its one-line summary)."""
    if screenshot is not None:
        from app.viewer.capture import write_png
        write_png(screenshot, app.screenshot())
    if stats is None:
        return
    skip = min(10, app.frame_index // 10)
    data = app.stats.write(stats, skip=skip, size=list(size), headless=headless,
                           renderer=app.ctx.info.get("GL_RENDERER", "?"),
                           engine_solves=app.state.solve_count, errors=app.state.errors,
                           messages=[m for _, m in app.state.messages])
    f = data["frame_ms"]
    print(f"frames {data['frames']}: median {f['median']:.2f} ms, p95 {f['p95']:.2f}, "
          f"p99 {f['p99']:.2f}; first frame {data.get('time_to_first_frame_s', 0):.2f} s")


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
    return tuple(number("--size", side, MIN_SIDE_PX, MAX_SIDE_PX, integer=True) for side in (w, h))


def _check_outputs(screenshot: Optional[Path], stats: Optional[Path]) -> None:
    """UserError before the window opens for an output the run could not write."""
    if screenshot is not None:
        from app.cli.render import check_png_out
        check_png_out(screenshot, "--screenshot")
    if stats is not None:
        folder = stats.parent if str(stats.parent) else Path(".")
        if not folder.is_dir():
            raise UserError(f"--stats {stats}: folder {folder} does not exist")
        if stats.is_dir():
            raise UserError(f"--stats {stats} is a folder")


def _refuse_failures(app) -> None:
    """Headless, a missing piece (library, renderer) or an error reported while
    the script ran (a failed render, screenshot or export) fails the run: one line,
    exit 2, nothing written. A window shows the same messages and keeps running."""
    state = app.state
    broken = [f"{piece}: {why}" for piece, why in state.status.items() if why != "ok"]
    if broken:
        raise UserError(broken[0])
    if state.errors:
        more = f" (and {state.errors - 1} more)" if state.errors > 1 else ""
        raise UserError(f"{state.messages[-1][1] if state.messages else 'an error'}{more}")
