"""The fit's check of the acceleration route (dobwind/accelroute.py): when the noise at low airflow stays
above the target with an acceleration input, the calibration logs are replayed through the velocity
route, and the fit recommends it only when it is clearly quieter and checks as well. End to end, on a
simulated vehicle with a noisy acceleration input: the recommendation appears, the written airframe
keeps its route, and following the advice makes an unseen still-air flight read less wind."""
from __future__ import annotations

import dataclasses
import json

import pytest

from dobwind.accelroute import QUIETER_SHARE, route_check, velocity_route
from dobwind.cli import main
from dobwind.hovernoise import HoverNoise
from dobwind.model.airframe import load_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.selfcheck import SelfCheck
from tests.helpers import make_airframe


def _check(passed: bool, still: float | None) -> SelfCheck:
    return SelfCheck(passed, [] if passed else ["a reason"], 0.05, 8.0, 0.5, 0.5, 10.0, [], 0.05, 0.04, still)


def test_the_velocity_route_changes_the_acceleration_only():
    af = make_airframe(**{"observer.acceleration": "specific_force", "observer.acceleration_bias_time": 5.0})
    routed = velocity_route(af)
    assert routed.observer.acceleration == "velocity" and routed.observer.acceleration_bias_time_s == 0.0
    for name in ("sample_time_s", "gains", "discretization", "force_offset_n"):
        assert getattr(routed.observer, name) == getattr(af.observer, name)
    others = [f.name for f in dataclasses.fields(af) if f.name != "observer"]
    assert others and all(getattr(routed, name) == getattr(af, name) for name in others)


@pytest.mark.parametrize("mode", ["ned", "specific_force"])
def test_a_clearly_quieter_velocity_route_is_recommended(mode):
    af = make_airframe(**{"observer.acceleration": mode})
    seen = []

    def recheck(other):
        seen.append(other.observer.acceleration)
        return _check(True, 0.05)

    found, warnings = route_check(af, _check(True, 0.2), HoverNoise(), recheck)
    assert seen == ["velocity"]
    assert found == {"acceleration": mode, "still_noise_mps": 0.2, "velocity_still_noise_mps": 0.05,
                     "velocity_passed": True, "velocity_reasons": []}
    assert len(warnings) == 1 and "leaves 0.200 m/s" in warnings[0] and "give 0.050 m/s" in warnings[0]
    assert 'set [observer] acceleration = "velocity"' in warnings[0]


def test_no_recommendation_unless_quieter_by_the_share_and_checking_as_well():
    af = make_airframe(**{"observer.acceleration": "specific_force"})
    just_above = QUIETER_SHARE * 0.2 * 1.01
    found, warnings = route_check(af, _check(True, 0.2), HoverNoise(), lambda other: _check(True, just_above))
    assert found["velocity_still_noise_mps"] == just_above and warnings == []
    # Quieter, but its self-check fails where the airframe's passed.
    found, warnings = route_check(af, _check(True, 0.2), HoverNoise(), lambda other: _check(False, 0.05))
    assert found["velocity_passed"] is False and warnings == []
    # Both fail: the quieter route is still worth saying.
    _, warnings = route_check(af, _check(False, 0.2), HoverNoise(), lambda other: _check(False, 0.05))
    assert len(warnings) == 1
    # No low-airflow segment through the velocity route: nothing to compare.
    found, warnings = route_check(af, _check(True, 0.2), HoverNoise(), lambda other: _check(True, None))
    assert found["velocity_still_noise_mps"] is None and warnings == []


@pytest.mark.parametrize("case", ["velocity airframe", "within target", "no figure", "target 0"])
def test_no_extra_replay_when_there_is_nothing_to_gain(case):
    af = make_airframe(**{"observer.acceleration": "velocity" if case == "velocity airframe" else "ned"})
    noise = {"within target": 0.07, "no figure": None}.get(case, 0.3)
    hover = HoverNoise(target_mps=0.0) if case == "target 0" else HoverNoise()

    def recheck(other):
        raise AssertionError("the logs were replayed again")

    assert route_check(af, _check(True, noise), hover, recheck) == ({}, [])


