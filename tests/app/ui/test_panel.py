"""The panel's readout formatting."""
import math

from app.ui.panel import _fmt


def test_a_readout_without_a_value_is_a_dash_not_nan():
    # while the solver compiles the readouts hold NaN: the panel shows a dash
    assert _fmt(math.nan, ".2f") == "-"
    assert _fmt(math.inf, ".1f") == "-"
    assert _fmt(0.0012, ".3f") == "0.001"
    assert _fmt(-3.25, ".1f") == "-3.2"
