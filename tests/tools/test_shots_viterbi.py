"""tools.shots_ik's Viterbi charges: the bat roll's continuity charge against brute force."""
import itertools

import numpy as np

from tools.shots_viterbi import continuity_charge, viterbi


def brute_force(cost, points, allowed, weight):
    F, K, P = cost.shape
    out = np.zeros((F - 1, K, K))
    for f, i, j in itertools.product(range(F - 1), range(K), range(K)):
        pairs = [0.5 * cost[f, i, p] + 0.5 * cost[f + 1, j, q]
                 + weight * max(0.0, np.linalg.norm(points[f, i, p] - points[f + 1, j, q]) - allowed[f]) ** 2
                 for p, q in itertools.product(range(P), range(P))]
        out[f, i, j] = min(pairs) - 0.5 * cost[f, i].min() - 0.5 * cost[f + 1, j].min()
    return out


def test_the_continuity_charge_is_the_cheapest_continuous_pair_beyond_the_best():
    rng = np.random.default_rng(3)
    cost = rng.uniform(0.0, 10.0, (4, 3, 5))
    points = rng.uniform(-30.0, 30.0, (4, 3, 5, 3))
    allowed = np.array([5.0, 20.0, 0.0])
    got = continuity_charge(cost, points, allowed, 3.0)
    assert np.allclose(got, brute_force(cost, points, allowed, 3.0), atol=1e-6)
    assert got.min() >= -1e-9


def test_no_charge_where_the_best_choices_already_join_up():
    """Each state's best sub-choice sits where the next frame's best is: nothing to pay."""
    cost = np.ones((3, 2, 4))
    cost[:, :, 1] = 0.0                               # sub-choice 1 is every state's best
    points = np.zeros((3, 2, 4, 3))
    points[..., 0] = np.arange(4) * 50.0              # sub-choice p sits 50 p cm along x
    assert np.allclose(continuity_charge(cost, points, np.full(2, 1.0), 3.0), 0.0)


def test_a_state_whose_best_choice_would_pop_is_charged_and_avoided():
    """Two rolls, both ends in roll 0: in roll 1 the best elbow jumps 60 cm between frames 1
    and 2, and keeping it in place there costs 5; roll 0 is 1 dearer a frame but continuous.
    Without the charge the Viterbi takes roll 1 through the pop; with it, only up to it."""
    F, P = 4, 2
    cost = np.zeros((F, 2, P))
    points = np.zeros((F, 2, P, 3))
    cost[:, 0, 1] = cost[:, 1, 1] = 50.0              # sub-choice 1: far from comfortable
    cost[:, 0, 0] = 1.0
    points[2:, 1, 0, 0] = 60.0                        # roll 1's comfortable elbow jumps at frame 2
    cost[2:, 1, 1] = 5.0                              # ... while its other stays put, at a price
    cost[[0, -1], 1] += 10.0                          # the shared end frames: roll 0
    charge = continuity_charge(cost, points, np.full(F - 1, 3.0), 3.0)
    unary = cost.min(2)
    assert charge[1, 1, 1] > 0.0 and charge[0, 0, 0] == 0.0
    charged, free = viterbi(unary, np.zeros(2), 0.0, extra=charge), viterbi(unary, np.zeros(2), 0.0)
    assert list(free) == [0, 1, 1, 0]                 # through the pop
    assert list(charged) == [0, 1, 0, 0]              # roll 1 only where its elbow stays put
    # the charges given frame by frame (as the arms' pass does) choose the same path
    assert list(viterbi(unary, np.zeros(2), 0.0, extra=lambda f: charge[f])) == list(charged)
