"""The ``hitpoint`` command line: ``root`` builds the typer app and turns every
error into one line; a module per sub-command (``adapt``, ``analyse``, ``bench``,
``render``, ``shots``, ``synth``, ``view``), each exposing ``register(cli)``."""
from app.cli.root import cli, main, run  # noqa: F401  (the console script is app.cli:main)
