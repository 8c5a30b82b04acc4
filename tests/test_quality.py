"""Gaps, the quality bits (SETTLING, EXTRAPOLATED), the sigma outputs and the dt tolerance, through
the Python reference and the generated C in both precisions."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from dobwind.analysis.figures import settling_time_s as analysis_settling_time
from dobwind.analysis.linear import axis_system
from dobwind.cli.app import main
from dobwind.calibrate.envelope import calibration_envelope, observer_noise, pooled_noise, uncertainty_table, with_observer_noise
from dobwind.core.errors import InputError
from dobwind.io.logs import read_log, required_columns, step_inputs
from dobwind.model import reference
from dobwind.model.airframe import Envelope, ForceAirModel, Uncertainty, load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe, dumps
from dobwind.model.exercise import flight_inputs
from dobwind.model.discretization import first_order
from dobwind.model.settling import settling_time_s
from dobwind.model.status import DT_TOLERANCE, REJECTED_MASK, STATUS_BITS
from dobwind.model.step import build_step
from dobwind.model.terms import parse_term
from dobwind.replay.replay import run_backend
from dobwind.simulate.simulate import write_log
from tests.flight import accel_inputs, balance, thrust_inputs
from tests.helpers import M300, airframe_dict, all_modes, make_airframe

BIT = {bit.name: bit.value for bit in STATUS_BITS}
BAD_DT, SETTLING, EXTRAPOLATED = BIT["BAD_DT"], BIT["SETTLING"], BIT["EXTRAPOLATED"]

# After a gap, the estimate must be back on the gap-free run's within one settling time. What may
# remain: the filters' 2 % band of the gap's transient, and the acceleration-bias estimate, which
# misses the gap's samples (each moves it by up to ~2e-3 m/s^2 at 50 Hz from velocity noise; 0.005
# m/s^2 after a 10 s gap, 0.04 N on 8 kg) and forgets that only at its own 20 s time constant. With
# the linear 0.4 m/s/N model below the largest difference measured after settling is 0.035 m/s (10 s
# gap, bias mode; 0.002-0.025 m/s otherwise). 0.05 m/s is a tenth of the error the issue reported.
# Differencing across the gap (the bug) fails the 10 s gap here in every variant (0.09-0.12 m/s, and
# 0.4-2.7 m/s with a steeper model); the shorter gaps' effect is mostly inside the settling time, so
# the bug itself is pinned sample by sample by the stale-previous-sample test at the end.
GAP_TOLERANCE_MPS = 0.05
GAPS = (("one sample", None), ("0.5 s", 0.5), ("1.5 s", 1.5), ("10 s", 10.0))


def _linear_m300(**observer: object):
    """The m300 with a linear force-air model: near zero force the paper's constant term makes the
    wind direction (not the force estimate) arbitrarily sensitive, which would test the model, not gaps."""
    af = load_airframe(M300)
    return dataclasses.replace(af, horizontal=ForceAirModel((parse_term("m"), parse_term("n")), (0.4, 0.4)),
                               observer=dataclasses.replace(af.observer, **observer))


VARIANTS = {
    "ned_bias": {},
    "velocity": {"acceleration": "velocity", "acceleration_bias_time_s": 0.0},
    "tustin_velocity": {"discretization": "tustin", "acceleration": "velocity", "acceleration_bias_time_s": 0.0},
}


@pytest.fixture(scope="module")
def still_air(tmp_path_factory):
    """Two minutes of the simulator's still-air manoeuvres at 50 Hz (climbs, turns, sensor noise)."""
    path = tmp_path_factory.mktemp("gap") / "still.csv"
    write_log(path, load_airframe(M300), "still-air", seed=4, rate_hz=50.0)
    return str(path)


def _gap_runs(model, log, backend: str, precision: str = "double"):
    u = step_inputs(model, log)
    t = log.time_s
    keep = t < t[0] + 110.0
    u, t = u[keep], t[keep]
    if precision == "single":
        u = u.astype(np.float32).astype(np.float64)
    base = run_backend(model, u, backend, precision)
    wind = model.outputs.slice("wind_ned")
    for label, seconds in GAPS:
        start = int(np.searchsorted(t, t[0] + 60.0))
        rows = 1 if seconds is None else int(round(seconds / np.median(np.diff(t))))
        gapped = u.copy()
        gapped[start:start + rows, model.inputs.slice("q")] = np.nan  # attitude lost
        traj = run_backend(model, gapped, backend, precision)
        end = t[start + rows - 1]
        yield label, t, end, base, traj, wind


