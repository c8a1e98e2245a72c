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
}


def region(azimuth_deg: float) -> str:
    """The fielding region a ball going ``azimuth_deg`` lands in."""
    a = float(wrap_deg(azimuth_deg))
    for limit, name in REGIONS:
        if a < limit:
            return name
    return "behind, off side"


def _key(name: str) -> str:
    return "-".join(str(name).strip().lower().replace("_", " ").replace("-", " ").split())


def position_azimuth(name: str) -> float:
    """The azimuth of a named fielding position ("mid-off", "Square Leg", "third_man");
    ValueError, listing the names, for one it does not know."""
    key = _key(name)
    if key not in POSITIONS:
        raise ValueError(f"{name!r} is not a fielding position ({', '.join(POSITIONS)})")
    return POSITIONS[key]
