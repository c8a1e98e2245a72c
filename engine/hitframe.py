"""Finding the impact in a captured swing: where the implement comes back to
its address position at the fastest part of the swing.

A golfer (and a batsman) addresses the ball with the implement behind it and
meets the ball with the implement back at that position, moving fastest. So:
the frame of peak implement speed, then, within ``WINDOW_S`` of it, the frame
where the implement is closest to its address position — when it comes that
close (``RETURN_CM``); otherwise the speed peak itself.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import quat

WINDOW_S = 0.15          # impact lies this close to the speed peak (seconds)
RETURN_CM = 15.0         # "back at the address" when this close to it
ADDRESS_S = 0.25         # the address: the first quarter second of the motion
TPOSE_DEG = 20.0         # a first frame this far from the second is a T-pose the conversion added


@dataclass
class HitFrame:
    frame: int
    method: str              # how it was found, for the user
    peak_frame: int          # the implement's speed peak
    peak_speed_ms: float     # m/s
    first_frame: int         # 1 when frame 0 is an added T-pose


def motion_start(local_rotations: np.ndarray) -> int:
    """1 when frame 0 is a T-pose the conversion added (a jump no motion makes), else 0.

    local_rotations (F, J, 4)."""
    if local_rotations.shape[0] < 3:
        return 0
    step = quat.angle_between(local_rotations[:-1], local_rotations[1:]).max(axis=-1)   # (F-1,) radians
    typical = float(np.median(step[1:]))
    return int(np.degrees(step[0]) > TPOSE_DEG and step[0] > 10.0 * typical)


def find_hit_frame(points: np.ndarray, fps: float, first_frame: int = 0) -> HitFrame:
    """The impact of a swing from the implement's hit point ``points (F, 3)`` cm."""
    F = points.shape[0]
    if F - first_frame < 5:
        raise ValueError(f"{F} frames: too short to find an impact (give the hit frame)")
    p = points[first_frame:]
    speed = np.zeros(len(p))
    speed[1:-1] = np.linalg.norm(p[2:] - p[:-2], axis=-1) * fps / 2.0 / 100.0   # m/s
    kernel = np.ones(3) / 3.0       # one-frame jitter of a marker must not make the peak
    smooth = np.convolve(speed, kernel, mode="same")
    peak = int(np.argmax(smooth))
    n_address = max(1, int(round(ADDRESS_S * fps)))
    address = np.median(p[:n_address], axis=0)
    w = max(1, int(round(WINDOW_S * fps)))
    lo, hi = max(0, peak - w), min(len(p), peak + w + 1)
    d = np.linalg.norm(p[lo:hi] - address, axis=-1)
    k = int(np.argmin(d))
    if d[k] <= RETURN_CM:
        frame, method = lo + k, (f"the implement back at its address position ({d[k]:.1f} cm) "
                                 f"within {WINDOW_S:g} s of its speed peak")
    else:
        frame, method = peak, "the implement's speed peak"
    return HitFrame(frame + first_frame, method, peak + first_frame, float(speed[peak]), first_frame)
