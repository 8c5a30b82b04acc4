"""Every `--json` output parses with a strict parser: NaN and Infinity become null, and are listed."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.io.jsonout import NULL_PATHS_KEY, dumps
from dobwind.model.airframe_toml import dumps as toml_dumps
from tests.helpers import M300, airframe_dict


def _refuse(constant: str):
    raise AssertionError(f"not JSON: {constant}")


def strict_loads(text: str):
    return json.loads(text, parse_constant=_refuse)


# The subcommands with --json that the tests below run; the walk over the parser below keeps it complete.
JSON_COMMANDS = {"analyze", "check", "fit", "replay", "verify", "inspect", "init", "profile"}


def _json_run(argv: list[str], capsys) -> tuple[int, dict]:
    """Run a command with --json: stdout must be one strict JSON object in the common style (indent 2)."""
    capsys.readouterr()
    code = main(argv)
    text = capsys.readouterr().out
    report = strict_loads(text)
    assert isinstance(report, dict) and text == json.dumps(report, indent=2) + "\n", f"{argv[0]}: not the common style"
    return code, report


def test_every_command_with_json_is_tested_here():
    import argparse

    from dobwind.cli.app import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    with_json = {name for name, p in sub.choices.items() if any("--json" in a.option_strings for a in p._actions)}
    assert with_json == JSON_COMMANDS


def test_the_helper_nulls_every_non_finite_value_and_says_where():
    obj = {"a": math.nan, "b": [1.0, np.float64(np.inf), {"c": -math.inf}], "d": np.array([1.0, np.nan]),
           "e": np.int64(3), "f": (0.5, None), "g": "NaN is fine inside a string"}
    parsed = strict_loads(dumps(obj))
    assert parsed["a"] is None and parsed["b"] == [1.0, None, {"c": None}] and parsed["d"] == [1.0, None]
    assert parsed["e"] == 3 and parsed["f"] == [0.5, None] and parsed["g"] == obj["g"]
    assert parsed[NULL_PATHS_KEY] == ["a", "b[1]", "b[2].c", "d[1]"]
    assert NULL_PATHS_KEY not in strict_loads(dumps({"x": 1.0}))


def test_the_strict_parser_used_here_does_refuse_nan():
    with pytest.raises(AssertionError):
        strict_loads(json.dumps({"x": math.nan}))


def test_analyze_json_on_unstable_gains(tmp_path, capsys):
    """The known case: an unstable observer has an infinite noise gain."""
    path = tmp_path / "hot.toml"
    path.write_text(toml_dumps(airframe_dict(**{"observer.discretization": "euler", "observer.gains": [20.0, 300.0, 30.0]})))
    code, report = _json_run(["analyze", str(path), "--json"], capsys)
    assert code == 1 and report["stable"] is False
    assert report["unstable_reason"] and "axis y" in report["unstable_reason"]
    assert report["observer"][1]["noise_gain"] is None
    assert "observer[1].noise_gain" in report[NULL_PATHS_KEY]


def test_analyze_bandwidth_json(capsys):
    code, report = _json_run(["analyze", str(M300), "--bandwidth", "0.5", "--json"], capsys)
    assert code == 0 and report["gains"][0] > 0


def test_check_json(capsys):
    code, summary = _json_run(["check", str(M300), "--json"], capsys)
    assert code == 0 and summary["name"] == "m300"


def test_verify_json_with_a_non_finite_figure(capsys, monkeypatch):
    from dobwind.harness import verify

    real = verify.verify_precision

    def with_nan_error(*args, **kwargs):
        report = real(*args, **kwargs)
        report.cases = __import__("dataclasses").replace(report.cases, outputs=tuple(
            __import__("dataclasses").replace(e, max_abs=math.nan) for e in report.cases.outputs))
        return report
    monkeypatch.setattr(verify, "verify_precision", with_nan_error)
    code, report = _json_run(["verify", str(M300), "--precision", "double", "--steps", "200", "--json"], capsys)
    assert report["precisions"][0]["cases"]["outputs"][0]["max_abs"] is None
    assert report[NULL_PATHS_KEY]


def test_replay_json_with_nan_true_wind(tmp_path, capsys):
    log = tmp_path / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "50", "-o", str(log)]) == 0
    lines = log.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    column = lines[header].split(",").index("wind_n")
    for i in range(header + 1, header + 400):  # the first 8 s of true wind unknown
        cells = lines[i].split(",")
        cells[column] = "nan"
        lines[i] = ",".join(cells)
    log.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    code, report = _json_run(["replay", str(M300), str(log), "--json"], capsys)
    assert code == 0 and report["rows"] > 0
    assert report["per_sample"]["speed_mean"] is None and "per_sample.speed_mean" in report[NULL_PATHS_KEY]


def test_inspect_and_init_json(tmp_path, capsys):
    """On a simulated CSV log: each prints one strict JSON object in the common style."""
    log = tmp_path / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "2", "--rate", "50", "-o", str(log)]) == 0
    code, report = _json_run(["inspect", str(log), "--json"], capsys)
    assert code == 0 and report["format"] == "csv" and report["roles"]["rpm"]["source"].startswith("rpm_1")
    code, report = _json_run(["init", str(log), "--mass", "8", "-o", str(tmp_path / "v.toml"), "--json"], capsys)
    assert code == 0 and report["calibration"] == "prior" and report["choices"]["rate_hz"] == 50.0


def test_profile_json_with_unknown_sigmas(tmp_path, capsys):
    log = tmp_path / "vertical.csv"
    assert main(["simulate", "vertical", "--hold", "2", "--rate", "50", "-o", str(log)]) == 0
    capsys.readouterr()
    code, report = _json_run(["profile", str(M300), str(log), "-o", str(tmp_path / "p.csv"), "--json"], capsys)
    assert code == 0 and sum(b["count"] for b in report["bins"]) > 0
    # m300 records no [uncertainty] table: every bin's sigma is unknown, null and named as such
    assert all(b["sigma_h_mps"] is None for b in report["bins"])
    assert "bins[0].sigma_h_mps" in report[NULL_PATHS_KEY]


def test_fit_json_with_a_non_finite_figure(tmp_path, capsys, monkeypatch):
    import dobwind.calibrate.fit as fit
    import dobwind.calibrate.fitfamily as fitfamily
    import dobwind.calibrate.fitreport as fitreport
    from dobwind.model.airframe import load_airframe

    af = load_airframe(M300)
    from dobwind.calibrate.selfcheck import Thresholds, verdict

    passed = verdict(af, [], 0.05, 8.0, Thresholds())  # the self-check is not what this test is about
    monkeypatch.setattr(fitfamily, "fit_airframe", lambda *a, **k: (af, fit.FitReport(points=9, self_check=passed), None))
    monkeypatch.setattr(fitreport, "fit_plot", lambda *a, **k: None)
    out = tmp_path / "fitted.toml"
    code, report = _json_run(["fit", str(M300), "x.csv", "-o", str(out), "--json"], capsys)
    assert code == 0 and report["horizontal_rmse_mps"] is None  # FitReport's default is NaN
    assert "horizontal_rmse_mps" in report[NULL_PATHS_KEY]


def test_the_real_data_check_prints_strict_json(monkeypatch, capsys):
    """`make realdata --json` is not a subcommand, but its output is read by tools too."""
    from benchmarks import realdata

    from benchmarks.runconsistency import RunForce

    run = RunForce("35wind", 4.2, 4.2, 0.0, math.inf)
    found = {"training_controller": "baseline", "runs": [run], "offset_n": [1.0, 0.5]}
    monkeypatch.setattr(realdata, "_both", lambda *a, **k: ({"split": {"run": {"speed_mps": math.nan}}}, found))
    assert realdata.main(["--json"]) == 0
    text = capsys.readouterr().out
    report = strict_loads(text)
    assert report["split"]["run"]["speed_mps"] is None and text == json.dumps(report, indent=2) + "\n"
    assert report["consistency"]["runs"][0]["bound_mps"] is None and report["consistency"]["runs"][0]["below_bound"]
