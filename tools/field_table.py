"""Per autopilot log, what replay gives: the tables of docs/field-logs.md and docs/autopilot-logs.md.

    .venv/bin/python tools/field_table.py AIRFRAME.toml LOG [LOG ...]
        one summary row per log from `dobwind replay AIRFRAME LOG --json -o est.csv` (a subprocess, so the
        wall time is the command's): rows, airborne rows, trusted and NO_DATA shares of the airborne rows,
        the plausibility findings, the mean horizontal wind, the first `t` and the wall time;
    .venv/bin/python tools/field_table.py --per-log [--no-bridge] [--markdown] AIRFRAME.toml LOG [LOG ...]
        per log, in process: airborne time (rows not LANDED), the trusted share of airborne rows (status 0),
        the settled share (accepted without SETTLING), NaN in trusted rows, mean |vertical wind| and mean
        horizontal wind over trusted rows, the rows bridged, and each topic's longest silence next to its gap
        tolerance. ``--no-bridge`` replays as before dobwind/io/bridge.py (every NO_DATA row rejected).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

NO_DATA, LANDED = 1 << 8, 1 << 9
SETTLING = 1 << 6


def row(airframe: str, log: str, work: Path) -> str:
    est = work / "est.csv"
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "dobwind.cli", "replay", airframe, log, "--json", "-o", str(est)],
                          capture_output=True, text=True)
    wall = time.perf_counter() - start
    if proc.returncode != 0:
        return f"| {Path(log).name} | exit {proc.returncode}: {proc.stderr.strip()} |"
    summary = json.loads(proc.stdout)
    e = np.genfromtxt(est, delimiter=",", names=True)
    status = e["status"].astype(int)
    air = (status & LANDED) == 0
    n_air = max(int(air.sum()), 1)
    trusted = int(((status == 0) & air).sum())
    no_data = int((((status & NO_DATA) != 0) & air).sum())
    checks = ", ".join(f["check"] for f in summary.get("plausibility", [])) or "-"
    wind = summary["mean_wind_speed_h_mps"]
    return (f"| {Path(log).name} | {len(status)} | {int(air.sum())} | {100 * trusted / n_air:.1f} % | "
            f"{100 * no_data / n_air:.1f} % | {checks} | {'-' if wind is None else f'{wind:.2f}'} | "
            f"{e['t'][0]:.3f} | {wall:.1f} s |")


@dataclass(frozen=True)
class LogRow:
    log: str
    airborne_s: float
    trusted: float          # share of airborne rows with status 0
    settled: float          # share of airborne rows accepted and not SETTLING
    nan_trusted: int        # trusted rows with a NaN or infinite output
    vertical_mps: float     # mean |vertical wind| over trusted rows
    horizontal_mps: float   # mean horizontal wind speed over trusted rows
    bridged: int            # rows bridged (NO_DATA, fed interpolated)
    silences: tuple[tuple[str, float, float], ...]


def measure(airframe: str, log: str, bridge_gaps: bool = True) -> LogRow:
    from dobwind.model.airframe import load_airframe
    from dobwind.model.status import accepted
    from dobwind.replay.replay import replay_ulog

    af = load_airframe(airframe)
    model, flight, traj = replay_ulog(af, log, bridge_gaps=bridge_gaps)
    air = ~flight.landed
    status = traj.status.astype(np.int64)
    trusted = air & (status == 0)
    settled = air & accepted(status) & ((status & SETTLING) == 0)
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    dt = float(np.median(np.diff(flight.log.time_s)))
    n_air = max(int(air.sum()), 1)
    return LogRow(log, float(air.sum()) * dt, trusted.sum() / n_air, settled.sum() / n_air,
                  int((~np.isfinite(traj.outputs[trusted])).any(axis=1).sum()),
                  float(np.mean(np.abs(wind[trusted, 2]))) if trusted.any() else float("nan"),
                  float(np.mean(np.hypot(wind[trusted, 0], wind[trusted, 1]))) if trusted.any() else float("nan"),
                  0 if flight.bridged is None else int(flight.bridged.sum()), flight.silences)


def text(row: LogRow) -> str:
    gaps = ", ".join(f"{name} {gap:.3f} s (tol {tol:.3f})" for name, tol, gap in row.silences)
    return (f"{row.log}\n  airborne {row.airborne_s:.1f} s, trusted {100 * row.trusted:.1f} %, settled "
            f"{100 * row.settled:.1f} %, NaN in trusted rows {row.nan_trusted}, mean |vertical wind| "
            f"{row.vertical_mps:.2f} m/s, mean horizontal wind {row.horizontal_mps:.2f} m/s, bridged rows "
            f"{row.bridged}\n  longest silence per topic: {gaps}")


def _mps(value: float) -> str:
    return "- (no trusted row)" if np.isnan(value) else f"{value:.2f} m/s"


def markdown(row: LogRow, before: LogRow | None = None) -> str:
    """One table per log; with ``before`` (the same log without bridging) a column for it too."""
    def cells(r: LogRow) -> list[str]:
        return [f"{r.airborne_s:.1f} s", f"{100 * r.trusted:.1f} %", f"{100 * r.settled:.1f} %", f"{r.nan_trusted}",
                _mps(r.vertical_mps), _mps(r.horizontal_mps), f"{r.bridged}"]

    names = ["airborne time", "trusted share of airborne rows", "settled share of airborne rows (not SETTLING)",
             "NaN in trusted rows", "mean vertical wind (abs, trusted rows)", "mean horizontal wind (trusted rows)",
             "rows bridged"]
    header = ["| quantity | without bridging | with bridging |", "|---|---|---|"] if before else \
        ["| quantity | value |", "|---|---|"]
    now = cells(row)
    then = cells(before) if before else None
    lines = header + [f"| {n} | {then[i]} | {now[i]} |" if then else f"| {n} | {now[i]} |" for i, n in enumerate(names)]
    pad = " - |" if before else ""
    lines += [f"| longest silence of {name} (tolerance {tol:.3f} s) |{pad} {gap:.3f} s |" for name, tol, gap in row.silences]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if "--per-log" in argv:
        parser = argparse.ArgumentParser(prog="tools/field_table.py --per-log")
        parser.add_argument("--per-log", action="store_true")
        parser.add_argument("airframe")
        parser.add_argument("logs", nargs="+")
        parser.add_argument("--no-bridge", action="store_true", help="reject every NO_DATA row (replay before bridging)")
        parser.add_argument("--markdown", action="store_true", help="one Markdown table per log")
        parser.add_argument("--compare", action="store_true", help="with --markdown: a column without bridging too")
        args = parser.parse_args(argv)
        for log in args.logs:
            measured = measure(args.airframe, log, not args.no_bridge)
            before = measure(args.airframe, log, False) if args.compare else None
            print(f"#### {Path(log).name}\n\n{markdown(measured, before)}\n" if args.markdown else text(measured))
        return 0
    if len(argv) < 2:
        print(__doc__)
        return 2
    print("| log | rows | airborne rows | trusted (of airborne) | NO_DATA (of airborne) | plausibility | mean wind m/s | first t s | wall |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        for log in argv[1:]:
            print(row(argv[0], log, Path(work)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