def _check_recovery(model, t, end, base, traj, wind, label):
    assert np.all(traj.status[(t > t[0] + 60) & (t <= end)] & REJECTED_MASK)
    late = t > end + model.settling_time_s
    diff = np.abs(traj.outputs[late][:, wind] - base.outputs[late][:, wind]).max()
    assert diff < GAP_TOLERANCE_MPS, f"{label}: {diff:.3f} m/s from the gap-free estimate after settling"
    # The samples right after the gap are SETTLING (accepted, not trusted), and later ones are not.
    after = (t > end) & (t < end + model.settling_time_s - 0.05)
    assert np.all(traj.status[after] == SETTLING)
    assert np.all(traj.status[t > end + model.settling_time_s + 0.05] == 0)


@pytest.mark.parametrize("variant", list(VARIANTS))
def test_a_gap_recovers_to_the_gap_free_estimate_in_the_reference(still_air, variant):
    af = _linear_m300(**VARIANTS[variant])
    model = build_step(af)
    log = read_log(still_air, required_columns(af))
    for label, t, end, base, traj, wind in _gap_runs(model, log, "python"):
        _check_recovery(model, t, end, base, traj, wind, label)


@pytest.mark.parametrize("precision", ["double", "single"])
@pytest.mark.parametrize("variant", ["ned_bias", "velocity"])
def test_a_gap_recovers_in_the_generated_c(still_air, variant, precision):
    af = _linear_m300(**VARIANTS[variant])
    model = build_step(af)
    log = read_log(still_air, required_columns(af))
    for label, t, end, base, traj, wind in _gap_runs(model, log, "c", precision):
        _check_recovery(model, t, end, base, traj, wind, label)


def test_settling_time_agrees_with_the_analysis():
    """Two independent computations: the step-response cascade here, the linearized step in analysis."""
    for disc in ("paper", "euler", "zoh", "tustin"):
        af = make_airframe(**{"observer.discretization": disc})
        model = build_step(af)
        slow = int(np.argmin(af.observer.gains))
        figure = analysis_settling_time(axis_system(model, slow, with_filter=True, wind_speed_mps=0.0))
        assert abs(model.settling_time_s - figure) <= 2 * af.observer.sample_time_s + 1e-9, disc


def test_settling_time_limit_of_an_instant_observer():
    """With an observer far faster than the low-pass, only the low-pass remains: a first-order lag at
    cutoff fc is within 2 % after ln(50) / (2 pi fc)."""
    af = make_airframe(**{"observer.discretization": "zoh", "observer.gains": [1e5, 1e5, 1e5],
                          "filter.speeds": [0.0], "filter.cutoffs": [0.25], "observer.sample_time": 0.001,
                          "limits.max_dt": 0.01})
    expected = math.log(50) / (2 * math.pi * 0.25)
    assert settling_time_s(af) == pytest.approx(expected, abs=2e-3)


def _settling_by_lfilter(af) -> float:
    """The cascade's step response through scipy.signal.lfilter (what model/settling.py used before it
    wrote the recursions out to keep scipy out of every command's imports)."""
    import scipy.signal

    from dobwind.model.settling import MAX_SAMPLES, THRESHOLD_PHASE

    dt = af.observer.sample_time_s
    c = first_order(af.observer.discretization, min(af.observer.gains) / af.mass_kg, dt)
    alpha = -math.expm1(-2 * math.pi * min(af.filter.cutoffs_hz) * dt)
    slowest = max(dt / (1 - abs(float(c.pole))), dt / alpha)
    n = min(int(math.ceil(20 * slowest / dt)) + 2, MAX_SAMPLES)
    observed = scipy.signal.lfilter([float(c.b0), float(c.b1)], [1.0, -float(c.pole)], np.ones(n))
    filtered = scipy.signal.lfilter([alpha], [1.0, -(1 - alpha)], observed)
    outside = np.flatnonzero(np.abs(filtered - 1.0) > 0.02)
    return float(((outside[-1] if outside.size else -1) + 1 + THRESHOLD_PHASE) * dt)


