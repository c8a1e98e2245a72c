"""The field as a batsman names it: fielding regions and positions by the ball's azimuth
(DESIGN.md: degrees, 0 straight back past the bowler, positive toward the batsman's off side,
so the names hold for a left-hander too).

``region(az)`` says where a ball goes ("cover"); ``position_azimuth("mid-off")`` is where a
named position lies, for ``hitpoint adapt --direction mid-off``.
"""
from __future__ import annotations

from .face import wrap_deg

# (upper azimuth limit, region) from the leg side round to the off side; past the last
# limit, "behind, off side"
REGIONS = ((-160.0, "behind, leg side"), (-115.0, "fine leg"), (-80.0, "square leg"),
           (-25.0, "mid-wicket"), (-8.0, "mid-on"), (8.0, "straight"), (25.0, "mid-off"),
           (75.0, "cover"), (110.0, "point"), (160.0, "third man"))

# A right-hander's usual positions (ring and boundary alike), degrees: each region's own
# name lies inside its region
POSITIONS = {
    "straight": 0.0, "long-off": 10.0, "mid-off": 18.0, "extra-cover": 40.0, "cover": 60.0,
    "point": 90.0, "backward-point": 105.0, "gully": 125.0, "third-man": 145.0,
    "long-on": -10.0, "mid-on": -18.0, "mid-wicket": -55.0, "square-leg": -90.0,
    "backward-square-leg": -105.0, "fine-leg": -140.0,
    "slip": 160.0, "cow-corner": -40.0, "short-leg": -100.0, "long-leg": -150.0, "leg-slip": -165.0,
}
# how far out a fielder stands does not change the ball's direction
DISTANCES = ("deep", "short", "silly")


def region(azimuth_deg: float) -> str:
    """The fielding region a ball going ``azimuth_deg`` lands in."""
    a = float(wrap_deg(azimuth_deg))
    for limit, name in REGIONS:
        if a < limit:
            return name
    return "behind, off side"


def _key(name: str) -> str:
    return "-".join(str(name).strip().lower().replace("_", " ").replace("-", " ").split())


# the names as people run them together: "midwicket", "squareleg", "thirdman"
_JOINED = {k.replace("-", ""): k for k in POSITIONS}


def position_azimuth(name: str) -> float:
    """The azimuth of a named fielding position ("mid-off", "Square Leg", "third_man",
    "midwicket", "deep cover": how deep does not change the direction); ValueError,
    listing the names, for one it does not know."""
    words = _key(name).split("-")
    tries = [words, words[1:]] if len(words) > 1 and words[0] in DISTANCES else [words]
    joined = ["".join(w) for w in tries]
    key = next((_JOINED[j] for j in joined + [j.removesuffix("s") for j in joined] if j in _JOINED), None)
    if key is None:
        raise ValueError(f"{name!r} is not a fielding position ({', '.join(POSITIONS)})")
    return POSITIONS[key]
