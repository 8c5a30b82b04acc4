"""Fuzz of the command line (issue #10): hundreds of bad invocations, each run in-process through
``dobwind.cli.app.main``.

Every case must end with exit status 2 (bad input; 1 only where a check ran and failed), exactly one
non-empty stderr line, no traceback and no output file. The cases are generated from a few valid
inputs by one deliberate fault each, so a case that unexpectedly succeeds is itself a finding.
"""
from __future__ import annotations

import copy
import itertools
import os
import re
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import pytest

from dobwind.cli.app import main
from dobwind.model.airframe_toml import dumps
from tests.helpers import M300, airframe_dict


@dataclass(frozen=True)
class Case:
    id: str
    argv: tuple[str, ...]          # "{af}", "{log}", "{out}" are filled in per run
    airframe: dict | str | None = None  # a document or raw TOML text for "{af}"
    log: Callable[[list[str]], list[str]] | None = None  # a change to the good CSV's lines for "{log}"
    exit_codes: tuple[int, ...] = (2,)


# --- options --------------------------------------------------------------------------------------
NUMBERS = ["-5", "0", "nan", "inf", "-inf", "1e-300", "1e300", "abc", "", "0x10", "1e6", "--"]
OPTION_SITES = [
    ("simulate --rate", ["simulate", "tunnel", "-o", "{out}", "--rate"]),
    ("simulate --hold", ["simulate", "tunnel", "-o", "{out}", "--hold"]),
    ("simulate --seed", ["simulate", "tunnel", "-o", "{out}", "--seed"]),
    ("verify --steps", ["verify", "{af}", "--steps"]),
    ("verify --seed", ["verify", "{af}", "--seed"]),
    ("replay --rate", ["replay", "{af}", "x.ulg", "-o", "{out}", "--rate"]),
    ("analyze --freq", ["analyze", "{af}", "--freq"]),
    ("analyze --bandwidth", ["analyze", "{af}", "--bandwidth"]),
]
# Values that are legal for some options (0 for a seed, 1e6 for nothing): skipped where they are fine.
LEGAL = {("simulate --seed", "0"), ("verify --seed", "0")}


def option_cases() -> list[Case]:
    cases = [Case(f"{site} {value!r}", (*argv, value)) for (site, argv), value in itertools.product(OPTION_SITES, NUMBERS)
             if (site, value) not in LEGAL]
    cases += [
        Case("no command", ()),
        Case("unknown command", ("fly",)),
        Case("unknown option", ("check", "{af}", "--fast")),
        Case("missing airframe", ("check",)),
        Case("missing output", ("simulate", "tunnel")),
        Case("unknown scenario", ("simulate", "hurricane", "-o", "{out}")),
        Case("precision choice", ("generate", "{af}", "-o", "{out}", "--precision", "half")),
        Case("backend choice", ("replay", "{af}", "{log}", "--backend", "fortran")),
        Case("rate on a csv", ("replay", "{af}", "{log}", "-o", "{out}", "--rate", "50")),
        Case("airframe missing file", ("check", "/nonexistent/af.toml")),
        Case("airframe is a folder", ("check", "/")),
        Case("log missing file", ("replay", "{af}", "/nonexistent/log.csv", "-o", "{out}")),
        Case("ulog missing file", ("replay", "{af}", "/nonexistent/log.ulg", "-o", "{out}")),
        Case("fit missing log", ("fit", "{af}", "/nonexistent/log.csv", "-o", "{out}")),
        Case("simulate bad airframe path", ("simulate", "tunnel", "--airframe", "/nonexistent.toml", "-o", "{out}")),
    ]
    return cases


# --- airframe files -------------------------------------------------------------------------------
def _paths(doc: dict, prefix: str = "") -> list[str]:
    out = []
    for key, value in doc.items():
        out.append(prefix + key)
        if isinstance(value, dict):
            out += _paths(value, prefix + key + ".")
    return out


def _get_parent(doc: dict, path: str) -> tuple[dict, str]:
    *parents, last = path.split(".")
    for p in parents:
        doc = doc[p]
    return doc, last


def _changed(path: str, change: Callable[[dict, str], None]) -> dict:
    doc = copy.deepcopy(airframe_dict())
    parent, key = _get_parent(doc, path)
    change(parent, key)
    return doc


def _typo(parent: dict, key: str) -> None:
    parent[key + key[-1]] = parent.pop(key)


# Each is wrong for every leaf of the test airframe: a string where a number goes (or a number where a
# string goes), a boolean, a table, a negative number (all numeric keys are positive), an empty list.
WRONG_VALUES: list[Any] = ["text", True, {"a": 1}, -1.0, [], [1.0, "x"]]
RAW_VALUES = ["nan", "inf", "-inf", "0", "-0.0", "1e999", "9" * 400, '"8"', "[]"]


