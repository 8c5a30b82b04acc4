"""Output targets, disk-full, signals and stale temporaries, for every command that writes.

The disk-full runs set RLIMIT_FSIZE in the child (SIGXFSZ ignored, so a write past the limit fails
with EFBIG as on a full disk); the signal runs wait until a temporary of ours exists, i.e. the command
is writing, then signal it. Each asserts: the exit status, one stderr line, no traceback, the previous
output byte for byte, and no temporary left behind.
"""
from __future__ import annotations

import os
import resource
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from dobwind.io.atomic import TEMP_PREFIX
from dobwind.cli.app import main
from tests.helpers import M300, ROOT

LIMIT_BYTES = 20_000   # every command's largest output is bigger (CSV logs, PNGs, the C self-test)
OLD = "previous good output\n"


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> dict[str, str]:
    import matplotlib.font_manager  # noqa: F401  (builds matplotlib's font cache before any size limit)

    folder = tmp_path_factory.mktemp("logs")
    paths = {}
    # The fit case's logs with 4 s holds (were 8 and 15): the fit still succeeds and writes, in about a
    # third of the time (3 s holds leave no scorable segment and fit refuses before writing)
    for name, seed, hold in (("sweep", 1, "4"), ("vertical", 2, "4"), ("tunnel", 3, "20")):
        path = folder / f"{name}.csv"
        args = ["simulate", name, "--seed", str(seed), "--rate", "25", "-o", str(path)]
        assert main(args + (["--hold", hold] if hold else [])) == 0
        paths[name] = str(path)
    return paths


def _limit_file_size() -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (LIMIT_BYTES, LIMIT_BYTES))


def _start(args: list[str], cwd: Path, full_disk: bool = False) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "dobwind.cli", *args], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, preexec_fn=_limit_file_size if full_disk else None,
                            env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})


def _temporaries(*folders: Path, probes: bool = True) -> list[Path]:
    return [p for folder in folders if folder.exists() for p in folder.rglob(f"{TEMP_PREFIX}*")
            if probes or not p.name.endswith("-probe")]


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _one_line(err: str) -> str:
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    return err


# Each writing command, with its previous good output: (arguments, files it replaces, folder it writes in).
def _cases(logs: dict[str, str], tmp: Path) -> dict[str, tuple[list[str], list[Path], Path]]:
    gen = tmp / "gen"
    demo = tmp / "demo"
    return {
        "simulate": (["simulate", "tunnel", "--hold", "20", "--rate", "25", "-o", str(tmp / "sim.csv")],
                     [tmp / "sim.csv"], tmp),
        "replay": (["replay", str(M300), logs["tunnel"], "-o", str(tmp / "est.csv"), "--plot", str(tmp / "est.png")],
                   [tmp / "est.csv", tmp / "est.png"], tmp),
        "fit": (["fit", str(M300), logs["sweep"], logs["vertical"], "-o", str(tmp / "fit.toml")],
                [tmp / "fit.toml", tmp / "fit_fit.png"], tmp),
        "analyze": (["analyze", str(M300), "-o", str(tmp / "plots")],
                    [tmp / "plots" / "bode.png", tmp / "plots" / "discretizations.png", tmp / "plots" / "ramp.png"], tmp),
        "generate": (["generate", str(M300), "-o", str(gen)],
                     [gen / n for n in ("m300_wind.h", "m300_wind.c", "m300_wind_selftest.c", "CMakeLists.txt")], tmp),
        "demo": (["demo", "-o", str(demo)], [demo / "fit.png", demo / "logs" / "sweep.csv"], tmp),
    }


def _previous_outputs(files: list[Path]) -> None:
    for path in files:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(OLD)


@pytest.mark.parametrize("command", ["simulate", "replay", "fit", "analyze", "generate", "demo"])
def test_a_full_disk_changes_nothing(command, logs, tmp_path):
    args, files, folder = _cases(logs, tmp_path)[command]
    _previous_outputs(files)
    before = _snapshot(folder)
    done = _start(args, tmp_path, full_disk=True)
    out, err = done.communicate(timeout=600)
    assert done.returncode == 2, err
    line = _one_line(err)
    assert "File too large" in line and "-o" in line and "nothing was changed" in line
    assert _snapshot(folder) == before
    assert _temporaries(folder) == []


SIGNAL_CASES = [("simulate", signal.SIGTERM), ("replay", signal.SIGINT),
                ("fit", signal.SIGTERM), ("analyze", signal.SIGINT), ("generate", signal.SIGTERM),
                ("demo", signal.SIGINT)]


