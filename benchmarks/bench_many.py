"""Many logs at once (issue #35): `replay AIRFRAME FOLDER --jobs N` wall time for each N, and the peak
resident memory of the largest single process (the parent or one worker: ``wait4`` reports the max
over the process and its waited-for workers), so "memory per worker flat" can be read off.

    .venv/bin/python -m benchmarks.bench_many [--logs 20] [--minutes 60] [--rate 100] [--jobs 1 2]
        [--work out/bench-many] [--backend python|c] [--write]

One sweep log of the given length is simulated once (kept in the work folder) and hard-linked --logs
times into the folder replayed, so every job has the same work; jobs counts run interleaved over
--rounds and the median is reported. The issue's goal: 20 one-hour logs, --jobs 2 at least 1.8 times
faster than --jobs 1 on a 2-core machine with nothing else running.
"""
from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
from pathlib import Path

from benchmarks.bench_replay import measure_process

AIRFRAME = Path(__file__).resolve().parents[1] / "airframes" / "m300.toml"
SWEEP_HOLDS = 324  # the sweep scenario's holds: --hold = duration / 324
GOAL_SPEEDUP_2_JOBS = 1.8


def _dobwind(*args: str) -> list[str]:
    return [sys.executable, "-P", "-m", "dobwind.cli", *args]


def _folder(work: Path, logs: int, minutes: float, rate: float) -> Path:
    one = work / f"sweep_{minutes:g}min_{rate:g}hz.csv"
    if not one.exists():
        hold = f"{minutes * 60 / SWEEP_HOLDS:.6f}"
        subprocess.run(_dobwind("simulate", "sweep", "--rate", f"{rate:g}", "--hold", hold, "-o", str(one)),
                       check=True, stdout=subprocess.DEVNULL)
    folder = work / f"logs_{logs}x{minutes:g}min"
    if not folder.exists() or len(list(folder.iterdir())) != logs:
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir(parents=True)
        for k in range(logs):
            os.link(one, folder / f"flight{k:03d}.csv")
    return folder


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--logs", type=int, default=20)
    parser.add_argument("--minutes", type=float, default=60.0)
    parser.add_argument("--rate", type=float, default=100.0)
    parser.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--backend", choices=("python", "c"), default="python")
    parser.add_argument("--write", action="store_true", help="also write every estimate CSV (disk: ~110 B per row)")
    parser.add_argument("--work", default="out/bench-many")
    args = parser.parse_args(argv)
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    folder = _folder(work, args.logs, args.minutes, args.rate)
    load = os.getloadavg()[0]
    times: dict[int, list[float]] = {j: [] for j in args.jobs}
    peaks: dict[int, float] = {j: 0.0 for j in args.jobs}
    cpu: dict[int, list[float]] = {j: [] for j in args.jobs}
    for _ in range(args.rounds):
        for jobs in args.jobs:
            out = work / f"estimates_jobs{jobs}"
            shutil.rmtree(out, ignore_errors=True)
            cmd = ["replay", str(AIRFRAME), str(folder), "--jobs", str(jobs), "--backend", args.backend]
            wall, peak, cpu_s = measure_process(_dobwind(*cmd, *(["-o", str(out)] if args.write else [])))
            times[jobs].append(wall)
            cpu[jobs].append(cpu_s)
            peaks[jobs] = max(peaks[jobs], peak)
            shutil.rmtree(out, ignore_errors=True)
    base = statistics.median(times[args.jobs[0]])
    print(f"{args.logs} logs x {args.minutes:g} min at {args.rate:g} Hz, {args.backend} backend, "
          f"{os.cpu_count()} cores, median of {args.rounds} round(s)")
    print(f"load average before: {load:.1f} (a loaded machine cannot show the speed-up: compare "
          "the CPU seconds, which parallel work must not inflate)")
    print("jobs  wall s   speed-up  CPU s   peak MB (largest process)")
    for jobs in args.jobs:
        wall = statistics.median(times[jobs])
        print(f"{jobs:4d}  {wall:7.1f}  {base / wall:8.2f}  {statistics.median(cpu[jobs]):6.1f}  {peaks[jobs]:8.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
