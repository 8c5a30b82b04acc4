"""`make accuracy` machinery on one tiny vehicle (20 Hz, short holds), and the goal arithmetic."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from benchmarks.accuracy import main
from benchmarks.accuracy_real import real_lines, real_runs
from benchmarks.accuracy_report import GOALS, per_run_ratio_line, worst
from benchmarks.accuracy_run import Job, run_job
from dobwind.model.airframe_toml import dumps
from tests.helpers import ROOT

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


@pytest.fixture(scope="module")
def vehicle_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("vehicles")
    (folder / "tiny.vehicle.toml").write_text(dumps(TINY_VEHICLE))
    (folder / "tiny.airframe.toml").write_text(dumps(TINY_AIRFRAME))
    return folder


def test_whole_benchmark_on_a_tiny_vehicle(vehicle_dir, tmp_path, capsys):
    out = tmp_path / "acc"
    assert main(["--vehicles", "tiny", "--seeds", "1", "--hold", "7", "--workers", "1",
                 "--vehicle-dir", str(vehicle_dir), "--data", str(tmp_path / "no-data"), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    document = json.loads((out / "accuracy.json").read_text())
    (run,) = document["runs"]
    assert run["fit"]["exit_code"] == 0 and "error" not in run
    tunnel = run["tunnel"]
    # The RMS of the per-hold errors lies between their mean absolute value and their maximum.
    assert tunnel["speed_mean"] <= tunnel["speed_rms"] + 1e-12 <= tunnel["speed_max"] + 2e-12
    # The ratio's denominator is the fit's own prediction for these holds: inside the calibrated range,
    # each hold's speed band's bias and noise for a hold scored as long as this one,
    # sqrt(bias^2 + noise^2 / T) (interpolated between bands); beyond it, the extrapolation error.
    table, calibrated = run["fit"]["hold_cv_by_speed"], run["fit"]["calibrated_speed_mps"]
    assert 0 < tunnel["predicted_rms"] <= max(table["rms_mps"] + [run["fit"]["hold_extrapolation_mps"]])
    rows = [(s, e, t) for s, e, t in zip(tunnel["hold_speeds"], tunnel["hold_errors"], tunnel["hold_scored_s"]) if s <= calibrated]
    assert all(14.0 < t <= 15.01 for _, _, t in rows)  # 20 s holds scored after replay's 5 s settle
    expected = [np.interp(s, table["speeds_mps"], np.square(table["bias_mps"]))
                + np.interp(s, table["speeds_mps"], np.square(table["noise_mps_sqrt_s"])) / t for s, _, t in rows]
    assert tunnel["predicted_rms_calibrated"] == pytest.approx(math.sqrt(sum(expected) / len(expected)))
    assert tunnel["predicted_rms_calibrated"] < math.sqrt(np.mean(np.square(table["rms_mps"])))  # longer holds
    inside = [e for _, e, _ in rows]
    assert 0 < len(inside) < len(tunnel["hold_speeds"])  # 3-10 m/s holds against a 0-8 m/s calibration
    assert run["cv_ratio"] == pytest.approx(math.sqrt(sum(e * e for e in inside) / len(inside))
                                            / tunnel["predicted_rms_calibrated"])
    assert run["cv_ratio_all"] == pytest.approx(tunnel["speed_rms"] / tunnel["predicted_rms"])
    assert run["fit"]["self_check_passed"] is True
    assert run["fit"]["peak_rss_mb"] > 50 and run["fit"]["time_s"] > 0  # the child's own figures
    for scenario, key in (("still-air", "horizontal_mps"), ("outdoor", "speed_mean"), ("outdoor", "direction_mean")):
        assert math.isfinite(run[scenario][key])
    assert document["worst"]["tun spd max"] == pytest.approx(tunnel["speed_max"])
    assert set(document["goals"]) == {g.label for g in GOALS}
    assert "WORST" in text and ("PASS" in text or "MISS" in text) and "Real runs: skipped" in text


def test_a_failed_fit_is_a_result_not_a_crash(vehicle_dir, tmp_path):
    """4 s holds leave no steady data for the polynomial family (the only one forced here): fit exits 1,
    and the run says so."""
    result = run_job(Job("tiny", str(vehicle_dir), 1, 4.0, str(tmp_path / "w"), ("--model", "polynomial")))
    assert result["fit"]["exit_code"] == 1 and result["error"].startswith("fit: exit 1: dobwind fit:")
    assert "tunnel" not in result
    assert worst([result])["tun spd mean"] is None  # a failed run is the worst, shown as FAIL


def test_worst_row_and_goals():
    rows = [{"tunnel": {"speed_mean": 0.05}, "cv_ratio": 1.8}, {"tunnel": {"speed_mean": 0.09}, "cv_ratio": 0.3}]
    w = worst(rows)
    assert w["tun spd mean"] == 0.09
    assert w["tun/CV"] == 0.3  # a factor 3.3 too small is further from 1 than a factor 1.8 too large
    goals = {g.column: g for g in GOALS}
    assert goals["tun spd mean"].met(0.08) and not goals["tun spd mean"].met(0.0801)
    ratio = goals["tun/CV pool"]
    assert ratio.met(0.5) and ratio.met(2.0) and not ratio.met(0.49) and not ratio.met(2.01) and not ratio.met(None)


def test_the_cv_ratio_goal_pools_each_vehicles_runs_then_takes_the_worst_vehicle():
    """Vehicle a: runs with tunnel RMS 0.01 and 0.03 against predictions 0.02 and 0.02, pooled
    sqrt((0.01^2 + 0.03^2) / 2) / 0.02 = 1.118 although the runs alone read 0.5 and 1.5; vehicle b
    reads 0.2 / 0.05 = 4: the worst vehicle is b."""
    def run(vehicle, actual, predicted):
        return {"vehicle": vehicle, "cv_ratio": actual / predicted,
                "tunnel": {"speed_rms_calibrated": actual, "predicted_rms_calibrated": predicted}}
    a = [run("a", 0.01, 0.02), run("a", 0.03, 0.02)]
    assert worst(a)["tun/CV pool"] == pytest.approx(math.sqrt((0.01 ** 2 + 0.03 ** 2) / 2) / 0.02)
    assert worst(a)["tun/CV"] == pytest.approx(0.5)  # the run farthest from 1, two-sided
    both = a + [run("b", 0.2, 0.05)]
    assert worst(both)["tun/CV pool"] == pytest.approx(4.0)
    assert "2 of 3 within a factor 2; farthest b seed None: 4.00" in per_run_ratio_line(both)
    assert worst([run("a", 0.01, 0.02), {"vehicle": "a", "tunnel": {}}])["tun/CV pool"] is None  # a failed run


def test_real_runs_are_skipped_without_the_data(tmp_path):
    assert real_runs(tmp_path / "absent") is None


def test_real_run_verdicts():
    def run(error, training):
        return {"nominal_mps": 8.5, "estimate_mps": 8.5 + error, "error_mps": error, "training": training}
    split = {"fit_exit_code": 0, "runs": {"a": run(0.29, True), "b": run(-0.2, True), "c": run(0.7, False),
                                          "d": run(-0.2, False)}}
    _, verdicts = real_lines({"split": split})
    assert verdicts == {"real: training runs within 0.3 m/s": True, "real: held-out runs within 0.5 m/s on average": True}
    split["runs"]["b"] = run(-0.31, True)
    split["runs"]["d"] = run(-0.31, False)
    _, verdicts = real_lines({"split": split})
    assert verdicts == {"real: training runs within 0.3 m/s": False, "real: held-out runs within 0.5 m/s on average": False}


def test_benchmark_vehicles_cover_the_brief():
    """Six vehicles at least, masses 0.03 to 25 kg, rates 50 to 500 Hz, every acceleration mode and
    both thrust sources; one drag law outside the linear + quadratic family."""
    from dobwind.analysis.design import design_gain
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate.vehicle import load_vehicle

    folder = ROOT / "benchmarks" / "vehicles"
    names = [p.name.removesuffix(".vehicle.toml") for p in folder.glob("*.vehicle.toml")]
    vehicles = {n: load_vehicle(folder / f"{n}.vehicle.toml") for n in names}
    airframes = {n: load_airframe(folder / f"{n}.airframe.toml") for n in names}
    assert len(names) >= 6
    assert min(v.mass_kg for v in vehicles.values()) <= 0.03 and max(v.mass_kg for v in vehicles.values()) >= 25
    assert min(v.rate_hz for v in vehicles.values()) <= 50 and max(v.rate_hz for v in vehicles.values()) >= 500
    assert {a.observer.acceleration for a in airframes.values()} == {"ned", "specific_force", "velocity"}
    assert {a.thrust.source for a in airframes.values()} == {"rpm", "collective"}
    assert any(v.reynolds_gain > 0 or any(d.exponent != 2.0 for d in v.drag) for v in vehicles.values())
    for n in names:  # the nominal airframe's sample time is the vehicle's rate
        assert airframes[n].observer.sample_time_s == pytest.approx(1 / vehicles[n].rate_hz)
        # The same 0.5 Hz observer bandwidth for all: lambda ~ 2 pi f m (6.28 kg/s per kg, less for the
        # paper's discrete form at a low rate: 5.35 at the ArduPilot SITL stand-in's 10 Hz), so the gain
        # is the one designed for 0.5 Hz at the airframe's own rate.
        assert airframes[n].observer.gains[0] == pytest.approx(design_gain(airframes[n], 0.5), rel=1e-4), n
        assert 5.3 < airframes[n].observer.gains[0] / airframes[n].mass_kg < 6.3, n


def test_rate_study_fits_each_rate_and_measures_the_spread_of_one_tunnel(vehicle_dir, tmp_path):
    """The tiny vehicle calibrated at 20 and 40 Hz; both fits replay one tunnel flight, so the spread
    of a hold's estimate over rates is the difference of its two errors."""
    from benchmarks.accuracy_rates import RATE_GOAL, rate_lines, rate_study

    study = rate_study(vehicle_dir, tmp_path / "rates", 7.0, 2, vehicle="tiny", rates_hz=(20.0, 40.0))
    low, high = study["rates"]
    assert "error" not in low and "error" not in high
    assert 1.9 < high["rows"] / low["rows"] < 2.1  # the same flight at twice the rate
    calibrated = min(low["fit"]["calibrated_speed_mps"], high["fit"]["calibrated_speed_mps"])
    spreads = [abs(a - b) for s, a, b in zip(low["tunnel"]["hold_speeds"], low["tunnel"]["hold_errors"],
                                            high["tunnel"]["hold_errors"]) if s <= calibrated]
    assert study["spread_mps"] == pytest.approx(max(spreads))
    assert study["predicted_mps"] == max(low["tunnel"]["predicted_rms_calibrated"], high["tunnel"]["predicted_rms_calibrated"])
    lines, verdict = rate_lines(study)
    assert verdict == {RATE_GOAL: study["spread_mps"] <= study["predicted_mps"]}
    assert any(line.strip().startswith("20  ") for line in lines) and any(line.strip().startswith("40  ") for line in lines)
    failed = {**study, "rates": [low, {"rate_hz": 40.0, "error": "fit: exit 1"}]}
    from benchmarks.accuracy_rates import spread
    assert spread(failed["rates"]) == (None, None)
