"""The drag force-air family: the law, its inversion in the step, its calibration from filtered data."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from dobwind.calibrate import dragfit
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe
from dobwind.model.forceair import DragLaw, drag_airflow_numpy, drag_force
from tests.helpers import M300, observed_force

LAWS = {
    "rotor drag, body y 50 % above x (per axis)": DragLaw(0.30, 0.0, l2c=-0.075, l2s=0.075),
    "body drag, front/back and deflection": DragLaw(0.0, 0.25, q2c=-0.05, q2s=0.03, q1c=0.02, lz=0.1, qz=0.2,
                                                    i1=0.01, i2=0.005),
    "mixed, every term": DragLaw(0.6, 0.12, 0.1, 0.02, 0.01, -0.05, 0.01, 0.3, 0.1, 0.02, 0.01),
}


@pytest.mark.parametrize("name", list(LAWS))
def test_inversion_round_trips_forward_law(name):
    law = LAWS[name]
    rng = np.random.default_rng(3)
    speed, angle, vz = rng.uniform(0.05, 15, 4000), rng.uniform(-math.pi, math.pi, 4000), rng.uniform(-4, 4, 4000)
    vx, vy = speed * np.cos(angle), speed * np.sin(angle)
    fx, fy, fz = drag_force(law, vx, vy, vz)
    back = drag_airflow_numpy(law, fx, fy, fz)
    assert np.abs(back[:, :2] - np.column_stack([vx, vy])).max() < 1e-4
    if law.lz + law.qz > 0:
        assert np.abs(back[:, 2] - vz).max() < 1e-4


def test_per_axis_drag_is_the_special_case_the_docstring_names():
    """F_x = kx v_x, F_y = ky v_y is l0 = (kx+ky)/2, l2c = (kx-ky)/2, l2s = -(kx-ky)/2."""
    kx, ky = 0.3, 0.45
    law = DragLaw((kx + ky) / 2, 0.0, l2c=(kx - ky) / 2, l2s=-(kx - ky) / 2)
    vx, vy = np.array([2.0, -1.0, 3.0]), np.array([1.0, 4.0, -2.0])
    fx, fy, _ = drag_force(law, vx, vy, np.zeros(3))
    np.testing.assert_allclose(fx, kx * vx, rtol=1e-12)
    np.testing.assert_allclose(fy, ky * vy, rtol=1e-12)
    # so the air does not move along the force: the model, not an assumption, gives its direction
    air = drag_airflow_numpy(law, fx, fy, np.zeros(3))
    np.testing.assert_allclose(air[:, :2], np.column_stack([vx, vy]), atol=1e-6)


def test_isotropic_quadratic_inverts_in_closed_form():
    law = DragLaw(0.0, 0.2)
    force = np.array([0.0, 0.05, 2.0, 20.0])
    air = drag_airflow_numpy(law, force, np.zeros(4), np.zeros(4))
    np.testing.assert_allclose(air[:, 0], np.sqrt(force / 0.2), atol=2e-4)
    assert np.all(np.isfinite(air))


def _drag_file(law: DragLaw) -> str:
    af = dataclasses.replace(load_airframe(M300), drag=law)
    return dump_airframe(af)


def test_airframe_round_trip_and_bad_keys():
    law = LAWS["mixed, every term"]
    af = parse_airframe(_drag_file(law), "x.toml")
    assert af.drag == law and af.force_air_model == "drag"
    assert parse_airframe(dump_airframe(af), "x.toml").drag == law
    text = _drag_file(dataclasses.replace(law, q0=-1.0))
    with pytest.raises(Exception, match="force_air.drag.q0"):
        parse_airframe(text, "x.toml")


def test_step_airflow_equals_the_inverted_law():
    """The step's force-air stage runs the same inversion: a steady force gives the law's airflow."""
    from dobwind.model.step import build_step

    law = LAWS["rotor drag, body y 50 % above x (per axis)"]
    af = parse_airframe(_drag_file(law), "x.toml")
    stage = next(s for s in build_step(af).stages if s.name == "force_air")
    fx, fy, _ = drag_force(law, np.array([3.0]), np.array([2.0]), np.zeros(1))
    air = stage.function(np.array([fx[0], fy[0], 0.0]), 0.0)[stage.outputs.index("air_rel_ned")]
    np.testing.assert_allclose(np.asarray(air).ravel()[:2], [3.0, 2.0], atol=1e-5)


def test_filtered_regression_recovers_a_known_law():
    """Synthetic force made by H from a known law, with noise and yaw changes: the fit returns the law."""
    af = load_airframe(M300)
    law = DragLaw(0.2, 0.08, l2c=0.02, q2c=0.01, l2s=-0.02, q2s=-0.005, lz=3.0, qz=0.2, i1=0.02, i2=0.01)
    rate, seconds = 50.0, 1200.0
    rng = np.random.default_rng(5)
    t = np.arange(int(rate * seconds)) / rate
    yaw = np.repeat(rng.uniform(-math.pi, math.pi, int(seconds / 20)), int(rate * 20))
    wind = np.repeat(rng.uniform(0, 9, int(seconds / 20)), int(rate * 20))
    climb = np.repeat(rng.uniform(-2, 2, int(seconds / 20)), int(rate * 20))
    air = np.column_stack([wind, np.zeros_like(wind), climb])
    c, s = np.cos(yaw), np.sin(yaw)
    air_c = np.column_stack([c * air[:, 0] + s * air[:, 1], -s * air[:, 0] + c * air[:, 1], air[:, 2]])
    fx, fy, fz = drag_force(law, air_c[:, 0], air_c[:, 1], air_c[:, 2])
    thrust = np.column_stack([np.zeros_like(t), np.zeros_like(t), np.full_like(t, 78.0)])
    kappa = 0.02
    force = np.column_stack([c * fx - s * fy, s * fx + c * fy, fz]) + kappa * thrust
    force_observed = observed_force(af, rate, force, 0.02, rng)
    part = dragfit.log_samples(af, 0.5, t, force_observed, air, thrust, yaw, np.ones(len(t), dtype=bool))
    samples = dragfit.merge([part])
    theta = dragfit.robust_fit(samples, ("l0", "q0", "l2c", "q2c", "l2s", "q2s") + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS)
    got = dict(zip(dragfit.PARAMETERS, theta))
    for key, value in law.as_dict().items():
        assert got[key] == pytest.approx(value, abs=0.003 + 0.03 * abs(value)), key
    assert got["kappa"] == pytest.approx(kappa, abs=0.002)


def test_direction_coverage_in_closed_form():
    """Airflow evenly spread over the circle: a quarter in each 45-deg sector of the axis, 135/360 from the
    front (within 67.5 deg of the nose) and as much from the back; one direction: one sector; airflow below
    DIRECTION_MIN_SPEED_MPS has no direction and is not counted."""
    theta = np.radians(np.arange(0.25, 360.0, 0.5))  # no sample on a sector boundary
    even = dragfit.direction_coverage(3.0 * np.column_stack([np.cos(theta), np.sin(theta)]))
    assert even.axial == pytest.approx((0.25,) * 4) and even.front == pytest.approx(135 / 360)
    assert even.back == pytest.approx(135 / 360) and even.moving == 720 and even.allows(("l0", "q0", "l2c", "q1c"))
    one = dragfit.direction_coverage(np.tile([[-4.0, 1.0]], (50, 1)))
    assert sorted(one.axial) == [0.0, 0.0, 0.0, 1.0] and one.back == 1.0 and one.front == 0.0
    assert one.allows(("l0", "q0")) and not one.allows(("l0", "q0", "q2c", "q2s")) and not one.allows(("q1c",))
    slow = dragfit.direction_coverage(0.9 * np.column_stack([np.cos(theta), np.sin(theta)]))
    assert slow.moving == 0 and not slow.allows(("l2c",))
    # the front and back both seen, but half the axis never: the axial harmonics are still unidentified
    ends = np.r_[np.radians(np.arange(-44.75, 45.0, 0.5)), np.radians(np.arange(135.25, 225.0, 0.5))]
    half = dragfit.direction_coverage(3.0 * np.column_stack([np.cos(ends), np.sin(ends)]))
    assert half.front == pytest.approx(0.5) and half.back == pytest.approx(0.5) and not half.allows(("l2c",))


def _anisotropic_samples(yaw_spread_rad: float) -> dragfit.DragSamples:
    """An anisotropic law (front/side drag 0.2/0.3 N per m/s) in 3-9 m/s of wind from the north, the
    heading held for 20 s at a time within +-``yaw_spread_rad`` of north."""
    af = load_airframe(M300)
    law = DragLaw(0.25, 0.06, l2c=-0.05, q2c=-0.01)
    rate, seconds = 20.0, 800.0
    rng = np.random.default_rng(7)
    t = np.arange(int(rate * seconds)) / rate
    hold = int(rate * 20)
    yaw = np.repeat(rng.uniform(-yaw_spread_rad, yaw_spread_rad, int(seconds / 20)), hold)
    air = np.column_stack([np.repeat(rng.uniform(3, 9, int(seconds / 20)), hold), np.zeros((len(t), 2))])
    c, s = np.cos(yaw), np.sin(yaw)
    air_c = np.column_stack([c * air[:, 0] + s * air[:, 1], -s * air[:, 0] + c * air[:, 1], air[:, 2]])
    fx, fy, fz = drag_force(law, air_c[:, 0], air_c[:, 1], air_c[:, 2])
    force = np.column_stack([c * fx - s * fy, s * fx + c * fy, fz])
    thrust = np.column_stack([np.zeros_like(t), np.zeros_like(t), np.full_like(t, 78.0)])
    observed = observed_force(af, rate, force, 0.02, rng)
    return dragfit.merge([dragfit.log_samples(af, 0.5, t, observed, air, thrust, yaw, np.ones(len(t), dtype=bool))])


@pytest.mark.parametrize("spread_deg", [15.0, 180.0])
def test_direction_harmonics_are_fitted_only_where_the_air_came_from_every_direction(spread_deg):
    """Headings within 15 deg of the wind: the harmonics are not candidates (they would trade with the
    isotropic terms and the offsets and extrapolate badly to directions never seen), and the choice says
    why. Headings all round: the anisotropy is identified and kept."""
    choice = dragfit.choose_drag_law(_anisotropic_samples(math.radians(spread_deg)), lambda samples, sets: 0)
    harmonics = set(dragfit.AXIAL_HARMONICS + dragfit.FORE_AFT_HARMONICS)
    if spread_deg < 90:
        assert not harmonics & set(choice.active) and choice.directions is not None
        assert not choice.directions.axial_identified()
    else:
        assert choice.directions is None and {"l2c", "q2c"} <= set(choice.active)
