"""Generated fuzz of the command line (issue #16's goal): 1,050 seeded cases mutated from good airframe
files, CSV logs and ULogs, and option values across and beyond their ranges (tests/fuzzgen.py), each
run in-process through ``dobwind.cli.app.main`` under a time limit.

Every case must end with an expected exit status, never a traceback or a hang; a failure prints its
error as the last stderr line (after any warnings), a success only warnings. Outputs are judged too:
``-o`` names an existing file holding a sentinel, which a failed run must leave as it was and a
successful one must replace with a complete output; nothing else may be left in the folder.
"""
from __future__ import annotations

import json
import random
import signal
import traceback
import warnings
from pathlib import Path

import pytest

from dobwind.cli.app import main
from dobwind.io.logs import ESTIMATE_COLUMNS
from dobwind.model.airframe import load_airframe
from tests import fuzzgen
from tests.helpers import M300

SEED = 16
COUNTS = {"airframe": 420, "log": 300, "ulog": 180, "option": 150}
TIME_LIMIT_S = 30  # per case; the slowest legitimate case (a short fit) takes about 2 s
SENTINEL = b"an earlier result that a failed run must leave alone\n"
OUT_NAMES = {"estimates": "out.csv", "log": "out.csv", "toml": "out.toml", "dir": "out", None: "out.csv"}


class ModelMemo:
    """build_step and the reference's rolled step, computed once per airframe in this module (issue #34).

    Every log and ULog case replays the same good airframe, and each built its step (about 20 ms) and
    rolled it (about 25 ms) again: most of a 60 ms case, none of it the case's input. Both are pure
    functions of the airframe, so they are kept, keyed by the airframe's repr (every field, -0.0 apart from
    0.0, as the build sees them); the mutated input (the log, the airframe's bytes, the options) is still
    read, checked and stepped in full by each case. The StepModel and the CasADi Functions are not changed
    by their users (a Runner keeps its own state)."""

    def __init__(self, build, roll):
        self.build, self.roll, self.models, self.rolled, self.computed = build, roll, {}, {}, 0

    def build_step(self, af):
        key = repr(af)
        if key not in self.models:
            self.computed += 1
            self.models[key] = self.build(af)
        return self.models[key]

    def rolled_reference(self, model):
        # keyed by the model object; the models dict keeps it alive, so its id is never reused
        if id(model) not in self.rolled:
            self.rolled[id(model)] = (model, self.roll(model))
        return self.rolled[id(model)][1]


@pytest.fixture(scope="module", autouse=True)
def shared_models():
    from dobwind.model import step
    from dobwind.replay import backends, replay

    memo = ModelMemo(step.build_step, backends.rolled_reference)
    with pytest.MonkeyPatch.context() as patch:
        for module in (step, replay):
            patch.setattr(module, "build_step", memo.build_step)
        patch.setattr(backends, "rolled_reference", memo.rolled_reference)
        yield memo


@pytest.fixture(scope="module", autouse=True)
def shared_parser():
    """One parser (app.build_parser) for the module's 1,050 cases instead of one per case: building it
    (twelve subcommands, argparse's gettext and terminal-size lookups for each argument) takes 2.6-3.9 ms,
    about a tenth of a case. Every case still parses its own argv with it. argparse never changes a parser while
    parsing (defaults and values go to the namespace, "append" copies its default), and the teardown
    checks that: every subcommand's help reads as a freshly built parser's."""
    from dobwind.cli import app

    def helps(parser) -> dict[str, str]:
        sub = next(a for a in parser._actions if a.dest == "command")
        return {name: p.format_help() for name, p in sub.choices.items()} | {"": parser.format_help()}

    parser = app.build_parser()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(app, "build_parser", lambda: parser)
        yield parser
    assert helps(parser) == helps(app.build_parser())


class Hang(BaseException):
    """Raised by the timer: a BaseException, so that no `except Exception` in the code swallows it."""


@pytest.fixture(scope="module")
def good_files(tmp_path_factory) -> dict[str, bytes]:
    from tests.test_ulog import _flight, _ulog

    folder = tmp_path_factory.mktemp("fuzz-good")
    log = folder / "log.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "50", "--seed", "4", "-o", str(log)]) == 0
    lines = log.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    _, cols = _flight(rate=20.0)
    return {"af": M300.read_bytes(), "log": ("\n".join(lines[:header + 401]) + "\n").encode(),
            "ulog": _ulog(folder / "good.ulg", cols).read_bytes()}


@pytest.fixture(scope="module")
def cases(good_files) -> dict[str, list[fuzzgen.FuzzCase]]:
    rng = {kind: random.Random(f"{SEED}-{kind}") for kind in COUNTS}
    return {
        "airframe": fuzzgen.airframe_cases(rng["airframe"], COUNTS["airframe"], good_files["af"].decode()),
        "log": fuzzgen.log_cases(rng["log"], COUNTS["log"], good_files["log"].decode()),
        "ulog": fuzzgen.ulog_cases(rng["ulog"], COUNTS["ulog"], good_files["ulog"]),
        "option": fuzzgen.option_cases(rng["option"], COUNTS["option"]),
    }