# Generous limits: a loaded 2-core machine has been seen to take 100 s to reach fit's first write.
def _wait_for_temporary(proc: subprocess.Popen, folder: Path, timeout_s: float = 300.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not _temporaries(folder, probes=False):  # the target check's probe is not a write
        assert proc.poll() is None, "finished before it wrote anything: " + proc.stderr.read()
        assert time.monotonic() < deadline, "no temporary appeared"
        time.sleep(0.002)


@pytest.mark.parametrize("command,signo", SIGNAL_CASES, ids=[f"{c}-{s.name}" for c, s in SIGNAL_CASES])
def test_a_signal_mid_write_leaves_the_previous_output(command, signo, logs, tmp_path):
    args, files, folder = _cases(logs, tmp_path)[command]
    _previous_outputs(files)
    before = _snapshot(folder)
    proc = _start(args, tmp_path)
    _wait_for_temporary(proc, folder)
    # Frozen where it is (writing), signalled, resumed: the signal lands mid-write however fast the write.
    proc.send_signal(signal.SIGSTOP)
    proc.send_signal(signo)
    proc.send_signal(signal.SIGCONT)
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 128 + signo, err
    assert signal.Signals(signo).name in _one_line(err)
    assert _snapshot(folder) == before
    assert _temporaries(folder) == []


def test_the_next_run_removes_what_a_killed_run_left_and_nothing_else(logs, tmp_path):
    args, _, folder = _cases(logs, tmp_path)["simulate"]
    mine = tmp_path / ".sim.csv.swp"            # someone else's dotfile: never touched
    mine.write_text("keep")
    proc = _start(args, tmp_path)
    _wait_for_temporary(proc, folder)
    proc.kill()
    proc.wait()
    left = _temporaries(folder)
    assert left, "SIGKILL leaves its temporary (nothing can run on SIGKILL)"
    time.sleep(0.05)
    # A new process: temporaries younger than the running process (here pytest's) are never removed.
    again = _start(["simulate", "tunnel", "--hold", "2", "--rate", "25", "-o", str(tmp_path / "sim.csv")], tmp_path)
    assert again.wait(timeout=300) == 0
    assert _temporaries(folder) == [] and mine.read_text() == "keep"


def test_a_live_runs_temporary_is_not_removed(tmp_path):
    from dobwind.io.atomic import remove_stale

    sleeper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        busy = tmp_path / f"{TEMP_PREFIX}{sleeper.pid}-abc-out.csv"
        busy.write_text("being written")
        os.utime(busy, (0, 0))  # old, but its run is alive
        dead = tmp_path / f"{TEMP_PREFIX}999999999-abc-out.csv"
        dead.write_text("left by a killed run")
        os.utime(dead, (0, 0))
        fresh = tmp_path / f"{TEMP_PREFIX}999999998-abc-out.csv"
        fresh.write_text("newer than this process")
        assert remove_stale(tmp_path) == [dead]
        assert busy.exists() and fresh.exists()
    finally:
        sleeper.kill()
        sleeper.wait()


# --- targets refused before any work ---------------------------------------------------------------

def _unwritable(tmp_path: Path) -> Path:
    if os.geteuid() == 0:  # root writes through permissions: /proc refuses new files even to root
        return Path("/proc")
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    return locked


def _bad_file_targets(tmp_path: Path, log: str) -> dict[str, tuple[str, str]]:
    (tmp_path / "a_folder").mkdir()
    (tmp_path / "a_file").write_text("x")
    return {"device": ("/dev/null", "not a regular file"), "empty": ("", "empty path"),
            "folder": (str(tmp_path / "a_folder"), "is a folder"),
            "under a file": (str(tmp_path / "a_file" / "out"), "is a file, not a folder"),
            "the input": (log, "is the input file"),
            "unwritable": (str(_unwritable(tmp_path) / "out"), "cannot write in")}


@pytest.mark.parametrize("case", ["device", "empty", "folder", "under a file", "the input", "unwritable"])
def test_file_targets_are_refused_before_any_work(case, logs, tmp_path, capsys):
    path, reason = _bad_file_targets(tmp_path, logs["tunnel"])[case]
    missing = str(tmp_path / "no_such_log.csv")  # the target is refused before the logs are read
    commands = [["replay", str(M300), missing, "-o", path], ["replay", str(M300), missing, "--plot", path],
                ["fit", str(M300), missing, "-o", path], ["fit", str(M300), missing, "-o", str(tmp_path / "f.toml"),
                                                         "--plot", path],
                ["simulate", "tunnel", "--airframe", str(tmp_path / "no.toml"), "-o", path]]
    if case == "the input":
        commands = [["replay", str(M300), path, "-o", path], ["fit", str(M300), path, "-o", path],
                    ["fit", str(M300), path, "-o", str(tmp_path / "f.toml"), "--plot", path]]
    for args in commands:
        capsys.readouterr()
        assert main(args) == 2, args
        err = _one_line(capsys.readouterr().err)
        option = args[-2]
        assert f"{option} " in err and reason in err, (args, err)
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    assert list(tmp_path.glob("f*")) == [] and _temporaries(tmp_path) == []


@pytest.mark.parametrize("command", ["generate", "analyze", "demo"])
def test_folder_targets_are_refused_before_any_work(command, tmp_path, capsys):
    (tmp_path / "a_file").write_text("x")
    airframe = [str(tmp_path / "no.toml")] if command != "demo" else []
    for path, reason in ((str(tmp_path / "a_file"), "is not a folder"), ("", "empty path"),
                         (str(tmp_path / "a_file" / "sub"), "is a file, not a folder"),
                         (str(_unwritable(tmp_path) / "sub"), "cannot write in")):
        capsys.readouterr()
        assert main([command, *airframe, "-o", path]) == 2, path
        err = _one_line(capsys.readouterr().err)
        assert "-o " in err and reason in err, err


@pytest.mark.parametrize("command", ["generate", "demo"])
def test_a_replaced_folder_must_hold_only_what_the_command_writes(command, tmp_path, capsys):
    """`-o .` must never delete the user's other files."""
    (tmp_path / "notes.txt").write_text("mine")
    args = [command, str(M300), "-o", str(tmp_path)] if command == "generate" else [command, "-o", str(tmp_path)]
    assert main(args) == 2
    assert "notes.txt" in _one_line(capsys.readouterr().err)
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]