@pytest.mark.parametrize("disc", ["paper", "euler", "zoh", "tustin"])
def test_settling_time_equals_the_lfilter_cascade(disc):
    """Gains from a sluggish observer to one that overshoots (a negative pole under euler), cutoffs
    from slow to fast: the same sample index, so the same constant in the generated step."""
    # gain * dt / mass (2.5 kg): 0.16, 0.008, 1.6 (a pole near -0.6 under euler), 0.24, 4 (zoh, tustin only).
    cases = [(20.0, 0.3, 0.02), (2.0, 0.05, 0.01), (200.0, 2.0, 0.02), (150.0, 5.0, 0.004), (1e4, 1.0, 0.001)]
    compared = 0
    for gains, cutoff, dt in cases:
        af = make_airframe(**{"observer.discretization": disc, "observer.gains": [gains, gains * 1.5, gains * 2],
                              "observer.sample_time": dt, "limits.max_dt": 5 * dt, "filter.speeds": [0.0],
                              "filter.cutoffs": [cutoff]})
        if abs(float(first_order(disc, gains / af.mass_kg, dt).pole)) >= 1:
            assert settling_time_s(af) == math.inf  # unstable: never settles
            continue
        assert settling_time_s(af) == _settling_by_lfilter(af), (disc, gains, cutoff, dt)
        compared += 1
    assert compared >= 3


def _first_sample(model, force_ned, yaw=0.3):
    """One steady row: the first accepted sample's filtered force is exactly its observed force."""
    af = model.airframe
    q, u_f = balance(af, np.asarray(force_ned, float), yaw)
    row = {"dt": af.observer.sample_time_s, "vel_ned": np.zeros(3), "q": q, "yaw_ref": yaw}
    row.update(thrust_inputs(af, u_f))
    row.update(accel_inputs(af, q, np.zeros(3)))
    return model.inputs.pack(row)


def _quality_airframe():
    af = make_airframe(**{"observer.force_offset": [0.0, 0.0, 0.0],
                          "force_air.horizontal.terms": ["fh"], "force_air.horizontal.coefficients": [2.0]})
    return dataclasses.replace(af, envelope=Envelope(3.0, (-1.0, 1.0), 5.0),
                               uncertainty=Uncertainty((0.0, 4.0, 8.0), (0.1, 0.3, 0.7), (0.2, 0.2, 0.6)))


@pytest.mark.parametrize("force,extrapolated", [
    ([1.0, 1.0, 0.0], False),   # fh 1.41 N, airflow 2.83 m/s: inside
    ([2.0, 2.5, 0.0], True),    # fh 3.20 N > 3
    ([1.0, 0.0, 1.5], True),    # fz 1.5 N > 1
    ([1.0, 0.0, -1.2], True),   # fz -1.2 N < -1
    ([1.6, 1.6, 0.0], False),   # fh 2.26 N, airflow 4.53 m/s: inside
    ([1.8, 1.8, 0.0], True),    # fh 2.55 N inside, but airflow 5.09 m/s > 5
])
def test_extrapolated_bit_and_sigma_on_the_first_sample(force, extrapolated):
    af = _quality_airframe()
    model = build_step(af)
    _, y, status = model.step(model.initial_state(), _first_sample(model, force))
    status = int(status)
    fh = math.hypot(force[0], force[1])
    airflow = 2.0 * fh
    assert bool(status & EXTRAPOLATED) == extrapolated
    assert status & SETTLING and not status & REJECTED_MASK  # accepted, first sample: settling
    out = model.outputs.unpack(np.asarray(y).ravel())
    assert float(out["wind_sigma_h"][0]) == pytest.approx(np.interp(airflow, [0, 4, 8], [0.1, 0.3, 0.7]), rel=1e-9)
    assert float(out["wind_sigma_up"][0]) == pytest.approx(np.interp(airflow, [0, 4, 8], [0.2, 0.2, 0.6]), rel=1e-9)


def _noisy_quality_airframe(noise_h: float, noise_up: float):
    af = _quality_airframe()
    return dataclasses.replace(af, uncertainty=with_observer_noise(af.uncertainty, noise_h, noise_up))


