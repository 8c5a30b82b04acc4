"""Seeded generators of hostile command-line cases (issue #16's fuzz goal): airframe files, CSV logs and
ULog files mutated from good ones, and option values drawn across and beyond their ranges.

Each generator is a pure function of a ``random.Random``: the same seed gives the same cases, so a
failure is reproduced by its case id alone. The mutations are generic (bytes, lines, cells, TOML
values), not a list of the faults known today, so that they can find new ones.
"""
from __future__ import annotations

import copy
import json
import math
import random
import tomllib
from dataclasses import dataclass, field
from typing import Any

from dobwind.core import options as opt


@dataclass(frozen=True)
class FuzzCase:
    id: str
    argv: tuple[str, ...]                 # "{af}", "{log}", "{ulog}", "{out}" are filled in per run
    files: dict[str, bytes] = field(default_factory=dict)  # "af", "log", "ulog" -> content (else the good one)
    exit_codes: tuple[int, ...] = (0, 2)
    output: str | None = None             # "estimates" | "log" | "toml" | "dir": what {out} must hold on exit 0


# --- values ---------------------------------------------------------------------------------------
SPECIAL_TOKENS = ["nan", "-nan", "inf", "-inf", "", " ", "0", "-0", "1e", "e5", "0x1p3", "1_000", "--", "-",
                  "1e999", "-1e999", "9" * 400, "\u00e9", "\x00", "1,5", "true", "[]", "\"x\"", "+", ".", "1..2"]


def number_text(rng: random.Random) -> str:
    """A number anywhere from subnormal to overflow, or a special token."""
    roll = rng.random()
    if roll < 0.3:
        return rng.choice(SPECIAL_TOKENS)
    if roll < 0.5:
        return str(rng.choice([-1, 1]) * rng.randrange(0, 10 ** rng.randrange(1, 30)))
    return f"{rng.choice(['-', ''])}{rng.uniform(1, 10):.6g}e{rng.randrange(-330, 331)}"  # text: 1e330 is past float


def toml_value(rng: random.Random, current: Any) -> Any:
    """A replacement value for a TOML leaf: near the current one, extreme, or of the wrong type."""
    roll = rng.random()
    if isinstance(current, (int, float)) and not isinstance(current, bool) and roll < 0.35:
        return current * rng.choice([-1.0, 0.0, 1e-300, 1e-9, 0.5, 1.0001, 2.0, 1e9, 1e300])
    if isinstance(current, list) and current and roll < 0.5:
        items = list(current)
        action = rng.randrange(4)
        if action == 0:
            items.pop(rng.randrange(len(items)))
        elif action == 1:
            items.append(items[-1])
        elif action == 2:
            items = items * rng.choice([2, 20, 100])
        else:
            k = rng.randrange(len(items))
            items[k] = toml_value(rng, items[k])
        return items
    choices: list[Any] = [rng.choice([-1.0, 1.0]) * 10.0 ** rng.uniform(-320, 308), rng.randrange(-10**6, 10**6),
                          True, "text", "", {"x": 1.0}, [], [1.0, "x"], "m^" + number_text(rng), "a" * rng.choice([65, 300]),
                          "abs(m)^0.5*n^3", "fh^-1", "m\n"]
    return rng.choice(choices)