OPTIONAL_KEYS = {"thrust.scale", "observer.force_offset", "limits", "limits.max_dt", "limits.max_tilt_deg"}


def airframe_cases() -> list[Case]:
    base = airframe_dict()
    cases = []
    for path in _paths(base):
        cases.append(Case(f"airframe typo {path}", ("check", "{af}"), _changed(path, _typo)))
        if path not in OPTIONAL_KEYS:
            cases.append(Case(f"airframe missing {path}", ("check", "{af}"), _changed(path, lambda p, k: p.pop(k))))
    leaves = [p for p in _paths(base) if not isinstance(_get_parent(base, p)[0][_get_parent(base, p)[1]], dict)]
    for path in leaves:
        current = _get_parent(base, path)[0][_get_parent(base, path)[1]]
        for value in WRONG_VALUES:
            if isinstance(current, str) and value == "text":
                value = 3.0
            doc = _changed(path, lambda p, k, v=value: p.__setitem__(k, v))
            cases.append(Case(f"airframe {path} = {value!r}", ("check", "{af}"), doc))
    text = dumps(base)
    for key in ("mass", "sample_time", "max_dt", "max_rpm", "max_tilt_deg"):
        for value in RAW_VALUES:
            changed = re.sub(rf"^{key} = .*$", f"{key} = {value}", text, count=1, flags=re.M)
            assert changed != text, key
            cases.append(Case(f"airframe raw {key} = {value[:12]}", ("check", "{af}"), changed))
    raw = {
        "empty": "", "binary": "\x00\x01", "syntax": "name = \n", "array top": "[[name]]\n",
        "deep nesting": "x = " + "[" * 1000 + "]" * 1000 + "\n", "huge int": f"mass = {'9' * 400}\n",
    }
    cases += [Case(f"airframe text {k}", ("check", "{af}"), v) for k, v in raw.items()]
    # The same faults through the other commands that read an airframe, with an output named.
    for command in (("generate", "{af}", "-o", "{out}"), ("analyze", "{af}", "-o", "{out}"),
                    ("simulate", "tunnel", "--airframe", "{af}", "-o", "{out}"), ("verify", "{af}")):
        cases.append(Case(f"{command[0]} typo mass", command, _changed("mass", _typo)))
        cases.append(Case(f"{command[0]} mass text", command, _changed("mass", lambda p, k: p.__setitem__(k, "8"))))
    return cases


# --- CSV logs ---------------------------------------------------------------------------------------
def _header_index(lines: list[str]) -> int:
    return next(i for i, line in enumerate(lines) if not line.startswith("#"))


def _set_cell(column: str, row: int, value: str) -> Callable[[list[str]], list[str]]:
    def change(lines: list[str]) -> list[str]:
        h = _header_index(lines)
        c = lines[h].split(",").index(column)
        cells = lines[h + 1 + row].split(",")
        cells[c] = value
        return lines[:h + 1 + row] + [",".join(cells)] + lines[h + 2 + row:]
    return change


def _drop_column(column: str) -> Callable[[list[str]], list[str]]:
    def change(lines: list[str]) -> list[str]:
        h = _header_index(lines)
        c = lines[h].split(",").index(column)
        return lines[:h] + [",".join(x for j, x in enumerate(line.split(",")) if j != c) for line in lines[h:]]
    return change


