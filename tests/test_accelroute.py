"""The fit's blend of an acceleration input with the velocity's derivative (dobwind/calibrate/accelroute.py): when
the noise at low airflow stays above the target with an acceleration input, the fit runs again with a
short velocity-aided bias time, and keeps that fit only when it is clearly quieter and checks as well.
End to end, on a simulated vehicle with a noisy acceleration input: the blend is kept, the written
airframe keeps its input, and an unseen still-air flight reads less wind than without the blend."""
from __future__ import annotations

import dataclasses
import json

import pytest

from dobwind.calibrate import fitfamily
from dobwind.calibrate.accelroute import BLEND_TIME_S, QUIETER_SHARE, blend_record, blended, keeps_blend, needs_blend_check
from dobwind.cli.app import main
from dobwind.core.errors import CheckFailed
from dobwind.calibrate.fitreport import _low_pass_line, _route_line
from dobwind.calibrate.hovernoise import HoverNoise
from dobwind.model.airframe import load_airframe
from dobwind.calibrate.reportparts import AccelerationRoute, LowPassChange, SelfCheck
from tests.helpers import make_airframe, noisy_flights


def _check(passed: bool, still: float | None, noise_h: float = 0.05) -> SelfCheck:
    return SelfCheck(passed, [] if passed else ["a reason"], 0.05, 8.0, 0.5, 0.5, 10.0, [], noise_h, 0.04, still)


def test_the_blend_changes_the_bias_time_only():
    af = make_airframe(**{"observer.acceleration": "specific_force", "observer.acceleration_bias_time": 20.0})
    mixed = blended(af)
    assert mixed.observer.acceleration == "specific_force" and mixed.observer.acceleration_bias_time_s == BLEND_TIME_S
    for name in ("sample_time_s", "gains", "discretization", "force_offset_n"):
        assert getattr(mixed.observer, name) == getattr(af.observer, name)
    others = [f.name for f in dataclasses.fields(af) if f.name != "observer"]
    assert others and all(getattr(mixed, name) == getattr(af, name) for name in others)


@pytest.mark.parametrize("mode,bias_time", [("ned", 0.0), ("specific_force", 0.0), ("ned", 20.0),
                                            ("specific_force", 2 * BLEND_TIME_S)])
def test_a_noisy_acceleration_input_is_checked(mode, bias_time):
    af = make_airframe(**{"observer.acceleration": mode, "observer.acceleration_bias_time": bias_time})
    assert needs_blend_check(af, _check(True, 0.2), HoverNoise())


@pytest.mark.parametrize("case", ["velocity airframe", "already blended", "blended faster", "within target",
                                  "no figure", "target 0"])
def test_no_second_fit_when_there_is_nothing_to_gain(case):
    fields = {"observer.acceleration": "velocity" if case == "velocity airframe" else "ned"}
    if case in ("already blended", "blended faster"):
        fields["observer.acceleration_bias_time"] = BLEND_TIME_S * (1.0 if case == "already blended" else 0.5)
    af = make_airframe(**fields)
    noise = {"within target": 0.07, "no figure": None}.get(case, 0.3)
    hover = HoverNoise(target_mps=0.0) if case == "target 0" else HoverNoise()
    assert not needs_blend_check(af, _check(True, noise), hover)


def test_the_blend_is_kept_only_when_clearly_quieter_and_checking_as_well():
    assert keeps_blend(_check(True, 0.2), _check(True, 0.05))
    assert not keeps_blend(_check(True, 0.2), _check(True, QUIETER_SHARE * 0.2 * 1.01))
    assert keeps_blend(_check(True, 0.2), _check(True, QUIETER_SHARE * 0.2 * 0.99))
    assert not keeps_blend(_check(True, 0.2), _check(False, 0.05))   # fails where the airframe's passed
    assert keeps_blend(_check(False, 0.2), _check(True, 0.05))       # the blend mends a failing first fit
    assert not keeps_blend(_check(False, 0.2), _check(False, 0.05))  # both fail: the airframe's observer stays
    assert not keeps_blend(_check(True, 0.2), _check(True, None))    # nothing to compare
    # A blend that passes where the airframe's failed is kept however little quieter, even unmeasured.
    assert keeps_blend(_check(False, 0.2), _check(True, 0.199)) and keeps_blend(_check(False, 0.2), _check(True, None))