def _run(argv: list[str]) -> int:
    def expire(signo, frame):
        raise Hang()

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, TIME_LIMIT_S)
    try:
        return main(argv)
    except SystemExit as exc:  # argparse, while parsing
        return exc.code if isinstance(exc.code, int) else 2
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _run_recording_warnings(argv: list[str]) -> tuple[int, list[str]]:
    """The exit status and every warning raised (a numpy or scipy warning reaches a user's stderr)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = _run(argv)
    return code, [f"{w.category.__name__} at {w.filename}:{w.lineno}: {w.message}" for w in caught]


def _complete(kind: str, out: Path) -> str | None:
    """Why the output of a successful run is not a complete output of its kind, or None."""
    if kind == "dir":
        names = {p.name for p in out.iterdir()}
        return None if any(n.endswith("_wind.c") for n in names) and any(n.endswith("_wind.h") for n in names) \
            else f"generated folder holds {sorted(names)}"
    data = out.read_bytes()
    if data == SENTINEL:
        return "the output was not written"
    if kind == "toml":
        load_airframe(out)  # raises on a partial file
        return None
    lines = [line for line in data.decode().splitlines() if not line.startswith("#")]
    if kind == "estimates" and lines[0].split(",") != list(ESTIMATE_COLUMNS):
        return f"header {lines[0]!r}"
    width = len(lines[0].split(","))
    for number, line in enumerate(lines[1:], start=2):
        cells = line.split(",")
        if len(cells) != width:
            return f"row {number} has {len(cells)} cells for {width} columns"
        [float(c) for c in cells]
    return None if len(lines) > 1 else "no data rows"


@pytest.mark.parametrize("kind,index", [(k, i) for k, n in COUNTS.items() for i in range(n)],
                         ids=[f"{k}-{i:04d}" for k, n in COUNTS.items() for i in range(n)])
def test_a_generated_case_ends_cleanly_within_its_time_limit(kind, index, cases, good_files, tmp_path, capsys):
    case = cases[kind][index]
    paths = {}
    for name, suffix in (("af", ".toml"), ("log", ".csv"), ("ulog", ".ulg")):
        paths[name] = tmp_path / f"input_{name}{suffix}"
        paths[name].write_bytes(case.files.get(name, good_files[name]))
    out = tmp_path / OUT_NAMES[case.output]
    if case.output != "dir":
        out.write_bytes(SENTINEL)
    argv = [a.format(**paths, out=out) for a in case.argv]
    try:
        code, raised = _run_recording_warnings(argv)
    except Hang:
        pytest.fail(f"{case.id}: no result within {TIME_LIMIT_S} s for {argv}")
    except Exception:  # noqa: BLE001 - the finding this test exists for
        pytest.fail(f"{case.id}: traceback for {argv}:\n{traceback.format_exc()}")
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert code in case.exit_codes, f"{case.id}: exit {code} for {argv}; stderr {captured.err[-500:]!r}"
    assert "Traceback" not in captured.err, f"{case.id}: {captured.err[-2000:]}"
    assert not raised, f"{case.id}: warnings for {argv}: {raised}"
    warnings = lines if code == 0 else lines[:-1]
    assert all(": warning:" in line for line in warnings), f"{case.id}: stderr {captured.err[-1000:]!r}"
    if code != 0:
        assert lines and lines[-1].startswith("dobwind ") and len(lines[-1]) < 1000, f"{case.id}: stderr {captured.err!r}"
        assert not out.exists() if case.output == "dir" else out.read_bytes() == SENTINEL, f"{case.id}: output damaged"
    elif case.output is not None and "-o" in case.argv:
        problem = _complete(case.output, out)
        assert problem is None, f"{case.id}: incomplete output for {argv}: {problem}"
    if code == 0 and "--json" in argv:
        assert isinstance(json.loads(captured.out), dict), f"{case.id}: stdout is not one JSON object"
    expected = {p.name for p in paths.values()} | {out.name}
    if code == 0 and case.argv[0] == "fit":
        expected.add("out_fit.png")
    left = {p.name for p in tmp_path.iterdir()} - expected
    assert not left, f"{case.id}: left behind {sorted(left)}"


def test_the_generated_suite_is_large_and_reproducible(cases, good_files):
    assert sum(len(v) for v in cases.values()) >= 1000
    again = fuzzgen.log_cases(random.Random(f"{SEED}-log"), COUNTS["log"], good_files["log"].decode())
    assert again == cases["log"]
    assert len({c.files.get("af") for c in cases["airframe"]}) > 0.8 * COUNTS["airframe"]  # mostly distinct
