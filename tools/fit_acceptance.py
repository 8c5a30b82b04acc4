"""Acceptance record of `dobwind fit` for a change that must not alter what it prints (issue #34: the
fit report's nested parts typed, the bytes of `fit --json` and of the text report unchanged).

Usage: python -m tools.fit_acceptance OUT_DIR [--code DIR] [--work DIR] [CASE ...]
       python -m tools.fit_acceptance --compare BEFORE_DIR AFTER_DIR   (exit 1 and the files that differ)

Simulates the logs once into WORK/logs (default /tmp/dobwind-fit-acceptance), then for each case runs
`python -m dobwind.cli fit ... --force` twice (with --json and without) from ``--code`` (a checkout of the
commit to record: its directory comes first on sys.path, so an older commit's files can be recorded with
this venv) and keeps stdout, stderr with the exit code, and the airframe written. The airframe is written
to the same path in WORK every time, so the paths printed are the same before and after.

The cases cover every nested part of the report: both families on a sweep and a climb (the low-pass
lowered), the polynomial family alone, four tunnel-style runs one of which a vehicle with another thrust
scale and drag flew (per-log runs, an anchored law, an outlier; and --exclude-outliers), --wind unknown on
a box flight, and a heavy vehicle with a noisy accelerometer (the acceleration route)."""
from __future__ import annotations

import argparse
import filecmp
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VEHICLES = ROOT / "benchmarks" / "vehicles"
# tests/test_accelroute.py's noisy vehicle, with tests/helpers.NOISY_AIRFRAME (written out here: tools/ does
# not import the tests).
NOISY_AIRFRAME = """name = "noisy"
mass = 6.0
[thrust]
source = "collective"
[observer]
sample_time = 0.05
gains = [36.0, 36.0, 36.0]
discretization = "paper"
acceleration = "ned"
[force_air.horizontal]
terms = ["fh^0.5"]
coefficients = [4.0]
[force_air.vertical]
terms = ["fz"]
coefficients = [0.5]
[filter]
speeds = [0.0, 3.0, 10.0]
cutoffs = [0.2, 0.35, 0.5]
"""
NOISY_VEHICLE = """mass = 6.0
rate = 20.0
[drag.x]
linear = 0.3
quadratic = 0.05
[drag.y]
linear = 0.3
quadratic = 0.05
[drag.z]
linear = 0.8
[thrust]
scale = 1.02
[sensors]
acc_noise = 0.2
vel_noise = 0.03
"""


def _dobwind(code: Path, argv: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "dobwind.cli", *argv], cwd=code, capture_output=True, text=True)


def make_logs(code: Path, logs: Path) -> dict[str, str]:
    """The flights and airframes of the cases (simulated once: the simulator is not what is recorded)."""
    logs.mkdir(parents=True, exist_ok=True)
    px4 = VEHICLES / "px4quad.vehicle.toml"
    files = {"odd.vehicle.toml": px4.read_text().replace("scale = 1.05", "scale = 1.25")
             .replace("quadratic = 0.035", "quadratic = 0.07"),
             "noisy.airframe.toml": NOISY_AIRFRAME, "noisy.vehicle.toml": NOISY_VEHICLE}
    for name, text in files.items():
        (logs / name).write_text(text)
    found = {"px4": str(VEHICLES / "px4quad.airframe.toml"), "noisy": str(logs / "noisy.airframe.toml")}
    odd, noisy = str(logs / "odd.vehicle.toml"), str(logs / "noisy.vehicle.toml")
    flights = {"sweep": ("sweep", 5, "px4", str(px4), ["--rate", "12.5", "--hold", "10"]),
               "vertical": ("vertical", 6, "px4", str(px4), ["--rate", "12.5", "--hold", "10"]),
               **{f"tunnel{seed}": ("tunnel", seed, "px4", str(px4), ["--rate", "25"]) for seed in (1, 2, 3)},
               "tunnelodd": ("tunnel", 4, "px4", odd, ["--rate", "25"]),
               "box": ("box", 5, "px4", str(px4), ["--hold", "6"]),
               "nsweep": ("sweep", 1, "noisy", noisy, ["--hold", "6"]),
               "nvertical": ("vertical", 2, "noisy", noisy, ["--hold", "8"])}
    for name, (scenario, seed, airframe, vehicle, extra) in flights.items():
        path = logs / f"{name}.csv"
        if not path.exists():
            done = _dobwind(code, ["simulate", scenario, "--airframe", found[airframe], "--vehicle", vehicle,
                                   "--seed", str(seed), "-o", str(path), *extra])
            if done.returncode != 0:
                raise SystemExit(f"fit_acceptance: simulate {scenario} failed: {done.stderr.strip()}")
        found[name] = str(path)
    return found


def cases(found: dict[str, str]) -> dict[str, list[str]]:
    tunnels = [found[f"tunnel{k}"] for k in ("1", "2", "3", "odd")]
    return {"sweep_auto": [found["px4"], found["sweep"], found["vertical"]],
            "sweep_poly": [found["px4"], found["sweep"], found["vertical"], "--model", "polynomial"],
            "tunnel": [found["px4"], *tunnels],
            "tunnel_excl": [found["px4"], *tunnels, "--exclude-outliers"],
            "box_unknown": [found["px4"], found["box"], "--wind", "unknown", "--model", "drag-heading"],
            "noisy": [found["noisy"], found["nsweep"], found["nvertical"]]}


def record(code: Path, work: Path, out: Path, wanted: list[str]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for name, argv in cases(make_logs(code, work / "logs")).items():
        if wanted and name not in wanted:
            continue
        for mode in ("json", "text"):
            toml = work / f"{name}.toml"
            for old in work.glob(f"{name}*"):
                old.unlink()
            done = _dobwind(code, ["fit", *argv, "--force", "-o", str(toml), *(["--json"] if mode == "json" else [])])
            (out / f"{name}.{mode}.out").write_text(done.stdout)
            (out / f"{name}.{mode}.err").write_text(done.stderr + f"\nexit {done.returncode}\n")
            if toml.exists():
                (out / f"{name}.{mode}.toml").write_text(toml.read_text())
            print(f"{name} {mode}: exit {done.returncode}", flush=True)


def compare(before: Path, after: Path) -> int:
    names = sorted({p.name for p in before.iterdir()} | {p.name for p in after.iterdir()})
    differ = [n for n in names if not ((before / n).exists() and (after / n).exists()
                                       and filecmp.cmp(before / n, after / n, shallow=False))]
    for name in differ:
        print(f"differs: {name}")
    print(f"{len(names) - len(differ)} of {len(names)} files identical")
    return 1 if differ else 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", nargs="?")
    p.add_argument("cases", nargs="*")
    p.add_argument("--code", default=str(ROOT), help="the checkout whose dobwind runs (default: this one)")
    p.add_argument("--work", default="/tmp/dobwind-fit-acceptance", help="logs and the airframes written")
    p.add_argument("--compare", nargs=2, metavar=("BEFORE", "AFTER"))
    args = p.parse_args(argv)
    if args.compare:
        return compare(Path(args.compare[0]), Path(args.compare[1]))
    if not args.out:
        p.error("OUT_DIR is required unless --compare")
    record(Path(args.code).resolve(), Path(args.work), Path(args.out), args.cases)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
