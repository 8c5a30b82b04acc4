"""`replay` over several logs or a folder (issue #35): worker processes write exactly what single runs
write, one summary table, a failed log does not stop the others, clashing output names are refused."""
from __future__ import annotations

import json

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.io.logs import write_csv
from dobwind.model.airframe import load_airframe
from dobwind.simulate.simulate import simulate
from tests.helpers import M300


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("many") / "logs"
    folder.mkdir()
    af = load_airframe(M300)
    paths = []
    for seed in (1, 2, 3):
        cols = simulate(af, "tunnel", seed=seed, hold_s=0.6, rate_hz=50.0)
        names = list(cols)
        path = folder / f"flight{seed}.csv"
        write_csv(path, names, np.column_stack([cols[n] for n in names]), ["%.10g"] * len(names))
        paths.append(path)
    (folder / "notes.txt").write_text("not a log\n")
    return folder, paths


def test_parallel_outputs_equal_single_runs_byte_for_byte(logs, tmp_path, capsys):
    folder, paths = logs
    for path in paths:
        assert main(["replay", str(M300), str(path), "-o", str(tmp_path / "single" / f"{path.stem}.csv")]) == 0
    capsys.readouterr()
    assert main(["replay", str(M300), str(folder), "-o", str(tmp_path / "many"), "--jobs", "2"]) == 0
    text = capsys.readouterr().out
    for path in paths:
        assert (tmp_path / "many" / f"{path.stem}.csv").read_bytes() == \
            (tmp_path / "single" / f"{path.stem}.csv").read_bytes()
        assert path.name in text
    assert sorted(p.name for p in (tmp_path / "many").iterdir()) == [f"{p.stem}.csv" for p in paths]
    assert "3 of 3 logs replayed" in text


def test_one_bad_log_is_reported_and_the_others_written(logs, tmp_path, capsys):
    _, paths = logs
    bad = tmp_path / "broken.csv"
    bad.write_text("t,vel_n\n0,1\n")
    code = main(["replay", str(M300), str(paths[0]), str(bad), "-o", str(tmp_path / "out"), "--jobs", "2", "--json"])
    captured = capsys.readouterr()
    assert code == 2
    report = json.loads(captured.out)
    assert [r["exit"] for r in report["logs"]] == [0, 2]
    assert report["logs"][0]["summary"]["rows"] > 0
    assert "broken.csv" in captured.err
    assert (tmp_path / "out" / f"{paths[0].stem}.csv").exists() and not (tmp_path / "out" / "broken.csv").exists()


def test_netcdf_format_and_clashing_names(logs, tmp_path, capsys):
    pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    folder, paths = logs
    assert main(["replay", str(M300), *map(str, paths[:2]), "-o", str(tmp_path / "nc"), "--format", "nc",
                 "--jobs", "1"]) == 0
    assert sorted(p.name for p in (tmp_path / "nc").iterdir()) == [f"{p.stem}.nc" for p in paths[:2]]
    twin = tmp_path / "elsewhere"
    twin.mkdir()
    (twin / paths[0].name).write_bytes(paths[0].read_bytes())
    capsys.readouterr()
    assert main(["replay", str(M300), str(paths[0]), str(twin / paths[0].name), "-o", str(tmp_path / "x")]) == 2
    assert "rename one of the logs" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_an_empty_folder_and_plot_with_several_logs_are_refused(logs, tmp_path, capsys):
    _, paths = logs
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["replay", str(M300), str(empty)]) == 2
    assert "holds no flight logs" in capsys.readouterr().err
    assert main(["replay", str(M300), *map(str, paths[:2]), "--plot", str(tmp_path / "p.png")]) == 2
    assert "--plot" in capsys.readouterr().err


@pytest.mark.parametrize("argv, says", [
    (["profile", "{af}", "{missing}", "-o", "{out}.csv"], "cannot read"),
    (["profile", "{af}", "{log}", "-o", "{out}.csv", "--allow", "tilt"], "not a quality flag"),
    (["profile", "{af}", "{log}", "-o", "{out}.csv", "--bin", "0"], "--bin"),
    (["profile", "{af}", "{log}", "-o", "{out}.csv", "--jobs", "0"], "--jobs"),
    (["profile", "{af}", "{log}", "-o", "{out}.csv", "--min-seconds", "-1"], "--min-seconds"),
    (["profile", "{af}", "{log}", "-o", "{out}.csv", "--min-seconds", "nan"], "--min-seconds"),
    (["replay", "{af}", "{log}", "{log}", "-o", "{out}.csv"], "not a folder"),
    (["replay", "{af}", "{log}", "{missing}", "--jobs", "1"], "cannot read"),
])
def test_bad_input_is_one_stderr_line_and_exit_2(logs, tmp_path, capsys, argv, says):
    _, paths = logs
    (tmp_path / "out.csv").write_text("keep me\n")  # an existing file a refused command must not touch
    fill = {"{af}": str(M300), "{log}": str(paths[0]), "{missing}": str(tmp_path / "missing.bin"),
            "{out}.csv": str(tmp_path / "out.csv")}
    try:
        code = main([fill.get(a, a) for a in argv])
    except SystemExit as stop:  # argparse's refusals exit from inside the parser
        code = stop.code
    assert code == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and says in err[0] and "Traceback" not in err[0], err
    assert (tmp_path / "out.csv").read_text() == "keep me\n"
