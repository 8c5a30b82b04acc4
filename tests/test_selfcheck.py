"""The fit checks itself: hold-level CV arithmetic, the verdict's thresholds, and `fit` refusing (exit 1,
nothing written) or forcing (--force) a model that failed its self-check."""
from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.calibrate.holdcv import HoldCV, _window_ids, window_speed_errors
from dobwind.model.airframe import load_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.calibrate.selfcheck import LogCheck, Thresholds, check_log, text_table, verdict
from tests.helpers import M300

TINY_VEHICLE = {"mass": 2.0, "rate": 20.0, "drag": {"x": {"quadratic": 0.03}, "y": {"quadratic": 0.04},
                                                     "z": {"linear": 0.3}},
                "rotor_drag": {"coefficient": 0.2}, "thrust": {"scale": 1.03}}
TINY_AIRFRAME = {
    "name": "tiny", "mass": 2.0, "thrust": {"source": "collective"},
    "observer": {"sample_time": 0.05, "gains": [12.0, 12.0, 12.0], "discretization": "paper", "acceleration": "velocity"},
    "force_air": {"horizontal": {"terms": ["fh^0.5"], "coefficients": [4.0]},
                  "vertical": {"terms": ["fz"], "coefficients": [0.5]}},
    "filter": {"speeds": [0.0, 3.0, 10.0], "cutoffs": [0.2, 0.35, 0.5]},
}


# --- hold-level CV ------------------------------------------------------------------------------

def test_window_errors_average_noise_and_ignore_direction():
    """Truth at 5 m/s along x; the prediction 4 % fast, turned 3 deg, with zero-mean noise of 0.5 m/s on
    every sample. Per sample the vector error is about 0.6 m/s; per 100-sample window the hold-mean
    speed error is 0.2 m/s (4 % of 5), up to the noise's mean over the window."""
    rng = np.random.default_rng(3)
    n = 1000
    truth = np.tile([5.0, 0.0, 0.0], (n, 1))
    turn = math.radians(3.0)
    predicted = 1.04 * 5.0 * np.tile([math.cos(turn), math.sin(turn), 0.0], (n, 1))
    predicted[:, :2] += rng.normal(0.0, 0.5, (n, 2))
    per_sample = float(np.sqrt(np.mean(np.sum((predicted - truth)[:, :2] ** 2, axis=1))))
    windows = _window_ids(np.zeros(n, dtype=int), 100)
    errors = window_speed_errors(predicted, truth, windows)
    assert len(errors) == 10 and per_sample > 0.5
    assert np.all(np.abs(errors - 0.2) < 4 * 0.5 / math.sqrt(100))


def test_windows_split_blocks_and_never_span_two():
    group = np.array([0, 0, 0, 0, 0, 3, 3, 3])
    ids = _window_ids(group, 2)
    assert len(np.unique(ids)) == 3 + 2
    assert len(set(ids[:5]) & set(ids[5:])) == 0


