"""Per autopilot log: rows, airborne rows, trusted share of the airborne rows, NO_DATA share, the
plausibility findings, the mean horizontal wind, the first `t` and the wall time of `dobwind replay`
(docs/field-logs.md).

    .venv/bin/python tools/field_table.py AIRFRAME.toml LOG [LOG ...]
"""
from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

NO_DATA, LANDED = 1 << 8, 1 << 9


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


def main() -> int:
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    print("| log | rows | airborne rows | trusted (of airborne) | NO_DATA (of airborne) | plausibility | mean wind m/s | first t s | wall |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        for log in sys.argv[2:]:
            print(row(sys.argv[1], log, Path(work)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
