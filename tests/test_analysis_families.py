"""Every analysis experiment on every force-air family, through the one force-air home
(model/forceair.py): the forward law and its inversion round trip, and the ramp lag meets its closed
form on a pure quadratic law (issue #33: on a body-frame drag airframe the ramp read -10.6 s)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dobwind.analysis.ramp import LAG_LEVELS_MPS, RAMP_RATE_MPS2, ramp_experiment
from dobwind.model import forceair
from tests.families import FAMILIES, family_airframe, pure_quadratic


@pytest.mark.parametrize("family", FAMILIES)
def test_forward_law_and_inversion_round_trip(family):
    """airframe_force then airframe_airflow gives the airflow back, tilted and yawed, every family."""
    af = family_airframe(family)
    rng = np.random.default_rng(4)
    # Speeds from 1 m/s: below it the test polynomial's constant term leaves no force to find.
    heading = rng.uniform(-math.pi, math.pi, 40)
    speed = rng.uniform(1.0, 9.0, 40)
    air = np.column_stack([speed * np.cos(heading), speed * np.sin(heading), rng.uniform(-1.5, 1.5, 40)])
    yaw = rng.uniform(-math.pi, math.pi, 40)
    rot = Rotation.from_euler("xyz", rng.uniform(-0.3, 0.3, (40, 3))).as_matrix()
    rotor = rng.uniform(0.8, 1.2, 40)
    force = forceair.airframe_force(af, air, yaw, rot, rotor)
    back = forceair.airframe_airflow(af, force, yaw, rot, rotor)
    np.testing.assert_allclose(back, air, atol=2e-3)
    # The force opposes nothing: drag pushes along the airflow (positive work on the vehicle).
    assert np.all(np.einsum("ij,ij->i", force - _offset_ned(af, yaw), air) > 0)


def _offset_ned(af, yaw):
    off = np.asarray(af.observer.force_offset_n)
    c, s = np.cos(yaw), np.sin(yaw)
    return np.column_stack([c * off[0] - s * off[1], s * off[0] + c * off[1], np.full_like(yaw, off[2])])


@pytest.mark.parametrize("family", FAMILIES)
def test_quadratic_law_force_is_a_s_squared(family):
    """The forward law of the pure quadratic airframes is the closed form a s^2 along the airflow."""
    af = pure_quadratic(family, 0.03)
    air = np.array([[4.0, 0.0, 0.0], [0.0, -7.0, 0.0], [3.0, 4.0, 0.0]])
    force = forceair.airframe_force(af, air, np.array([0.0, 0.3, -2.0]))
    speed = np.linalg.norm(air, axis=1)
    np.testing.assert_allclose(force[:, :2], 0.03 * speed[:, None] * air[:, :2], rtol=1e-6, atol=1e-9)


def _quadratic_ramp_lag(t_observer: float, t_filter: float) -> float:
    """Mean lag behind a ramp r t at LAG_LEVELS_MPS of a pure quadratic law through two first-order lags
    T1, T2 (continuous). F = a (r t)^2 filtered settles to a r^2 (t^2 - 2 tau t + 2 (T1^2 + T1 T2 + T2^2)),
    tau = T1 + T2; the estimate sqrt(F_hat / a) reaches L at t = tau + sqrt((L / r)^2 - T1^2 - T2^2)."""
    r, tau = RAMP_RATE_MPS2, t_observer + t_filter
    reach = tau + np.sqrt((LAG_LEVELS_MPS / r) ** 2 - t_observer ** 2 - t_filter ** 2)
    return float(np.mean(reach - LAG_LEVELS_MPS / r))


@pytest.mark.parametrize("family", FAMILIES)
def test_ramp_lag_of_a_quadratic_law_meets_the_closed_form(family):
    """Fixed low-pass at 0.4 Hz, observer lambda / m = 8 /s, Tustin at 200 Hz (close to continuous)."""
    gain, cutoff = 20.0, 0.4
    af = pure_quadratic(family, 0.03, **{"observer.gains": [gain] * 3, "observer.discretization": "tustin",
                                         "observer.sample_time": 0.005, "limits.max_dt": 0.01,
                                         "filter.speeds": [0.0, 4.0], "filter.cutoffs": [cutoff, 2 * cutoff]})
    result = ramp_experiment(af)
    expected = _quadratic_ramp_lag(af.mass_kg / gain, 1 / (2 * math.pi * cutoff))
    assert result.fixed_lag_s == pytest.approx(expected, abs=0.006)  # about a sample
    assert 0 < result.scheduled_lag_s < result.fixed_lag_s
    assert np.max(result.scheduled_mps) == pytest.approx(10.0, abs=0.05)  # the law read back, no overshoot


@pytest.mark.parametrize("family", FAMILIES)
def test_ramp_lag_of_every_family_is_positive_and_reads_the_top(family):
    result = ramp_experiment(family_airframe(family))
    assert 0 < result.scheduled_lag_s < result.fixed_lag_s < 2.0
    assert result.scheduled_mps[-1] == pytest.approx(10.0, abs=0.05)


@pytest.mark.parametrize("family", FAMILIES)
def test_inversion_is_the_steps_own_force_air_stage(family):
    """airframe_airflow gives what the step's force_air stage gives for the same force, yaw, attitude
    and thrust: the analysis reads wind the way the C will."""
    from dobwind.model.step import build_step

    af = family_airframe(family)
    stage = next(s for s in build_step(af).stages if s.name == "force_air")
    rng = np.random.default_rng(7)
    force = rng.normal(0, 2.0, (12, 3))
    yaw = rng.uniform(-math.pi, math.pi, 12)
    rot = Rotation.from_euler("xyz", rng.uniform(-0.3, 0.3, (12, 3))).as_matrix()
    thrust = rng.uniform(0.8, 1.3, 12) * af.mass_kg * af.gravity_mps2
    ours = forceair.airframe_airflow(af, force, yaw, rot, np.sqrt(thrust / (af.mass_kg * af.gravity_mps2)))
    for k in range(12):
        # The body-drag step tracks the airflow from its previous solution (state.air_prev, body frame): at
        # the converged answer the tracking is a fixed point, so the stage must return it unchanged.
        values = {"f_filt_new": force[k], "in.yaw_ref": yaw[k], "rot_body_to_ned": rot[k].reshape(-1, order="F"),
                  "u_f": thrust[k], "state.air_prev": rot[k].T @ ours[k], "state.initialized": 1.0}
        out = stage.function(*[values[name] for name in stage.inputs])
        air = np.asarray(out[stage.outputs.index("air_rel_ned")]).ravel()
        np.testing.assert_allclose(ours[k], air, rtol=1e-9, atol=1e-9)
