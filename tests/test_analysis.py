"""Analysis against closed forms: poles, -3 dB points, noise, ramp lag; gain design round trips."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dobwind.analysis.design import design_gain, observer_bandwidth_hz, with_gains
from dobwind.analysis.figures import bandwidth_hz, group_delay_s, noise_gain
from dobwind.analysis.linear import axis_system, continuous_observer, linearize
from dobwind.analysis.ramp import ramp_experiment
from dobwind.cli.app import main
from dobwind.model.airframe import parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.step import build_step
from tests.helpers import airframe_dict, make_airframe

CASES = [(8.0, 50.0, 0.01), (2.5, 20.0, 0.02), (1.2, 3.0, 0.005)]


def _af(mass, gain, dt, disc="paper", acceleration="ned", **more):
    return make_airframe(**{"mass": mass, "observer.gains": [gain, gain * 1.3, gain * 0.7], "observer.sample_time": dt,
                            "observer.discretization": disc, "observer.acceleration": acceleration,
                            "limits.max_dt": 2 * dt, **more})


@pytest.mark.parametrize("mass,gain,dt", CASES)
def test_paper_pole_and_bandwidth_closed_form(mass, gain, dt):
    model = build_step(_af(mass, gain, dt))
    for axis, lam in enumerate((gain, gain * 1.3, gain * 0.7)):
        sys_ = axis_system(model, axis, with_filter=False)
        a = dt * lam / (2 * mass)
        p = 1 - a
        assert np.real(sys_.poles()[0]) == pytest.approx(p, rel=1e-12)
        # |H(e^jw)|^2 = a^2 / (1 - 2 p cos w + p^2) = 1/2
        omega = math.acos((1 + p * p - 2 * a * a) / (2 * p))
        assert bandwidth_hz(sys_) == pytest.approx(omega / (2 * math.pi * dt), rel=1e-8)


@pytest.mark.parametrize("mass,gain,dt", CASES)
def test_other_discretization_poles(mass, gain, dt):
    w = gain / mass
    expected = {"zoh": math.exp(-dt * w), "euler": 1 - dt * w, "tustin": (1 - w * dt / 2) / (1 + w * dt / 2)}
    for disc, pole in expected.items():
        sys_ = axis_system(build_step(_af(mass, gain, dt, disc)), 0, with_filter=False)
        assert np.max(np.real(sys_.poles())) == pytest.approx(pole, rel=1e-12), disc


def test_continuous_bandwidth_and_group_delay():
    sys_ = continuous_observer(6.25)
    assert bandwidth_hz(sys_) == pytest.approx(6.25 / (2 * math.pi), rel=1e-8)
    assert group_delay_s(sys_) == pytest.approx(1 / 6.25, rel=1e-4)


def test_cascade_poles_are_observer_and_low_pass():
    af = _af(2.5, 20.0, 0.02)
    model = build_step(af)
    for speed, cutoff in [(0.0, 0.3), (2.0, 0.45), (8.0, 0.8), (20.0, 1.0)]:
        sys_ = axis_system(model, 0, with_filter=True, wind_speed_mps=speed)
        poles = sorted(np.real(sys_.poles()))
        assert poles == pytest.approx(sorted([1 - 0.02 * 20 / 5, math.exp(-2 * math.pi * cutoff * 0.02)]), rel=1e-12)


@pytest.mark.parametrize("disc", ["paper", "euler", "zoh", "tustin"])
@pytest.mark.parametrize("target", [0.2, 0.5, 2.0])
def test_gain_design_round_trip(disc, target):
    af = _af(3.0, 10.0, 0.01, disc)
    gain = design_gain(af, target)
    assert observer_bandwidth_hz(af, gain) == pytest.approx(target, abs=1e-7)
    assert bandwidth_hz(axis_system(build_step(with_gains(af, (gain,) * 3)), 2, with_filter=False)) == pytest.approx(target, abs=1e-7)


def test_m300_design_near_the_papers_gain(tmp_path, capsys):
    path = tmp_path / "m300.toml"
    path.write_text((__import__("tests.helpers", fromlist=["M300"]).M300).read_text())
    assert main(["analyze", str(path), "--bandwidth", "0.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert 45.0 < out["gains"][0] < 50.0 and out["gains"][0] == out["gains"][2]


def test_noise_gain_closed_forms():
    mass, gain, dt = 2.5, 20.0, 0.02
    a = dt * gain / (2 * mass)
    p = 1 - a
    ned = linearize(build_step(_af(mass, gain, dt)), kind="noise")
    # f_e = m a_meas: impulse response m a p^k  ->  RMS gain m a / sqrt(1 - p^2)
    assert noise_gain(ned.axis(0, with_filter=False)) == pytest.approx(mass * a / math.sqrt(1 - p * p), rel=1e-9)
    vel = linearize(build_step(_af(mass, gain, dt, acceleration="velocity")), kind="noise")
    # f_e = m (v_k - v_{k-1}) / dt: sum of squares (m/dt)^2 * 2 a^2 / (1 + p)
    assert noise_gain(vel.axis(0, with_filter=False)) == pytest.approx(mass / dt * a * math.sqrt(2 / (1 + p)), rel=1e-9)


@pytest.mark.parametrize("acceleration", ["ned", "specific_force", "velocity"])
def test_force_path_is_the_same_in_every_acceleration_mode(acceleration):
    """A force is a force: how it is measured must not change the observer's response to it."""
    ref = axis_system(build_step(_af(2.5, 20.0, 0.02)), 1, wind_speed_mps=3.0)
    sys_ = axis_system(build_step(_af(2.5, 20.0, 0.02, acceleration=acceleration)), 1, wind_speed_mps=3.0)
    freqs = np.array([0.05, 0.5, 2.0])
    from dobwind.analysis.figures import response
    np.testing.assert_allclose(response(sys_, freqs), response(ref, freqs), rtol=1e-9)


