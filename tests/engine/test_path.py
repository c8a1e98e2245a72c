"""engine.path_nb.cheapest_path against every path of small problems."""
import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.path_nb import cheapest_path


def _total(cost, charges, path):
    return cost[np.arange(len(path)), path].sum() + sum(charges[f, path[f], path[f + 1]] for f in range(len(path) - 1))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 6), st.integers(1, 3), st.integers(0, 2 ** 31 - 1))
def test_the_path_is_the_cheapest_of_all(frames, k, seed):
    rng = np.random.default_rng(seed)
    # whole numbers: ties are common, and the lower index must win them
    cost = rng.integers(0, 4, (frames, k)).astype(float)
    charges = rng.integers(0, 4, (max(frames - 1, 0), k, k)).astype(float)
    path = cheapest_path(cost, charges)
    assert path.shape == (frames,) and path.dtype == np.int64
    best = min(_total(cost, charges, np.array(p)) for p in itertools.product(range(k), repeat=frames))
    assert _total(cost, charges, path) == best


def test_a_charge_keeps_the_path_on_one_candidate():
    """Two candidates swap being cheaper every frame; switching costs more than staying pays."""
    cost = np.array([[0.0, 1.0], [1.0, 0.0]] * 3)
    stay = np.zeros((5, 2, 2))
    switch = stay + 5.0 * (1.0 - np.eye(2))
    assert cheapest_path(cost, stay).tolist() == [0, 1] * 3
    assert len(set(cheapest_path(cost, switch).tolist())) == 1
