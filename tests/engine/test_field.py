"""engine.field: the fielding regions and named positions, in DESIGN.md's azimuth convention
(0 straight back past the bowler, positive toward the batsman's off side)."""
import pytest

from engine import field


def test_regions_follow_the_azimuth_convention():
    assert field.region(0.0) == "straight"
    assert field.region(60.0) == "cover" and field.region(90.0) == "point"
    assert field.region(-70.0) == "mid-wicket" and field.region(-140.0) == "fine leg"
    assert field.region(179.0) == field.region(-181.0 + 360.0)
    assert field.region(540.0) == field.region(180.0)


def test_every_region_named_as_a_position_lies_in_its_region():
    named = {name for _, name in field.REGIONS if field._key(name) in field.POSITIONS}
    assert len(named) >= 9
    for name in named:
        assert field.region(field.position_azimuth(name)) == name


def test_positions_mirror_across_the_straight_line():
    """Off side positive, leg side negative: mid-off and mid-on, long-off and long-on, point
    and square leg sit at the same angle either side."""
    for off, leg in (("mid-off", "mid-on"), ("long-off", "long-on"), ("point", "square-leg"),
                     ("backward-point", "backward-square-leg")):
        assert field.position_azimuth(off) == -field.position_azimuth(leg) > 0.0


@pytest.mark.parametrize("spelling", ["square leg", "Square-Leg", "square_leg", "  SQUARE   LEG "])
def test_names_are_read_as_people_write_them(spelling):
    assert field.position_azimuth(spelling) == field.POSITIONS["square-leg"]


@pytest.mark.parametrize("spelling,name", [("midwicket", "mid-wicket"), ("Deep Mid Wicket", "mid-wicket"),
                                           ("deep cover", "cover"), ("silly point", "point"),
                                           ("short leg", "short-leg"), ("the slips", None), ("slips", "slip"),
                                           ("thirdman", "third-man"), ("long_on", "long-on")])
def test_run_together_and_deep_or_close_names_are_the_same_direction(spelling, name):
    """How deep a fielder stands does not change the ball's direction; names run together
    (midwicket) are the hyphenated ones; a name that is no position is still refused."""
    if name is None:
        with pytest.raises(ValueError):
            field.position_azimuth(spelling)
    else:
        assert field.position_azimuth(spelling) == field.POSITIONS[name]


def test_an_unknown_position_is_refused_with_the_names():
    for name in ("car park", "deep", "mid", ""):
        with pytest.raises(ValueError, match="mid-off"):
            field.position_azimuth(name)
