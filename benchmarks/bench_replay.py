"""Replay's speed and memory on long logs (issue #13), against a bare ``csv.reader`` pass over the file.

Makes a 1 h and a 4 h sweep at 100 Hz with ``dobwind simulate`` (kept in the work folder between runs),
then runs each case as its own process, interleaved over the rounds so that the machine's load falls on
all cases alike, and reports median wall times and each case's peak resident memory (``wait4``).

    .venv/bin/python -m benchmarks.bench_replay [--rounds 3] [--work out/bench-replay] [--simulate]

``--before PYTHON`` also runs every replay case with another interpreter (a virtual environment of an
earlier checkout), interleaved with these, for before/after ratios from one run.
``--simulate`` also reports the peak memory of ``dobwind simulate`` writing the 1 h and the 4 h log (one
run each: memory, not time, is its goal). ``--fit`` also reports the peak memory and wall time of ``dobwind
fit`` on a 1 h and a 4 h sweep of the px4quad benchmark vehicle at 100 Hz (one run each), and ``--no-replay``
skips the replay cases (for ``--simulate`` or ``--fit`` alone).
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

AIRFRAME = Path(__file__).resolve().parents[1] / "airframes" / "m300.toml"
FIT_VEHICLE = Path(__file__).resolve().parents[1] / "benchmarks" / "vehicles" / "px4quad"
FIT_SEED = "11"
SWEEP_HOLDS = 324            # the sweep scenario's holds: --hold = duration / 324
GOAL_TIME_RATIO = 1.5
GOAL_PEAK_MB = 300.0
GOAL_4H_PEAK_RATIO = 1.3
_CSV_PASS = "import csv,sys\nwith open(sys.argv[1], newline='') as f:\n    for row in csv.reader(f): pass\n"


@dataclass(frozen=True)
class Case:
    label: str
    argv: list[str]


def _dobwind(*args: str, python: str = sys.executable) -> list[str]:
    # -P: the package comes from the interpreter's own install, never from the working folder
    return [python, "-P", "-m", "dobwind.cli", *args]


def _log(work: Path, hours: int) -> Path:
    path = work / f"sweep_{hours}h_100hz.csv"
    if not path.exists():
        hold = f"{hours * 3600 / SWEEP_HOLDS:.6f}"
        subprocess.run(_dobwind("simulate", "sweep", "--rate", "100", "--hold", hold, "-o", str(path)), check=True,
                       stdout=subprocess.DEVNULL)
    return path


def measure_process(argv: list[str]) -> tuple[float, float, float]:
    """(wall seconds, peak resident MB of the largest process in the tree, CPU seconds of the whole tree)."""
    start = time.perf_counter()
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(argv)} failed: {proc.stderr.read().decode()[-500:]}")
    proc.stderr.close()
    return wall, usage.ru_maxrss / 1024.0, usage.ru_utime + usage.ru_stime


def replay_cases(work: Path, log: Path, suffix: str, python: str = sys.executable, prefix: str = "") -> list[Case]:
    out = str(work / f"estimates_{'before_' if prefix else ''}{log.stem}.csv")
    replay = ("replay", str(AIRFRAME), str(log))
    return [
        Case(f"{prefix}replay python -o{suffix}", _dobwind(*replay, "-o", out, python=python)),
        Case(f"{prefix}replay c -o{suffix}", _dobwind(*replay, "--backend", "c", "-o", out, python=python)),
        Case(f"{prefix}replay c, no -o{suffix}", _dobwind(*replay, "--backend", "c", python=python)),
    ]


def cases(work: Path, log: Path, suffix: str, before: str | None = None) -> list[Case]:
    found = [Case(f"csv.reader pass{suffix}", [sys.executable, "-c", _CSV_PASS, str(log)]),
             *replay_cases(work, log, suffix)]
    return found + (replay_cases(work, log, suffix, before, "before: ") if before else [])


def run(rounds: int, work: Path, with_4h: bool, before: str | None = None) -> dict[str, tuple[float, float]]:
    work.mkdir(parents=True, exist_ok=True)
    all_cases = cases(work, _log(work, 1), " (1 h)", before)
    if with_4h:
        all_cases += [c for c in cases(work, _log(work, 4), " (4 h)", before) if "python" in c.label or "reader" in c.label]
    # Warms the compiled-library caches (the step's and the formatter's), as any second run finds them.
    for python in (sys.executable, *([before] if before else [])):
        warm = _dobwind("replay", str(AIRFRAME), str(_log(work, 1)), "--backend", "c", "-o", str(work / "warm.csv"),
                        python=python)
        subprocess.run(warm, check=True, stdout=subprocess.DEVNULL)
    times: dict[str, list[float]] = {c.label: [] for c in all_cases}
    peaks: dict[str, float] = {c.label: 0.0 for c in all_cases}
    for _ in range(rounds):
        for case in all_cases:
            wall, peak, _ = measure_process(case.argv)
            times[case.label].append(wall)
            peaks[case.label] = max(peaks[case.label], peak)
    return {label: (statistics.median(times[label]), peaks[label]) for label in times}


def simulate_peaks(work: Path) -> dict[str, float]:
    """Peak resident MB of `dobwind simulate` writing the 1 h and the 4 h sweep (into the work folder)."""
    peaks = {}
    for hours in (1, 4):
        hold = f"{hours * 3600 / SWEEP_HOLDS:.6f}"
        out = work / f"simulated_{hours}h.csv"
        peaks[f"{hours} h"] = measure_process(_dobwind("simulate", "sweep", "--rate", "100", "--hold", hold, "-o", str(out)))[1]
        out.unlink()
    return peaks


def simulate_report(peaks: dict[str, float]) -> str:
    ratio = peaks["4 h"] / peaks["1 h"]
    return (f"simulate peak MB: 1 h {peaks['1 h']:.0f}, 4 h {peaks['4 h']:.0f}; 4 h / 1 h {ratio:.2f} "
            f"(goal <= {GOAL_4H_PEAK_RATIO})")


def _fit_log(work: Path, hours: int) -> Path:
    """The px4quad sweep of ``hours`` at 100 Hz (its true vehicle, not the airframe's own drag)."""
    path = work / f"px4quad_sweep_{hours}h_100hz.csv"
    if not path.exists():
        hold = f"{hours * 3600 / SWEEP_HOLDS:.6f}"
        subprocess.run(_dobwind("simulate", "sweep", "--airframe", f"{FIT_VEHICLE}.airframe.toml", "--vehicle",
                                f"{FIT_VEHICLE}.vehicle.toml", "--seed", FIT_SEED, "--rate", "100", "--hold", hold,
                                "-o", str(path)), check=True, stdout=subprocess.DEVNULL)
    return path


def fit_peaks(work: Path) -> dict[str, tuple[float, float]]:
    """(wall s, peak resident MB) of `dobwind fit` on the 1 h and the 4 h px4quad sweep."""
    work.mkdir(parents=True, exist_ok=True)
    results = {}
    for hours in (1, 4):
        out = work / f"fit_{hours}h.toml"
        results[f"{hours} h"] = measure_process(_dobwind("fit", f"{FIT_VEHICLE}.airframe.toml", str(_fit_log(work, hours)),
                                                  "-o", str(out), "--plot", str(work / f"fit_{hours}h.png")))[:2]
    return results


def fit_report(results: dict[str, tuple[float, float]]) -> str:
    (one_s, one), (four_s, four) = results["1 h"], results["4 h"]
    return (f"fit (px4quad sweep, 100 Hz): 1 h {one:.0f} MB in {one_s:.1f} s, 4 h {four:.0f} MB in {four_s:.1f} s; "
            f"4 h / 1 h peak {four / one:.2f} (goal <= {GOAL_4H_PEAK_RATIO})")


def report(results: dict[str, tuple[float, float]]) -> str:
    lines = ["| case | median s | vs csv.reader | peak MB |", "|---|---:|---:|---:|"]
    for label, (wall, peak) in results.items():
        base = results[f"csv.reader pass{label[label.rfind(' ('):]}"][0]
        lines.append(f"| {label} | {wall:.2f} | {wall / base:.2f}x | {peak:.0f} |")
    one = results["replay python -o (1 h)"][1]
    for label, (wall, _) in results.items():
        if label.startswith("before: "):
            now = results[label[len("before: "):]][0]
            lines.append(f"{label[len('before: '):]}: after / before {now / wall:.2f}")
    if "replay python -o (4 h)" in results:
        four = results["replay python -o (4 h)"][1]
        lines.append(f"\n4 h peak / 1 h peak (python backend, -o): {four / one:.2f} (goal <= {GOAL_4H_PEAK_RATIO})")
    lines.append(f"goals: replay <= {GOAL_TIME_RATIO}x the csv.reader pass, peak <= {GOAL_PEAK_MB:.0f} MB")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--work", type=Path, default=Path("out/bench-replay"))
    parser.add_argument("--no-4h", action="store_true", help="skip the 4 h log (its simulation takes minutes)")
    parser.add_argument("--before", metavar="PYTHON", help="also run the replay cases with this interpreter, interleaved")
    parser.add_argument("--simulate", action="store_true", help="also the peak memory of simulate (1 h and 4 h)")
    parser.add_argument("--fit", action="store_true", help="also the peak memory of fit (1 h and 4 h)")
    parser.add_argument("--no-replay", action="store_true", help="skip the replay cases")
    args = parser.parse_args(argv)
    if not args.no_replay:
        print(report(run(args.rounds, args.work, not args.no_4h, args.before)))
    if args.simulate:
        print(simulate_report(simulate_peaks(args.work)))
    if args.fit:
        print(fit_report(fit_peaks(args.work)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
