"""tools/thrust_timing.py, the thrust-lag and topic-timing measurement of docs/field-calibration.md: its
retiming filters against closed forms, and the measurement against a timing error put in on purpose
(a simulated flight's thrust and attitude are on time, so the error put in is the only one)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from dobwind.calibrate.fieldtruth import LogTime
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import load_airframe
from dobwind.simulate.simulate import simulate
from tests.helpers import ROOT
from tools.thrust_timing import QUATERNION, delayed, first_order_lag, measure, retimed

# uneven steps (a resampled log's are even; the filter must not assume it)
TIMES = np.cumsum(np.r_[0.0, np.random.default_rng(3).uniform(0.01, 0.07, 400)])


@pytest.mark.parametrize("tau", [0.01, 0.04, 0.12])
def test_lag_of_a_ramp_is_the_closed_form(tau: float) -> None:
    # y' = (x - y) / tau, x = r t, y(0) = 0: y = r (t - tau + tau exp(-t / tau)); the hold is exact on a ramp
    r = 2.5
    y = first_order_lag(TIMES, r * TIMES, tau)
    assert np.allclose(y, r * (TIMES - tau + tau * np.exp(-TIMES / tau)), rtol=0, atol=1e-12)


def test_lag_of_a_step_rises_as_one_minus_exp() -> None:
    # a step held from the second sample on (the hold ramps it over the first interval): after it,
    # 1 - exp(-(t - t1) / tau) times the value the ramp reached
    tau, t = 0.05, np.linspace(0.0, 0.5, 501)
    x = np.where(t > 0, 1.0, 0.0)
    y = first_order_lag(t, x, tau)
    dt = t[1]
    at_t1 = 1 - tau / dt * (1 - math.exp(-dt / tau))   # the ramp's response over the first interval
    expected = 1 - (1 - at_t1) * np.exp(-(t[1:] - dt) / tau)
    assert np.allclose(y[1:], expected, rtol=0, atol=1e-12)


def test_no_lag_and_a_constant_are_unchanged_and_nan_stays_put() -> None:
    x = np.sin(TIMES)
    assert np.array_equal(first_order_lag(TIMES, x, 0.0), x)
    flat = np.full(len(TIMES), 0.6)
    flat[50:60] = np.nan
    y = first_order_lag(TIMES, flat, 0.08)
    assert np.isnan(y[50:60]).all()
    assert np.allclose(np.delete(y, range(50, 60)), 0.6, rtol=0, atol=1e-15)


def test_ground_rows_at_the_start_do_not_spread_and_an_all_nan_column_stays_nan() -> None:
    """A log starts on the ground (NaN rows): the lag starts at rest at the first finite value and the
    delay holds it, so the flight after them is as without them; a column with no finite row stays NaN."""
    flat = np.full(len(TIMES), 0.6)
    flat[:10] = np.nan
    for y in (first_order_lag(TIMES, flat, 0.08), delayed(TIMES, flat, 0.05), delayed(TIMES, flat, -0.05)):
        assert np.isnan(y[:10]).all() and np.allclose(y[10:], 0.6, rtol=0, atol=1e-15)
    line = 1.0 + 3.0 * TIMES
    line[:10] = np.nan
    y = delayed(TIMES, line, 0.1)   # rows within 0.1 s of the first finite one take its value (held)
    late = TIMES >= TIMES[10] + 0.1
    assert np.allclose(y[late], 1.0 + 3.0 * (TIMES[late] - 0.1), rtol=0, atol=1e-12)
    assert np.allclose(y[10:][~late[10:]], 1.0 + 3.0 * TIMES[10], rtol=0, atol=1e-12)
    none = np.full(len(TIMES), np.nan)
    assert np.isnan(first_order_lag(TIMES, none, 0.08)).all() and np.isnan(delayed(TIMES, none, 0.1)).all()


def test_delay_of_a_line() -> None:
    x = 1.0 + 3.0 * TIMES
    y = delayed(TIMES, x, 0.1)
    inside = TIMES >= TIMES[0] + 0.1
    assert np.allclose(y[inside], 1.0 + 3.0 * (TIMES[inside] - 0.1), rtol=0, atol=1e-12)
    assert np.allclose(delayed(TIMES, x, -0.1)[TIMES <= TIMES[-1] - 0.1], (1.0 + 3.0 * (TIMES + 0.1))[TIMES <= TIMES[-1] - 0.1])


def test_retimed_attitude_stays_unit_and_unknown_change_refused() -> None:
    af = load_airframe(ROOT / "benchmarks" / "vehicles" / "px4quad.airframe.toml")
    angle = np.linspace(0.0, 1.0, len(TIMES)) ** 2
    cols = {"t": TIMES, "q_w": np.cos(angle), "q_x": np.zeros_like(angle), "q_y": np.sin(angle),
            "q_z": np.zeros_like(angle), "thrust": np.ones_like(angle)}
    log = retimed(FlightLog("x.csv", cols), af, "qdelay", 0.05)
    q = np.column_stack([log.columns[c] for c in QUATERNION])
    assert np.allclose(np.linalg.norm(q, axis=1), 1.0)
    assert np.array_equal(log.columns["thrust"], cols["thrust"])
    with pytest.raises(ValueError, match="unknown change"):
        retimed(FlightLog("x.csv", cols), af, "shift", 0.05)


def test_an_attitude_delay_put_in_is_found() -> None:
    # a box flight with its attitude logged 50 ms EARLY: the law's residual at the true wind, at the
    # observer's band, drops clearly when the measurement delays the attitude back by those 50 ms (the
    # fit's 0.15 Hz band hardly sees it: docs/field-calibration.md)
    af = load_airframe(ROOT / "benchmarks" / "vehicles" / "px4quad.airframe.toml")
    cols = simulate(af, "box", seed=5, hold_s=6.0, rate_hz=20.0)
    log = retimed(FlightLog("box.csv", {k: np.asarray(v, dtype=float) for k, v in cols.items()}), af, "qdelay", -0.05)
    flight = LogTime(log, 0.0)
    known = np.column_stack([log.columns["wind_n"], log.columns["wind_e"]])
    on_time, put_back = (measure(af, "box.csv", flight, "qdelay", s, known).observer_rms_n for s in (0.0, 0.05))
    assert put_back < 0.8 * on_time
