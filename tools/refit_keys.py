"""Re-fit the shots' bat keys to where a grip's arms hold the bat, and write them for the grip.

The bundled shots' bat keys were authored for the library grip. Built with another grip
(tools/grips), the authoring's passes (the roll, tools/shots_roll; the planning lean,
tools/shots_lean; the top hand's leans, tools/shots_grips.TopHand) turn the bat, frame by frame,
from its keys toward where that grip's arms hold it. Their choices step (a 15 deg grid of
leans, 10 deg top leans, 7.5 deg rolls), and where they step the bat jerks and its face turns
fast. This builds a shot, reads the bat as the top hand held it (the solver's ``bat_rot``),
smooths it over frames, and keys that axis and face at each of the shot's bat keys away from
the swing through the ball (it stays as authored: the face meets the ball as keyed) and from
the shared stance and rest. The keys then interpolate what the passes found, and the passes
start from there. Each round re-fits from the last round's build; the round whose build is
best (:func:`rank`: the library's bounds first, then face_keys.score) is kept, and written
into the grip's ``bat_keys`` file (tools/grips.bat_keys; the round of the keys as they are
included, so a shot is never made worse).

    python -m tools.refit_keys --grip anatomical [--only SHOT ...] [--rounds 3] [--sigmas 1.5 3 1]
"""
from __future__ import annotations

import argparse
import json
import sys
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from engine import bvh, quat
from engine.rig import rig_from_dict

from . import make_shots
from .face_keys import FACE_TURN_MAX, SWING_S, figures
from .grips import GRIPS, bat_keys
from .make_rig import rig as rig_dict
from .shots_defs import SHOTS, FPS_KEYS
from .shots_maths import gaussian_smooth

STANCE_S = -0.80        # the bat is keyed at the stance until here in every shot
REST_S = 0.16           # ... and at rest from this before the shot's last key
SMOOTH_FRAMES = (1.5, 3.0, 1.0)   # the solved bat's steps smoothed (Gaussian sigma, frames),
                                  # a round each in turn: the rounds do not settle, so each looks
                                  # somewhere else
CLAMP_DEG = 20.0        # a top arm clamped further than this into its limits leaves the keys


def fitted_keys(keys: list, bat_rot: np.ndarray, hit: int, sigma: float = SMOOTH_FRAMES[0]) -> list:
    """``[(t, bat_d, bat_n)]`` for each bat key of ``keys`` (a shot's, t in s from the hit) away
    from the swing, the stance and the rest: the solved bat frames ``bat_rot (F, 3, 3)``
    (columns: across the blade, face normal, up the handle), smoothed, at the key's time."""
    q = quat.make_continuous(quat.from_matrix(bat_rot))
    q = quat.normalize(gaussian_smooth(q, sigma, int(np.ceil(4 * sigma))))
    t_last = keys[-1][0]
    out = []
    for t, k in keys:
        if "bat_d" not in k or abs(t) < SWING_S or t <= STANCE_S + 1e-6 or t >= t_last - REST_S:
            continue
        f = float(np.clip(hit + t * FPS_KEYS, 0, len(q) - 1))
        f0 = min(int(f), len(q) - 2)
        m = quat.to_matrix(quat.slerp(q[f0], q[f0 + 1], f - f0))
        out.append((round(float(t), 4), np.round(-m[:, 2], 4), np.round(m[:, 1], 4)))   # as written
    return out


def rank(fig: dict) -> tuple:
    """Lower is better: how many of the library's bounds the build misses (the hit's problems,
    the face's turn, a jerk, the clamp), then face_keys.score."""
    misses = (fig["hit_problems"] + (fig["face_turn"] > FACE_TURN_MAX) + (fig["jerk"] > 0.0)
              + (fig["clamp"] > CLAMP_DEG))
    return misses, fig["score"]


def search(name: str, grip_name: str, rounds: int, sigmas=SMOOTH_FRAMES) -> tuple[list, dict, list]:
    """(the best round's fitted keys, its figures, every round's figures) for shot ``name``,
    its rounds smoothing the solved bat by ``sigmas`` in turn."""
    rig = rig_from_dict(rig_dict(grip_name))
    keys = SHOTS[name]()[0]
    fitted = bat_keys(name, GRIPS[grip_name])
    best, seen = None, []
    for r in range(rounds + 1):
        _, clip, hit, _, info = make_shots.build(name, rig, fitted=fitted)
        fig = figures(name, rig, clip, hit, info)
        seen.append(fig)
        if best is None or rank(fig) < rank(best[1]):
            best = (fitted, fig)
        fitted = fitted_keys(keys, info["bat_rot"], hit, sigmas[r % len(sigmas)])
    return best[0], best[1], seen


def _line(fig: dict) -> str:
    misses, score = rank(fig)
    return (f"misses {misses}, score {score:.0f} (face turn {fig['face_turn']:.1f}, jerk {fig['jerk']:+.1f}, "
            f"clamp {fig['clamp']:.1f}, hit problems {fig['hit_problems']}, pops {fig['pops']}, "
            f"horizontal {fig['horizontal']}, axial {fig['axial']}, folds {fig['folds']})")


def dumps(data: dict) -> str:
    """The bat keys file's text: a shot a block, a key ``[t, bat_d, bat_n]`` a line."""
    shots = [f" {json.dumps(name)}: [\n" + ",\n".join(f"  {json.dumps(k)}" for k in keys) + "\n ]"
             for name, keys in sorted(data.items())]
    return "{\n" + ",\n".join(shots) + "\n}\n"


def _search(args):
    return args[0], search(*args)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grip", required=True, choices=sorted(g for g in GRIPS if "bat_keys" in GRIPS[g]))
    ap.add_argument("--only", nargs="+", choices=sorted(SHOTS), help="these shots (default: all)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--sigmas", type=float, nargs="+", default=SMOOTH_FRAMES,
                    help="each round's smoothing (frames), in turn: a search that settled looks elsewhere")
    a = ap.parse_args(argv)
    path = Path(__file__).parent / GRIPS[a.grip]["bat_keys"]
    data = json.loads(path.read_text()) if path.exists() else {}
    names = a.only or list(SHOTS)
    with Pool(2) as pool:
        for name, (fitted, fig, seen) in pool.imap(_search, [(n, a.grip, a.rounds, a.sigmas) for n in names]):
            for r, f in enumerate(seen):
                print(f"{name} round {r}: {_line(f)}")
            print(f"{name} kept: {_line(fig)}", flush=True)
            data[name] = [[t, d.tolist(), n.tolist()] for t, d, n in fitted]
            bvh.atomic_write_text(path, dumps(data))    # each shot as it is found
    return 0


if __name__ == "__main__":
    sys.exit(main())
