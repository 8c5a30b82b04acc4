"""The wind-unit analysis (dobwind/analysis/windunits.py) against closed forms, on every family."""
from __future__ import annotations

import math

import numpy as np
import pytest

from dobwind.analysis.design import WindTarget, design_gain_for_wind, with_gains
from dobwind.analysis.figures import group_delay_s, response
from dobwind.analysis.linear import linearize
from dobwind.analysis.windunits import local_slope, wind_scatter, wind_units
from dobwind.model.step import build_step
from tests.families import FAMILIES, family_airframe, pure_quadratic
from tests.helpers import ROOT


def _linear(family: str, l0: float):
    """F = l0 v: the polynomial family as s = fh / l0, the drag laws as l0 alone."""
    if family == "polynomial":
        return family_airframe(family, **{"observer.force_offset": [0.0, 0.0, 0.0],
                                          "force_air.horizontal.terms": ["fh"],
                                          "force_air.horizontal.coefficients": [1 / l0]})
    law = {"l0": l0, "lz": 0.2} if family == "drag-heading" else {"frame": "body", "l0": l0, "lz": l0}
    return family_airframe(family, **{"observer.force_offset": [0.0, 0.0, 0.0], "force_air.drag": law})


@pytest.mark.parametrize("family", FAMILIES)
def test_slope_of_a_quadratic_law(family):
    """F = a s^2 along the airflow: ds/dF = 1 / (2 a s) along, s / F = 1 / (a s) across."""
    a = 0.03
    af = pure_quadratic(family, a)
    for speed in (2.0, 5.0, 10.0):
        along, across = local_slope(af, speed)
        assert along == pytest.approx(1 / (2 * a * speed), rel=1e-3)  # the step guards 1/fh at 1e-3 N
        assert across == pytest.approx(1 / (a * speed), rel=1e-3)


@pytest.mark.parametrize("family", FAMILIES)
def test_noise_of_a_linear_law_is_the_force_noise_over_l0(family):
    af = _linear(family, 0.25)
    for speed in (0.0, 4.0):
        along, across = wind_scatter(af, speed, (0.1, 0.2))
        assert along == pytest.approx(0.1 / 0.25, rel=1e-3)
        assert across == pytest.approx(0.2 / 0.25, rel=1e-3)


@pytest.mark.parametrize("family", FAMILIES)
def test_noise_of_a_quadratic_law_at_zero_airflow(family):
    """s = sqrt(r / a) along the force, r Rayleigh(sigma): E[w_x^2] = E[r] / (2 a) = sigma sqrt(pi / 2) / (2 a).
    The linearized slope is infinite there; the quadrature is not."""
    a, sigma = 0.03, 0.2
    along, across = wind_scatter(pure_quadratic(family, a), 0.0, (sigma, sigma))
    expected = math.sqrt(sigma * math.sqrt(math.pi / 2) / (2 * a))
    assert along == pytest.approx(expected, rel=0.01) and across == pytest.approx(expected, rel=0.01)


def test_noise_at_speed_is_the_slope_times_the_force_noise_when_small():
    af = pure_quadratic("drag-heading", 0.03)
    along, across = wind_scatter(af, 6.0, (0.01, 0.01))
    assert along == pytest.approx(0.01 / (2 * 0.03 * 6.0), rel=1e-3)
    assert across == pytest.approx(0.01 / (0.03 * 6.0), rel=1e-3)


@pytest.mark.parametrize("family", FAMILIES)
def test_report_block_per_breakpoint_and_airspeed(family):
    af = family_airframe(family)
    model = build_step(af)
    block = wind_units(af, model, [0.5], [2.0, 5.0], force_noise_n=0.3)
    assert [p["airspeed_mps"] for p in block["breakpoints"]] == list(af.filter.speeds_mps)
    assert [p["airspeed_mps"] for p in block["airspeeds"]] == [2.0, 5.0]
    for p in block["breakpoints"] + block["airspeeds"]:
        delay = group_delay_s(linearize(model, p["airspeed_mps"]).axis(0))
        assert p["ramp_lag_s"] == pytest.approx(delay) and p["ramp_error_mps"] == pytest.approx(0.5 * delay)
        assert p["wind_noise_along_mps"] > 0 and p["slope_along_mps_per_n"] > 0
        # Bode of force to wind: the force path's gain at 0.5 Hz times the slope.
        h = abs(response(linearize(model, p["airspeed_mps"]).axis(0), np.array([0.5]))[0])
        assert p["bode"][0]["gain_db_re_1mps_per_n"] == pytest.approx(20 * math.log10(h * p["slope_along_mps_per_n"]))
    # A drag law is steepest at zero airflow: the slope falls with airspeed (the test polynomial is no
    # drag law: its m^2 and n^2 terms make it steepen again).
    slopes = [p["slope_along_mps_per_n"] for p in block["breakpoints"]]
    assert family == "polynomial" or slopes == sorted(slopes, reverse=True)
    # The noise at the file's gains before the low-pass is what --force-noise said.
    assert block["breakpoints"][0]["force_noise_n"] < 0.3  # the low-pass takes some away


