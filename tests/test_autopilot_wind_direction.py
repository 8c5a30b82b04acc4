"""The comparison with the autopilot's own wind says where each mean wind blows FROM (the meteorological
convention), from the two winds' north and east air velocities, in closed form."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.io.ulog import compare_with_px4
from dobwind.replay.replay import autopilot_wind_lines


def _compare(ours_ne, theirs_ne):
    t = np.arange(0.0, 10.0, 0.1)
    ours = np.tile([*ours_ne, 0.0], (len(t), 1))
    theirs = np.tile(theirs_ne, (len(t), 1))
    return compare_with_px4(t, ours, np.ones(len(t), bool), ("wind_estimate", t, theirs))


def test_each_mean_wind_has_its_speed_and_the_direction_it_blows_from():
    # Ours: air moving east at 4 m/s, a westerly (from 270). Theirs: air moving north at 3, a southerly (from 180).
    got = _compare([0.0, 4.0], [3.0, 0.0])
    assert got["mean_wind_ours_speed_mps"] == pytest.approx(4.0)
    assert got["mean_wind_ours_from_deg"] == pytest.approx(270.0)
    assert got["mean_wind_theirs_speed_mps"] == pytest.approx(3.0)
    assert got["mean_wind_theirs_from_deg"] == pytest.approx(180.0)
    assert got["direction_difference_deg"] == pytest.approx(90.0)
    lines = "\n".join(autopilot_wind_lines(got))
    assert "ours 4.00 m/s from 270 deg, theirs 3.00 m/s from 180 deg; direction +90 deg" in lines


def test_the_direction_difference_wraps_across_north():
    # Ours from 350 (air moving towards 170), theirs from 10 (towards 190): 20 deg apart, not 340.
    ours = -2.0 * np.array([np.cos(np.radians(350.0)), np.sin(np.radians(350.0))])
    theirs = -2.0 * np.array([np.cos(np.radians(10.0)), np.sin(np.radians(10.0))])
    got = _compare(ours, [*theirs, 0.0])
    assert got["direction_difference_deg"] == pytest.approx(-20.0)


def test_a_calm_mean_has_no_direction():
    got = _compare([0.0, 0.05], [1.0, 0.0])
    assert got["mean_wind_ours_from_deg"] is None and got["direction_difference_deg"] is None
    assert "ours 0.05 m/s, theirs 1.00 m/s from 180 deg" in "\n".join(autopilot_wind_lines(got))