# --- airframe files -------------------------------------------------------------------------------
def _leaves(doc: dict, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    out = []
    for key, value in doc.items():
        out += _leaves(value, prefix + (key,)) if isinstance(value, dict) else [prefix + (key,)]
    return out


def _structured(rng: random.Random, doc: dict) -> str:
    doc = copy.deepcopy(doc)
    for _ in range(rng.choice([1, 1, 2, 3])):
        path = rng.choice(_leaves(doc))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        action = rng.random()
        if action < 0.15:
            parent.pop(path[-1])
        elif action < 0.25:
            parent[path[-1] + rng.choice(["s", "_x", ""]) + "z"] = parent[path[-1]]
        else:
            parent[path[-1]] = toml_value(rng, parent[path[-1]])
        if not _leaves(doc):
            break
    return _toml(doc)


def _toml_value(value: Any) -> str:
    """TOML text of any value the mutations make: inline tables in arrays and inf included."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string for these characters
    return repr(value)


def _toml(doc: dict, prefix: str = "") -> str:
    scalars = [f"{k} = {_toml_value(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    text = (f"[{prefix}]\n" if prefix and scalars else "") + "".join(line + "\n" for line in scalars)
    for key, value in doc.items():
        if isinstance(value, dict):
            text += _toml(value, f"{prefix}.{key}" if prefix else key)
    return text


TOML_PUNCTUATION = list('[]{}="\'#.,\n\\ ') + ["[[", "]]", "\"\"\"", "= =", "\t", "\r\n"]


def _textual(rng: random.Random, text: str) -> str:
    for _ in range(rng.choice([1, 1, 2, 4])):
        lines = text.split("\n")
        action = rng.randrange(6)
        k = rng.randrange(len(lines))
        if action == 0:
            lines.pop(k)
        elif action == 1:
            lines.insert(k, lines[rng.randrange(len(lines))])
        elif action == 2:
            j = rng.randrange(len(lines))
            lines[k], lines[j] = lines[j], lines[k]
        elif action == 3 and lines[k]:
            c = rng.randrange(len(lines[k]))
            lines[k] = lines[k][:c] + rng.choice(TOML_PUNCTUATION) + lines[k][c + 1:]
        elif action == 4:
            text = text[:rng.randrange(len(text) + 1)]
            continue
        else:
            lines[k] = lines[k].split("=")[0] + "= " + number_text(rng) if "=" in lines[k] else lines[k]
        text = "\n".join(lines)
    return text


def airframe_cases(rng: random.Random, count: int, base_text: str) -> list[FuzzCase]:
    base = tomllib.loads(base_text)
    cases = []
    for i in range(count):
        text = _structured(rng, base) if rng.random() < 0.6 else _textual(rng, base_text)
        if rng.random() < 0.1:
            argv, output = ("generate", "{af}", "-o", "{out}"), "dir"
        elif rng.random() < 0.05:
            argv, output = ("simulate", "still-air", "--airframe", "{af}", "--hold", "0.5", "--rate", "20",
                            "-o", "{out}"), "log"
        else:
            argv, output = ("check", "{af}"), None
        cases.append(FuzzCase(f"airframe-{i:04d}-{argv[0]}", argv, {"af": text.encode("utf-8", "surrogatepass")},
                              output=output))
    return cases


# --- CSV logs -------------------------------------------------------------------------------------
def _mutate_csv(rng: random.Random, text: str) -> bytes:
    lines = text.split("\n")
    header = next(i for i, line in enumerate(lines) if line and not line.startswith("#"))
    data = bytearray()
    for _ in range(rng.choice([1, 1, 2, 3])):
        action = rng.randrange(9)
        k = rng.randrange(header, len(lines))
        if action <= 2 and lines[k]:  # a cell
            cells = lines[k].split(",")
            cells[rng.randrange(len(cells))] = number_text(rng)
            lines[k] = ",".join(cells)
        elif action == 3:
            lines.pop(k)
        elif action == 4:
            lines.insert(k, lines[rng.randrange(header, len(lines))])
        elif action == 5:
            lines.insert(k, rng.choice(["", "#", "# comment", ",,,", "\ufeff", "\r"]))
        elif action == 6:  # a column dropped or renamed in the header
            cells = lines[header].split(",")
            cells[rng.randrange(len(cells))] = rng.choice(["", "x", "t", "T", "vel_n "])
            lines[header] = ",".join(cells)
        elif action == 7:  # a row's separators
            lines[k] = lines[k].replace(",", rng.choice([";", "\t", ",,", " "]), rng.randrange(1, 4))
        else:
            lines = lines[:k]
    data += "\n".join(lines).encode()
    if rng.random() < 0.2:  # raw bytes: truncation mid-line, NUL, invalid UTF-8
        at = rng.randrange(len(data) + 1)
        data = data[:at] + (rng.choice([b"", b"\x00", b"\xff\xfe", b"\r", b"\xe9"]) if rng.random() < 0.7 else b"")
    return bytes(data)


def log_cases(rng: random.Random, count: int, good_log: str) -> list[FuzzCase]:
    cases = []
    for i in range(count):
        data = _mutate_csv(rng, good_log)
        if rng.random() < 0.04:
            argv, output, codes = ("fit", "{af}", "{log}", "-o", "{out}"), "toml", (0, 1, 2)
        elif rng.random() < 0.15:
            argv, output, codes = ("replay", "{af}", "{log}", "--json"), None, (0, 2)
        else:
            argv, output, codes = ("replay", "{af}", "{log}", "-o", "{out}"), "estimates", (0, 2)
        cases.append(FuzzCase(f"log-{i:04d}-{argv[0]}", argv, {"log": data}, codes, output))
    return cases


# --- ULogs ----------------------------------------------------------------------------------------
def _mutate_bytes(rng: random.Random, good: bytes) -> bytes:
    data = bytearray(good)
    action = rng.randrange(6)
    if action == 0:  # bit flips past the 16-byte file header (those are refused at once)
        for _ in range(rng.choice([1, 2, 6, 20])):
            k = rng.randrange(16, len(data))
            data[k] ^= 1 << rng.randrange(8)
    elif action == 1:
        data = data[:rng.randrange(len(data) + 1)]
    elif action == 2:
        k = rng.randrange(len(data))
        data[k:k] = rng.randbytes(rng.choice([1, 3, 64, 4096]))
    elif action == 3:
        k = rng.randrange(len(data))
        data[k:k + rng.choice([2, 8, 300])] = b"\x00" * rng.choice([2, 8, 300])
    elif action == 4:  # a message's 16-bit length field
        k = rng.randrange(16, len(data) - 2)
        data[k:k + 2] = rng.choice([b"\xff\xff", b"\x00\x00", b"\x01\x00"])
    else:
        data = data[:16] + rng.randbytes(rng.choice([10, 1000, 50_000]))
    return bytes(data)


def ulog_cases(rng: random.Random, count: int, good_ulog: bytes) -> list[FuzzCase]:
    cases = []
    for i in range(count):
        json = rng.random() < 0.3
        argv = ("replay", "{af}", "{ulog}", "--json") if json else ("replay", "{af}", "{ulog}", "-o", "{out}")
        cases.append(FuzzCase(f"ulog-{i:04d}", argv, {"ulog": _mutate_bytes(rng, good_ulog)},
                              output=None if json else "estimates"))
    return cases


# --- options --------------------------------------------------------------------------------------
def _bounded_value(rng: random.Random, bound: opt.Bound) -> tuple[str, bool]:
    """A value for an option and whether it is inside the option's range."""
    if rng.random() < 0.25:  # inside: the cheap end of the range, so a valid case stays quick
        value = bound.low if rng.random() < 0.5 else bound.low + (bound.high - bound.low) * 1e-6
        return (str(int(value)) if bound.integer else repr(value)), True
    text = number_text(rng)
    try:
        bound(text)
        return text, True
    except Exception:  # noqa: BLE001 - argparse's ArgumentTypeError: outside
        return text, False


def option_cases(rng: random.Random, count: int) -> list[FuzzCase]:
    # (site, argv before the options, [(option, bound)], whether a valid set is cheap enough to run)
    sites = [
        ("simulate", ("simulate", "still-air", "-o", "{out}"),
         [("--hold", opt.SIMULATE_HOLD), ("--rate", opt.SIMULATE_RATE), ("--seed", opt.SEED)], "log"),
        ("replay-ulog", ("replay", "{af}", "{ulog}", "-o", "{out}"), [("--rate", opt.ULOG_RATE)], "estimates"),
        ("verify", ("verify", "{af}"), [("--steps", opt.VERIFY_STEPS), ("--seed", opt.SEED)], None),
        ("analyze", ("analyze", "{af}"), [("--freq", opt.FREQUENCY), ("--bandwidth", opt.BANDWIDTH)], None),
        ("fit", ("fit", "{af}", "{log}", "-o", "{out}"),
         [("--max-error-share", opt.ERROR_SHARE), ("--error-floor", opt.ERROR_FLOOR),
          ("--max-direction-error", opt.DIRECTION_LIMIT)], None),
    ]
    cases = []
    while len(cases) < count:
        name, argv, options, output = rng.choice(sites)
        chosen = [(o, *_bounded_value(rng, b)) for o, b in options if rng.random() < 0.7]
        if not chosen:
            continue
        every_valid = all(valid for _, _, valid in chosen)
        if every_valid and output is None:
            continue  # a valid verify, analyze or fit runs for seconds: the fuzz wants the bad ones
        if every_valid and name == "simulate" and any(o == "--hold" and float(v) > 1 for o, v, _ in chosen):
            continue
        tail = tuple(x for o, v, _ in chosen for x in (o, v))
        if name == "simulate" and "--rate" not in tail:
            tail += ("--rate", "5")  # the scenario's default rate with a long default hold: keep it short
        if name == "simulate" and "--hold" not in tail:
            tail += ("--hold", "0.2")
        cases.append(FuzzCase(f"option-{len(cases):04d}-{name}", argv + tail,
                              exit_codes=(0, 2) if every_valid else (2,), output=output if every_valid else None))
    return cases