def test_sigma_adds_the_observer_noise_in_quadrature():
    """Model error and observer noise are independent: sigma^2 = table^2 + noise^2. At fh 1.5 N the
    airflow is 3 m/s and the table gives 0.1 + 0.2 * 3/4 = 0.25 (h) and 0.2 (up); with noise 0.6 and
    0.15 the sigmas are the 3-4-5 and 4-3-5 triangles' 0.65 and 0.25."""
    model = build_step(_noisy_quality_airframe(0.6, 0.15))
    _, y, _ = model.step(model.initial_state(), _first_sample(model, [1.5, 0.0, 0.0]))
    out = model.outputs.unpack(np.asarray(y).ravel())
    assert float(out["wind_sigma_h"][0]) == pytest.approx(0.65, rel=1e-12)
    assert float(out["wind_sigma_up"][0]) == pytest.approx(0.25, rel=1e-12)
    # No noise term: the table's value itself (0.25 h), not a rounded sqrt(x*x).
    plain = build_step(_quality_airframe())
    _, y, _ = plain.step(plain.initial_state(), _first_sample(plain, [1.5, 0.0, 0.0]))
    assert float(plain.outputs.unpack(np.asarray(y).ravel())["wind_sigma_h"][0]) == pytest.approx(0.25, rel=1e-12)


@pytest.mark.parametrize("precision", ["double", "single"])
def test_sigma_with_observer_noise_agrees_in_c(precision):
    model = build_step(_noisy_quality_airframe(0.3, 0.1))
    u = flight_inputs(model, 1500, seed=12, bad_every=0)
    if precision == "single":
        u = u.astype(np.float32).astype(np.float64)
    py = reference.run(model, u)
    c = run_backend(model, u, "c", precision)
    for name in ("wind_sigma_h", "wind_sigma_up"):
        cols = model.outputs.slice(name)
        assert np.all(py.outputs[:, cols] >= (0.3 if name == "wind_sigma_h" else 0.1))
        np.testing.assert_allclose(c.outputs[:, cols], py.outputs[:, cols], rtol=1e-5 if precision == "single" else 0)


def test_observer_noise_is_the_scatter_about_each_segment_mean():
    """Segments with different biases (the model's error) and white noise of 0.12 m/s: the pooled
    scatter is 0.12 to sampling error, whatever the biases; one-sample segments add nothing."""
    rng = np.random.default_rng(5)
    segments = [bias + rng.normal(0, 0.12, 4000) for bias in (-0.5, 0.0, 0.3, 2.0)] + [np.array([9.0])]
    noise, dof = observer_noise(segments)
    assert dof == 4 * 3999 and noise == pytest.approx(0.12, rel=0.02)
    bias_only = observer_noise([np.full(50, 0.7)])  # a pure bias is no noise
    assert bias_only[1] == 49 and bias_only[0] < 1e-12
    assert observer_noise([]) == (0.0, 0)
    # Pooled over logs by degrees of freedom: variances 0.01 (dof 100) and 0.04 (dof 300) -> 0.0325.
    assert pooled_noise([(0.1, 100), (0.2, 300)]) == pytest.approx(math.sqrt(0.0325), rel=1e-12)
    assert pooled_noise([(0.5, 0)]) == 0.0


def test_no_envelope_never_extrapolates_and_sigma_is_unknown():
    model = build_step(make_airframe())
    _, y, status = model.step(model.initial_state(), _first_sample(model, [10.0, 0.0, 5.0]))
    assert int(status) == SETTLING  # a strong force, 12 m/s of wind: no envelope to leave
    # ... but a wind beyond 50 m/s (146 here) is beyond any calibration: flagged, never trusted
    _, y_far, status_far = model.step(model.initial_state(), _first_sample(model, [40.0, 0.0, 30.0]))
    assert np.linalg.norm(model.outputs.unpack(np.asarray(y_far).ravel())["wind_ned"]) > 50.0
    assert int(status_far) == SETTLING | EXTRAPOLATED
    out = model.outputs.unpack(np.asarray(y).ravel())
    assert float(out["wind_sigma_h"][0]) == -1.0 and float(out["wind_sigma_up"][0]) == -1.0


@pytest.mark.parametrize("precision", ["double", "single"])
def test_quality_bits_and_sigma_agree_in_c(precision):
    """A flight in and out of the envelope: the C sets the same bits and sigmas as the reference."""
    af = _quality_airframe()
    model = build_step(af)
    u = flight_inputs(model, 3000, seed=11, bad_every=0)
    if precision == "single":
        u = u.astype(np.float32).astype(np.float64)
    py = reference.run(model, u)
    c = run_backend(model, u, "c", precision)
    assert np.any(py.status & EXTRAPOLATED) and np.any(py.status == 0) and np.any(py.status & SETTLING)
    np.testing.assert_array_equal(c.status, py.status)
    sigma = model.outputs.slice("wind_sigma_h")
    np.testing.assert_allclose(c.outputs[:, sigma], py.outputs[:, sigma], rtol=1e-5 if precision == "single" else 0)


