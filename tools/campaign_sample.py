"""A sample of issue #37's hostile-input campaign, rerun on demand: `python -m tools.campaign_sample`.

Each case runs `python -m dobwind.cli ...` in its own process (so that a hang is a timeout, not a stuck
test, and output printed below Python by a library is seen), then the case's outcome is classed:

- traceback: "Traceback" on stderr; hang: no exit within the time limit;
- multi-line error: a non-zero exit with more than one stderr line;
- stray temporary: a ``.dobwind-tmp*`` entry left in the output folder;
- damaged output: a failed run that changed a file that existed before it;
- absurd trusted wind: an estimate row with status 0 and |wind| > 50 m/s or NaN.

The classes of cases: special files as any input (a FIFO, /dev/zero, /dev/null, a folder), logs in absurd
units (rpm x60, velocity in cm/s, acceleration x100, a 0.5 s block of velocity or acceleration at an
absurd value), and edge-of-range airframes through `generate` (self-test) and `check`. Bit flips in logs
are tools/bitflip_sample.py, on the same runner. The counts go to stdout as one table; the exit status is
1 when any case is bad.
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import random
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
M300 = REPO / "airframes" / "m300.toml"
TIMEOUT_S = 120.0
MAX_WIND_MPS = 50.0
BAD_CLASSES = ("traceback", "hang", "multi-line error", "noisy success", "stray temporary", "damaged output",
               "absurd trusted wind")
NOISY_LINES = 5  # a successful run's own warnings fit in a few lines; thousands are a library's noise


@dataclass(frozen=True)
class Case:
    name: str
    argv: tuple[str, ...]
    estimate: str | None = None      # an estimate CSV the case writes, checked for absurd trusted rows
    guarded: str | None = None       # a file that exists before the case and must survive a failure


@dataclass(frozen=True)
class Outcome:
    case: str
    exit_code: int | None            # None: a hang
    problems: tuple[str, ...]


def cli(*args: str) -> tuple[str, ...]:
    return (sys.executable, "-m", "dobwind.cli", *args)


def run_case(case: Case, folder: Path) -> Outcome:
    """Runs one case in ``folder`` (its outputs' folder) and classes what it did."""
    before = Path(case.guarded).read_bytes() if case.guarded and Path(case.guarded).exists() else None
    try:
        done = subprocess.run(case.argv, capture_output=True, text=True, errors="replace", timeout=TIMEOUT_S,
                              cwd=folder, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return Outcome(case.name, None, ("hang",))
    problems = []
    if "Traceback" in done.stderr:
        problems.append("traceback")
    if done.returncode != 0 and len(done.stderr.strip().splitlines()) > 1:
        problems.append("multi-line error")
    if done.returncode == 0 and len(done.stderr.strip().splitlines()) > NOISY_LINES:
        problems.append("noisy success")
    if any(p.name.startswith(".dobwind-tmp") for p in folder.iterdir()):
        problems.append("stray temporary")
    if done.returncode != 0 and before is not None and Path(case.guarded).read_bytes() != before:
        problems.append("damaged output")
    if done.returncode == 0 and case.estimate and absurd_trusted_rows(Path(case.estimate)):
        problems.append("absurd trusted wind")
    return Outcome(case.name, done.returncode, tuple(problems))


def absurd_trusted_rows(path: Path) -> int:
    """Rows with status 0 whose wind is NaN or beyond MAX_WIND_MPS."""
    if not path.is_file():
        return 0
    with path.open(newline="") as handle:
        rows = csv.DictReader(line for line in handle if not line.startswith("#"))
        count = 0
        for row in rows:
            if int(float(row["status"])) != 0:
                continue
            wind = [float(row[k]) for k in ("wind_n", "wind_e", "wind_d")]
            count += not all(math.isfinite(w) for w in wind) or math.hypot(*wind) > MAX_WIND_MPS
    return count


# --- the cases ------------------------------------------------------------------------------------

def special_file_cases(folder: Path) -> list[Case]:
    """Every input position of every file-reading command, given a special file."""
    fifo = folder / "fifo"
    if not fifo.exists():
        os.mkfifo(fifo)
    (folder / "a_folder").mkdir(exist_ok=True)
    specials = [str(fifo), "/dev/zero", "/dev/null", str(folder / "a_folder")]
    log = str(folder / "good.csv")
    out = []
    for k, special in enumerate(specials):
        out += [Case(f"check {special}", cli("check", special)),
                Case(f"generate {special}", cli("generate", special, "-o", f"gen{k}")),
                Case(f"verify {special}", cli("verify", special)),
                Case(f"analyze {special}", cli("analyze", special)),
                Case(f"replay airframe {special}", cli("replay", special, log, "-o", f"e{k}.csv")),
                Case(f"replay log {special}", cli("replay", str(M300), special, "-o", f"f{k}.csv")),
                Case(f"simulate --airframe {special}", cli("simulate", "outdoor", "--airframe", special, "-o", f"s{k}.csv")),
                Case(f"inspect {special}", cli("inspect", special)),
                Case(f"fit log {special}", cli("fit", str(M300), special, "-o", f"fit{k}.toml"))]
    return out


# (column names, factor or a replacement value over a 0.5 s block, what it stands for)
UNIT_MUTATIONS = [
    (("rpm_1", "rpm_2", "rpm_3", "rpm_4"), 60.0, None, "rpm logged as rev/s x 60 twice"),
    (("rpm_1", "rpm_2", "rpm_3", "rpm_4"), 2.0, None, "rpm doubled"),
    (("vel_n", "vel_e", "vel_d"), 100.0, None, "velocity in cm/s"),
    (("acc_n", "acc_e", "acc_d"), 100.0, None, "acceleration x100"),
    (("acc_n", "acc_e", "acc_d"), None, -5.0, "acceleration -5 m/s^2 for 0.5 s"),
    (("acc_n", "acc_e", "acc_d"), None, -49.0, "acceleration -5 g for 0.5 s"),
    (("vel_n",), None, 1e6, "velocity 1e6 for 0.5 s"),
    (("acc_d",), None, 1e6, "acceleration 1e6 for 0.5 s"),
    (("rpm_1", "rpm_2", "rpm_3", "rpm_4"), None, 1e6, "rpm 1e6 for 0.5 s"),
]


def write_mutated_log(good: Path, path: Path, columns: tuple[str, ...], factor: float | None,
                      value: float | None) -> None:
    """``good`` with ``columns`` scaled by ``factor`` everywhere, or set to ``value`` over 0.5 s a third in."""
    lines = good.read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header].split(",")
    rows = [line.split(",") for line in lines[header + 1:]]
    t = [float(r[names.index("t")]) for r in rows]
    start = t[0] + (t[-1] - t[0]) / 3
    for row, when in zip(rows, t):
        for name in columns:
            k = names.index(name)
            if factor is not None:
                row[k] = repr(float(row[k]) * factor)
            elif start <= when < start + 0.5:
                row[k] = repr(value)
    path.write_text("\n".join(lines[:header + 1] + [",".join(r) for r in rows]) + "\n")


def failed_write_cases(folder: Path) -> list[Case]:
    """Runs that fail after their output file exists: the file must come out unchanged (issue #37, class 3)."""
    kept = folder / "kept.toml"
    kept.write_text(M300.read_text())
    estimate = folder / "kept.csv"
    estimate.write_text("t,status\n0,0\n")
    bandwidths = [" 5", "5 ", "\u0665", "nan", "1e9", "-1"]
    out = [Case(f"analyze --bandwidth {b!r} -o existing", cli("analyze", str(M300), "--bandwidth", b, "-o", str(kept)),
                guarded=str(kept)) for b in bandwidths]
    out.append(Case("replay of /dev/zero -o existing", cli("replay", str(M300), "/dev/zero", "-o", str(estimate)),
                    guarded=str(estimate)))
    out.append(Case("fit of a csv without wind -o existing", cli("fit", str(M300), str(folder / "good.csv"), "-o",
                                                                 str(kept), "--wind", "1e9@0"), guarded=str(kept)))
    return out


def absurd_unit_cases(folder: Path) -> list[Case]:
    good = folder / "good.csv"
    out = []
    for k, (columns, factor, value, what) in enumerate(UNIT_MUTATIONS):
        log = folder / f"units{k}.csv"
        write_mutated_log(good, log, columns, factor, value)
        estimate = folder / f"units{k}_est.csv"
        out.append(Case(f"replay, {what}", cli("replay", str(M300), str(log), "-o", str(estimate)), str(estimate)))
    return out


def edge_airframe_cases(folder: Path, rng: random.Random, count: int) -> list[Case]:
    """m300 with one number set to an extreme: generate (self-test) and check must not disagree, which the
    pair of cases shows as the same exit code (compared by the caller)."""
    text = M300.read_text()
    keys = [("mass = 8.0", "mass = {}"), ("max_tilt_deg = 60.0", "max_tilt_deg = {}"),
            ("cutoffs = [0.2, 0.35, 0.5]", "cutoffs = [{0}, {0}, {0}]"), ("gains = [50.0, 50.0, 50.0]", "gains = [{0}, {0}, {0}]"),
            ("max_rpm = 12000.0", "max_rpm = {}"), ("gravity = 9.80665", "gravity = {}"),
            ("force_offset = [0.0, 0.0, 0.0]", "force_offset = [{0}, 0.0, 0.0]"),
            ("coefficients = [0.90, 0.06, 0.16, 0.09, 0.07]", "coefficients = [{0}, 0.06, 0.16, 0.09, 0.07]")]
    values = [1e-30, 1e-3, 0.005, 1.0, 6.0, 89.999, 100.0, 1e4, 1e6, 1e30, -1.0]
    out = []
    for k in range(count):
        old, new = rng.choice(keys)
        path = folder / f"edge{k}.toml"
        path.write_text(text.replace(old, new.format(rng.choice(values))))
        out += [Case(f"generate edge{k}", cli("generate", str(path), "-o", f"edge{k}_c")),
                Case(f"check edge{k}", cli("check", str(path)))]
    return out


def good_log(folder: Path) -> Path:
    path = folder / "good.csv"
    subprocess.run(cli("simulate", "outdoor", "--hold", "2", "--rate", "100", "-o", str(path)), check=True,
                   capture_output=True, timeout=TIMEOUT_S)
    return path


def run_all(cases: list[Case], folder: Path) -> list[Outcome]:
    return [run_case(case, folder) for case in cases]


def disagreements(outcomes: list[Outcome]) -> list[str]:
    """Edge airframes where check and generate's exit codes differ (check accepted what generate refused)."""
    codes = {o.case: o.exit_code for o in outcomes}
    return [name for name in codes if name.startswith("generate edge")
            and codes[name] != codes.get(name.replace("generate", "check", 1))]


def table(outcomes: list[Outcome], extra: dict[str, int] | None = None) -> str:
    counts = {c: sum(c in o.problems for o in outcomes) for c in BAD_CLASSES}
    counts.update(extra or {})
    lines = [f"cases {len(outcomes)}"] + [f"{name:22s} {n}" for name, n in counts.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=37)
    parser.add_argument("--edges", type=int, default=20, help="edge-of-range airframes (two cases each)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="dobwind-campaign-") as work:
        folder = Path(work)
        good_log(folder)
        cases = (special_file_cases(folder) + failed_write_cases(folder) + absurd_unit_cases(folder)
                 + edge_airframe_cases(folder, random.Random(args.seed), args.edges))
        outcomes = run_all(cases, folder)
    bad = [o for o in outcomes if o.problems]
    split = disagreements(outcomes)
    print(table(outcomes, {"check != generate": len(split)}))
    for o in bad:
        print(f"BAD {o.case}: exit {o.exit_code}, {', '.join(o.problems)}")
    for name in split:
        print(f"BAD {name}: check and generate disagree")
    return 1 if bad or split else 0


if __name__ == "__main__":
    sys.exit(main())
