"""Command-line contracts of issue #10: commands agree with each other and fail with one line."""
from __future__ import annotations

import pytest

from dobwind.cli.app import main
from dobwind.model.airframe_toml import dumps
from tests.helpers import airframe_dict


def _one_line(err: str) -> str:
    assert err.count("\n") == 1 and err.endswith("\n") and "Traceback" not in err, err
    return err


def test_check_and_generate_agree_on_unstable_gains(tmp_path, capsys):
    # Paper form: pole 1 - dt*gain/(2m) = 1 - 0.02*600/5 = -1.4 on axis y: outside the unit circle.
    bad = tmp_path / "bad.toml"
    bad.write_text(dumps(airframe_dict(**{"observer.gains": [20.0, 600.0, 30.0]})))
    assert main(["check", str(bad)]) == 2
    check_err = _one_line(capsys.readouterr().err)
    assert main(["generate", str(bad), "-o", str(tmp_path / "out")]) == 2
    generate_err = _one_line(capsys.readouterr().err)
    for err in (check_err, generate_err):
        assert str(bad) in err and "observer.gains" in err and "-1.4" in err and "axis y" in err
    assert not (tmp_path / "out").exists()


def test_check_refuses_gains_unstable_only_at_max_dt(tmp_path, capsys):
    # 1 - 0.02*120/5 = 0.52 at the sample time, but 1 - 0.1*120/5 = -1.4 at limits.max_dt = 0.1 s.
    bad = tmp_path / "late.toml"
    bad.write_text(dumps(airframe_dict(**{"observer.gains": [20.0, 25.0, 120.0]})))
    assert main(["check", str(bad)]) == 2
    err = _one_line(capsys.readouterr().err)
    assert "limits.max_dt" in err and "axis z" in err


def test_check_and_generate_agree_on_stable_gains(tmp_path, capsys):
    # Worst pole 1 - 0.1*30/5 = 0.4 at limits.max_dt: inside.
    good = tmp_path / "good.toml"
    good.write_text(dumps(airframe_dict(**{"observer.gains": [20.0, 25.0, 30.0]})))
    assert main(["check", str(good)]) == 0
    assert main(["generate", str(good), "-o", str(tmp_path / "out")]) == 0


@pytest.mark.parametrize("typo, right, where", [
    ("masss", "mass", ""), ("gainz", "gains", "observer."), ("speed", "speeds", "filter."),
    ("max_rpms", "max_rpm", "thrust."),
])
def test_a_misspelt_key_is_named_before_the_missing_one(tmp_path, capsys, typo, right, where):
    doc = airframe_dict()
    table = doc
    for part in where.rstrip(".").split(".") if where else []:
        table = table[part]
    table[typo] = table.pop(right)
    path = tmp_path / "typo.toml"
    path.write_text(dumps(doc))
    assert main(["check", str(path)]) == 2
    err = _one_line(capsys.readouterr().err)
    assert f"{path}: {where}{typo}: unknown key; did you mean '{right}'?" in err
    assert "missing" not in err


def test_compile_step_leaves_no_temporary_folder_and_still_runs(tmp_path, monkeypatch):
    import tempfile

    import numpy as np

    from dobwind.harness.cstep import compile_step
    from dobwind.model import reference
    from dobwind.model.airframe import parse_airframe
    from dobwind.model.exercise import flight_inputs
    from dobwind.model.step import build_step

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))  # every temporary folder lands here
    model = build_step(parse_airframe(dumps(airframe_dict()), "<test>"))
    cstep = compile_step(model, "double")
    assert list(tmp_path.iterdir()) == []
    rows = flight_inputs(model, 200, seed=1)
    got, ref = cstep.run(rows), reference.run(model, rows)  # the loaded library outlives its file
    assert np.array_equal(got.status, ref.status) and np.allclose(got.outputs, ref.outputs, rtol=1e-9, atol=1e-9)


def _run(argv: list[str], capsys) -> tuple[int, str, str]:
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse refuses options while parsing
        code = int(exc.code or 0)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