def _periodic_log_inputs(model, period: float, rows: int) -> np.ndarray:
    u = flight_inputs(model, rows, seed=3, bad_every=0)
    u[:, model.inputs.slice("dt")] = np.diff(np.arange(rows + 1) * period)[:, None]  # t = k * period
    return u


@pytest.mark.parametrize("period,rows", [(0.02, 1500), (0.1, 400)])
def test_backends_agree_on_every_status_bit_at_max_dt(period, rows):
    """Issue 16: np.diff of t = k * 0.02 gives 0.020000000000000004 > max_dt; with the tolerance every
    backend accepts every row, and all agree on every bit (SETTLING included)."""
    af = make_airframe(**{"observer.sample_time": period / 2, "limits.max_dt": period})
    model = build_step(af)
    u = _periodic_log_inputs(model, period, rows)
    assert np.any(u[:, model.inputs.offset("dt")] > period)  # the rounding the issue found is present
    py = reference.run(model, u)
    assert not np.any(py.status & BAD_DT)
    for precision in ("double", "single"):
        got = run_backend(model, u.astype(np.float32).astype(np.float64) if precision == "single" else u, "c", precision)
        np.testing.assert_array_equal(got.status, py.status, err_msg=precision)


def test_dt_beyond_the_tolerance_is_rejected_by_every_backend():
    af = make_airframe(**{"limits.max_dt": 0.02, "observer.sample_time": 0.01})
    model = build_step(af)
    u = _periodic_log_inputs(model, 0.02, 200)
    u[50, model.inputs.offset("dt")] = 0.02 * (1 + 3 * DT_TOLERANCE)
    u[120, model.inputs.offset("dt")] = 0.02 * (1 + 0.3 * DT_TOLERANCE)
    py = reference.run(model, u)
    assert py.status[50] == BAD_DT and not py.status[120] & REJECTED_MASK
    for precision in ("double", "single"):
        got = run_backend(model, u.astype(np.float32).astype(np.float64) if precision == "single" else u, "c", precision)
        np.testing.assert_array_equal(got.status, py.status, err_msg=precision)


def test_uncertainty_table_recovers_known_sigmas():
    """Residuals of known standard deviation 0.1 + 0.05 v (horizontal) and 0.2 (vertical): each band's
    RMS is that sigma at the band's mean speed, to sampling error (1/sqrt(2 * 5000) = 1 %)."""
    rng = np.random.default_rng(1)
    speed = rng.uniform(0, 10, 30000)
    sigma_h = 0.1 + 0.05 * speed
    table = uncertainty_table(speed, speed + rng.normal(0, 1, speed.size) * sigma_h,
                              np.zeros(speed.size), rng.normal(0, 0.2, speed.size))
    assert len(table.speeds_mps) == 6 and np.all(np.diff(table.speeds_mps) > 0)
    np.testing.assert_allclose(table.sigma_h_mps, 0.1 + 0.05 * np.asarray(table.speeds_mps), rtol=0.05)
    np.testing.assert_allclose(table.sigma_up_mps, 0.2, rtol=0.05)


def test_uncertainty_table_counts_a_bias_as_error():
    """A constant residual c has RMS exactly |c| (a standard deviation would report 0)."""
    speed = np.linspace(0, 8, 80)
    table = uncertainty_table(speed, speed - 0.25, speed * 0, speed * 0 + 0.5)
    np.testing.assert_allclose(table.sigma_h_mps, 0.25)
    np.testing.assert_allclose(table.sigma_up_mps, 0.5)
    few = uncertainty_table(speed[:5], speed[:5] + 0.1, speed[:5] * 0, speed[:5] * 0)
    assert len(few.speeds_mps) == 1  # too few residuals for bands: one constant sigma