def test_two_options_naming_one_file_are_refused(logs, tmp_path, capsys):
    same = str(tmp_path / "x.png")   # a name --plot takes: refused only for being given twice
    assert main(["replay", str(M300), logs["tunnel"], "-o", same, "--plot", same]) == 2
    assert "--plot" in _one_line(capsys.readouterr().err)
    assert not Path(same).exists()


def test_generate_replaces_the_folder_as_a_whole(tmp_path):
    """A folder of another airframe's files is replaced, not merged: no stale .h beside the new one."""
    out = tmp_path / "gen"
    out.mkdir()
    (out / "other_wind.h").write_text("old")
    assert main(["generate", str(M300), "-o", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["CMakeLists.txt", "m300_wind.c", "m300_wind.h",
                                                      "m300_wind_selftest.c"]
    assert (out / "m300_wind.h").read_text() == (ROOT / "generated_c" / "m300" / "m300_wind.h").read_text()


@pytest.mark.parametrize("command", ["replay", "fit", "profile"])
def test_a_plot_not_named_png_is_refused_before_any_work(command, logs, tmp_path, capsys):
    """--plot p.pdf used to receive PNG bytes: the figure is PNG only, so the name must say .png; the
    refusal names the option and the extension and comes before the log is read (it does not exist)."""
    missing = str(tmp_path / "no_such_log.csv")
    out = {"replay": [], "fit": ["-o", str(tmp_path / "f.toml")], "profile": ["-o", str(tmp_path / "p.csv")]}[command]
    for name, said in (("p.pdf", "'.pdf'"), ("p", "no extension"), ("p.png.txt", "'.txt'")):
        capsys.readouterr()
        assert main([command, str(M300), missing, *out, "--plot", str(tmp_path / name)]) == 2
        err = _one_line(capsys.readouterr().err)
        assert "--plot " in err and said in err and "PNG only" in err, err
    assert list(tmp_path.iterdir()) == [] or all(p.name == "unwritable" for p in tmp_path.iterdir())


@pytest.mark.parametrize("name", ["x.ulg", "x.BIN", "x.mcap", "x.db3", "x.csv"])
@pytest.mark.parametrize("command", ["init", "fit"])
def test_an_airframe_named_as_a_flight_log_is_refused_before_any_work(command, name, tmp_path, capsys):
    """`init LOG -o x.ulg` wrote the TOML under a log's name, which the next command then read as a log:
    the airframe's name may be anything but a flight log's (any case); refused before the log is read."""
    missing = str(tmp_path / "no_such_log.ulg")
    args = {"init": ["init", missing, "--mass", "2"], "fit": ["fit", str(M300), missing, "--wind", "3@90"]}[command]
    assert main([*args, "-o", str(tmp_path / name)]) == 2
    err = _one_line(capsys.readouterr().err)
    assert f"-o {tmp_path / name}" in err and "names a flight log" in err and "name it .toml" in err, err
    assert list(tmp_path.iterdir()) == []


def test_an_airframe_may_still_be_named_as_the_user_likes(tmp_path):
    from dobwind.io.outputs import AIRFRAME, Target, check_target

    for name in ("x.toml", "x", "x.txt", "x.ulg.toml"):
        check_target(Target("-o", str(tmp_path / name), refused=AIRFRAME))


@pytest.mark.parametrize("argv", [["simulate", "still-air", "--hold", "0.2", "-o"],
                                  ["replay", str(M300), "{log}", "-o"],
                                  ["replay", str(M300), "{log}", "--px4-wind"]])
def test_a_csv_output_named_as_an_airframe_is_refused_before_any_work(argv, tmp_path, capsys):
    """`simulate sweep -o fit.toml` (meant: --airframe fit.toml) replaced a fitted airframe with the CSV log;
    a CSV output may not end in .toml (any case), and the file there is left as it was."""
    kept = tmp_path / "fit.TOML"
    kept.write_text(M300.read_text())
    missing = str(tmp_path / "no_such_log.ulg")   # refused before the log is read
    assert main([a.format(log=missing) for a in argv] + [str(kept)]) == 2
    err = _one_line(capsys.readouterr().err)
    assert f"{argv[-1]} {kept}" in err and "names an airframe" in err and "name it .csv" in err, err
    assert kept.read_text() == M300.read_text() and sorted(p.name for p in tmp_path.iterdir()) == ["fit.TOML"]
