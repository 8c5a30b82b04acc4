"""--wind unknown's thrust scale (dobwind/calibrate/thrustscale.py, issue #36).

A starter airframe's collective thrust is often 10-25 % off, and the wind solver reads the error as wind.
Pinned here: the vertical balance recovers a known kappa in closed form through the step's filters; the
nested-model test's arithmetic; and on a simulated box flight, a starter whose thrust scale is 1.25x off
gives the simulator's wind back (it does not with the estimate disabled: the mutation), while a starter
with the right scale gets exactly the solution it got before the thrust scale existed."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dobwind.calibrate import thrustscale, windrows, windsolve
from dobwind.calibrate.fieldtruth import flight_of
from dobwind.calibrate.windsolve import estimate_winds
from dobwind.core.errors import CheckFailed
from dobwind.io.logs import write_csv
from dobwind.simulate.simulate import simulate
from tests.conftest import SolveMemo
from tests.test_fieldcal import _airframe, _mean_wind


def _synthetic(af, kappa: float, lz: float, qz: float, noise: float, seed: int = 1):
    """A jittered 10 Hz climb-and-descend record whose raw down force is exactly kappa t_d + lz a + qz |a| a."""
    rng = np.random.default_rng(seed)
    n = 1500
    times = np.cumsum(0.1 * (1 + 0.1 * rng.standard_normal(n)))
    vel_d = 2.0 * np.sin(times / 7.0) + 0.5 * np.sin(times / 1.3)
    thrust_d = -af.mass_kg * af.gravity_mps2 * (1 + 0.1 * np.sin(times / 2.1))
    air = -vel_d
    raw = kappa * thrust_d + lz * air + qz * np.abs(air) * air
    path = windrows.observer_path(af, np.diff(times, prepend=times[0]), axes=(2, 2))
    filtered = windrows.through_observer(path, np.column_stack([raw, raw]))[:, 0] + noise * rng.standard_normal(n)
    fitted = np.arange(n) % 2 == 0
    return thrustscale.vertical_rows(af, times, filtered, thrust_d, vel_d, fitted, 0.1)


def test_the_vertical_balance_recovers_kappa_in_closed_form(tmp_path):
    """Noise-free: kappa, exactly (the filters are linear and the regressors go through the same ones);
    noisy: within a few of its 1-sigmas, and the 1-sigma shrinks with the noise."""
    _, af = _airframe(tmp_path)
    exact = thrustscale.estimate([_synthetic(af, -0.2, 0.4, 0.1, 0.0)])
    assert exact.kappa == pytest.approx(-0.2, abs=1e-9)
    noisy = thrustscale.estimate([_synthetic(af, 0.15, 0.4, 0.1, 0.3)])
    assert abs(noisy.kappa - 0.15) < 4 * noisy.sigma and 0 < noisy.sigma < 0.02
    assert thrustscale.worth_trying(noisy) and not thrustscale.worth_trying(thrustscale.estimate([_synthetic(af, 0.0, 0.4, 0.1, 0.3)]))


def test_a_small_or_uncertain_vertical_kappa_is_not_tried():
    """Below MIN_KAPPA (thrust's own variation with the airflow), or within SIGNIFICANCE 1-sigmas of zero."""
    floor, k = thrustscale.MIN_KAPPA, thrustscale.SIGNIFICANCE
    assert thrustscale.worth_trying(thrustscale.ThrustScale(floor * 1.1, 1e-4, False))
    assert not thrustscale.worth_trying(thrustscale.ThrustScale(floor * 0.9, 1e-4, False))
    assert not thrustscale.worth_trying(thrustscale.ThrustScale(-0.2, 0.2 / k * 1.01, False))
    assert thrustscale.worth_trying(thrustscale.ThrustScale(-0.2, 0.2 / k * 0.99, False))
    assert "not used (within" in thrustscale.ThrustScale(0.02, 1e-4, False).text()


def test_the_nested_model_test_counts_the_residual_drop_in_variances():
    """Residuals of unit MAD scale: a drop of sum(without^2) - sum(with^2) in those units, divided by the
    correlation's inflation squared, against chi-square(1) at 0.999."""
    rng = np.random.default_rng(3)
    with_kappa = rng.standard_normal(4000)
    sigma = 1.4826 * np.median(np.abs(with_kappa - np.median(with_kappa)))
    base = thrustscale.ThrustScale(0.2, 0.01, False)
    for shift, inflation in ((0.01, 1.0), (0.1, 1.0), (0.1, 3.0)):
        without = with_kappa + shift
        expected = (np.sum(without ** 2) - np.sum(with_kappa ** 2)) / (sigma * sigma * inflation * inflation)
        verdict = thrustscale.nested_test(base, without, with_kappa, inflation)
        assert verdict.evidence == pytest.approx(expected, rel=1e-9)
        assert verdict.used == (expected > thrustscale.CHI2_1) and verdict.applied == (0.2 if verdict.used else 0.0)


@pytest.fixture(scope="module")
def box_csv(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("thrustscale")
    _, af = _airframe(tmp)
    cols = simulate(af, "box", seed=5, hold_s=6.0, rate_hz=10.0)
    names = [k for k in cols if not k.startswith("wind_")]
    csv = tmp / "box.csv"
    write_csv(csv, names, np.column_stack([cols[k] for k in names]), ["%.9g"] * len(names))
    return af, str(csv), _mean_wind(cols)


@pytest.fixture(scope="module")
def _problem_memo() -> SolveMemo:
    return SolveMemo(windsolve.solve)


@pytest.fixture
def shared_problems(_problem_memo: SolveMemo, monkeypatch: pytest.MonkeyPatch) -> SolveMemo:
    """windsolve.solve (the nine bounded least-squares runs: 1-5 s a solve here, idle to loaded) computed once per
    distinct Problem in this module (issue #34). Each test below solves a flight with and without the thrust
    scale, and both begin with the same kappa-0 problem: asked again, it is the same pure function of the
    same pickled Problem (rows, prior, scale, kappa). A Problem that differs in any value (a kappa applied
    where it should not be) is solved afresh, so the comparisons below still see any difference."""
    monkeypatch.setattr(windsolve, "solve", _problem_memo)
    return _problem_memo


def _scaled(af, factor: float):
    return dataclasses.replace(af, thrust=dataclasses.replace(af.thrust, scale=af.thrust.scale * factor))


def _solve(af, csv: str, thrust_scale: bool):
    return estimate_winds(af, [(csv, flight_of(csv, af, None))], thrust_scale=thrust_scale)


@pytest.mark.slow
def test_a_starter_with_the_thrust_25_percent_high_still_finds_the_wind(box_csv, shared_problems):
    """The starter's thrust 1.25x the vehicle's: the vertical balance finds kappa = 1 - 1/1.25 within a few
    percent (the simulated vehicle's own thrust is a few percent off the nominal curve), the nested test
    keeps it, and the wind is within the solver's own 0.5 m/s limit. Mutation: with the estimate disabled
    the same flight's wind is more than 1 m/s off (or refused)."""
    af, csv, truth = box_csv
    high = _scaled(af, 1.25)
    solution = _solve(high, csv, thrust_scale=True)
    scale = solution.thrust_scale
    assert scale.used and abs(scale.kappa - (1 - 1 / 1.25)) < 0.05, scale
    (group,) = solution.groups
    assert np.hypot(*(np.array(group.wind_ne) - truth)) < 0.5, (group, truth)
    try:
        (blind,) = _solve(high, csv, thrust_scale=False).groups
        assert np.hypot(*(np.array(blind.wind_ne) - truth)) > 1.0, (blind, truth)
    except CheckFailed:
        pass   # refused: not found either


@pytest.mark.slow
def test_a_starter_with_the_right_thrust_scale_gets_the_solution_it_got_without_it(box_csv, shared_problems):
    """The nominal vehicle: the vertical balance's small kappa (+0.02, the simulated vehicle's own thrust
    error) is not tried, and the winds are exactly those of the solve without a thrust scale."""
    af, csv, truth = box_csv
    solution = _solve(af, csv, thrust_scale=True)
    plain = _solve(af, csv, thrust_scale=False)
    assert not solution.thrust_scale.used and solution.law["kappa"] == 0.0
    assert [g.wind_ne for g in solution.groups] == [g.wind_ne for g in plain.groups]
    assert np.hypot(*(np.array(solution.groups[0].wind_ne) - truth)) < 0.25
    assert shared_problems.calls > shared_problems.computed   # the plain problem was solved once, not twice
