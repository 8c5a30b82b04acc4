"""The drag fit's force offset is the force measured at zero airflow (dobwind/calibrate/zerooffset.py)."""
from __future__ import annotations

import math

import numpy as np

from dobwind.calibrate import dragfit
from dobwind.calibrate.zerooffset import MIN_ZERO_AIRFLOW_S, pinned_system, zero_airflow_offset
from dobwind.simulate.vehicle import AxisDrag, VehicleSpec, body_force

OFFSET = (0.12, -0.08)  # N, heading frame: a 4 kg vehicle's accelerometer bias (0.03, -0.02) m/s^2
# Per-axis drag, side 6x the front, shaped front/back (cos1): the law's q1c cannot follow that shape
# (benchmarks/anisovehicles/nv_longthin.vehicle.toml).
LONG_THIN = VehicleSpec(mass_kg=4.0, drag=(AxisDrag(0.02, 0.025), AxisDrag(0.05, 0.15), AxisDrag(0.4, 0.2)),
                        per_axis_speed=True, rotor_drag=0.2, shape_cos1=-0.2, shape_cos2=0.2)
LAW = ("l0", "q0", "l2c", "q2c", "q1c", "l2s", "q2s", "lz") + dragfit.ALWAYS


def _turned(m: np.ndarray, n: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Heading-frame (m, n) turned to NED by the yaw."""
    return np.column_stack([np.cos(yaw) * m - np.sin(yaw) * n, np.sin(yaw) * m + np.cos(yaw) * n, 0 * m])


def test_the_offset_is_the_heading_frame_force_at_zero_airflow_and_needs_ten_seconds():
    rows = int(round(MIN_ZERO_AIRFLOW_S / 0.1)) + 2   # 10.1 s of zero airflow and one sample with airflow
    yaw = np.linspace(0.0, 3.0, rows)
    observed = _turned(np.full(rows, OFFSET[0]), np.full(rows, OFFSET[1]), yaw)
    airflow = np.zeros((rows, 3))
    # A sample with airflow is not zero-airflow flight, whatever force it saw.
    airflow[0, 0], observed[0] = 1.0, (50.0, 50.0, 0.0)
    found = zero_airflow_offset(observed, np.cos(yaw), np.sin(yaw), airflow, np.full(rows, 0.1))
    assert found is not None and np.allclose(found, OFFSET, atol=1e-12)
    # 9.9 s of zero airflow: too short to measure it.
    short = slice(0, rows - 2)
    assert zero_airflow_offset(observed[short], np.cos(yaw[short]), np.sin(yaw[short]), airflow[short],
                               np.full(rows - 2, 0.1)) is None


def test_the_pinned_system_is_the_regression_with_the_known_columns_moved_across():
    rng = np.random.default_rng(1)
    a = rng.standard_normal((40, 4))
    truth = np.array([0.7, 0.12, -0.3, -0.08])   # columns 1 and 3 are ox, oy
    y = a @ truth + 0.01 * rng.standard_normal(40)
    names, gram, rhs = pinned_system(("l0", "ox", "q0", "oy"), a.T @ a, a.T @ y, (0.12, -0.08))
    known = a[:, [1, 3]] @ np.array([0.12, -0.08])
    expected = np.linalg.lstsq(a[:, [0, 2]], y - known, rcond=None)[0]
    assert names == ("l0", "q0") and np.allclose(np.linalg.solve(gram, rhs), expected, atol=1e-12)


def _samples(pinned: bool) -> dragfit.DragSamples:
    """Level flight from every direction at 1-8 m/s, then 30 s of hover, heading frame = NED."""
    theta, speed = np.meshgrid(np.radians(np.arange(0.0, 360.0, 5.0)), np.arange(1.0, 8.01, 0.5))
    moving = np.column_stack([speed.ravel() * np.cos(theta.ravel()), speed.ravel() * np.sin(theta.ravel())])
    airflow = np.column_stack([np.vstack([moving, np.zeros((300, 2))]), np.zeros(len(moving) + 300)])
    n = len(airflow)
    # Sensor noise: without it the robust fit's Huber scale would shrink to the noise-free hover's
    # residuals and weigh the hover above everything else.
    noise = 0.05 * np.random.default_rng(2).standard_normal((n, 3))
    force = body_force(LONG_THIN, airflow, np.ones(n)) + (*OFFSET, 0.0) + noise
    ones, zeros = np.ones(n), np.zeros(n)
    pin = zero_airflow_offset(force, ones, zeros, airflow, None) if pinned else None
    return dragfit.DragSamples(force, dragfit.basis(airflow), ones, zeros, airflow, np.arange(n) // 100,
                               np.zeros(n, int), offset_pin=pin)


def test_a_law_misfit_at_speed_does_not_move_the_offset_measured_at_zero_airflow():
    parameters = dragfit.PARAMETERS
    samples = _samples(True)
    pinned = dragfit.robust_fit(samples, LAW)
    assert samples.offset_pin is not None and np.allclose(samples.offset_pin, OFFSET, atol=0.01)
    assert math.isclose(pinned[parameters.index("ox")], samples.offset_pin[0], abs_tol=1e-12)
    assert math.isclose(pinned[parameters.index("oy")], samples.offset_pin[1], abs_tol=1e-12)
    # Fitted freely, the offset takes up the direction-independent part of the misfit: the premise.
    free = dragfit.robust_fit(_samples(False), LAW)
    assert abs(free[parameters.index("ox")] - OFFSET[0]) > 0.02 > 4 * abs(samples.offset_pin[0] - OFFSET[0])


def test_a_cv_split_measures_the_offset_on_its_own_samples():
    samples = _samples(True)
    moving = np.hypot(samples.airflow[:, 0], samples.airflow[:, 1]) > 0.5
    assert samples.select(moving).offset_pin is None   # no zero airflow left: fitted with the law
    hover_half = moving | (np.arange(len(samples)) % 2 == 0)
    split = samples.select(hover_half)
    assert split.offset_pin is not None and split.offset_pin != samples.offset_pin
    assert np.allclose(split.offset_pin, OFFSET, atol=0.015)


def test_a_climb_or_descent_in_still_air_is_not_zero_airflow():
    """Zero horizontal airflow while climbing at 2 m/s is no zero-airflow flight: the vertical drag's
    horizontal part (a tilted body) is in the force there, so only the samples still on every axis count."""
    rows = 200
    yaw = np.zeros(rows)
    observed = _turned(np.full(rows, OFFSET[0]), np.full(rows, OFFSET[1]), yaw)
    airflow = np.zeros((rows, 3))
    airflow[:150, 2], observed[:150, :2] = -2.0, (1.0, -1.0)   # 15 s climbing, 5 s of hover
    assert zero_airflow_offset(observed, np.cos(yaw), np.sin(yaw), airflow, np.full(rows, 0.1)) is None
    airflow[:150, 2] = 0.0   # the same rows in hover: now 20 s of zero airflow, and the mean takes them in
    found = zero_airflow_offset(observed, np.cos(yaw), np.sin(yaw), airflow, np.full(rows, 0.1))
    assert found is not None and np.allclose(found, (0.75 + 0.25 * OFFSET[0], -0.75 + 0.25 * OFFSET[1]))