def test_with_segments_each_hold_is_one_window_scored_after_its_transition():
    """Two logs of three 8 s segments at 10 Hz; the prediction is 1 m/s off during each segment's first
    5 s (the transition) and exact after it. Scored per segment after HOLD_SETTLE_S, the hold-mean
    errors are 0; the fixed 10 s windows, which straddle transitions, see the transitions' error."""
    from dobwind.calibrate import dragfit, holdcv

    t = np.arange(240) / 10.0
    segment = (t // 8).astype(int)
    hold, age = dragfit.segment_runs(t, segment)
    assert list(np.unique(hold)) == [0, 1, 2] and age.max() == pytest.approx(7.9) and age[80] == 0.0
    n = 2 * len(t)
    truth = np.tile([5.0, 0.0, 0.0], (n, 1))
    predicted = truth.copy()
    predicted[np.tile(age < holdcv.HOLD_SETTLE_S, 2), 0] += 1.0
    zeros = np.zeros(n)
    samples = dragfit.DragSamples(zeros[:, None] * np.ones(3), np.zeros((n, 3, len(dragfit.PARAMETERS))), zeros + 1,
                                  zeros, truth, np.repeat([0, 1], len(t)), np.repeat([0, 1], len(t)),
                                  hold=np.tile(hold, 2), hold_age_s=np.tile(age, 2))
    windows, scored = holdcv._scored_windows(samples, 100)
    assert len(np.unique(windows[scored])) == 6
    assert np.all(window_speed_errors(predicted[scored], truth[scored], windows[scored]) == 0.0)
    fixed = dataclasses.replace(samples, hold=None, hold_age_s=None)
    windows, scored = holdcv._scored_windows(fixed, 100)
    assert scored.all() and np.max(window_speed_errors(predicted, truth, windows)) > 0.3


def _hold_samples(holds: int, rate_hz: float = 10.0, hold_s: float = 8.0):
    """One log of ``holds`` segments along heading x, at 1-8 m/s in turn; ``observed[:, 0]`` carries each
    sample's index so that a fake fit_predict can add a known error to it."""
    from dobwind.calibrate import dragfit

    t = np.arange(int(holds * hold_s * rate_hz)) / rate_hz
    hold, age = dragfit.segment_runs(t, (t // hold_s).astype(int))
    n = len(t)
    observed = np.zeros((n, 3))
    observed[:, 0] = np.arange(n)
    truth = np.zeros((n, 3))
    truth[:, 0] = 1.0 + hold % 8
    return dragfit.DragSamples(observed, np.zeros((n, 3, len(dragfit.PARAMETERS))), np.ones(n), np.zeros(n), truth,
                               hold, np.zeros(n, dtype=int), hold=hold, hold_age_s=age)


def _adding(error_x: np.ndarray):
    return lambda train, test: test.airflow + np.c_[error_x[test.observed[:, 0].astype(int)], np.zeros((len(test), 2))]


def test_hold_cv_separates_a_bias_that_stays_from_noise_that_averages_out():
    """A constant 0.05 m/s bias plus white noise of 0.2 m/s per 10 Hz sample: a window's mean has noise
    variance 0.04 / n, so noise x sqrt(T) = 0.2 sqrt(0.1 s) whatever the window; the bias is 0.05. The
    scored part of an 8 s hold is 3 s, so on it the RMS error is sqrt(0.05^2 + 0.04 / 30), and on a
    hold scored for 15 s, sqrt(0.05^2 + 0.004 / 15)."""
    from dobwind.calibrate import holdcv

    samples = _hold_samples(600)
    noise = np.random.default_rng(3).normal(0.0, 0.2, len(samples))
    hold = holdcv.hold_cv(samples, _adding(0.05 + noise))
    assert hold.window_s == pytest.approx(3.0)
    assert hold.rms_mps == pytest.approx(math.sqrt(0.05 ** 2 + 0.04 / 30), rel=0.06)
    assert len(hold.band_bias_mps) == 5   # five speed bands of 120 windows each
    assert np.mean(hold.band_bias_mps) == pytest.approx(0.05, rel=0.1) and np.allclose(hold.band_bias_mps, 0.05, rtol=0.3)
    assert np.allclose(hold.band_noise_mps_sqrt_s, 0.2 * math.sqrt(0.1), rtol=0.15)
    assert hold.predicted(5.0, 8.0, 15.0) == pytest.approx(math.sqrt(0.05 ** 2 + 0.004 / 15), rel=0.1)
    speed = hold.band_speeds_mps[2]
    assert hold.predicted(speed, 8.0) == pytest.approx(hold.band_rms_mps[2])  # no length: as measured
    # Limiting cases: a pure bias has no noise and predicts itself at any length; pure noise no bias.
    biased = holdcv.hold_cv(samples, _adding(np.full(len(samples), 0.05)))
    assert np.allclose(biased.band_bias_mps, 0.05) and np.allclose(biased.band_noise_mps_sqrt_s, 0.0)
    assert biased.predicted(5.0, 8.0, 100.0) == pytest.approx(0.05)
    noisy = holdcv.hold_cv(samples, _adding(noise))
    assert max(noisy.band_bias_mps) < 0.015 and noisy.predicted(5.0, 8.0, 300.0) < 0.5 * noisy.rms_mps


def test_hold_cv_halves_are_halves_in_time():
    """+0.1 m/s in each scored window's first half, -0.1 in its second: every window's mean is exact,
    the halves differ by 0.2, so the split reads noise of variance 0.01 per window and no bias."""
    from dobwind.calibrate import holdcv

    samples = _hold_samples(100)
    scored_age = samples.hold_age_s - holdcv.HOLD_SETTLE_S
    error = np.where(scored_age < 1.5, 0.1, -0.1)
    hold = holdcv.hold_cv(samples, _adding(error))
    assert hold.rms_mps == pytest.approx(0.0, abs=1e-9)
    assert np.allclose(hold.band_noise_mps_sqrt_s, math.sqrt(0.01 * 3.0)) and np.allclose(hold.band_bias_mps, 0.0)


def test_predicted_hold_error_inside_and_beyond_the_calibration():
    hold = HoldCV(0.05, (1.0, 5.0), (0.10, 0.02), 0.3)
    assert hold.predicted(3.0, 8.0) == pytest.approx(0.06)     # linear between bands
    assert hold.predicted(0.0, 8.0) == pytest.approx(0.10)     # clamped below
    assert hold.predicted(7.0, 8.0) == pytest.approx(0.02)     # clamped above, still calibrated
    assert hold.predicted(9.0, 8.0) == pytest.approx(0.3)      # beyond the range: extrapolation
    assert HoldCV(0.05, (), (), math.nan).predicted(9.0, 8.0) == pytest.approx(0.05)


# --- the verdict ----------------------------------------------------------------------------------

def _log(name, fit_samples=500, rms=0.05, direction=1.0):
    return LogCheck(name, 1000, fit_samples, 800, [], rms, rms, direction, direction)


def test_limits_scale_with_the_speed_range_above_a_floor():
    limits = Thresholds(cv_share=0.05, replay_share=0.1, floor_mps=0.2)
    af = load_airframe(M300)
    check = verdict(af, [_log("a.csv")], 0.3, 10.0, limits)
    assert check.cv_limit_mps == pytest.approx(0.5) and check.replay_limit_mps == pytest.approx(1.0)
    assert check.passed and check.reasons == []
    small = verdict(af, [_log("a.csv")], 0.19, 1.0, limits)  # 5 % of 1 m/s is below the floor
    assert small.cv_limit_mps == pytest.approx(0.2) and small.passed


@pytest.mark.parametrize("cv, diverged", [(0.6, False), (49.9, False), (480.7, True)])
def test_a_cv_only_diverged_predictions_can_give_says_so(cv, diverged):
    """Held-out predictions that diverge count as dragfit.ERROR_CLIP_MPS (1000 m/s): a CV of tens of m/s
    and more is theirs, never an airflow's, and the reason says it (a 31 s real flight read 480.693 m/s)."""
    check = verdict(load_airframe(M300), [_log("a.csv")], cv, 10.0, Thresholds(cv_share=0.05, replay_share=0.1))
    reason = next(r for r in check.reasons if r.startswith("hold-level CV"))
    assert reason.startswith(f"hold-level CV {cv:.3f} m/s > 0.500 m/s")
    assert ("held-out predictions diverged, each counted as 1000 m/s" in reason) == diverged, reason


@pytest.mark.parametrize("case,expected", [
    ("cv", "hold-level CV 0.600 m/s > 0.500 m/s"),
    ("nothing", "b.csv: contributed no usable sample"),
    ("replay", "b.csv: training replay speed error RMS 1.200 m/s > 1.000 m/s"),
    ("direction", "b.csv: training replay direction error mean 12.00 deg > 10 deg"),
    ("coefficient", "coefficient horizontal[1] = inf"),
    ("no cv", "no cross-validation figure"),
])
def test_each_reason_fails_the_check(case, expected):
    af = load_airframe(M300)
    logs, cv = [_log("a.csv"), _log("b.csv")], 0.3
    if case == "cv":
        cv = 0.6
    elif case == "nothing":
        logs[1] = _log("b.csv", fit_samples=0)
    elif case == "replay":
        logs[1] = _log("b.csv", rms=1.2)
    elif case == "direction":
        logs[1] = _log("b.csv", direction=12.0)
    elif case == "coefficient":
        coefficients = (math.inf,) + af.horizontal.coefficients[1:]
        af = dataclasses.replace(af, horizontal=dataclasses.replace(af.horizontal, coefficients=coefficients))
    else:
        cv = None
    check = verdict(af, logs, cv, 10.0, Thresholds(cv_share=0.05, replay_share=0.1, floor_mps=0.2))
    assert not check.passed and len(check.reasons) == 1 and expected in check.reasons[0], check.reasons
    assert "FAIL: " + check.reasons[0] in text_table(check)


def test_the_direction_chord_is_the_distance_an_angle_puts_between_two_winds_of_one_speed():
    from dobwind.calibrate.selfcheck import direction_chord_mps

    v, angle = 3.0, 37.0
    a, b = np.array([v, 0.0]), v * np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle))])
    assert direction_chord_mps(v, angle) == pytest.approx(np.linalg.norm(a - b), rel=1e-12)
    assert direction_chord_mps(v, 180.0) == pytest.approx(2 * v) and direction_chord_mps(v, 0.0) == 0.0
    assert direction_chord_mps(v, 10.0) == pytest.approx(v * math.radians(10.0), rel=2e-3)  # small: v times the angle