M300_PATH = str(__import__("tests.helpers", fromlist=["M300"]).M300)
BAD_OPTIONS = [
    (["simulate", "sweep", "-o", "{out}", "--rate", v], "--rate") for v in ("-5", "0", "nan", "inf", "1e-300", "1e6")
] + [
    (["simulate", "sweep", "-o", "{out}", "--hold", v], "--hold") for v in ("nan", "inf", "1e-3", "1e9", "-1")
] + [
    (["simulate", "sweep", "-o", "{out}", "--seed", "-1"], "--seed"),
    (["simulate", "sweep", "-o", "{out}", "--seed", "1.5"], "--seed"),
    (["verify", M300_PATH, "--steps", "-5"], "--steps"),
    (["verify", M300_PATH, "--steps", "1e9"], "--steps"),
    (["verify", M300_PATH, "--seed", "-5"], "--seed"),
    (["replay", M300_PATH, "x.ulg", "--rate", "inf"], "--rate"),
    (["replay", M300_PATH, "x.ulg", "--rate", "1e9"], "--rate"),
    (["analyze", M300_PATH, "--freq", "200"], "--freq"),     # m300: 100 Hz, Nyquist 50 Hz
    (["analyze", M300_PATH, "--freq", "0.1", "50"], "--freq"),  # at Nyquist is not below it
    (["analyze", M300_PATH, "--freq", "nan"], "--freq"),
    (["analyze", M300_PATH, "--bandwidth", "1e-300"], "--bandwidth"),
    (["analyze", M300_PATH, "--bandwidth", "50"], "--bandwidth"),
    (["simulate", "sweep", "-o", "{out}", "--rate", "400"], "--rate/--hold"),  # 6480 s at 400 Hz: 2.6 M rows
]


@pytest.mark.parametrize("argv, option", BAD_OPTIONS, ids=[" ".join(a[2:]) for a, _ in BAD_OPTIONS])
def test_every_numeric_option_is_bounded(argv, option, tmp_path, capsys):
    out = tmp_path / "out.csv"
    code, stdout, err = _run([a.format(out=out) for a in argv], capsys)
    assert code == 2 and stdout == ""
    assert option in _one_line(err)
    assert not out.exists()


def test_the_option_ranges_are_stated_in_help(capsys):
    code, stdout, _ = _run(["simulate", "--help"], capsys)
    assert code == 0 and "1 to 500 Hz" in stdout and "0.1 to 600 s" in stdout and "0 to 4294967295" in stdout


def test_the_nyquist_bound_follows_the_airframe(tmp_path, capsys):
    # sample_time 0.02 s: Nyquist 25 Hz. 24 Hz is fine at this rate, and refused at 0.05 s (10 Hz).
    fast = tmp_path / "fast.toml"
    fast.write_text(dumps(airframe_dict()))
    slow = tmp_path / "slow.toml"
    slow.write_text(dumps(airframe_dict(**{"observer.sample_time": 0.05, "filter.cutoffs": [0.3, 0.6, 1.0]})))
    assert _run(["analyze", str(fast), "--freq", "24"], capsys)[0] == 0
    code, _, err = _run(["analyze", str(slow), "--freq", "24"], capsys)
    assert code == 2 and "Nyquist frequency 10 Hz" in _one_line(err)


def test_a_closed_pipe_is_not_a_traceback(tmp_path):
    import os
    import subprocess
    import sys

    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader (`| head`) has already gone
    try:
        # --no-selftest: the self-test builds come before any output and are not what is tested here
        done = subprocess.run([sys.executable, "-m", "dobwind.cli", "check", M300_PATH, "--no-selftest"],
                              stdout=write_end, stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write_end)
    assert done.stderr == "" and done.returncode == 141


def test_a_byte_order_mark_is_not_part_of_the_first_column(tmp_path, capsys):
    log = tmp_path / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "50", "-o", str(log)]) == 0
    lines = log.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    plain = tmp_path / "plain.csv"
    plain.write_text("\n".join(lines[header:header + 400]) + "\n")  # header first: "t" is the first name
    marked = tmp_path / "marked.csv"
    marked.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes())
    capsys.readouterr()
    results = []
    for path in (plain, marked):
        assert main(["replay", M300_PATH, str(path), "--json"]) == 0
        results.append(__import__("json").loads(capsys.readouterr().out))
    assert results[0]["rows"] == results[1]["rows"] == 399
    assert results[0]["per_sample"] == results[1]["per_sample"]


