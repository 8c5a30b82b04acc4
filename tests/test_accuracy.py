"""`make accuracy` machinery on one tiny vehicle (20 Hz, short holds), and the goal arithmetic."""
from __future__ import annotations

import json
import math

import pytest

from dobwind.accuracy import main
from dobwind.accuracy_real import real_lines, real_runs
from dobwind.accuracy_report import GOALS, worst
from dobwind.accuracy_run import Job, run_job
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
    # The ratio's denominator is the fit's own prediction for these holds: the hold-level CV of each
    # hold's speed band, the hold-level extrapolation error beyond the calibrated range.
    bands = run["fit"]["hold_cv_by_speed"]["rms_mps"]
    assert 0 < tunnel["predicted_rms"] <= max(bands + [run["fit"]["hold_extrapolation_mps"]])
    assert min(bands) <= tunnel["predicted_rms_calibrated"] <= max(bands)
    inside = [e for s, e in zip(tunnel["hold_speeds"], tunnel["hold_errors"]) if s <= run["fit"]["calibrated_speed_mps"]]
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
    ratio = goals["tun/CV"]
    assert ratio.met(0.5) and ratio.met(2.0) and not ratio.met(0.49) and not ratio.met(2.01) and not ratio.met(None)


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
    from dobwind.model.airframe import load_airframe
    from dobwind.vehicle import load_vehicle

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
        # The same 0.5 Hz observer bandwidth for all: lambda ~ 2 pi f m (6.28 kg/s per kg, a little
        # less for the paper's discrete form at a low rate).
        assert 5.8 < airframes[n].observer.gains[0] / airframes[n].mass_kg < 6.3, n