# A heavy, slow vehicle whose acceleration input is noisy: the low-pass reaches its floor.
NOISY_VEHICLE = {"mass": 6.0, "rate": 20.0, "drag": {"x": {"linear": 0.3, "quadratic": 0.05},
                                                      "y": {"linear": 0.3, "quadratic": 0.05},
                                                      "z": {"linear": 0.8}},
                 "thrust": {"scale": 1.02}, "sensors": {"acc_noise": 0.2, "vel_noise": 0.03}}
NOISY_AIRFRAME = {
    "name": "noisy", "mass": 6.0, "thrust": {"source": "collective"},
    "observer": {"sample_time": 0.05, "gains": [36.0, 36.0, 36.0], "discretization": "paper", "acceleration": "ned"},
    "force_air": {"horizontal": {"terms": ["fh^0.5"], "coefficients": [4.0]},
                  "vertical": {"terms": ["fz"], "coefficients": [0.5]}},
    "filter": {"speeds": [0.0, 3.0, 10.0], "cutoffs": [0.2, 0.35, 0.5]},
}


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    folder = tmp_path_factory.mktemp("noisy_route")
    (folder / "v.toml").write_text(dumps(NOISY_VEHICLE))
    (folder / "a.toml").write_text(dumps(NOISY_AIRFRAME))
    paths = {"airframe": str(folder / "a.toml")}
    for name, seed, hold in (("sweep", 1, "6"), ("vertical", 2, "8"), ("still-air", 4, None)):
        path = folder / f"{name}.csv"
        args = ["simulate", name, "--airframe", paths["airframe"], "--vehicle", str(folder / "v.toml"),
                "--seed", str(seed), "-o", str(path)] + (["--hold", hold] if hold else [])
        assert main(args) == 0
        paths[name] = str(path)
    return paths


def _still_air_wind(airframe, noisy, capsys) -> float:
    capsys.readouterr()
    assert main(["replay", str(airframe), noisy["still-air"], "--json"]) == 0
    return json.loads(capsys.readouterr().out)["mean_estimated_wind"]["horizontal_mps"]


def test_fit_recommends_the_velocity_route_and_following_it_reads_less_still_air(noisy, tmp_path, capsys):
    capsys.readouterr()
    out = tmp_path / "fit.toml"
    assert main(["fit", noisy["airframe"], noisy["sweep"], noisy["vertical"], "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    route = report["acceleration_route"]
    assert route["acceleration"] == "ned" and route["still_noise_mps"] == report["self_check"]["still_noise_mps"]
    assert route["still_noise_mps"] > 0.07 and route["velocity_passed"]
    assert route["velocity_still_noise_mps"] < QUIETER_SHARE * route["still_noise_mps"]
    assert any('acceleration = "velocity"' in w for w in report["warnings"])
    written = load_airframe(out)
    assert written.observer.acceleration == "ned"   # the route is the user's interface: never switched
    # Following the advice on the written airframe (its law and low-pass unchanged).
    followed = tmp_path / "velocity.toml"
    followed.write_text(out.read_text().replace('acceleration = "ned"', 'acceleration = "velocity"'))
    assert load_airframe(followed).observer.acceleration == "velocity"
    assert _still_air_wind(followed, noisy, capsys) < 0.5 * _still_air_wind(out, noisy, capsys)


def test_the_text_report_shows_both_routes(noisy, tmp_path, capsys):
    capsys.readouterr()
    assert main(["fit", noisy["airframe"], noisy["sweep"], noisy["vertical"], "-o", str(tmp_path / "t.toml")]) == 0
    text = capsys.readouterr()
    assert 'with acceleration = "ned"; with the acceleration derived from the velocity ' in text.out