@pytest.mark.parametrize("cell", ["", "nan", "inf", "1.5"])
def test_a_segment_label_must_be_a_whole_number(tmp_path, capsys, cell):
    log = tmp_path / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "50", "-o", str(log)]) == 0
    lines = log.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    cells = lines[header + 5].split(",")
    cells[lines[header].split(",").index("segment")] = cell
    lines[header + 5] = ",".join(cells)
    log.write_text("\n".join(lines) + "\n")
    capsys.readouterr()
    assert main(["replay", M300_PATH, str(log)]) == 2
    assert f"line {header + 6}, column segment" in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize("argv, parsed", [
    (["fit", "a", "--wind", "-2@90"], ["fit", "a", "--wind=-2@90"]),
    (["--wind", "-.5@90", "-o", "x"], ["--wind=-.5@90", "-o", "x"]),
    (["analyze", "--freq", "-1", "2"], ["analyze", "--freq", "-1", "2"]),   # argparse's own negative number
    (["--wind=-2@90"], ["--wind=-2@90"]), (["--", "-2@90"], ["--", "-2@90"]),
    (["-o", "-2@90"], ["-o", "-2@90"]), (["--wind", "-x"], ["--wind", "-x"])])
def test_a_dash_value_is_attached_only_after_a_long_option(argv, parsed):
    from dobwind.cli.app import attach_dash_values

    assert attach_dash_values(argv) == parsed


@pytest.mark.parametrize("command", ["replay", "profile"])
def test_a_rate_slower_than_max_dt_is_refused(command, tmp_path, capsys):
    """m300's limits.max_dt is 0.1 s: at 9 Hz the step would reject every instant as BAD_DT (replay wrote
    an estimate with 0 valid rows and exit 0); at 10 Hz every step is within it."""
    from tests.test_inspect import _px4_log

    log = str(_px4_log(tmp_path / "a.ulg"))
    out = tmp_path / "e.csv"
    code, stdout, err = _run([command, M300_PATH, log, "--rate", "9", "-o", str(out)], capsys)
    assert code == 2 and stdout == "" and not out.exists()
    assert "--rate: 9 Hz" in _one_line(err) and "limits.max_dt (0.1 s)" in err and "at least 10 Hz" in err
    if command == "replay":
        code, _, err = _run([command, M300_PATH, log, "--rate", "10", "-o", str(out)], capsys)
        assert code == 0 and out.exists() and "--rate" not in err


@pytest.mark.parametrize("argv, shown", [(["check", ""], "AIRFRAME"), (["replay", M300_PATH, ""], "LOG"),
                                         (["replay", "", "x.csv"], "AIRFRAME"), (["inspect", ""], "LOG"),
                                         (["profile", M300_PATH, "{log}", "", "-o", "{out}"], "LOG"),
                                         (["fit", M300_PATH, "{log}", "--truth", "", "-o", "{out}"], "--truth"),
                                         (["simulate", "sweep", "--vehicle", "", "-o", "{out}"], "--vehicle"),
                                         (["verify", M300_PATH, "--c-dir", ""], "--c-dir")])
def test_an_empty_input_path_is_refused(argv, shown, tmp_path, capsys, monkeypatch):
    """An empty argument (`replay af.toml "$LOG"` with LOG unset) is the current folder to the readers: replay
    replayed every log in it, and check said '.: cannot read: Is a directory'. Now one line naming the argument;
    the working folder holds a log, so that a replay of it would have exit 0."""
    monkeypatch.chdir(tmp_path)
    log = tmp_path / "here.csv"
    log.write_text("t,vel_n\n0.0,0.0\n")
    out = tmp_path / "out.csv"
    code, stdout, err = _run([a.format(log=log, out=out) for a in argv], capsys)
    assert code == 2 and stdout == "" and not out.exists()
    assert _one_line(err).startswith(f"dobwind {argv[0]}: {shown}: an empty path ''"), err
