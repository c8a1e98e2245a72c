"""numba's disk cache in a directory keyed by the engine's sources (engine/__init__.py)."""
import os
import subprocess
import sys
import time
from pathlib import Path

import engine


def test_the_key_follows_every_source_file(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "b.py").write_text("y = 2\n")
    k0 = engine.sources_key(tmp_path)
    assert engine.sources_key(tmp_path) == k0
    (tmp_path / "b.py").write_text("y = 3\n")      # a callee's module, not the kernel's own
    k1 = engine.sources_key(tmp_path)
    assert k1 != k0
    (tmp_path / "c.py").write_text("")
    assert engine.sources_key(tmp_path) not in (k0, k1)


def test_kernels_cache_in_the_keyed_directory():
    from numba.core import config

    from engine import end_nb
    here = Path(engine.__file__).resolve().parent
    assert engine.NUMBA_CACHE_DIR.name == engine.CACHE_PREFIX + engine.sources_key(here)
    assert Path(config.CACHE_DIR) == engine.NUMBA_CACHE_DIR
    assert Path(end_nb.grip_solve._cache._cache_path).is_relative_to(engine.NUMBA_CACHE_DIR)


def test_a_users_cache_dir_is_where_the_keyed_directory_goes(tmp_path):
    code = "import engine, os; print(engine.NUMBA_CACHE_DIR); print(os.environ['NUMBA_CACHE_DIR'])"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    mine, child_env = out.stdout.split()
    assert Path(mine).parent == tmp_path and Path(mine).name.startswith(engine.CACHE_PREFIX)
    # a child process inherits the keyed directory as it is, not one inside it
    env["NUMBA_CACHE_DIR"] = child_env
    again = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert again.stdout.split()[0] == mine


def test_old_directories_of_other_sources_are_pruned(tmp_path):
    keep = tmp_path / (engine.CACHE_PREFIX + "current")
    old = tmp_path / (engine.CACHE_PREFIX + "old")
    recent = tmp_path / (engine.CACHE_PREFIX + "recent")     # another checkout may be using it
    mine = tmp_path / "not-ours"
    for d in (keep, old, recent, mine):
        d.mkdir()
        (d / "k.nbi").write_bytes(b"x")
    hours_ago = time.time() - 2 * engine.PRUNE_AFTER_S
    for d in (keep, old, mine):
        os.utime(d, (hours_ago, hours_ago))
    engine._prune(tmp_path, keep)
    assert keep.exists() and recent.exists() and mine.exists()
    assert not old.exists()