def test_calibration_envelope_bounds_every_point_with_a_margin():
    force_h, force_z, airflow = np.array([0.5, 2.0, 4.0]), np.array([-1.0, 0.5, 2.0]), np.array([1.0, 5.0, 8.0])
    env = calibration_envelope(force_h, force_z, airflow)
    margin = 0.05 * 4.0
    assert env.force_h_max_n == pytest.approx(4.0 + margin)
    assert env.force_z_n == pytest.approx((-1.0 - margin, 2.0 + margin))
    assert env.airflow_h_max_mps == pytest.approx(8.0 * 1.05)


@pytest.mark.parametrize("doc", all_modes(), ids=[d["name"] for d in all_modes()])
def test_the_first_sample_after_a_gap_ignores_the_stale_previous_sample(doc):
    """After a rejected sample, vel_prev and fe_prev are from before the gap: the next accepted sample
    must not use them (no velocity difference across the gap, no bias update from it). Its result is
    then the same whatever they hold, and the bias estimate is exactly the one before the gap."""
    model = build_step(parse_airframe(dumps(doc), "<test>"))
    hover = _first_sample(model, [0.5, -0.3, 0.2])
    x = model.initial_state()
    for _ in range(40):
        x, _, _ = model.step(x, hover)
    bad = hover.copy()
    bad[model.inputs.slice("q")] = np.nan
    gap, _, status = model.step(x, bad)
    gap = np.asarray(gap).ravel()
    assert int(status) & REJECTED_MASK and gap[model.state.slice("run_s")][0] == 0.0
    resume = hover.copy()
    resume[model.inputs.slice("vel_ned")] = [4.0, -3.0, 1.0]  # the vehicle moved during the gap
    results = []
    for stale in (0.0, 7.0):
        start = gap.copy()
        for name in ("vel_prev", "fe_prev"):
            if name in model.state:
                start[model.state.slice(name)] = stale
        nxt, _, status = model.step(start, resume)
        assert int(status) == SETTLING
        results.append(np.asarray(nxt).ravel())
    np.testing.assert_array_equal(results[0], results[1])
    if "acc_bias" in model.state:
        bias = model.state.slice("acc_bias")
        np.testing.assert_array_equal(results[0][bias], gap[bias])


def test_envelope_and_uncertainty_tables_round_trip_through_toml():
    af = _quality_airframe()
    again = parse_airframe(dump_airframe(af), "<again>")
    assert again.envelope == af.envelope and again.uncertainty == af.uncertainty
    noisy = _noisy_quality_airframe(0.2, 0.05)
    assert parse_airframe(dump_airframe(noisy), "<noisy>").uncertainty == noisy.uncertainty
    assert "noise_h" not in dump_airframe(af)  # 0 is the default: older files read back unchanged
    assert parse_airframe(dump_airframe(make_airframe()), "<plain>").envelope is None  # optional


@pytest.mark.parametrize("table,key,value,where", [
    ("envelope", "force_z", [2.0, 1.0], "envelope.force_z"),
    ("envelope", "force_h_max", -1.0, "envelope.force_h_max"),
    ("envelope", "airflow_hmax", 3.0, "envelope.airflow_hmax"),       # a typo: unknown key
    ("uncertainty", "sigma_h", [0.1, 0.2], "uncertainty.sigma_h"),    # 2 values for 3 speeds
    ("uncertainty", "sigma_up", [0.1, -0.2, 0.3], "uncertainty.sigma_up"),
    ("uncertainty", "speeds", [0.0, 4.0, 4.0], "uncertainty.speeds"),
    ("uncertainty", "noise_h", -0.1, "uncertainty.noise_h"),
    ("uncertainty", "noise_up", "0.1", "uncertainty.noise_up"),
    ("uncertainty", "noise", 0.1, "uncertainty.noise"),                # unknown key
])
def test_bad_tables_name_the_key(table, key, value, where, tmp_path, capsys):
    doc = airframe_dict()
    doc["envelope"] = {"force_h_max": 3.0, "force_z": [-1.0, 1.0], "airflow_h_max": 5.0}
    doc["uncertainty"] = {"speeds": [0.0, 4.0, 8.0], "sigma_h": [0.1, 0.3, 0.7], "sigma_up": [0.2, 0.2, 0.6]}
    parse_airframe(dumps(doc), "<good>")  # the tables as given are valid
    doc[table][key] = value
    path = tmp_path / "bad.toml"
    path.write_text(dumps(doc))
    with pytest.raises(InputError) as raised:
        parse_airframe(path.read_text(), str(path))
    assert raised.value.where == where
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and where in err and str(path) in err
