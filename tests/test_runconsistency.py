"""The runs' consistency check (benchmarks/runconsistency.py), on runs made from a known convex law.

A figure-8 sweeps the airflow sinusoidally about its mean, so for F = l s + q s^2 along the mean
airflow the least-squares slope is exactly F'(s_mean) = l + 2 q s_mean (the quadratic's covariance with
the speed is 2 s_mean var(s); the third central moment of a sinusoid is zero) and the mean force is
l s + q (s^2 + A^2 / 2)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import runconsistency as rc

L, Q = 0.3, 0.08          # N/(m/s), N/(m/s)^2
AMPLITUDE = 1.0           # m/s, the figure-8's sweep of the airflow
OFFSET = np.array([1.0, -0.5])


def _run(speed: float, logged: float | None = None, noise: float = 0.0, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """(force_h, airflow) of one run along -x at ``speed``; the airflow logged at ``logged`` instead."""
    phase = np.linspace(0, 20 * math.pi, 2000, endpoint=False)
    s = speed + AMPLITUDE * np.sin(phase)
    force = np.column_stack([-(L * s + Q * s * np.abs(s)), np.zeros_like(s)]) + OFFSET  # drag opposes either way
    force += noise * np.random.default_rng(seed).standard_normal(force.shape)
    shown = s - speed + (speed if logged is None else logged)
    airflow = np.column_stack([-shown, np.zeros_like(s), 0.5 * np.cos(2 * phase)])  # the figure-8's vertical motion
    return force, airflow


def _check(speeds, logged=None, noise=0.0):
    logged = logged or {}
    made = [_run(v, logged.get(v), noise, seed) for seed, v in enumerate(speeds)]
    return rc.check_runs([f"{v:g}" for v in speeds], [f for f, _ in made], [a for _, a in made])


def test_slope_mean_force_and_offset_follow_the_closed_forms():
    runs, offset = _check([0.0, 4.0, 8.0, 12.0])
    assert offset == pytest.approx(OFFSET, abs=1e-9)
    assert [r.name for r in runs] == ["4", "8", "12"]          # the zero-airflow run gives the offset only
    for r, s in zip(runs, (4.0, 8.0, 12.0)):
        assert r.speed_mps == pytest.approx(s, abs=1e-9)
        assert r.slope_n_per_mps == pytest.approx(L + 2 * Q * s, rel=1e-9)
        assert r.force_n == pytest.approx(L * s + Q * (s * s + AMPLITUDE ** 2 / 2), rel=1e-9)
        assert r.bound_mps == pytest.approx(r.force_n / r.slope_n_per_mps)
        # The bound holds for the true law: about half the speed for a mostly quadratic law.
        assert r.bound_mps <= s and not r.below_bound
    assert rc.out_of_order(runs) == []


def test_a_run_logged_slower_than_its_force_is_flagged_and_so_is_the_pair():
    # A run flown at 6 m/s but logged at 3: its bound F/F' = 4.72 / 1.26 = 3.75 m/s is above 3, and its
    # force per m/s (1.57) is above the 8 m/s run's (0.95) and the 12 m/s run's (15.16 / 12 = 1.26).
    runs, _ = _check([0.0, 6.0, 8.0, 12.0], logged={6.0: 3.0})
    flagged = {r.name: r.below_bound for r in runs}
    assert flagged == {"6": True, "8": False, "12": False}
    assert rc.out_of_order(runs) == [("6", "8"), ("6", "12")]
    text = "\n".join(rc.lines(runs, OFFSET))
    assert "BELOW its bound" in text and "6 -> 8: force per m/s falls with the speed" in text


def test_noise_does_not_flag_a_consistent_run():
    runs, _ = _check([0.0, 4.0, 8.0, 12.0], noise=0.3)
    assert not any(r.below_bound for r in runs) and rc.out_of_order(runs) == []
    for r, s in zip(runs, (4.0, 8.0, 12.0)):
        assert r.slope_n_per_mps == pytest.approx(L + 2 * Q * s, rel=0.05)


def test_without_a_zero_airflow_run_there_is_no_bound():
    runs, offset = _check([4.0, 8.0])
    assert runs == [] and offset is None
    assert rc.lines(runs, offset) == ["  no run at zero mean airflow with 10 finite samples: no force offset, no bound"]


def test_a_cut_zero_airflow_run_gives_no_offset_rather_than_nan_bounds():
    # Two rows of the zero-airflow run (a truncated log): no offset, so no run is flagged on NaN figures.
    made = [_run(v) for v in (0.0, 4.0, 8.0)]
    force, airflow = made[0]
    runs, offset = rc.check_runs(["0", "4", "8"], [force[:2]] + [f for f, _ in made[1:]],
                                 [airflow[:2]] + [a for _, a in made[1:]])
    assert runs == [] and offset is None
    # Non-finite rows are dropped before the figures: the same run with NaN rows gives the same bound.
    clean = rc.run_force("4", *made[1], OFFSET)
    dirty_force, dirty_air = made[1][0].copy(), made[1][1].copy()
    dirty_force[::7] = np.nan
    dirty_air[3::11, 2] = np.inf
    dirty = rc.run_force("4", dirty_force, dirty_air, OFFSET)
    assert clean is not None and dirty is not None
    assert dirty.bound_mps == pytest.approx(clean.bound_mps, rel=0.02) and math.isfinite(dirty.bound_mps)
    assert rc.run_force("4", made[1][0][:5], made[1][1][:5], OFFSET) is None


def _figures(name: str, speed: float, per_mps: float) -> rc.RunForce:
    return rc.RunForce(name, speed, per_mps * speed, 2 * per_mps, speed / 2)


def test_a_fall_spread_over_runs_is_found_and_the_order_of_the_runs_does_not_matter():
    # Two falls of 4 %, each inside the 5 % tolerance, 7.8 % from the first run to the last.
    runs = [_figures("a", 4.0, 1.0), _figures("b", 8.0, 0.96), _figures("c", 12.0, 0.9216)]
    assert rc.out_of_order(runs) == [("a", "c")]
    assert rc.out_of_order(runs[::-1]) == [("a", "c")]
    # Runs of the same speed are never a pair, in either order; a faster one is compared with the higher.
    same = [_figures("x", 8.0, 1.0), _figures("y", 8.0, 0.5), _figures("z", 10.0, 0.7)]
    assert rc.out_of_order(same) == [("x", "z")] == rc.out_of_order(same[::-1])


def test_a_force_that_falls_with_the_airflow_has_no_finite_bound():
    force, airflow = _run(5.0)
    reversed_slope = rc.run_force("odd", 2 * force.mean(axis=0) - force, airflow, OFFSET)
    assert reversed_slope is not None and reversed_slope.slope_n_per_mps < 0
    assert reversed_slope.bound_mps == math.inf and reversed_slope.below_bound


def test_a_vertical_airflow_that_moves_the_horizontal_force_does_not_bend_the_slope():
    # A figure-8 in a tilted plane: the vertical airflow follows the along-airflow sweep in part, and it
    # adds 0.8 N per m/s to the horizontal force; regressed on s alone the slope would gain 0.8 x 0.5.
    phase = np.linspace(0, 20 * math.pi, 2000, endpoint=False)
    speed = 6.0
    s = speed + AMPLITUDE * np.sin(phase)
    vz = 0.5 * np.sin(phase) + 0.5 * np.cos(3 * phase)   # cos 3 phase: orthogonal to the sweep squared
    force = np.column_stack([-(L * s + Q * s * s + 0.8 * vz), np.zeros_like(s)]) + OFFSET
    airflow = np.column_stack([-s, np.zeros_like(s), vz])
    r = rc.run_force("tilted", force, airflow, OFFSET)
    assert r is not None
    assert r.slope_n_per_mps == pytest.approx(L + 2 * Q * speed, rel=1e-6)
    assert r.force_n == pytest.approx(L * speed + Q * (speed ** 2 + AMPLITUDE ** 2 / 2), rel=1e-6)
