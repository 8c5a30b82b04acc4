"""--wind unknown's comparison through the observer (dobwind/calibrate/windrows.py, issue #36).

The claim the all-rows fit rests on: the calibration step's filtered force is a fixed linear filter of
the raw external force, so the law's force passed through the same filter is compared without lag. It
is pinned here against the step itself, on the raw force computed in closed form from the log
(docs/model.md: f_e = m p'' - m g e3 + u_f z_b), on a simulated flight with timestamp jitter."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.calibrate import dragfit, windrows
from dobwind.calibrate.fieldtruth import flight_of
from dobwind.calibrate.fit import calibration_run
from dobwind.io.logs import write_csv
from dobwind.model.status import accepted
from dobwind.simulate.simulate import simulate
from tests.test_fieldcal import _airframe


@pytest.fixture(scope="module")
def flight(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("windrows")
    _, af = _airframe(tmp)
    cols = simulate(af, "box", seed=3, hold_s=2.0, rate_hz=10.0)
    csv = tmp / "box.csv"
    write_csv(csv, list(cols), np.column_stack([cols[k] for k in cols]), ["%.9g"] * len(cols))
    return af, flight_of(str(csv), af, None).log


def _raw_force(af, cal, log) -> np.ndarray:
    """f_e's north/east from the log: m dv/dt (the velocity's backward difference, as the step's
    acceleration = "velocity" reads it) plus the thrust along the body's down axis."""
    t, v = log.time_s, log.stack("vel_n", "vel_e")
    acc = np.vstack([np.zeros((1, 2)), np.diff(v, axis=0) / np.diff(t)[:, None]])
    thrust = dragfit.thrust_ned(cal, None, log.columns["thrust"], log.stack("q_w", "q_x", "q_y", "q_z"))
    return af.mass_kg * acc + thrust[:, :2]


def test_the_observer_path_reproduces_the_steps_filtered_force(flight):
    """The raw force through windrows' filters at each row's own dt is the step's force_ned to rounding
    (the log's dt jitters by about 13 %: one filter at the median dt was 0.12 N RMS off)."""
    af, log = flight
    run = calibration_run(af, [log])
    ok = accepted(run.status[0])
    assert np.std(np.diff(log.time_s)) > 0.005   # the jitter this test is about
    t = log.time_s[ok]
    path = windrows.observer_path(run.airframe, np.diff(t, prepend=t[0]))
    filtered = windrows.through_observer(path, _raw_force(af, run.airframe, log)[ok])
    step = run.force_ned[0][ok][:, :2]
    assert np.abs(step).max() > 1.0   # a flight with force to filter
    assert np.abs(filtered - step).max() < 1e-9


def test_the_recursion_is_a_first_order_step_response_across_blocks():
    """y_k = p y_(k-1) + (1 - p) from y_0 = 0 is 1 - p^k, over many BLOCKs; a pole near zero (the plain
    loop) gives the input itself."""
    n, p = 5 * windrows.BLOCK + 3, 0.8
    y = windrows._recursion(np.full((n, 2), p), np.full((n, 2), 1 - p), np.zeros(2))
    assert np.allclose(y[:, 0], 1 - p ** np.arange(n), atol=1e-12, rtol=0)
    poles = np.full((n, 2), p)
    poles[-1] += 1e-13   # no longer one pole: the blocked path
    y = windrows._recursion(poles, np.full((n, 2), 1 - p), np.zeros(2))
    assert np.allclose(y[:, 0], 1 - p ** np.arange(n), atol=1e-9, rtol=0)
    u = np.random.default_rng(1).normal(size=(n, 2))
    assert np.allclose(windrows._recursion(np.zeros((n, 2)), u, u[0]), u)


def test_long_blocks_keep_the_plain_loops_accuracy_at_the_smallest_blocked_pole():
    """Jittered poles (every dt differs) down to 0.05, the smallest the blocked path takes: the products
    over a whole BLOCK reach 0.05**BLOCK, and the result still equals the plain loop to rounding."""
    rng = np.random.default_rng(7)
    n = 3 * windrows.BLOCK + 5
    for low in (0.05, 0.5, 0.95):
        poles = rng.uniform(low, min(low + 0.04, 0.999), size=(n, 2))
        u = rng.normal(size=(n, 2)) * 10.0
        y0 = np.array([3.0, -2.0])
        expected = np.empty_like(u)
        expected[0] = last = y0
        for k in range(1, n):
            last = poles[k] * last + u[k]
            expected[k] = last
        got = windrows._recursion(poles, u, y0)
        assert np.all(np.isfinite(got))
        assert np.max(np.abs(got - expected)) <= 1e-11 * np.sum(np.abs(u)), low


def test_the_zero_phase_smoothing_adds_no_lag():
    """A slow sine through the smoothing keeps its phase (a causal filter of the same order would
    delay it by about a quarter second), and the same sine lagged by 0.5 s is told apart."""
    dt = 0.1
    t = np.arange(0, 120, dt)
    x = np.column_stack([np.sin(2 * np.pi * 0.03 * t)] * 2)
    y = windrows.smooth(windrows.smoothing(dt), x)
    middle = slice(200, -200)
    assert np.abs(y - x)[middle].max() < 0.02
    lagged = np.sin(2 * np.pi * 0.03 * (t - 0.5))
    assert np.abs(lagged - x[:, 0])[middle].max() > 0.05


def test_the_offset_prior_is_a_degree_of_tilt_and_the_robust_loss_spares_the_priors(flight):
    """The offset's prior 1-sigma is m g tan(1 deg); a starter without a drag law puts no prior on the
    drag terms; the loss is soft-L1 on the data (2 (sqrt(1 + z) - 1)) and plain z on the prior rows."""
    import math

    from dobwind.calibrate import windsolve

    af, _ = flight
    p = windsolve.prior(af)
    k = windsolve.LAW.index("ox")
    assert p.mean[k] == 0 and math.isclose(p.sigma[k], af.mass_kg * af.gravity_mps2 * math.tan(math.radians(1)))
    assert af.drag is None and np.isinf(p.sigma[windsolve.LAW.index("l0")])
    z = np.array([3.0, 8.0, 3.0, 8.0])
    rho = windsolve._loss(2)(z)
    assert np.allclose(rho[0], [2.0, 4.0, 3.0, 8.0]) and np.allclose(rho[1, 2:], 1.0)