class _Stub:
    """_fit_once replaced: the first call is the airframe's fit, the second the blended one."""

    def __init__(self, first: SelfCheck, second: SelfCheck | Exception):
        self.first, self.second, self.seen = first, second, []

    def __call__(self, af, log_paths, options):
        self.seen.append(af.observer.acceleration_bias_time_s)
        result = self.first if len(self.seen) == 1 else self.second
        if isinstance(result, Exception):
            raise result
        which = "first" if len(self.seen) == 1 else "blend"
        return af, fitfamily.FitReport(model=which), {"fit": which}, result


@pytest.mark.parametrize("second,kept", [(_check(True, 0.05, 0.03), True), (_check(True, 0.19, 0.03), False),
                                         (CheckFailed("no model could be fitted"), False)])
def test_fit_airframe_keeps_the_better_fit(monkeypatch, second, kept):
    stub = _Stub(_check(True, 0.2, 0.3), second)
    monkeypatch.setattr(fitfamily, "_fit_once", stub)
    noise_used = []
    monkeypatch.setattr(fitfamily, "with_observer_noise", lambda unc, h, up: noise_used.append((h, up)) or unc)
    af = make_airframe(**{"observer.acceleration": "ned"})
    new, report, points = fitfamily.fit_airframe(af, ["a.csv"])
    assert stub.seen == [0.0, BLEND_TIME_S]
    which = "blend" if kept else "first"
    # Airframe, report, points and self-check all come from the fit kept.
    assert new.observer.acceleration_bias_time_s == (BLEND_TIME_S if kept else 0.0)
    assert report.model == which and points == {"fit": which}
    assert report.self_check.still_noise_mps == (0.05 if kept else 0.2)
    assert report.self_check.noise_h_mps == (0.03 if kept else 0.3)
    # The sigma outputs take the observer noise of the fit kept, once.
    assert noise_used == [(0.03 if kept else 0.3, 0.04)]
    route = report.acceleration_route
    assert route.kept is kept and route.bias_time_s == (0.0, BLEND_TIME_S)
    blend_warnings = [w for w in report.warnings if w.startswith("the acceleration blend")]
    if isinstance(second, Exception):
        assert route.still_noise_mps == (0.2, None) and route.blend_passed is None
        assert route.blend_reasons == ["no model could be fitted"]
        # The user asked for less noise and got the first fit: one warning says why.
        assert blend_warnings == [f"the acceleration blend (acceleration_bias_time {BLEND_TIME_S:g} s) could not be "
                                  "fitted (no model could be fitted); the airframe's acceleration input is kept as written"]
    else:
        assert blend_warnings == []
        assert route.still_noise_mps == (0.2, second.still_noise_mps) and route.blend_passed is True


def _report_with(route: AccelerationRoute | None) -> str:
    return "\n".join(_route_line(fitfamily.FitReport(model="drag", acceleration_route=route)))


def test_the_text_report_says_which_fit_was_kept():
    af = make_airframe(**{"observer.acceleration": "specific_force"})
    kept = _report_with(blend_record(af, _check(True, 0.2), _check(True, 0.05), True))
    assert kept.startswith("acceleration blended: noise at low airflow 0.200 m/s per axis with acceleration = "
                           '"specific_force" (acceleration_bias_time 0 s)') and kept.endswith("velocity, 0.050 m/s")
    failing = _report_with(blend_record(af, _check(True, 0.2), _check(False, 0.05), False))
    assert failing.startswith("acceleration not blended:") and failing.endswith("0.050 m/s, self-check failed")
    crashed = _report_with(blend_record(af, _check(True, 0.2), None, False, "no model could be fitted"))
    assert crashed.endswith("the blended fit failed (no model could be fitted)")
    assert _report_with(None) == ""


