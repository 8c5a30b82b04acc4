"""The leave-one-out bounds (benchmarks/loobound.py) on runs made from known laws, and the goal's verdict
(benchmarks/realdata.loo_goal) on made-up results.

With only the zero-airflow slope g and one training run (upper point (s1, h1)), the upper envelope is
the chord h0 + (h1 - h0) r / s1, so the slowest reading solves a quadratic in closed form; with a
lower point (s2, h2) beyond it, the lower envelope beyond s2 is the line through (0, g) and (s2, h2),
and so is the fastest reading. A sinusoidal sweep s = A sin(phase) of F = l s + q s |s| has the
least-squares slope l + q E|s|^3 / E s^2 = l + 8 q A / (3 pi)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks import loobound as lb
from benchmarks import realdata
from benchmarks.runconsistency import RunForce

L, Q = 0.5, 0.07


def _run(name: str, speed: float, logged: float | None = None) -> RunForce:
    """A run flown at ``speed`` under F = L s + Q s^2, logged at ``logged`` (its nominal) if given."""
    force = L * speed + Q * speed * speed
    return RunForce(name, speed if logged is None else logged, force, L + 2 * Q * speed, math.nan)


def _quadratic_root(a: float, b: float, c: float) -> float:
    """The positive root of a r^2 + b r - c = 0."""
    return (-b + math.sqrt(b * b + 4 * a * c)) / (2 * a)


def test_zero_airflow_slope_follows_the_sweeps_closed_form_and_bounds_the_linear_term():
    amplitude = 1.4
    phase = np.linspace(0, 40 * math.pi, 4000, endpoint=False)
    s = amplitude * np.sin(phase)
    force = np.column_stack([-(L * s + Q * s * np.abs(s)), np.zeros_like(s)]) + [1.0, -0.4]
    airflow = np.column_stack([-s, np.zeros_like(s), np.zeros_like(s)])
    slope = lb.zero_airflow_slope(force, airflow)
    assert slope == pytest.approx(L + 8 * Q * amplitude / (3 * math.pi), rel=1e-6)
    assert slope >= L
    assert lb.zero_airflow_slope(force, airflow - [2.0, 0, 0]) is None        # not a zero-airflow run


def test_slowest_and_fastest_readings_follow_the_closed_forms():
    tol, g = 0.5, 0.6
    training = [_run("8", 8.0)]
    held = _run("4", 4.0)
    h1 = training[0].force_n / (8.0 - tol)
    slowest, fastest = lb.readings(held.force_n, lb.training_bounds(training, g, tol), 30.0)
    assert slowest == pytest.approx(_quadratic_root((h1 - g) / (8.0 - tol), g, held.force_n), abs=2e-3)
    # Beyond the training run: the line through (0, g) and its lower point bounds h from below.
    fast = _run("12", 12.0)
    h2 = training[0].force_n / (8.0 + tol)
    _, fastest = lb.readings(fast.force_n, lb.training_bounds(training, g, tol), 40.0)
    assert fastest == pytest.approx(_quadratic_root((h2 - g) / (8.0 + tol), g, fast.force_n), abs=2e-3)
    # The zero-airflow slope that brings the slowest reading of the 4 m/s run to 4 + tol, in closed form.
    r = 4.0 + tol
    needed = (held.force_n / r - h1 * r / (8.0 - tol)) / (1 - r / (8.0 - tol))
    top = lb.REACH * 8.0
    assert lb.zero_slope_needed(held, training, top, tol) == pytest.approx(max(needed, 0.0), abs=2e-3)
    # The force above reach: the run's mean force less r times the chord at r = 4 + tol (none when below it).
    heavy = RunForce("4", 4.0, held.force_n + 1.5, math.nan, math.nan)
    (bound,) = [b for b in lb.held_out_bounds([heavy, training[0]], g, tol=tol) if b.name == "4"]
    assert bound.beyond_goal and bound.excess_force_n > 0.4
    assert bound.excess_force_n == pytest.approx(heavy.force_n - r * (g + (h1 - g) * r / (8.0 - tol)), abs=1e-9)
    (light,) = [b for b in lb.held_out_bounds([held, training[0]], g, tol=tol) if b.name == "4"]
    assert light.excess_force_n == 0.0 and not light.beyond_goal


def test_runs_of_one_convex_law_are_bracketed_and_within_reach():
    runs = [_run(f"{v:g}", v) for v in (4.0, 8.0, 8.5, 12.0)]
    slope = L   # a zero-airflow sweep's slope is at least l (test above); l itself is the tightest
    for bound in lb.held_out_bounds(runs, slope):
        assert bound.training_consistent and not bound.beyond_goal, bound
        true = bound.speed_mps
        assert bound.slowest_mps <= true + lb.GRID_MPS
        assert math.isnan(bound.fastest_mps) or bound.fastest_mps >= true - lb.GRID_MPS
        assert bound.zero_slope_needed <= slope


def test_a_run_logged_slower_than_it_flew_is_beyond_the_goal_and_named_in_the_table():
    """A run flown at 5.5 m/s and logged at 4: more force than any convex law through the others gives
    at 4.5 m/s. Trained on it, the others cannot all be read within the goal (35wind's pattern)."""
    runs = [_run("slow", 5.5, logged=4.0)] + [_run(f"{v:g}", v) for v in (8.0, 12.0)]
    bounds = {b.name: b for b in lb.held_out_bounds(runs, L)}
    assert bounds["slow"].beyond_goal and bounds["slow"].slowest_mps > 4.5
    assert bounds["slow"].zero_slope_needed > L
    assert not bounds["8"].training_consistent
    left_out = {b.name: b for b in lb.held_out_bounds(runs, L, left_out=("slow",))}
    assert set(left_out) == {"8", "12"} and not left_out["8"].beyond_goal
    text = "\n".join(lb.lines(lb.held_out_bounds(runs, L), L))
    assert "slow" in text and "BEYOND the goal for every convex law" in text
    assert "no convex law reads every training run within the goal" in text


def test_the_goal_verdict_exempts_the_flagged_run_and_ignores_the_loo_fits_own_outliers():
    def loo(nominal, read, training, outliers=()):
        return {"nominal_mps": nominal, "mean_speed_mps": read, "training_errors_mps": training,
                "fit_outliers": list(outliers)}

    results = {
        "leave_one_out": {
            "nowind": loo(0.0, 5.0, {}),                                  # not interior: not judged
            "35wind": loo(4.2, 4.6, {"b_nowind": 0.3, "b_70wind": 0.4}),
            "70wind": loo(8.5, 7.0, {"b_35wind": 0.2}),                   # flagged by the four-run fit
            "70p20sint": loo(8.5, 8.7, {"b_35wind": 0.2, "b_70wind": 1.3}, outliers=("b_70wind",)),
            "100wind": loo(12.1, 14.0, {}),                               # the fastest: not judged
        },
        "constant_wind_fit": {"per_run": [{"log": "b_70wind", "outlier": True}, {"log": "b_35wind", "outlier": False}]},
    }
    goal = realdata.loo_goal(results)
    assert set(goal) == {"35wind", "70wind", "70p20sint"}
    assert goal["35wind"]["met"] and goal["35wind"]["error_mps"] == pytest.approx(0.4)
    assert goal["70wind"]["exempt"] and goal["70wind"]["met"]
    assert goal["70p20sint"]["met"] and goal["70p20sint"]["training_max_error_mps"] == pytest.approx(0.2)
    results["leave_one_out"]["35wind"]["training_errors_mps"]["b_70wind"] = 0.6   # a training run off
    assert not realdata.loo_goal(results)["35wind"]["met"]
    assert realdata.loo_goal_lines(results)[-1] == "  goal NOT met"


def test_below_two_training_runs_the_line_through_them_bounds_the_fastest_reading():
    """Held out below runs at 8 and 12 m/s (no zero-airflow slope): a convex h lies above the line
    through the 8 m/s run's lower point (8 + tol, F8 / (8 + tol)) and the 12 m/s run's upper point
    (12 - tol, F12 / (12 - tol)), extended back below the former."""
    tol = 0.5
    training = [_run("8", 8.0), _run("12", 12.0)]
    held = _run("4", 4.0)
    (s2, h2), (s3, h3) = (8.0 + tol, training[0].force_n / (8.0 + tol)), (12.0 - tol, training[1].force_n / (12.0 - tol))
    m = (h3 - h2) / (s3 - s2)
    _, fastest = lb.readings(held.force_n, lb.training_bounds(training, None, tol), 40.0)
    assert fastest == pytest.approx(_quadratic_root(m, h2 - m * s2, held.force_n), abs=2e-3)
    assert fastest >= 4.0