def log_cases() -> list[Case]:
    replay = ("replay", "{af}", "{log}", "-o", "{out}")
    # An empty cell is a missing value (the step rejects that sample), so it is not a fault here, and
    # yaw_ref is optional; a missing required column and text in a number are.
    columns = ["t", "vel_n", "vel_d", "acc_e", "q_w", "q_z", "rpm_1", "rpm_4"]
    changes: dict[str, Callable[[list[str]], list[str]]] = {}
    for column in columns:
        changes[f"missing column {column}"] = _drop_column(column)
        changes[f"text in {column}"] = _set_cell(column, 10, "fast")
        changes[f"hex in {column}"] = _set_cell(column, 11, "0x1p3")
    changes["text in yaw_ref"] = _set_cell("yaw_ref", 10, "north")
    changes.update({
        "nan time": _set_cell("t", 20, "nan"),
        "inf time": _set_cell("t", 20, "inf"),
        "time goes back": _set_cell("t", 20, "0.1"),
        "time repeats": lambda ls: ls[:_header_index(ls) + 6] + [ls[_header_index(ls) + 5]] + ls[_header_index(ls) + 6:],
        "blank segment": _set_cell("segment", 10, ""),
        "inf segment": _set_cell("segment", 10, "inf"),
        "text segment": _set_cell("segment", 10, "a"),
        "BOM then garbage header": lambda ls: ["\ufeff" + "a;b;c"] + ls[_header_index(ls) + 1:],
        "short row": lambda ls: ls[:_header_index(ls) + 3] + [ls[_header_index(ls) + 3].rsplit(",", 1)[0]] + ls[_header_index(ls) + 4:],
        "long row": lambda ls: ls[:_header_index(ls) + 3] + [ls[_header_index(ls) + 3] + ",1"] + ls[_header_index(ls) + 4:],
        "header only": lambda ls: ls[:_header_index(ls) + 1],
        "empty file": lambda ls: [],
        "empty t": _set_cell("t", 10, ""),
        "nan segment": _set_cell("segment", 10, "nan"),
        "fractional segment": _set_cell("segment", 10, "1.5"),
        "comments only": lambda ls: ["# nothing"],
        "duplicate column": lambda ls: ls[:_header_index(ls)] + [ls[_header_index(ls)].replace("vel_e", "vel_n")] + ls[_header_index(ls) + 1:],
        "semicolons": lambda ls: [line.replace(",", ";") for line in ls],
        "binary garbage": lambda ls: ["\x00\x01\x02"] + ls,
    })
    cases = [Case(f"log {name}", replay, log=change) for name, change in changes.items()]
    cases += [Case(f"fit log {name}", ("fit", "{af}", "{log}", "-o", "{out}"), log=change)
              for name, change in list(changes.items())[::4]]
    return cases


def special_file_cases() -> list[Case]:
    """Issue #37: a FIFO hung every command forever, /dev/zero ran it out of memory; both are refused by
    type before anything opens them, in every argument that names an input."""
    cases = []
    for special in ("{fifo}", "/dev/zero"):
        for command in (("check", special), ("generate", special, "-o", "{out}"), ("verify", special),
                        ("analyze", special), ("simulate", "tunnel", "--airframe", special, "-o", "{out}"),
                        ("simulate", "tunnel", "--vehicle", special, "-o", "{out}"),
                        ("replay", "{af}", special, "-o", "{out}"), ("fit", "{af}", special, "-o", "{out}"),
                        ("report", "{af}", special, "-o", "{out}.html")):
            cases.append(Case(f"special {command[0]} {special.strip('{}')} {command.index(special)}", command))
    return cases


ALL_CASES = option_cases() + airframe_cases() + log_cases() + special_file_cases()


def test_there_are_enough_cases():
    assert len(ALL_CASES) >= 200, len(ALL_CASES)


@pytest.fixture(scope="module")
def good_log(tmp_path_factory) -> list[str]:
    path = tmp_path_factory.mktemp("log") / "tunnel.csv"
    assert main(["simulate", "tunnel", "--hold", "6", "--rate", "50", "-o", str(path)]) == 0
    lines = path.read_text().splitlines()
    return lines[:_header_index(lines) + 301]  # 6 s is enough to exercise the readers


def _fill(case: Case, folder: Path, good_log: list[str]) -> tuple[list[str], Path]:
    af = folder / "af.toml"
    if case.airframe is None:
        af.write_bytes(M300.read_bytes())
    elif isinstance(case.airframe, str):
        af.write_text(case.airframe)
    else:
        af.write_text(dumps(case.airframe))
    log = folder / "log.csv"
    log.write_text("\n".join(case.log(list(good_log)) if case.log else good_log) + "\n")
    out = folder / "out"
    fifo = folder / "pipe"
    if "{fifo}" in case.argv:
        os.mkfifo(fifo)
    argv = [a.format(af=af, log=log, out=out, fifo=fifo) for a in case.argv]
    return argv, out


@pytest.mark.parametrize("case", ALL_CASES, ids=[c.id for c in ALL_CASES])
def test_a_bad_invocation_gets_one_line_and_exit_2(case, tmp_path, good_log, capsys):
    argv, out = _fill(case, tmp_path, good_log)
    before = set(tmp_path.iterdir())
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse, while parsing
        code = exc.code if isinstance(exc.code, int) else 2
    except Exception:  # noqa: BLE001 - the finding this test exists for
        pytest.fail(f"traceback for {argv}:\n{traceback.format_exc()}")
    err = capsys.readouterr().err
    assert code in case.exit_codes, f"exit {code} for {argv}; stderr {err!r}"
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].strip(), f"stderr for {argv}: {err!r}"
    assert not out.exists(), f"{out} was created"
    assert set(tmp_path.iterdir()) == before, "a file was left behind"
