"""Help that stands on its own (issue #15): every argument of every subcommand is described, and every
option states its default; `simulate` follows the airframe's rate; `analyze --bandwidth -o` writes."""
from __future__ import annotations

import argparse
import re

import pytest

from dobwind.cli.app import build_parser, main
from dobwind.model.airframe import load_airframe
from tests.helpers import M300, airframe_dict

PARSER = build_parser()
SUBCOMMANDS = next(a for a in PARSER._actions if isinstance(a, argparse._SubParsersAction)).choices


def _help(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 0
    return capsys.readouterr().out


def _entries(text: str) -> dict[str, str]:
    """argparse's help body -> {first name of the argument: its description, lines joined}."""
    entries: dict[str, str] = {}
    name = None
    for line in text.splitlines():
        head = re.match(r"^  (\S.*?)(?:\s{2,}(.*))?$", line)
        if head and not line.startswith("   "):
            name = head.group(1).split(",")[0].split()[0]
            entries[name] = head.group(2) or ""
        elif name and line.startswith("      "):
            entries[name] = (entries[name] + " " + line.strip()).strip()
        elif not line.strip() or not line.startswith(" "):
            name = None
    return entries


@pytest.mark.parametrize("command", sorted(SUBCOMMANDS))
def test_every_argument_is_described_with_its_default(command, capsys):
    text = _help(capsys, [command, "--help"])
    entries = _entries(text)
    for action in SUBCOMMANDS[command]._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        name = action.option_strings[0] if action.option_strings else action.dest
        assert name in entries, f"{command}: {name} missing from --help"
        described = entries[name]
        assert len(described.split()) >= 3, f"{command} {name}: no description"
        if action.option_strings:  # positionals have no default; options state one, or that they are required
            assert re.search(r"default|required", described), f"{command} {name}: no default in {described!r}"
            assert "(default: )" not in described, f"{command} {name}: an empty default in {described!r}"


def test_version(capsys):
    assert re.fullmatch(r"dobwind \d+\.\d+\.\d+\S*\n", _help(capsys, ["--version"]))


def test_simulate_takes_the_airframes_rate(tmp_path, capsys):
    """The airframe says 0.01 s, the log must say 100 Hz: the time step of the rows, not a constant."""
    path = tmp_path / "fast.toml"
    path.write_text(make_airframe_text(sample_time=0.004))  # 250 Hz
    log = tmp_path / "t.csv"
    assert main(["simulate", "tunnel", "--airframe", str(path), "--hold", "0.5", "-o", str(log)]) == 0
    assert "at 250 Hz" in capsys.readouterr().out
    rows = [line for line in log.read_text().splitlines() if line and not line.startswith("#")]
    t = [float(r.split(",")[0]) for r in rows[1:200]]
    steps = sorted(b - a for a, b in zip(t, t[1:]))
    assert steps[len(steps) // 2] == pytest.approx(0.004, rel=0.05)
    assert main(["simulate", "tunnel", "--airframe", str(path), "--hold", "0.5", "--rate", "50", "-o", str(log)]) == 0
    assert "at 50 Hz" in capsys.readouterr().out


def make_airframe_text(sample_time: float) -> str:
    from dobwind.model.airframe_toml import dumps

    return dumps(airframe_dict(**{"observer.sample_time": sample_time, "limits.max_dt": 0.1,
                                  "filter.cutoffs": [0.3, 0.6, 1.0]}))


def test_analyze_bandwidth_writes_the_designed_airframe_and_analyses_it(tmp_path, capsys):
    new = tmp_path / "new.toml"
    assert main(["analyze", str(M300), "--bandwidth", "0.8", "-o", str(new), "--json"]) == 0
    report = __import__("json").loads(capsys.readouterr().out)
    written = load_airframe(new)
    gain = written.observer.gains[0]
    assert written.observer.gains == (gain, gain, gain) != load_airframe(M300).observer.gains
    assert report["design"]["gains_kg_per_s"][0] == pytest.approx(gain, rel=1e-12)
    # The analysis is of the new gains: its measured -3 dB bandwidth is the one asked for.
    assert report["observer"][0]["bandwidth_hz"] == pytest.approx(0.8, abs=1e-6)
    old = load_airframe(M300)
    same = __import__("dataclasses").replace(written, observer=old.observer, content_sha256=old.content_sha256)
    assert same == old  # nothing but the gains changed (and the file's hash with them)