@pytest.mark.parametrize("degrees, distance, fails", [
    (12.0, 1.05, True),    # 12 deg at 5 m/s: over both
    (17.5, 0.53, True),    # a real 1.75 m/s flight's 17.5 deg: 0.53 m/s, over the 0.424 tolerance
    (15.0, 0.31, False),   # 15 deg at 1.2 m/s: 0.31 m/s, within what the speed check allows along the wind
    (9.0, 2.0, False),     # within the degrees: the distance does not matter
    (12.0, None, True),    # no distance recorded (a report from before): the degrees alone, as before
])
def test_a_direction_error_fails_only_when_it_is_large_in_degrees_and_as_a_distance(degrees, distance, fails):
    from dobwind.calibrate.selfcheck import direction_fails

    log = dataclasses.replace(_log("b.csv", direction=degrees), direction_mean_mps=distance)
    assert direction_fails(log, 10.0, 0.424) == fails
    check = verdict(load_airframe(M300), [log], 0.1, 7.06, Thresholds())  # 6 % of 7.06 m/s: 0.424
    assert check.replay_limit_mps == pytest.approx(0.4236) and check.passed == (not fails), check.reasons


# --- the whole command ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tiny")
    (folder / "tiny.vehicle.toml").write_text(dumps(TINY_VEHICLE))
    (folder / "tiny.airframe.toml").write_text(dumps(TINY_AIRFRAME))
    paths = {"airframe": str(folder / "tiny.airframe.toml")}
    for name, seed, hold in (("sweep", 1, "5"), ("vertical", 2, "8"), ("tunnel", 3, "0.1")):
        path = folder / f"{name}.csv"
        assert main(["simulate", name, "--airframe", paths["airframe"], "--vehicle", str(folder / "tiny.vehicle.toml"),
                     "--seed", str(seed), "--hold", hold, "-o", str(path)]) == 0
        paths[name] = str(path)
    return paths


