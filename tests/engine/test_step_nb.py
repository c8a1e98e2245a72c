"""The one Levenberg-Marquardt loop (engine/step_nb.py: lm_loop) on a made-up problem
whose step overshoots when the damping is low: undone steps leave the pose exactly as it
was, the damping follows its schedule, the loop stops where its rules say; and the loop
compiled for a problem type is loaded from numba's disk cache by the next process."""
import os
import subprocess
import sys
from typing import NamedTuple

import numpy as np
from numba import njit

from engine.step_nb import NO, YES, lm_loop, lm_parts


class Toy(NamedTuple):
    """x (2,) walked toward target (2,) by ``reach / damping`` of the way: kept when the
    damping is above reach / 2, an overshoot (worse or equal) below. Each step logs
    (damping, x (2), cost) into log (N,4); count (1,) int64 the steps."""
    x: np.ndarray
    bak: np.ndarray
    target: np.ndarray
    reach: float
    tol: float
    log: np.ndarray
    count: np.ndarray


def _save(problem):
    problem.bak[:] = problem.x


def _restore(problem):
    problem.x[:] = problem.bak


def _step(problem, state, damping):
    i = problem.count[0]
    problem.log[i, 0] = damping
    problem.log[i, 1] = problem.x[0]
    problem.log[i, 2] = problem.x[1]
    problem.log[i, 3] = state[0]
    problem.count[0] = i + 1
    f = problem.reach / damping
    for c in range(2):
        problem.x[c] += f * (problem.target[c] - problem.x[c])


def _eval(problem):
    d0 = problem.target[0] - problem.x[0]
    d1 = problem.target[1] - problem.x[1]
    return (np.sqrt(d0 * d0 + d1 * d1),)


def _done(problem, state):
    return state[0] < problem.tol


lm_parts(Toy, _save, _restore, _step, _eval, _done)
loop = njit(lm_loop.py_func)        # uncached: a test's problem type stays out of the engine's cache


def _run(lm, stop, reach=1.0, tol=1e-9, x0=(3.0, -4.0)):
    p = Toy(np.array(x0), np.empty(2), np.array([0.1, 0.2]), reach, tol, np.full((200, 4), np.nan),
            np.zeros(1, np.int64))
    state, steps = loop(p, _eval(p), lm, stop)
    assert steps == p.count[0]
    return p, state[0], steps, p.log[:steps]


def test_an_undone_step_leaves_the_pose_exactly_and_damps_4x_a_kept_one_halves_to_the_floor():
    # reach 1: damping 0.1 and 0.4 overshoot, 1.6, 0.8 and 0.6 get closer
    for floor, undos in ((0.3, 5), (0.6, 2)):
        p, cost, steps, log = _run((0.1, floor, 1e3, NO), (np.int64(100), 0.0, 0.0, NO))
        undone = kept = 0
        for a, b in zip(log[:-1], log[1:]):
            if b[3] < a[3]:             # the step from a was kept
                kept += 1
                assert b[0] == max(floor, 0.5 * a[0])
            else:                       # undone: the very same pose and cost, 4 x the damping
                undone += 1
                assert b[1] == a[1] and b[2] == a[2] and b[3] == a[3]
                assert b[0] == 4.0 * a[0]
        assert undone >= undos and kept >= 5         # both branches seen
        assert (log[:, 0] == floor).any() == (floor == 0.6)     # halving stops at the floor
        assert cost < 1e-9 and steps < 100       # stopped on the tolerance
        assert np.hypot(*(p.x - p.target)) == cost


def test_a_step_that_only_makes_things_worse_ends_above_the_cap_with_the_pose_untouched():
    x0 = (3.0, -4.0)
    for lm, want in (((1.0, 0.3, 100.0, NO), [1.0, 4.0, 16.0, 64.0]), ((1.0, 0.3, 100.0, YES), [1.0])):
        p, cost, steps, log = _run(lm, (np.int64(100), 0.0, 0.0, NO), reach=-1.0, x0=x0)
        assert list(log[:, 0]) == want      # x4 until above the cap; or the first undo ends it
        assert tuple(p.x) == x0
        assert cost == np.hypot(3.0 - 0.1, -4.0 - 0.2)


def test_it_stops_on_a_stall_on_not_halving_and_at_once_when_already_done():
    # damping 3 with reach 1: each kept step leaves 2/3 of the error
    _, cost, steps, _ = _run((3.0, 3.0, 1e3, NO), (np.int64(100), 0.0, 0.0, YES))
    assert steps == 1 and np.isclose(cost, np.hypot(2.9, 4.2) * 2 / 3)
    _, cost_rel, steps_rel, _ = _run((3.0, 3.0, 1e3, NO), (np.int64(100), 0.0, 0.6, NO))
    assert steps_rel == 1            # gained 1/3 of the error, asked for 0.6 of the 2/3 left
    _, cost_abs, steps_abs, log = _run((3.0, 3.0, 1e3, NO), (np.int64(100), 1e-3, 0.0, NO))
    assert cost_abs < 3e-3 and steps_abs > 5 and log[-1, 3] - cost_abs < 1e-3
    _, _, steps_max, _ = _run((3.0, 3.0, 1e3, NO), (np.int64(4), 0.0, 0.0, NO))
    assert steps_max == 4
    p, cost0, steps0, _ = _run((3.0, 3.0, 1e3, NO), (np.int64(100), 0.0, 0.0, NO), tol=10.0)
    assert steps0 == 0 and tuple(p.x) == (3.0, -4.0)


CACHED = """
import numpy as np
from engine.ccd import chain_arrays
from engine.rig import default_rig
from engine.step_nb import PositionProblem, lm_eval, lm_loop, scratch, NO
ch = chain_arrays(default_rig(), "left_arm").packed()
n = len(ch.joints)
local = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
p = PositionProblem((1.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0), ch, local, np.zeros((n, 3)), (10.0, 20.0, 5.0),
                    scratch(n), 1e-3)
state = (100.0, (0.0, 0.0, 0.0))
lm_loop(p, state, (1.0, 1.0, 1e4, NO), (np.int64(5), 0.0, 0.0, NO))
print(sum(lm_loop.stats.cache_hits.values()), sum(lm_loop.stats.cache_misses.values()))
"""


def test_the_loop_for_a_problem_type_is_loaded_from_the_disk_cache_by_the_next_process(tmp_path):
    # the problem's parts are chosen by its type (overloads), not passed as compiled
    # functions, whose per-process ids would make every run's cache key new
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    runs = [subprocess.run([sys.executable, "-c", CACHED], env=env, capture_output=True, text=True, check=True)
            for _ in range(2)]
    assert runs[0].stdout.split() == ["0", "1"]     # compiled (and saved)
    assert runs[1].stdout.split() == ["1", "0"]     # loaded