@pytest.mark.parametrize("family,kind,value", [(f, "lag", 0.7) for f in FAMILIES] + [("drag-body", "noise", 0.15)])
def test_wind_design_round_trip(family, kind, value):
    af = family_airframe(family)
    model = build_step(af)
    source = wind_units(af, model, [], [], force_noise_n=0.3)["input_noise"]
    gain = design_gain_for_wind(af, WindTarget(kind, value, 5.0), source)
    new = with_gains(af, (gain, gain, gain))
    point = wind_units(new, build_step(new), [], [5.0], force_noise_n=None)["airspeeds"][0]
    if kind == "lag":
        assert point["ramp_lag_s"] == pytest.approx(value, rel=1e-5)
    else:  # the same input-referred noise through the new gains
        from dobwind.analysis.windunits import NoiseSource, wind_point
        from dobwind.analysis.linear import jacobian_function
        m2 = build_step(new)
        again = wind_point(new, m2, 5.0, [], NoiseSource(source, "test"),
                           (jacobian_function(m2, "force"), jacobian_function(m2, "noise")))
        assert again["wind_noise_along_mps"] == pytest.approx(value, rel=1e-5)


def _cli_json(args, capsys):
    import json

    from dobwind.cli.app import main

    code = main(args + ["--json"])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 else out.err)


@pytest.mark.parametrize("target,key,value", [("noise=0.2@5", "wind_noise_along_mps", 0.2),
                                              ("lag=0.9@5", "ramp_lag_s", 0.9)])
def test_analyze_designs_for_a_wind_target_and_reports_it(tmp_path, capsys, target, key, value):
    """The designed airframe's report, at the target airspeed, meets the target: the force noise is
    the file's, referred to the observer's input, not re-read at the new gains."""
    from dobwind.model.airframe_toml import dumps
    from tests.families import family_doc

    path = tmp_path / "af.toml"
    path.write_text(dumps(family_doc("drag-heading")))
    code, report = _cli_json(["analyze", str(path), "--bandwidth", target, "--airspeed", "5",
                              "--force-noise", "0.3", "-o", str(tmp_path / "new.toml")], capsys)
    assert code == 0, report
    assert report["wind_units"]["airspeeds"][0][key] == pytest.approx(value, rel=1e-4)
    assert report["design"]["target"]["kind"] == target.split("=")[0]
    assert report["gains_kg_per_s"] != [20.0, 25.0, 30.0]


def test_analyze_refuses_an_unreachable_or_malformed_target(tmp_path, capsys):
    from dobwind.model.airframe_toml import dumps
    from tests.families import family_doc

    path = tmp_path / "af.toml"
    path.write_text(dumps(family_doc("drag-heading")))
    code, err = _cli_json(["analyze", str(path), "--bandwidth", "lag=0.05@5"], capsys)  # the low-pass alone lags more
    assert code == 2 and "out of reach" in err and "\n" == err[-1] and err.count("\n") == 1
    code, err = _cli_json(["analyze", str(path), "--bandwidth", "noise=0.2@5"], capsys)  # no noise known
    assert code == 2 and "--force-noise" in err
    # nf_quad's law, s = 4 sqrt(F), needs 56 N for 30 m/s: beyond its weight, where the search stops.
    quad = tmp_path / "quad.toml"
    quad.write_text((ROOT / "airframes" / "nf_quad.toml").read_text())
    code, err = _cli_json(["analyze", str(quad), "--airspeed", "5", "30"], capsys)
    assert code == 2 and err.startswith(f"dobwind analyze: {quad}: --airspeed: the force-air law does not reach 30")
    with pytest.raises(SystemExit) as exit_:  # argparse's own exit for a malformed option
        _cli_json(["analyze", str(path), "--bandwidth", "wind=1@5"], capsys)
    assert exit_.value.code == 2 and "noise=M/S@AIRSPEED" in capsys.readouterr().err


def test_analyze_draws_the_wind_unit_figure_over_the_airspeeds_asked(tmp_path, capsys):
    from dobwind.cli.app import main

    assert main(["analyze", "nf_quad", "--airspeed", "1", "4", "--force-noise", "0.2", "-o", str(tmp_path / "a")]) == 0
    assert (tmp_path / "a" / "wind_units.png").stat().st_size > 10_000
    text = capsys.readouterr().out
    assert "In wind units" in text and "(asked)" in text and "--force-noise 0.2 N" in text
    assert main(["analyze", "nf_quad", "-o", str(tmp_path / "b")]) == 0  # none asked: the report's three figures
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == ["bode.png", "discretizations.png", "ramp.png"]