@pytest.mark.parametrize("kept", [True, False])
def test_the_low_pass_line_names_the_blended_fit_when_it_was_kept(kept):
    af = make_airframe(**{"observer.acceleration": "ned"})
    route = blend_record(af, _check(True, 0.2), _check(True, 0.05 if kept else 0.19), kept)
    change = LowPassChange((0.2, 0.05), (0.158, 0.079), 0.07)
    line = _low_pass_line(fitfamily.FitReport(model="drag", acceleration_route=route, low_pass=change))
    assert line == [f"low-pass at zero airflow{' (of the blended fit)' if kept else ''} lowered 0.2 -> 0.05 Hz: noise "
                    "at low airflow 0.158 -> 0.079 m/s per horizontal axis (target 0.07 m/s; --hover-noise)"]


# A heavy, slow vehicle whose acceleration input is noisy: the low-pass reaches its floor.
NOISY_VEHICLE = {"mass": 6.0, "rate": 20.0, "drag": {"x": {"linear": 0.3, "quadratic": 0.05},
                                                      "y": {"linear": 0.3, "quadratic": 0.05},
                                                      "z": {"linear": 0.8}},
                 "thrust": {"scale": 1.02}, "sensors": {"acc_noise": 0.2, "vel_noise": 0.03}}


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    return noisy_flights(tmp_path_factory.mktemp("noisy_route"), NOISY_VEHICLE)


def _still_air_wind(airframe, noisy, capsys) -> float:
    capsys.readouterr()
    assert main(["replay", str(airframe), noisy["still-air"], "--json"]) == 0
    return json.loads(capsys.readouterr().out)["mean_estimated_wind"]["horizontal_mps"]


def test_fit_blends_the_noisy_input_and_an_unseen_still_air_flight_reads_less(noisy, tmp_path, capsys, shared_fits):
    capsys.readouterr()
    out = tmp_path / "fit.toml"
    assert main(["fit", noisy["airframe"], noisy["sweep"], noisy["vertical"], "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    route = report["acceleration_route"]
    before, after = route["still_noise_mps"]
    assert route["kept"] and route["blend_passed"] and route["acceleration"] == "ned"
    assert before > 0.07 and after < QUIETER_SHARE * before and report["self_check"]["still_noise_mps"] == after
    written = load_airframe(out)
    # The input the autopilot fills is unchanged; only the bias estimate's time constant is set.
    assert written.observer.acceleration == "ned" and written.observer.acceleration_bias_time_s == BLEND_TIME_S
    # The same airframe without the blend (its law and low-pass unchanged) reads more still air.
    unblended = tmp_path / "unblended.toml"
    text = out.read_text()
    assert text.count(f"acceleration_bias_time = {BLEND_TIME_S}") == 1
    unblended.write_text(text.replace(f"acceleration_bias_time = {BLEND_TIME_S}\n", ""))
    assert load_airframe(unblended).observer.acceleration_bias_time_s == 0.0
    assert _still_air_wind(out, noisy, capsys) < 0.5 * _still_air_wind(unblended, noisy, capsys)


def test_the_text_report_shows_both_noise_figures(noisy, tmp_path, capsys, shared_fits):
    capsys.readouterr()
    assert main(["fit", noisy["airframe"], noisy["sweep"], noisy["vertical"], "-o", str(tmp_path / "t.toml")]) == 0
    text = capsys.readouterr()
    assert ('acceleration blended: noise at low airflow ' in text.out
            and f'with acceleration_bias_time {BLEND_TIME_S:g} s, the low frequencies from the velocity' in text.out)
    # CSV logs with wind columns: each log's airflow is said to come from those columns, not an estimate
    for log in (noisy["sweep"], noisy["vertical"]):
        assert f"  {log}: its own wind_n/wind_e/wind_d columns" in text.out


def test_hover_noise_0_keeps_the_observer(noisy, tmp_path, capsys):
    out = tmp_path / "kept.toml"
    assert main(["fit", noisy["airframe"], noisy["sweep"], noisy["vertical"], "-o", str(out),
                 "--hover-noise", "0", "--force"]) == 0
    assert load_airframe(out).observer.acceleration_bias_time_s == 0.0