def test_ramp_lag_equals_the_low_frequency_group_delay():
    """With a linear force-air model and a fixed filter, the steady lag behind a ramp is the DC group
    delay of the observer-plus-filter cascade: two independent routes to the same number."""
    doc = airframe_dict(**{"force_air.horizontal.terms": ["fh"], "force_air.horizontal.coefficients": [1.0],
                           "force_air.vertical.terms": ["fz"], "force_air.vertical.coefficients": [0.0],
                           "observer.force_offset": [0.0, 0.0, 0.0], "filter.speeds": [0.0], "filter.cutoffs": [0.4]})
    af = parse_airframe(dumps(doc), "<ramp>")
    result = ramp_experiment(af)
    delay = group_delay_s(axis_system(build_step(af), 0, wind_speed_mps=5.0))
    assert result.fixed_lag_s == pytest.approx(delay, abs=0.025)
    assert result.scheduled_lag_s == pytest.approx(delay, abs=0.025)  # one breakpoint: nothing to schedule


def test_schedule_reduces_ramp_lag_on_the_reference_airframe():
    from tests.helpers import M300
    from dobwind.model.airframe import load_airframe
    result = ramp_experiment(load_airframe(M300))
    assert 0 < result.scheduled_lag_s < result.fixed_lag_s


def test_analyze_reports_unstable_gains_and_exits_1(tmp_path, capsys):
    path = tmp_path / "hot.toml"
    path.write_text(dumps(airframe_dict(**{"observer.discretization": "euler", "observer.gains": [20.0, 300.0, 30.0]})))
    assert main(["analyze", str(path)]) == 1
    captured = capsys.readouterr()
    assert "UNSTABLE" in captured.out and "NO" in captured.out
    assert captured.err.count("\n") == 1 and "pole" in captured.err and "axis y" in captured.err


def test_analyze_json_and_plots(tmp_path, capsys):
    path = tmp_path / "craft.toml"
    path.write_text(dumps(airframe_dict()))
    out_dir = tmp_path / "plots"
    assert main(["analyze", str(path), "--json", "-o", str(out_dir), "--freq", "0.2", "0.7"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["stable"] and report["schedule"]["stable"]
    assert [g["freq_hz"] for g in report["observer"][0]["gain_phase"]] == [0.2, 0.7]
    assert len(report["cascade"]) == 9 and report["ramp"]["lag_reduction_s"] > 0
    for name in ("bode.png", "discretizations.png", "ramp.png"):
        data = (out_dir / name).read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20000


def test_the_stacked_frequency_response_is_python_controls_to_the_bit():
    """figures.response evaluates C (zI - A)^-1 B + D for every frequency in one stacked solve; the values are
    python-control's own per-frequency evaluation, bit for bit, on the shipped airframe's systems (observer
    alone and with the low-pass, in still air and in wind)."""
    import control as ct

    from dobwind.analysis.figures import response
    from dobwind.analysis.linear import axis_system
    from dobwind.model.airframe import load_airframe
    from dobwind.model.step import build_step
    from tests.helpers import M300

    model = build_step(load_airframe(M300))
    for with_filter, wind in ((False, 0.0), (True, 0.0), (True, 8.0)):
        sys = axis_system(model, 0, with_filter=with_filter, wind_speed_mps=wind)
        assert isinstance(sys, ct.StateSpace) and sys.nstates > 1
        freq = np.geomspace(1e-6, 0.5 / sys.dt * (1 - 1e-9), 500)
        own = np.atleast_1d(np.squeeze(np.asarray(sys(np.exp(2j * np.pi * freq * sys.dt)), dtype=complex)))
        assert np.array_equal(response(sys, freq), own)


def test_a_frequency_on_a_pole_is_left_to_python_control():
    """The stacked solve cannot invert zI - A at a pole: python-control's evaluation (inf) is kept."""
    import control as ct
    import warnings

    from dobwind.analysis.figures import response

    sys = ct.ss([[0.5, 0.1], [0.0, 0.2]], [[1.0], [1.0]], [[1.0, 0.0]], [[0.0]], 1.0)
    pole = ct.ss([[1.0, 0.0], [0.0, 0.2]], [[1.0], [1.0]], [[1.0, 0.0]], [[0.0]], 1.0)
    assert np.all(np.isfinite(response(sys, np.array([0.0, 0.1]))))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert not np.isfinite(response(pole, np.array([0.0]))[0])
