"""Optional checks on the real data in ../shared/data (never copied into the project). They skip
where the data is absent; CI has it beside the clone, so there they run."""
from __future__ import annotations

import math

import pytest

from benchmarks import realdata, runconsistency


@pytest.fixture(scope="module")
def results():
    """realdata.check(), whole (its seven fits, about 40 s serial), once for the module: every test here is
    marked slow (tests/conftest.py), so no quick run pays for it, and the leave-one-out test below reads the
    same call instead of fitting the split and the constant-wind runs a second time (12 s)."""
    if len(realdata.runs(realdata.DEFAULT_DATA)) < 5:
        pytest.skip("the Neural-Fly runs are not beside this checkout")
    return realdata.check()


@pytest.fixture(scope="module")
def consistency():
    """realdata.consistency() (the runs converted and their drag samples read, no fit: 1.5-3 s), once for
    the module: two tests read it, one beside the command line's own run of it."""
    if len(realdata.runs(realdata.DEFAULT_DATA)) < 5:
        pytest.skip("the Neural-Fly runs are not beside this checkout")
    return realdata.consistency()


def test_neural_fly_wind_direction(results):
    for name, r in results["split"].items():
        if r["nominal_mps"] > 0:
            assert abs((r["mean_from_deg"] + 180) % 360 - 180) < 15.0, name


def test_neural_fly_split_fit_warns_that_its_vertical_law_is_not_identified(results):
    """Level figure-8s move the air vertically by about 0.7 m/s RMS, and the collective thrust's error
    swamps the vertical drag: the fit says its vertical wind is unreliable rather than pass it silently."""
    warnings = results["split"]["nowind"]["warnings"]
    assert any(w.startswith("the vertical law predicts held-out vertical airflow no better than zero") for w in warnings)


def test_neural_fly_held_out_speed(results):
    held_out = results["split"]["70wind"]
    assert not held_out["trained_on"]
    assert held_out["mean_speed_mps"] == pytest.approx(held_out["nominal_mps"], rel=0.25)


def test_neural_fly_runs_against_a_convex_law(consistency, capsys):
    """The no-fit consistency check (runconsistency.py) through the module's command line: the offset is
    the ~1 N x bias the data's README mentions, and the runs the fit reproduces (70wind, 100wind within
    0.3 m/s in the README) sit above their bounds."""
    assert realdata.main(["--consistency"]) == 0
    text = capsys.readouterr().out
    found = consistency
    assert 0.5 < found["offset_n"][0] < 1.5
    by_name = {r.name: r for r in found["runs"]}
    assert set(by_name) == {"35wind", "70wind", "70p20sint", "100wind"}
    assert not by_name["70wind"].below_bound and not by_name["100wind"].below_bound
    # The README's finding: 35wind is logged below its bound, and its force per m/s is above 70wind's.
    assert by_name["35wind"].below_bound
    assert ("35wind", "70wind") in runconsistency.out_of_order(found["runs"])
    assert "35wind -> 70wind: force per m/s falls with the speed" in text
    assert all(r.slope_n_per_mps > 0 for r in by_name.values())
    assert text.splitlines()[1].startswith("  force offset from the zero-airflow run:")


def test_neural_fly_constant_wind_fit_writes_a_model_and_names_its_outlier(results):
    """Issue #31: `fit` on the four constant-wind runs, no options, writes a model. The run means
    disagree (no convex law meets them all, test above), so the fit anchored on the means flags one run
    and leaves every other within 0.5 m/s of its mean airflow."""
    fit = results["constant_wind_fit"]
    assert fit["anchored"] and fit["passed"], fit["reasons"]
    flagged = [run for run in fit["per_run"] if run["outlier"]]
    assert len(flagged) == 1 and flagged[0]["error_mps"] > 0.5
    assert all(run["error_mps"] < 0.5 for run in fit["per_run"] if not run["outlier"])


def test_neural_fly_leave_one_out_bounds_put_35wind_beyond_every_convex_law(consistency):
    """The no-fit leave-one-out bounds (loobound.py): held out, 35wind cannot be read within 0.5 m/s by any
    law with a convex force per m/s whose slope at zero airflow is the no-wind run's (it would need a
    steeper one), whether or not 70wind trains; without 35wind, 70wind and 70p20sint are within reach."""
    found = consistency
    slope = found["zero_slope_n_per_mps"]
    assert 0.3 < slope < 0.8
    bounds = {(b.name, b.left_out): b for b in found["held_out_bounds"]}
    for left_out in ((), ("70wind",)):
        held = bounds[("35wind", left_out)]
        assert held.beyond_goal and held.slowest_mps > held.speed_mps + 0.5 and held.zero_slope_needed > slope
    assert not bounds[("70wind", ("35wind",))].beyond_goal
    assert not bounds[("70p20sint", ("35wind",))].beyond_goal


def test_neural_fly_leave_one_out_scores_every_run_and_judges_the_interior_ones(results):
    """The whole of `make realdata`'s check: every training run held out once with finite figures, and the
    issue #31 verdict given for the interior runs only (neither the still-air run nor the fastest)."""
    full = results
    loo = full["leave_one_out"]
    assert set(loo) == set(full["split"]) and len(loo) >= 4
    assert all(math.isfinite(r["mean_speed_mps"]) for r in loo.values())
    fastest = max(loo, key=lambda n: loo[n]["nominal_mps"])
    judged = set(realdata.loo_goal(full))
    assert judged and fastest not in judged
    assert all(loo[n]["nominal_mps"] > 0 for n in judged)
