"""The run-mean anchored drag fit (dobwind/calibrate/runmeans.py, dragfit.anchor_on_runs), on synthetic runs.

Each run is a tunnel setting: a figure-8 sweeps the airflow +-1 m/s about the run's mean speed along x
(and 0.5 m/s vertically). The force follows a known heading-frame law exactly, so the regressor columns
are dragfit.basis of the airflow (no observer response: the fit is linear in them either way). Faults
the real Neural-Fly runs show are injected: one run with a force offset of its own (an outlier), and
within-run variation steeper than the run means imply."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from dobwind.calibrate import dragfit, runmeans
from dobwind.calibrate.fitfamily import refit_without_outliers
from dobwind.calibrate.fit import FitReport

TRUE = {"l0": 0.3, "q0": 0.08, "ox": 1.0, "oy": -0.5, "lz": 0.4, "kappa": 0.02}
SPEEDS = (0.0, 3.0, 6.0, 9.0, 12.0)
ACTIVE = dragfit.ANCHOR_TEST_SET + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS
NOISE_N = 0.05


def _theta() -> np.ndarray:
    return np.array([TRUE.get(p, 0.0) for p in dragfit.PARAMETERS])


def _samples(offsets: dict[float, float] | None = None, within_gain: float = 1.0, rows: int = 600) -> dragfit.DragSamples:
    """Runs at SPEEDS; ``offsets``: extra force along x (N) on a run; ``within_gain``: the within-run force
    variation along x scaled by this about the run's mean (the law holds for the means only)."""
    offsets = offsets or {}
    rng = np.random.default_rng(1)
    parts = []
    for index, speed in enumerate(SPEEDS):
        phase = np.linspace(0, 12 * math.pi, rows, endpoint=False)
        air = np.column_stack([speed + np.sin(phase), 0.3 * np.sin(0.5 * phase), 0.5 * np.cos(2 * phase)])
        columns = dragfit.basis(air)
        thrust = np.column_stack([0.2 * np.sin(phase), np.zeros(rows), -(26.0 + 3.0 * np.cos(2 * phase))])
        columns[:, :, dragfit.PARAMETERS.index("kappa")] = thrust
        force = np.einsum("nap,p->na", columns, _theta())
        mean_x = force[:, 0].mean()
        force[:, 0] = mean_x + within_gain * (force[:, 0] - mean_x) + offsets.get(speed, 0.0)
        force += NOISE_N * rng.standard_normal(force.shape)
        parts.append((force, columns, air, index))
    return dragfit.DragSamples(
        np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
        np.ones(rows * len(SPEEDS)), np.zeros(rows * len(SPEEDS)), np.concatenate([p[2] for p in parts]),
        np.concatenate([np.full(rows, p[3]) for p in parts]), np.concatenate([np.full(rows, p[3]) for p in parts]))


def _values(theta: np.ndarray) -> dict[str, float]:
    return dict(zip(dragfit.PARAMETERS, (float(v) for v in theta)))


def test_consistent_runs_are_not_anchored_and_the_law_is_recovered():
    samples = _samples()
    assert not dragfit.anchor_on_runs(samples).anchor     # the per-sample fit meets every run's mean
    values = _values(dragfit.robust_fit(samples, ACTIVE))
    assert values["l0"] == pytest.approx(TRUE["l0"], abs=0.02)
    assert values["q0"] == pytest.approx(TRUE["q0"], abs=0.002)
    verdicts = dragfit.run_verdicts(samples, ACTIVE, dragfit.robust_fit(samples, ACTIVE))
    assert [v.outlier for v in verdicts] == [False] * len(SPEEDS)
    assert max(v.error_mps for v in verdicts) < 0.05


def test_one_run_with_its_own_force_offset_is_flagged_and_moves_the_law_by_nothing():
    # The 6 m/s run reads 1.5 N less drag (the Neural-Fly 70wind run's fault): 1.5 / F'(6) = 1.5 / 1.26
    # = 1.19 m/s of airflow.
    samples = dragfit.anchor_on_runs(_samples({6.0: 1.5}))
    assert samples.anchor
    theta = dragfit.robust_fit(samples, ACTIVE)
    values = _values(theta)
    assert values["l0"] == pytest.approx(TRUE["l0"], abs=0.03)
    assert values["q0"] == pytest.approx(TRUE["q0"], abs=0.003)
    assert values["ox"] == pytest.approx(TRUE["ox"], abs=0.05)
    verdicts = dragfit.run_verdicts(samples, ACTIVE, theta)
    assert [v.outlier for v in verdicts] == [s == 6.0 for s in SPEEDS]
    flagged = next(v for v in verdicts if v.outlier)
    assert flagged.error_mps == pytest.approx(1.5 / (TRUE["l0"] + 2 * TRUE["q0"] * 6.0), rel=0.1)
    assert flagged.weight < runmeans.OUTLIER_WEIGHT
    assert max(v.error_mps for v in verdicts if not v.outlier) < 0.1