def test_a_good_fit_passes_and_its_replay_matches_replay(tiny, tmp_path, capsys, shared_fits):
    out = tmp_path / "good.toml"
    capsys.readouterr()
    assert main(["fit", tiny["airframe"], tiny["sweep"], tiny["vertical"], "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    check = report["self_check"]
    assert check["passed"] and report["written"] and out.exists()
    assert [c["log"] for c in check["logs"]] == [tiny["sweep"], tiny["vertical"]]
    sweep = check["logs"][0]
    assert sweep["fit_samples"] > 100 and len(sweep["segments"]) > 100 and sweep["speed_rms_mps"] < check["replay_limit_mps"]
    assert len(check["logs"][1]["segments"]) >= 10
    assert check["warnings"] == [] and not any("direction error" in w for w in report["warnings"])
    # The self-check runs the same step as `replay` (an independent path: its own reader, runner and
    # scoring). Scored from the same 5 s into each segment, the per-segment speed errors agree up to the
    # delay matching of the truth, which a steady hold's mean hardly sees.
    from dobwind.io.logs import read_log
    from dobwind.replay.replay import replay, score

    fitted = load_airframe(out)
    model, log, traj = replay(fitted, tiny["vertical"])
    by_segment = {r["segment"]: r["speed_error"] for r in score(log, traj, model)["per_segment"]["table"]}
    mine = {r.segment: r.speed_error_mps for r in check_log(fitted, read_log(tiny["vertical"]), 1, 5.0).segments}
    assert len(by_segment) >= 10 and set(by_segment) == set(mine)
    assert max(abs(by_segment[s] - mine[s]) for s in by_segment) < 0.01


def test_the_self_check_runs_the_compiled_double_step_or_without_a_compiler_the_reference(tiny, monkeypatch):
    """With a compiler the self-check replays through the double-precision C (faster for a body law);
    without one, through the reference. The project holds the two bit for bit equal, so the check's
    every figure is the same either way."""
    import dataclasses as dc

    from dobwind.calibrate import selfcheck
    from dobwind.io.logs import read_log

    fitted = load_airframe(tiny["airframe"])
    log = read_log(tiny["vertical"])
    compiled_runs = []
    real_compile = selfcheck.compile_step
    monkeypatch.setattr(selfcheck, "compile_step", lambda *a: compiled_runs.append(a[1]) or real_compile(*a))
    with_c = check_log(fitted, log, 1, 5.0)
    assert compiled_runs == ["double"]
    monkeypatch.setattr(selfcheck, "system_compiler", lambda: "/nonexistent/cc")
    without_c = check_log(fitted, log, 1, 5.0)
    assert compiled_runs == ["double"]   # not asked again: no compiler
    assert dc.asdict(with_c) == dc.asdict(without_c) and with_c.points_kept > 0 and with_c.noise_h_mps > 0


def test_fit_records_the_observer_noise_of_its_own_replay(tiny, tmp_path, capsys, shared_fits):
    """Issue #10: sigma = the residual table at the speed plus the observer noise. The self-check's
    replay measures the noise (scatter about each segment's mean error) on each log; the same vehicle
    and estimator give the same noise on both logs, and the written airframe carries their pooled value,
    which every accepted sample's sigma then includes."""
    out = tmp_path / "noisy.toml"
    capsys.readouterr()
    assert main(["fit", tiny["airframe"], tiny["sweep"], tiny["vertical"], "-o", str(out), "--json"]) == 0
    check = json.loads(capsys.readouterr().out)["self_check"]
    per_log = [c["noise_h_mps"] for c in check["logs"]]
    assert all(n > 0.005 for n in per_log) and max(per_log) < 1.25 * min(per_log), per_log
    assert min(per_log) <= check["noise_h_mps"] <= max(per_log) and check["noise_up_mps"] > 0
    fitted = load_airframe(out)
    assert fitted.uncertainty.noise_h_mps == pytest.approx(check["noise_h_mps"], rel=1e-12)
    assert fitted.uncertainty.noise_up_mps == pytest.approx(check["noise_up_mps"], rel=1e-12)
    from dobwind.model.status import accepted
    from dobwind.replay.replay import replay

    model, _, traj = replay(fitted, tiny["vertical"])
    sigma = traj.outputs[accepted(traj.status), model.outputs.slice("wind_sigma_h")][:, 0]
    lowest_table = min(fitted.uncertainty.sigma_h_mps)
    assert np.all(sigma >= np.hypot(lowest_table, fitted.uncertainty.noise_h_mps) * (1 - 1e-12))


def test_a_log_that_contributes_nothing_fails_and_nothing_is_written(tiny, tmp_path, capsys):
    """A 0.8 s tunnel log ends before the observer settles: it gives the fit nothing."""
    out = tmp_path / "bad.toml"
    plot = tmp_path / "bad_fit.png"
    out.write_text("earlier result\n")
    capsys.readouterr()
    args = ["fit", tiny["airframe"], tiny["sweep"], tiny["vertical"], tiny["tunnel"], "-o", str(out)]
    assert main(args + ["--json"]) == 1
    captured = capsys.readouterr()
    report = json.loads(captured.out)
    assert not report["self_check"]["passed"] and not report["written"]
    assert out.read_text() == "earlier result\n" and not plot.exists()
    last = captured.err.strip().splitlines()[-1]
    assert last.startswith("dobwind fit: the fitted model cannot be trusted: ")
    assert f"{tiny['tunnel']}: contributed no usable sample" in last and "--force" in last


def test_force_writes_a_model_that_failed_and_warns(tmp_path, capsys, monkeypatch):
    """--force: the same failed verdict is written, exit 0, one warning line with the reasons."""
    import dobwind.calibrate.fit as fit
    import dobwind.calibrate.fitfamily as fitfamily
    import dobwind.calibrate.fitreport as fitreport

    af = load_airframe(M300)
    failed = verdict(af, [_log("a.csv", fit_samples=0)], 0.3, 10.0, Thresholds())
    report = fit.FitReport(points=9, self_check=failed)
    monkeypatch.setattr(fitfamily, "fit_airframe", lambda *a, **k: (af, report, None))
    monkeypatch.setattr(fitreport, "fit_plot", lambda af, points, path: open(path, "wb").write(b"png"))
    out = tmp_path / "forced.toml"
    assert main(["fit", str(M300), "a.csv", "-o", str(out), "--force"]) == 0
    captured = capsys.readouterr()
    assert load_airframe(out).name == af.name and (tmp_path / "forced_fit.png").exists()
    assert "self-check: FAIL: a.csv: contributed no usable sample" in captured.out
    assert captured.err.strip().splitlines()[-1] == ("dobwind fit: warning: the self-check failed (a.csv: contributed "
                                                     "no usable sample to the fit); written anyway (--force)")
    assert main(["fit", str(M300), "a.csv", "-o", str(tmp_path / "refused.toml")]) == 1
    assert not (tmp_path / "refused.toml").exists()


# --- the direction tail (a warning) ---------------------------------------------------------------

def _segments(errors_deg, speed_mps=5.0):
    from dobwind.calibrate.reportparts import Segment

    return [Segment(k, speed_mps, 0.0, e, 0.0, 100) for k, e in enumerate(errors_deg)]


def test_the_direction_tail_is_the_error_that_the_share_of_fast_segments_stays_within():
    from dobwind.calibrate.selfcheck import direction_tail_deg

    # 20 fast segments 1..20 deg: 90 % (18 of them) are within 18 deg; slow and direction-less ones are left out.
    fast = _segments([float(e) for e in range(20, 0, -1)])
    slow = _segments([80.0, 90.0], speed_mps=1.5) + [dataclasses.replace(fast[0], direction_error_deg=None)]
    log = dataclasses.replace(_log("a.csv"), segments=fast + slow)
    assert direction_tail_deg(log, 0.9, 3.0) == 18.0
    assert direction_tail_deg(log, 1.0, 3.0) == 20.0 and direction_tail_deg(log, 0.5, 3.0) == 10.0
    assert direction_tail_deg(log, 0.9, 1.0) == 20.0  # the slow ones now count: 20 of 22 within 20 deg
    assert direction_tail_deg(log, 0.9, 30.0) is None


def test_a_direction_tail_warns_but_never_refuses():
    """A mean within the 10 deg limit with a tail of 15-20 deg (a long thin body's calibration): PASS,
    with a warning naming the log; a clean log says nothing."""
    errors = [5.0] * 16 + [15.0, 16.0, 18.0, 20.0]      # mean 7.45 deg; 90 % within 16 deg
    bad = dataclasses.replace(_log("b.csv", direction=7.45), segments=_segments(errors), direction_max_deg=20.0)
    good = dataclasses.replace(_log("a.csv", direction=2.0), segments=_segments([2.0] * 20))
    limits = Thresholds(direction_tail_deg=12.0, direction_tail_share=0.9, direction_tail_speed_mps=3.0)
    check = verdict(load_airframe(M300), [good, bad], 0.1, 10.0, limits)
    assert check.passed and len(check.warnings) == 1, check.warnings
    assert check.warnings[0].startswith("b.csv: training replay direction error 16.0 deg or more on at least 10% of its segments")
    assert "warning: b.csv" in text_table(check) and text_table(check).endswith("self-check: PASS")
    quiet = verdict(load_airframe(M300), [good, bad], 0.1, 10.0, dataclasses.replace(limits, direction_tail_deg=16.0))
    assert quiet.warnings == []   # at the limit is within it


def test_the_fit_reports_the_self_checks_direction_tail_warning(tiny):
    """The warning reaches the fit's report (the command prints its warnings on stderr and in --json):
    with the tail limit at 0 deg every log with a direction error at speed is named, and the model passes."""
    from dobwind.calibrate.fitfamily import fit_airframe

    limits = Thresholds(direction_tail_deg=0.0, direction_tail_speed_mps=0.0)
    _, report, _ = fit_airframe(load_airframe(tiny["airframe"]), [tiny["sweep"]], limits=limits)
    tails = [w for w in report.warnings if "training replay direction error" in w]
    assert report.self_check.passed and tails == report.self_check.warnings
    assert len(tails) == 1 and tails[0].startswith(tiny["sweep"] + ": ")
