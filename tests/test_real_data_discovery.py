"""Finding and converting the Neural-Fly runs of every controller, and judging them, without the licensed
data: the files here are small ones written in the data set's format (an unnamed index, vectors as
"[a, b, c]" text) with values chosen so that the converted log has a closed form."""
from __future__ import annotations

import gzip
import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks import accuracy_real, realdata
from benchmarks.accuracy_real import real_lines, real_runs
from benchmarks.accuracy_run import Child
from dobwind.core.errors import InputError
from dobwind.io.logs import read_log
from dobwind.model.airframe import load_airframe
from benchmarks.tunnelruns import convert, convert_all, discover, read_run, training_controller

HEADER = ["", "t", "p", "p_d", "v", "v_d", "q", "R", "w", "T_sp", "q_sp", "hover_throttle", "fa", "pwm"]
ROLL, PITCH, YAW = 0.1, -0.2, 0.7  # rad, body FLU to world (x, y, z up)


def _axis(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3  # the right-handed pair: (y, z), (z, x), (x, y)
    m = np.eye(3)
    m[i, i] = m[j, j] = c
    m[i, j], m[j, i] = -s, s
    return m


def _text(values) -> str:
    return "[" + ", ".join(_text(v) if np.ndim(v) else repr(float(v)) for v in values) + "]"


def nf_rows(n: int = 6) -> list[list[str]]:
    """n rows 0.02 s apart from t = 5 s; row 3 repeats row 2's time (the converter drops it)."""
    rot = _axis(2, YAW) @ _axis(1, PITCH) @ _axis(0, ROLL)
    rows = []
    for k in range(n):
        t = 5.0 + 0.02 * (k if k < 3 else k - 1)
        v = [1.0 + k, 2.0, 3.0]
        cells = [str(k), repr(t), _text([0, 0, 2]), _text([0, 0, 2]), _text(v), _text([0, 0, 0]),
                 _text([0, 0, 0, 1]), _text(rot), _text([0, 0, 0]), _text([0.6]), _text([0, 0, 0, 1]),
                 _text([0.48]), _text([1, 0, 0]), _text([1000] * 4)]
        rows.append(cells)
    return rows


def write_nf(path: Path, rows: list[list[str]] | None = None, header: list[str] = HEADER) -> Path:
    rows = nf_rows() if rows is None else rows
    quote = lambda cell: f'"{cell}"' if "," in cell else cell
    text = "\n".join(",".join(quote(c) for c in line) for line in [header, *rows]) + "\n"
    if path.suffix == ".gz":
        with gzip.open(path, "wt") as handle:
            handle.write(text)
    else:
        path.write_text(text)
    return path


def test_discovery_finds_every_controller_in_both_forms_and_says_what_it_leaves(tmp_path):
    for name in ("baseline_nowind.csv.gz", "baseline_70wind.csv", "indi_35wind.csv", "indi_100wind.csv.gz",
                 "NF-C_70p20sint.csv", "indi_60wind.csv", "baseline_nowind.csv"):
        write_nf(tmp_path / f"custom_figure8_{name}")
    # The public repository's shorter names for the same kind of run, one of them a second copy.
    write_nf(tmp_path / "NF-T_nowind.csv")
    write_nf(tmp_path / "indi_35wind.csv.gz")
    for name in ("custom_random_baseline_nowind.csv", "sample_log.csv", "NF-T_60wind.csv"):
        write_nf(tmp_path / name)  # another trajectory, and files that are not runs at all
    (tmp_path / "notes.txt").write_text("x")
    said: list[str] = []
    found = discover(tmp_path, warn=said.append)
    f = lambda name: tmp_path / f"custom_figure8_{name}"
    assert found == {"baseline": {"nowind": f("baseline_nowind.csv"), "70wind": f("baseline_70wind.csv")},
                     "NF-C": {"70p20sint": f("NF-C_70p20sint.csv")}, "NF-T": {"nowind": tmp_path / "NF-T_nowind.csv"},
                     "indi": {"35wind": f("indi_35wind.csv"), "100wind": f("indi_100wind.csv.gz")}}
    assert list(found) == ["baseline", "NF-C", "NF-T", "indi"]  # the baseline first, then by name
    assert list(found["indi"]) == ["35wind", "100wind"]  # wind settings in nominal order
    assert len(said) == 3
    (unknown,) = [line for line in said if "60wind" in line]
    assert "custom_figure8_indi_60wind.csv" in unknown and "'60wind'" in unknown
    duplicates = sorted(line for line in said if "the same run as" in line)
    assert "custom_figure8_baseline_nowind.csv.gz" in duplicates[0] and "custom_figure8_baseline_nowind.csv;" in duplicates[0]
    assert duplicates[1].startswith(f"realdata: {tmp_path / 'indi_35wind.csv.gz'}:") and "custom_figure8_indi_35wind" in duplicates[1]
    # The older entry point keeps its meaning: the baseline's runs by wind setting.
    assert realdata.runs(tmp_path) == found["baseline"]
    assert discover(tmp_path / "absent") == {}


def test_training_controller_prefers_the_baseline_then_any_complete_one():
    winds = ("nowind", "70wind", "100wind")
    full = {w: Path(w) for w in winds}
    assert training_controller({"L1": full, "baseline": full, "NF": full}, winds) == "baseline"
    assert training_controller({"indi": full, "baseline": {"nowind": Path("x")}, "L1": full}, winds) == "L1"
    assert training_controller({"indi": {"nowind": Path("x"), "70wind": Path("y")}}, winds) is None


@pytest.mark.parametrize("suffix", [".csv", ".csv.gz"])
def test_conversion_round_trip(tmp_path, suffix):
    """NED velocity is (vx, -vy, -vz); the attitude is the same rotation seen in NED/FRD, i.e. roll kept,
    pitch and yaw negated; thrust is m g T_sp / hover_throttle; the nominal wind blows along -x; time
    starts at 0 and a repeated time stamp is dropped."""
    af = load_airframe(realdata.AIRFRAME)
    source = write_nf(tmp_path / f"custom_figure8_NF_70wind{suffix}")
    log = read_log(convert(source, 8.5, af.mass_kg, af.gravity_mps2, tmp_path / "out.csv"))
    c = log.columns
    np.testing.assert_allclose(c["t"], [0.0, 0.02, 0.04, 0.06, 0.08], atol=1e-6)
    np.testing.assert_allclose(c["vel_n"], [1.0, 2.0, 3.0, 5.0, 6.0], rtol=1e-6)  # row 3 (4.0) dropped
    np.testing.assert_allclose(c["vel_e"], -2.0)
    np.testing.assert_allclose(c["vel_d"], -3.0)
    np.testing.assert_allclose(c["thrust"], af.mass_kg * af.gravity_mps2 * 0.6 / 0.48, rtol=1e-6)
    np.testing.assert_allclose(log.stack("wind_n", "wind_e", "wind_d"), [[-8.5, 0.0, 0.0]] * 5)
    half = lambda angle, axis: np.r_[math.cos(angle / 2), math.sin(angle / 2) * np.eye(3)[axis]]

    def product(a, b):  # Hamilton product, scalar first
        return np.r_[a[0] * b[0] - a[1:] @ b[1:], a[0] * b[1:] + b[0] * a[1:] + np.cross(a[1:], b[1:])]

    expected = product(product(half(-YAW, 2), half(-PITCH, 1)), half(ROLL, 0))
    got = log.stack("q_w", "q_x", "q_y", "q_z")
    sign = np.sign(got[:, :1] * expected[0])
    np.testing.assert_allclose(got * sign, np.tile(expected, (5, 1)), atol=1e-6)


def _expect_error(path: Path, *fragments: str) -> None:
    with pytest.raises(InputError) as caught:
        read_run(path)
    message = str(caught.value)
    assert "\n" not in message and str(path) in message, message
    for fragment in fragments:
        assert fragment in message, message


def test_a_missing_column_is_named(tmp_path):
    drop = HEADER.index("hover_throttle")
    rows = [r[:drop] + r[drop + 1:] for r in nf_rows()]
    _expect_error(write_nf(tmp_path / "a.csv", rows, HEADER[:drop] + HEADER[drop + 1:]), "'hover_throttle'", "missing")
    _expect_error(write_nf(tmp_path / "b.csv", [], ["", "t"]), "'v'", "'R'", "'T_sp'")
    (tmp_path / "empty.csv").write_text("")
    _expect_error(tmp_path / "empty.csv", "'t'", "missing")


def test_a_bad_cell_is_named_by_its_line_and_column(tmp_path):
    rows = nf_rows()
    rows[2][HEADER.index("v")] = "[1.0, 2.0]"
    _expect_error(write_nf(tmp_path / "a.csv", rows), "line 4, column 'v'", "not 3 numbers")  # header is line 1
    rows = nf_rows()
    rows[0][HEADER.index("T_sp")] = "full"
    _expect_error(write_nf(tmp_path / "b.csv.gz", rows), "line 2, column 'T_sp'")
    _expect_error(write_nf(tmp_path / "c.csv", nf_rows()[:1]), "1 data rows")


def test_an_unreadable_file_is_said_not_raised(tmp_path):
    (tmp_path / "plain.csv.gz").write_text("not gzip at all\n")
    _expect_error(tmp_path / "plain.csv.gz", "not readable")
    whole = gzip.compress(",".join(HEADER).encode() + b"\n" + b"0,1.0" * 2000)
    (tmp_path / "cut.csv.gz").write_bytes(whole[: len(whole) // 2])
    _expect_error(tmp_path / "cut.csv.gz", "not readable")


def test_convert_all_skips_a_bad_run_with_one_line_and_keeps_the_rest(tmp_path):
    data = tmp_path / "data"
    data.mkdir()
    good = write_nf(data / "custom_figure8_indi_35wind.csv.gz")
    drop = HEADER.index("R")
    write_nf(data / "custom_figure8_indi_70wind.csv", [r[:drop] + r[drop + 1:] for r in nf_rows()],
             HEADER[:drop] + HEADER[drop + 1:])
    said: list[str] = []
    logs, skipped = convert_all(discover(data), 2.0, 9.81, tmp_path, warn=said.append)
    assert list(logs) == ["indi"] and list(logs["indi"]) == ["35wind"]
    assert read_log(logs["indi"]["35wind"]).rows == 5 and good.exists()
    assert len(said) == 1 and "custom_figure8_indi_70wind.csv" in said[0] and "'R'" in said[0] and "skipped" in said[0]
    assert [(s["controller"], s["wind"]) for s in skipped] == [("indi", "70wind")]


def _fake_child(calls: list[list[str]], offsets: dict[str, float]):
    """A stand-in for the command line: `fit` succeeds, and `replay` reads mean |wind| = nominal +
    the offset given for the converted log's name (controller_wind), so each run's error is known."""
    def run(args: list[str], workdir: Path) -> Child:
        calls.append(args)
        if args[0] == "fit":
            return Child(0, "{}", "", 0.1, 10.0)
        log = read_log(args[2])
        nominal = float(-log.columns["wind_n"][0])
        estimate = nominal + offsets[Path(args[2]).stem]
        return Child(0, f'{{"mean_estimated_wind": {{"horizontal_mps": {estimate}}}}}', "", 0.1, 10.0)
    return run


def test_real_runs_score_every_controller_through_the_split_fit(tmp_path, monkeypatch, capsys):
    data = tmp_path / "data"
    data.mkdir()
    for name in ("baseline_nowind", "baseline_70wind", "baseline_100wind", "baseline_35wind", "indi_70wind",
                 "L1_nowind", "L1_100wind"):
        write_nf(data / f"custom_figure8_{name}.csv.gz")
    write_nf(data / "custom_figure8_NF_35wind.csv", nf_rows()[:1])  # malformed: skipped, said
    offsets = {"baseline_nowind": 0.1, "baseline_70wind": -0.2, "baseline_100wind": 0.0, "baseline_35wind": 0.3,
               "indi_70wind": -0.4, "L1_nowind": 0.5, "L1_100wind": 0.6}
    calls: list[list[str]] = []
    monkeypatch.setattr(accuracy_real, "run_child", _fake_child(calls, offsets))
    result = real_runs(data, leave_one_out=False)
    assert "custom_figure8_NF_35wind.csv" in capsys.readouterr().err
    assert result["training_controller"] == "baseline"
    assert result["split"]["trained_on"] == ["nowind", "70wind", "100wind"]
    assert set(result["split"]["runs"]) == {"nowind", "70wind", "100wind", "35wind"}
    others = result["other_controllers"]
    assert {c: sorted(w) for c, w in others.items()} == {"L1": ["100wind", "nowind"], "indi": ["70wind"]}
    assert others["L1"]["100wind"]["error_mps"] == pytest.approx(0.6) and not others["L1"]["100wind"]["training"]
    fits = [c for c in calls if c[0] == "fit"]
    assert len(fits) == 1 and all("baseline_" in arg for arg in fits[0][2:-3])
    assert all(c[1].endswith("fitted_split.toml") for c in calls if c[0] == "replay")
    assert [s["controller"] for s in result["skipped"]] == ["NF"]
    lines, verdicts = real_lines(result)
    # Held out: baseline 35wind (0.3), indi 70wind (0.4), L1 nowind (0.5), L1 100wind (0.6): mean 0.45.
    assert verdicts["real: every controller's runs within 0.5 m/s on average (4 runs)"] is True
    assert any("0.45 m/s over 4 runs" in line for line in lines)
    assert any("NF" in line and "skipped" in line for line in lines)


def test_without_the_baseline_another_controllers_runs_train(tmp_path, monkeypatch):
    data = tmp_path / "data"
    data.mkdir()
    for name in ("indi_nowind", "indi_70wind", "indi_100wind", "baseline_35wind"):
        write_nf(data / f"custom_figure8_{name}.csv")
    offsets = {"indi_nowind": 0.0, "indi_70wind": 0.0, "indi_100wind": 0.0, "baseline_35wind": 0.2}
    monkeypatch.setattr(accuracy_real, "run_child", _fake_child([], offsets))
    result = real_runs(data, leave_one_out=False)
    assert result["training_controller"] == "indi" and list(result["other_controllers"]) == ["baseline"]
    lines, _ = real_lines(result)
    assert "the indi controller's" in lines[0]


def test_real_runs_without_a_training_set_say_so(tmp_path, capsys):
    write_nf(tmp_path / "custom_figure8_indi_nowind.csv")
    assert real_runs(tmp_path) is None
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(tmp_path) in err[0] and "nowind, 70wind, 100wind" in err[0]


def test_realdata_without_a_training_set_exits_2_with_one_line(tmp_path, capsys):
    write_nf(tmp_path / "custom_figure8_indi_nowind.csv")
    write_nf(tmp_path / "custom_figure8_indi_35wind.csv", nf_rows()[:1])
    assert realdata.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "indi_35wind" in err[0] and "run skipped" in err[0]
    assert str(tmp_path) in err[1] and "1 readable runs" in err[1]


def _run(error: float | None, training: bool = False) -> dict:
    return {"nominal_mps": 8.5, "estimate_mps": None if error is None else 8.5 + error, "error_mps": error,
            "training": training}


def _result(held: list[float | None], others: dict[str, list[float | None]], training: float = 0.0) -> dict:
    runs = {f"t{k}": _run(training, True) for k in range(3)}
    runs.update({f"h{k}": _run(e) for k, e in enumerate(held)})
    return {"training_controller": "baseline",
            "split": {"fit_exit_code": 0, "fit_message": "", "trained_on": ["t0", "t1", "t2"], "runs": runs},
            "other_controllers": {c: {f"w{k}": _run(e) for k, e in enumerate(v)} for c, v in others.items()}}


EVERY = "real: every controller's runs within 0.5 m/s on average"


def _every(result: dict) -> tuple[str, bool]:
    (item,) = [(k, v) for k, v in real_lines(result)[1].items() if k.startswith(EVERY)]
    return item


def test_the_all_controller_verdict_counts_the_baselines_held_out_runs_too():
    # Baseline held out 0.1, 0.1; others 0.6, -0.6: mean 0.35 over 4 (0.6 without the baseline's).
    assert _every(_result([0.1, -0.1], {"indi": [0.6], "L1": [-0.6]})) == (f"{EVERY} (4 runs)", True)
    # The baseline's own held-out goal passes while the other controllers' runs fail the new one.
    result = _result([0.1, 0.1], {"indi": [0.9, -0.9, 0.9]})
    verdicts = real_lines(result)[1]
    assert verdicts["real: held-out runs within 0.5 m/s on average"] is True
    assert verdicts[f"{EVERY} (5 runs)"] is False  # (0.2 + 2.7) / 5 = 0.58


def test_the_all_controller_verdict_leaves_training_runs_out_and_fails_a_missing_figure():
    # Held out 0.6, 0.6, 0.6, 0.5: mean 0.575 fails; the three exact training runs must not dilute it.
    assert _every(_result([0.6, -0.6], {"indi": [0.6, 0.5]}, training=0.0)) == (f"{EVERY} (4 runs)", False)
    assert _every(_result([0.0], {"indi": [0.0, None]}))[1] is False  # a replay that failed counts against
    assert _every(_result([0.5], {"indi": [-0.5]}))[1] is True  # the goal's edge is inside


def test_no_other_controllers_no_new_verdict_and_the_old_ones_unchanged():
    result = _result([0.1, 0.2], {})
    lines, verdicts = real_lines(result)
    assert verdicts == {"real: training runs within 0.3 m/s": True, "real: held-out runs within 0.5 m/s on average": True}
    assert not any("other controllers" in line for line in lines)


def test_the_other_controllers_are_listed_grouped():
    lines, _ = real_lines(_result([0.1], {"indi": [0.2, -0.4], "L1": [0.3]}))
    start = next(i for i, line in enumerate(lines) if line.strip().startswith("indi:"))
    assert "2 runs, mean |error| 0.30" in lines[start]
    assert [lines[start + 1].split()[0], lines[start + 2].split()[0]] == ["w0", "w1"]
    assert lines[start + 3].strip().startswith("L1: 1 run,") and lines[start + 4].split()[0] == "w0"
    assert any("all held-out runs of 3 controllers: mean |error| 0.25 m/s over 4 runs" in line for line in lines)


def test_a_zero_estimate_is_printed_as_a_figure():
    result = _result([0.1], {"indi": [0.1]})
    result["other_controllers"]["indi"]["w0"] = {"nominal_mps": 0.0, "estimate_mps": 0.0, "error_mps": 0.0,
                                                "training": False}
    lines, _ = real_lines(result)
    (line,) = [line for line in lines if line.split()[:1] == ["w0"]]
    assert "estimate   0.00" in line and "nan" not in line


def test_realdata_summary_over_every_controllers_held_out_runs():
    score = lambda speed, nominal, trained: {"mean_speed_mps": speed, "nominal_mps": nominal, "trained_on": trained}
    results = {"split": {"a": score(0.3, 0.0, True), "b": score(8.0, 8.5, False)},
               "other_controllers": {"indi": {"c": score(4.4, 4.2, False), "d": score(13.0, 12.1, False)}}}
    error, count = realdata.held_out_error_mps(results)
    assert count == 3 and error == pytest.approx((0.5 + 0.2 + 0.9) / 3)


def test_realdata_tables_list_the_other_controllers_runs_and_the_skipped_ones():
    def score(speed, trained=False):
        return {"nominal_mps": 8.5, "mean_speed_mps": speed, "speed_of_mean_mps": speed, "mean_from_deg": 0.0,
                "mean_up_mps": 0.0, "fit_terms": ["fh"], "fit_cv_rmse_mps": 0.5, "trained_on": trained}
    results = {"training_controller": "baseline", "leave_one_out": {"70wind": score(8.0)},
               "split": {"70wind": score(8.4, True), "70p20sint": score(8.0)},
               "other_controllers": {"L1": {"70wind": score(9.1)}, "indi": {"70wind": score(8.3)}},
               "skipped": [{"controller": "NF", "wind": "nowind", "reason": "f.csv: column 'R' missing"}]}
    lines = realdata.tables(results)
    start = lines.index("  L1:")
    assert lines[start + 1].split()[:3] == ["70wind", "8.5", "9.10"]
    assert lines[start + 2] == "  indi:" and lines[start + 3].split()[:3] == ["70wind", "8.5", "8.30"]
    assert "  skipped NF nowind: f.csv: column 'R' missing" in lines
    assert lines[-1].endswith(f"3 controllers: mean |mean |wind| - nominal| {(0.5 + 0.6 + 0.2) / 3:.2f} m/s over 3 runs")
