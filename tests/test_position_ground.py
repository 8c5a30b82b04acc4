"""Height above the take-off point when the log records no home (dobwind/io/position.py): each flight
is measured from the ground it stood on, found from the landed rows, in closed form."""
from __future__ import annotations

import numpy as np

from dobwind.io.position import LocalHeight, Track, local_height_on_rows, on_rows


def _track(t: np.ndarray, alt: np.ndarray) -> Track:
    return Track(t, np.full_like(t, 47.0), np.full_like(t, 8.0), alt, "test track")


def test_a_log_that_begins_in_the_air_is_measured_from_where_it_landed():
    """A real PX4 log (no home_position) began 6 m up and landed: above the first position it read -6 m
    at the landing; the ground it landed on is the only ground the log knows."""
    t = np.arange(0.0, 40.0, 0.5)
    ground = 426.0
    up = np.where(t < 30.0, 6.0 + 0.3 * np.minimum(t, 20.0) - 0.8 * np.maximum(t - 20.0, 0.0), 0.0)
    landed = t >= 30.0
    pos = on_rows(_track(t, ground + up), t, landed)
    np.testing.assert_allclose(pos.height_m, up, atol=1e-9)
    assert "where it landed" in pos.height_source


def test_two_flights_from_different_grounds_each_from_its_own():
    """Two flights in one log, the second from a spot 20 m higher: each is measured from the ground
    it took off from (the landed rows just before it, not the whole stretch on the ground)."""
    t = np.arange(0.0, 60.0, 0.5)
    flight1, flight2 = (t >= 5) & (t < 20), (t >= 35) & (t < 50)
    landed = ~(flight1 | flight2)
    ground = np.where(t < 31.0, 300.0, 320.0)  # carried up the hill late in the stop
    up = np.where(flight1, 10.0, 0.0) + np.where(flight2, 4.0, 0.0)
    pos = on_rows(_track(t, ground + up), t, landed)
    np.testing.assert_allclose(pos.height_m[~landed], up[~landed], atol=1e-9)
    assert pos.height_source == "test track altitude above the ground before take-off"


def test_the_estimators_up_position_follows_the_same_rule():
    t = np.arange(0.0, 20.0, 0.1)
    landed = t >= 15.0
    up = np.where(landed, -3.0, -3.0 + 5.0 * (15.0 - t) / 15.0)  # EKF origin 3 m above the ground
    height, how = local_height_on_rows(LocalHeight(t, up, "XKF1.PD"), t, landed)
    np.testing.assert_allclose(height, up + 3.0, atol=1e-9)
    assert "up position above the ground where it landed" in how


def test_without_landed_rows_it_is_above_the_first_position():
    t = np.arange(0.0, 10.0, 1.0)
    pos = on_rows(_track(t, 100.0 + t), t, np.zeros(len(t), bool))
    np.testing.assert_allclose(pos.height_m, t)
    assert "first position" in pos.height_source


def test_the_ground_before_take_off_comes_before_a_home_that_is_not_on_it():
    """PX4 re-homed the x500 field log during its climb-out, 1.7 m above the ground it took off from: above
    home, the whole flight read 1.7 m low and the landing -2 m. The ground before the take-off is the
    take-off point; home serves where the log has no ground before the flight."""
    t = np.arange(0.0, 30.0, 0.5)
    landed = (t < 5.0) | (t >= 25.0)
    up = np.where(landed, 0.0, 8.0)
    ground = 184.1
    home = np.where(t < 6.0, ground, ground + 1.7)
    track = Track(t, np.full_like(t, 47.0), np.full_like(t, 8.0), ground + up, "vehicle_global_position", home)
    pos = on_rows(track, t, landed)
    np.testing.assert_allclose(pos.height_m, up, atol=1e-9)
    assert pos.height_source == "vehicle_global_position altitude above the ground before take-off"
    airborne_from_start = on_rows(track, t, t >= 25.0)  # no ground before: home, as it is then
    np.testing.assert_allclose(airborne_from_start.height_m[t < 25.0], (ground + up - home)[t < 25.0], atol=1e-9)
    assert "above home" in airborne_from_start.height_source


def test_a_land_detector_flicker_in_the_air_is_no_new_ground():
    """A landed flag for half a second 12 m up (a slow descent's ground contact), and one row of it at the
    take-off: neither is a stop, so the whole flight is measured from the ground before it, not from the
    altitude of the flicker (which read the rest of the flight 12 m low) nor from a single fix."""
    t = np.arange(0.0, 60.0, 0.1)
    ground = 500.0
    up = np.where((t >= 5) & (t < 55), 12.0, 0.0)
    noise = np.where(np.isclose(t, 5.2), 0.7, 0.0)  # one bad fix, where the detector flickered
    landed = (t < 5) | (t >= 55) | ((t >= 30) & (t < 30.5)) | np.isclose(t, 5.2)
    pos = on_rows(_track(t, ground + up + noise), t, landed)
    airborne = (t >= 5) & (t < 55) & ~np.isclose(t, 5.2)
    np.testing.assert_allclose(pos.height_m[airborne], up[airborne], atol=1e-9)
    assert pos.height_source == "test track altitude above the ground before take-off"


def test_a_log_that_begins_in_the_air_takes_the_ground_just_after_its_landing():
    """Landed, then carried 30 m down a slope in the rest of the log: the flight before is measured from
    where it touched down (the landed rows within GROUND_S after it), not from the whole landed stretch."""
    t = np.arange(0.0, 60.0, 0.5)
    landed = t >= 20.0
    ground = np.where(t < 28.0, 200.0, 170.0)
    up = np.where(landed, 0.0, 8.0)
    pos = on_rows(_track(t, ground + up), t, landed)
    np.testing.assert_allclose(pos.height_m[~landed], 8.0, atol=1e-9)
    assert "where it landed" in pos.height_source
