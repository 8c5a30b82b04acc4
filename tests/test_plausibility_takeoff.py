"""The hover force balance judges free-air hover only (issue #36, a new user's pass): on the PX4 SITL
x500 log the land detector declared flight ~2 s before lift-off (the rotors spooling up on the ground)
and of the 10 s hop only 1.2 s of near-hover was 0.5 m above the take-off, so the median "near-hover"
row was a ground row and replay told the user that `dobwind init`'s own airframe "does not fit this
vehicle" (0.74x)."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.model.airframe import load_airframe
from dobwind.model.status import STATUS_LANDED
from dobwind.replay.plausibility import FlightSeries, PlausibilityLimits, check_flight
from tests.helpers import M300

DT = 0.05


def _hop(weight: float, hover_s: float, hover_force_d: float, start_landed: bool = True) -> FlightSeries:
    """Landed 2 s; 'airborne' but on the ground 2.5 s (spool-up: the ground carries half the weight,
    f_d = -0.5 m g for an airframe that fits); climb 2 m at 1 m/s; hover; descend 2 m at 1 m/s;
    on the ground 2.5 s (spool-down); landed 2 s. NED: climbing is vel_d < 0."""
    phases = [(2.0, 0.0, 0.0, True), (2.5, 0.0, -0.5 * weight, False), (2.0, -1.0, 0.0, False),
              (hover_s, 0.0, hover_force_d, False), (2.0, 1.0, 0.0, False), (2.5, 0.0, -0.5 * weight, False),
              (2.0, 0.0, 0.0, True)]
    if not start_landed:
        phases = phases[2:5]
    vel_d, force_d, landed = [], [], []
    for seconds, vd, fd, on_ground in phases:
        n = int(round(seconds / DT))
        vel_d += [vd] * n
        force_d += [fd] * n
        landed += [on_ground] * n
    n = len(vel_d)
    z = np.zeros(n)
    status = np.where(landed, STATUS_LANDED, 0).astype(np.int64)
    return FlightSeries(np.arange(n) * DT, np.column_stack([z, z, vel_d]), np.column_stack([z, z, force_d]),
                        np.column_stack([np.full(n, 2.0), z, z]), status)


def test_ground_rows_after_the_land_detector_flips_are_not_hover():
    af = load_airframe(M300)
    weight = af.mass_kg * af.gravity_mps2
    # 2 s of hover at a perfect balance against 5 s of on-ground spool: the median near-hover row used to be a
    # ground row (ratio 0.5, "does not fit"); now those 2 s are too little to judge, and nothing is said.
    assert check_flight(af, _hop(weight, 2.0, 0.0)) == []
    # Long enough a hover is judged, and on the hover rows only: a fitting airframe passes ...
    assert check_flight(af, _hop(weight, 10.0, 0.0)) == []
    # ... a wrong one is found with the hover's own ratio, not a blend with the ground rows.
    found = check_flight(af, _hop(weight, 10.0, -0.4 * weight))
    assert [f.check for f in found] == ["hover_thrust"] and found[0].value == pytest.approx(0.6)
    assert "median over 10 s" in found[0].message


def test_without_a_take_off_in_the_log_every_near_hover_row_counts():
    """A log that begins in the air (or a CSV log, which has no ground state) has no take-off height:
    its hover rows are judged from the first row on."""
    af = load_airframe(M300)
    weight = af.mass_kg * af.gravity_mps2
    found = check_flight(af, _hop(weight, 6.0, -0.4 * weight, start_landed=False))
    assert [f.check for f in found] == ["hover_thrust"] and found[0].value == pytest.approx(0.6)


def test_the_height_guard_is_the_limit_it_names():
    af = load_airframe(M300)
    weight = af.mass_kg * af.gravity_mps2
    hop = _hop(weight, 10.0, -0.4 * weight)
    # The hover sits 2 m above the take-off: a guard above that leaves no hover to judge.
    assert check_flight(af, hop, PlausibilityLimits(hover_min_height_m=2.5)) == []
    assert check_flight(af, hop, PlausibilityLimits(hover_min_height_m=1.5))[0].value == pytest.approx(0.6)