def test_a_run_counts_once_however_many_samples_it_holds():
    # Every run's sweep is 2.5 times as steep as the law its mean follows (the real runs' within-run
    # slopes against their means), so the samples and the means disagree. Repeating the slowest run's
    # samples tenfold moves the per-sample fit (its sweep outvotes the other runs), and leaves the
    # anchored fit where it was: a run's mean and its normalized within-run variation each count once.
    raw = _samples(within_gain=2.5)
    repeat = np.r_[np.arange(len(raw)), np.tile(np.flatnonzero(raw.log_index == 0), 9)]
    heavy = raw.select(repeat)
    moved = {}
    for anchor in (False, True):
        fits = [_values(dragfit.robust_fit(dataclasses.replace(s, anchor=anchor), ACTIVE)) for s in (raw, heavy)]
        moved[anchor] = max(abs(fits[1][k] - fits[0][k]) / TRUE[k] for k in ("l0", "q0"))
    assert moved[True] < 0.01
    assert moved[False] > 5 * moved[True] and moved[False] > 0.05


def test_fewer_logs_than_min_logs_are_never_anchored_or_flagged():
    samples = _samples({6.0: 1.5}).select(np.isin(np.repeat(np.arange(len(SPEEDS)), 600), [1, 2]))
    assert not dragfit.anchor_on_runs(samples).anchor
    assert not any(v.outlier for v in dragfit.run_verdicts(samples, ACTIVE, dragfit.robust_fit(samples, ACTIVE)))


def test_tukey_weights_follow_the_bisquare_closed_form():
    errors = np.array([0.0, 0.5, 1.0, 2.0])
    scale = 0.2
    c = runmeans.TUKEY_C * scale
    expected = [(1 - (e / c) ** 2) ** 2 if e < c else 0.0 for e in errors]
    assert runmeans.tukey_weights(errors, scale) == pytest.approx(expected)
    assert runmeans.robust_scale(np.array([0.0, 0.0, 0.0])) == runmeans.SCALE_FLOOR_MPS


def test_refusal_advice_names_the_run_and_exclusion_refits_without_it():
    runs = [runmeans.RunVerdict("a.csv", 2.0, 0.1, 1.0, False), runmeans.RunVerdict("b.csv", 4.0, 1.25, 0.0, True)]
    advice = runmeans.outlier_advice(runs)
    assert advice is not None and "b.csv" in advice and "1.25 m/s" in advice and "--exclude-outliers" in advice
    assert "a.csv" not in advice
    assert runmeans.outlier_advice(runs[:1]) is None
    first = (None, dataclasses.replace(FitReport(), runs=runs), None)
    seen: list[list[str]] = []

    def fit(logs: list[str]):
        seen.append(logs)
        return None, FitReport(), None

    _, report, _ = refit_without_outliers(first, ["a.csv", "b.csv"], fit)  # type: ignore[arg-type]
    assert seen == [["a.csv"]] and report.excluded_logs == ["b.csv"]
    assert any("b.csv" in w for w in report.warnings)
    same = refit_without_outliers(first, ["b.csv"], fit)  # type: ignore[arg-type]  # none would be left
    assert same is first and len(seen) == 1


def _runs(flags: list[bool]) -> list[runmeans.RunVerdict]:
    return [runmeans.RunVerdict(f"{k}.csv", 3.0, 1.0 if f else 0.1, 0.0 if f else 1.0, f) for k, f in enumerate(flags)]


def test_only_a_minority_of_an_anchored_fits_outliers_is_exempt():
    assert runmeans.exempt_outliers(_runs([False, False, True, False]), anchored=True) == ["2.csv"]
    assert runmeans.exempt_outliers(_runs([False, False, True, False]), anchored=False) == []
    assert runmeans.exempt_outliers(_runs([False, True, False]), anchored=True) == []          # 1 of 3
    assert runmeans.exempt_outliers(_runs([True, True] + [False] * 5), anchored=True) == ["0.csv", "1.csv"]
    assert runmeans.exempt_outliers(_runs([True, True, True] + [False] * 4), anchored=True) == []
    assert runmeans.exempt_outliers(_runs([False] * 4), anchored=True) == []


def test_the_self_check_does_not_judge_an_exempt_log_but_judges_the_others():
    from dobwind.model.airframe import load_airframe
    from dobwind.calibrate.selfcheck import LogCheck, Thresholds, verdict
    from tests.helpers import M300

    logs = [LogCheck(f"{k}.csv", 100, 50, 80, speed_rms_mps=rms, speed_max_mps=rms, direction_mean_deg=1.0)
            for k, rms in enumerate((0.1, 0.1, 1.5, 0.1))]
    af = load_airframe(M300)
    assert not verdict(af, logs, 0.1, 10.0, Thresholds()).passed
    exempt = verdict(af, logs, 0.1, 10.0, Thresholds(outlier_logs=("2.csv",)))
    assert exempt.passed and exempt.outlier_logs == ["2.csv"]
    logs[1] = dataclasses.replace(logs[1], speed_rms_mps=1.5)   # another log failing is still refused
    again = verdict(af, logs, 0.1, 10.0, Thresholds(outlier_logs=("2.csv",)))
    assert not again.passed and any(r.startswith("1.csv") for r in again.reasons)
