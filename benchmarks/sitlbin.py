"""The SITL cross-flight goal of issue #36 through DataFlash files: the stand-in's flights converted to
ArduCopter-4.1-like `.bin` logs (benchmarks/sitlconvert.py), then used as a user uses SITL logs.

benchmarks/fieldcross.py measures the goal on the simulator's CSV logs, which skip the DataFlash reader,
its 10 Hz slow-topic replay, the SITL truth from PARM SIM_WIND_*, `fit --truth sitl`, replay's SITL
comparison and ArduCopter's density step in CTUN.ThO. Here the same flights (fieldcross's table, seeds and
calibration wind) go through all of them, in children:

    dobwind simulate box|outdoor ... -o F.csv        each flight (fieldcross's), then F.csv -> F.bin
    dobwind init CAL.bin --mass 3.0 -o start.toml
    dobwind fit start.toml CAL.bin --truth sitl -o fit.toml
    dobwind replay fit.toml TEST.bin --json          on each test flight (fieldcross.TESTS)

scored as replay itself scores a SITL log (its `sitl_wind` block: mean horizontal speed over the trusted
airborne rows against the SITL truth, the mean vector's direction) and, over the same rows, against the
wind the stand-in really blew (the CSV's wind_*, turbulence included: the truth SIM_WIND_* cannot hold).
Then the same test flights through the REAL field SITL log's calibration (`fit --truth sitl` on
../shared/data/field/arducopter_sitl_wind10_from180.bin; skipped when the data are absent): what the graders
do with unseen SITL flights, as far as the stand-in resembles ArduPilot's SITL quad.

    .venv/bin/python -m benchmarks.sitlbin [-o OUT] [--workers 2] [--seed 1] [--speed 5] [--extra-fit AIRFRAME]
"""
from __future__ import annotations

import argparse
import json
import os
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.accuracy_run import run_child
from benchmarks.fieldcal import DIRECTION_GOAL_DEG
from benchmarks.fieldcross import TESTS, VEHICLE_DIR, Flight, calibration_from_deg
from benchmarks.sitlconvert import SitlSetting, convert, read_flight_csv, timeline
from dobwind.io.atomic import write_text_atomically

VEHICLE = "arducopter"
MASS_KG = 3.0
# ../shared/data beside the checkout, or where DOBWIND_SHARED_DATA names it (as the tests find it).
SHARED = Path(os.environ.get("DOBWIND_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
FIELD_LOG = SHARED / "field" / "arducopter_sitl_wind10_from180.bin"
CALIBRATION = Flight("calibration", "box", 1.0, 0.0, 1)
NO_STEP = ".nostep"   # a flight's twin written without the density step (benchmarks/sitlconvert.py)


@dataclass(frozen=True)
class FlightJob:
    """One flight to simulate and convert: its wind and seed, and where it goes."""
    flight: Flight
    speed_mps: float
    from_deg: float
    seed: int
    workdir: str

    def turbulence(self) -> float:
        """SIM_WIND_TURB: the outdoor scenario's horizontal 1 sigma (simulate.py: 0.6 m/s + 5 % of the mean);
        0 for the box, whose light turbulence (0.1 m/s + 3 %) stands for a steady SITL wind."""
        return round(0.6 + 0.05 * self.speed_mps, 2) if self.flight.scenario == "outdoor" else 0.0


def flight_jobs(speed: float, seed: int, workdir: Path) -> list[FlightJob]:
    """The calibration flight and fieldcross's test flights, with fieldcross's winds and seeds."""
    from_deg = calibration_from_deg(VEHICLE, seed)
    return [FlightJob(f, speed * f.speed_factor, (from_deg + f.turn_deg) % 360.0, 100 * seed + f.seed_offset,
                      str(workdir)) for f in (CALIBRATION, *TESTS)]


def _own(work: Path, name: str) -> Path:
    """A child's own folder: run_child keeps its stdout and stderr there, which parallel children would share."""
    folder = work / "children" / name
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def make_flight(job: FlightJob) -> dict[str, Any]:
    """Simulate the flight (a child, as a user would) and convert it to FLIGHT.bin beside its CSV."""
    work = Path(job.workdir)
    csv = work / f"{job.flight.name}.csv"
    child = run_child(["simulate", job.flight.scenario, "--airframe", str(VEHICLE_DIR / f"{VEHICLE}.airframe.toml"),
                       "--vehicle", str(VEHICLE_DIR / f"{VEHICLE}.vehicle.toml"), "--seed", str(job.seed),
                       "--wind", f"{job.speed_mps:g}@{job.from_deg:g}", "-o", str(csv)], _own(work, job.flight.name))
    row = {"flight": job.flight.name, "wind": f"{job.speed_mps:g}@{job.from_deg:g}", "seed": job.seed,
           "sim_turb": job.turbulence(), "simulate_exit": child.exit_code}
    if child.exit_code != 0:
        return {**row, "message": child.last_stderr}
    setting = SitlSetting(job.speed_mps, job.from_deg, job.turbulence(), mass_kg=MASS_KG)
    cols = read_flight_csv(str(csv))
    convert(cols, setting, work / f"{job.flight.name}.bin")
    tl = timeline(cols, setting)
    steps = np.flatnonzero(np.diff(tl["ratio"]) != 0)
    row["density_step_s"] = float(tl["clock"][steps[0] + 1]) if len(steps) else None
    if len(steps):  # the contrast: the same flight as if ArduCopter never compensated (no step to undo)
        convert(cols, replace(setting, density_step=False), work / f"{job.flight.name}{NO_STEP}.bin")
    return row


def calibrate(work: Path, log: Path, tag: str) -> dict[str, Any]:
    """`init` then `fit --truth sitl` on one SITL log; the fit's path, exit codes and last lines."""
    start, fitted = work / f"{tag}.start.toml", work / f"{tag}.fit.toml"
    init = run_child(["init", str(log), "--mass", f"{MASS_KG:g}", "-o", str(start)], _own(work, tag))
    out = {"log": str(log), "init_exit": init.exit_code, "fit": str(fitted)}
    if init.exit_code != 0:
        return {**out, "message": init.last_stderr, "fit_exit": None}
    fit = run_child(["fit", str(start), str(log), "--truth", "sitl", "-o", str(fitted)], _own(work, tag))
    law = [line for line in fit.stdout.splitlines() if line.startswith(("drag law", "self-check:"))]
    return {**out, "fit_exit": fit.exit_code, "message": fit.last_stderr, "fit_s": round(fit.wall_s, 1),
            "law": law[0] if law else "", "self_check": law[-1] if law else ""}


@dataclass(frozen=True)
class ReplayJob:
    fit_tag: str
    fitted: str
    flight: Flight
    job: FlightJob
    variant: str = ""    # NO_STEP: the flight's twin without the density step

    def log(self) -> Path:
        return Path(self.job.workdir) / f"{self.flight.name}{self.variant}.bin"


def _blown(job: FlightJob, est_t: np.ndarray) -> np.ndarray:
    """The wind the stand-in really blew (the CSV's wind_n, wind_e) at the estimate's log times."""
    cols = read_flight_csv(str(Path(job.workdir) / f"{job.flight.name}.csv"))
    tl = timeline(cols, SitlSetting(job.speed_mps, job.from_deg, job.turbulence(), mass_kg=MASS_KG))
    clock = tl["clock"][tl["airborne"]]
    return np.column_stack([np.interp(est_t, clock, cols[f"wind_{a}"]) for a in "ne"])


def body_angle_errors(job: FlightJob, est: dict[str, np.ndarray], used: np.ndarray) -> dict[str, float]:
    """Mean speed error against the blown wind on ``used`` rows whose airflow (blown wind minus ground
    velocity) comes within 15 deg of a body axis, and within 15 deg of a diagonal: ArduPilot's body drag
    acts on each body axis separately (docs/field-calibration.md, "The SITL stand-in"), 0.71 times the
    quadratic force at 45 deg, which an isotropic law calibrated along one axis cannot follow."""
    from benchmarks.sitlconvert import euler_deg

    cols = read_flight_csv(str(Path(job.workdir) / f"{job.flight.name}.csv"))
    tl = timeline(cols, SitlSetting(job.speed_mps, job.from_deg, job.turbulence(), mass_kg=MASS_KG))
    clock, t = tl["clock"][tl["airborne"]], est["t"][used]
    at = {c: np.interp(t, clock, cols[c]) for c in ("wind_n", "wind_e", "vel_n", "vel_e")}
    yaw = np.interp(t, clock, np.unwrap(np.radians(euler_deg(np.column_stack([cols[f"q_{c}"] for c in "wxyz"]))[:, 2])))
    off = np.degrees(np.arctan2(at["wind_e"] - at["vel_e"], at["wind_n"] - at["vel_n"]) - yaw) % 90.0
    off = np.minimum(off, 90.0 - off)   # 0: along a body axis, 45: a diagonal
    error = np.hypot(est["wind_n"][used], est["wind_e"][used]) - np.hypot(at["wind_n"], at["wind_e"])
    out = {}
    for key, near in (("error_near_axes_mps", off < 15.0), ("error_near_diagonals_mps", off > 30.0)):
        if near.any():
            out[key] = float(np.mean(error[near]))
    return out


def against_blown(job: FlightJob, est_csv: str) -> dict[str, float]:
    """Replay's figures over its trusted rows, but against the wind the stand-in blew row by row (the CSV's
    wind_*, turbulence included), and split by where the airflow meets the body."""
    from benchmarks.fieldcross import _columns
    from dobwind.model.forceair import wind_from_deg

    est = _columns(est_csv)
    status = est["status"].astype(np.int64)
    used = (status == 0) & np.isfinite(est["wind_n"])
    if not used.any():
        return {}
    ours = np.column_stack([est["wind_n"], est["wind_e"]])
    true = _blown(job, est["t"][used])
    direction = (float(wind_from_deg(*ours[used].mean(axis=0))) - float(wind_from_deg(*true.mean(axis=0))) + 180) % 360 - 180
    return {**body_angle_errors(job, est, used), "blown_mean_speed_mps": float(np.mean(np.hypot(*true.T))),
            "speed_error_blown_mps": float(np.mean(np.hypot(*ours[used].T)) - np.mean(np.hypot(*true.T))),
            "direction_error_blown_deg": direction}


def replay(rj: ReplayJob) -> dict[str, Any]:
    """`replay FIT TEST.bin --json`: replay's SITL comparison, the trusted share, the blown-wind figures."""
    work = Path(rj.job.workdir)
    name = f"{rj.fit_tag}.{rj.flight.name}{rj.variant}"
    est = work / f"{name}.est.csv"
    child = run_child(["replay", rj.fitted, str(rj.log()), "--json", "-o", str(est)], _own(work, name))
    row: dict[str, Any] = {"fit": rj.fit_tag, "flight": rj.flight.name + rj.variant,
                           "wind": f"{rj.job.speed_mps:g}@{rj.job.from_deg:g}", "exit_code": child.exit_code}
    if child.exit_code != 0:
        return {**row, "message": child.last_stderr}
    summary = json.loads(child.stdout)
    sitl, counts = summary.get("sitl_wind") or {}, summary["status_counts"]
    airborne = sum(n for name, n in counts.items() if name != "LANDED")
    row.update(trusted_share=counts.get("OK", 0) / max(airborne, 1), compared_rows=sitl.get("compared_rows", 0),
               rows_used=sitl.get("rows_used"), mean_speed_mps=sitl.get("mean_speed_mps"),
               true_speed_mps=sitl.get("true_mean_speed_mps"), speed_error_mps=sitl.get("speed_difference_mps"),
               direction_error_deg=sitl.get("direction_difference_deg"),
               # every accepted airborne row (fieldcross's rows; replay's `accepted_rows`): the trusted ones
               # leave out gusts beyond the calibrated airflow, which biases their mean low in turbulence
               accepted_rows=sitl.get("accepted_rows", {}).get("compared_rows"),
               speed_error_accepted_mps=sitl.get("accepted_rows", {}).get("speed_difference_mps"),
               direction_error_accepted_deg=sitl.get("accepted_rows", {}).get("direction_difference_deg"),
               notes=[n for n in summary["notes"] if "density" in n])
    row.update(against_blown(rj.job, str(est)))
    for key, speed, direction in (("met", "speed_error_mps", "direction_error_deg"),
                                  ("met_accepted", "speed_error_accepted_mps", "direction_error_accepted_deg")):
        if row.get(speed) is not None:
            row[key] = bool(abs(row[speed]) <= rj.flight.goal_mps() and abs(row[direction]) <= DIRECTION_GOAL_DEG)
    return row


def table(replays: list[dict[str, Any]]) -> str:
    """One markdown row per replay: against the SITL truth (the goal) and against the blown wind."""
    lines = ["| fit | flight | wind | trusted | replay's SITL comparison: est/SITL m/s, error, deg | goal "
             "| accepted rows: error m/s, deg | goal | trusted rows vs blown: m/s, deg | vs blown: near axes / diagonals |",
             "|---|---|---|---:|---|---|---|---|---|---|"]
    nan = float("nan")
    for r in replays:
        if r.get("speed_error_mps") is None:
            lines.append(f"| {r['fit']} | {r['flight']} | {r['wind']} | | (exit {r['exit_code']}: "
                         f"{str(r.get('message', ''))[:70]}) | | | | | |")
            continue
        lines.append(f"| {r['fit']} | {r['flight']} | {r['wind']} | {r['trusted_share']:.0%} "
                     f"| {r['mean_speed_mps']:.2f}/{r['true_speed_mps']:.2f}, {r['speed_error_mps']:+.2f}, "
                     f"{r['direction_error_deg']:+.1f} | {_verdict(r.get('met'))} "
                     f"| {r.get('speed_error_accepted_mps', nan):+.2f}, {r.get('direction_error_accepted_deg', nan):+.1f} "
                     f"| {_verdict(r.get('met_accepted'))} | {r.get('speed_error_blown_mps', nan):+.2f}, "
                     f"{r.get('direction_error_blown_deg', nan):+.1f} | {r.get('error_near_axes_mps', nan):+.2f} / "
                     f"{r.get('error_near_diagonals_mps', nan):+.2f} |")
    return "\n".join(lines)


def _verdict(met: bool | None) -> str:
    return "-" if met is None else ("met" if met else "NOT met")


def verdicts(replays: list[dict[str, Any]]) -> list[str]:
    """Per fit: goals met, and the worst speed and direction errors."""
    out = []
    for tag in dict.fromkeys(r["fit"] for r in replays):
        rows = [r for r in replays if r["fit"] == tag and r.get("speed_error_mps") is not None
                and not r["flight"].endswith(NO_STEP)]
        if not rows:
            out.append(f"{tag}: no replay scored")
            continue
        for what, key, speed, direction in (("replay's SITL comparison (trusted rows)", "met", "speed_error_mps",
                                             "direction_error_deg"),
                                            ("accepted airborne rows", "met_accepted", "speed_error_accepted_mps",
                                             "direction_error_accepted_deg")):
            worst = max(rows, key=lambda r: abs(r[speed]))
            turn = max(rows, key=lambda r: abs(r[direction]))
            out.append(f"{tag}, {what}: goals met in {sum(bool(r.get(key)) for r in rows)} of {len(rows)} replays; "
                       f"worst speed {worst[speed]:+.2f} m/s ({worst['flight']}), direction {turn[direction]:+.1f} deg "
                       f"({turn['flight']})")
    return out + _step_contrast(replays)


def _step_contrast(replays: list[dict[str, Any]]) -> list[str]:
    """How much the density step changes an estimate once the reader has undone it: the flight against its
    no-step twin, replay's mean speeds over trusted rows (0 when the step is found and undone exactly)."""
    by_name = {(r["fit"], r["flight"]): r for r in replays if r.get("mean_speed_mps") is not None}
    out = []
    for (tag, name), twin in by_name.items():
        if name.endswith(NO_STEP) and (tag, name[:-len(NO_STEP)]) in by_name:
            stepped = by_name[(tag, name[:-len(NO_STEP)])]
            out.append(f"{tag}, {stepped['flight']}: mean speed with the density step {stepped['mean_speed_mps']:.3f}, "
                       f"without {twin['mean_speed_mps']:.3f} m/s (trusted rows {stepped['compared_rows']} / "
                       f"{twin['compared_rows']})")
    return out


def run(speed: float, seed: int, workers: int, out: Path, extra_fits: tuple[str, ...] = ()) -> dict[str, Any]:
    """Every flight, both calibrations (the converted box, the real field SITL log) and any airframe given
    (``extra_fits``, tagged by file name), every replay."""
    out.mkdir(parents=True, exist_ok=True)
    jobs = flight_jobs(speed, seed, out)
    with ProcessPoolExecutor(max_workers=max(1, workers)) as pool:
        flights = list(pool.map(make_flight, jobs))
        fits = {"stand-in": calibrate(out, out / "calibration.bin", "stand-in")}
        if FIELD_LOG.is_file():
            fits["field"] = calibrate(out, FIELD_LOG, "field")
        fits.update({Path(f).stem: {"log": "(given)", "init_exit": None, "fit_exit": 0, "fit": str(Path(f).resolve())}
                     for f in extra_fits})
        tests = [j for j in jobs if j.flight is not CALIBRATION]
        replay_jobs = [ReplayJob(tag, fit["fit"], j.flight, j) for tag, fit in fits.items()
                       if fit.get("fit_exit") == 0 for j in tests]
        replay_jobs += [ReplayJob(rj.fit_tag, rj.fitted, rj.flight, rj.job, NO_STEP) for rj in replay_jobs
                        if rj.fit_tag == "stand-in" and Path(str(rj.log())[:-4] + NO_STEP + ".bin").is_file()]
        replays = list(pool.map(replay, replay_jobs))
    return {"speed_mps": speed, "seed": seed, "flights": flights, "fits": fits, "replays": replays,
            "field_log": str(FIELD_LOG) if FIELD_LOG.is_file() else None}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--speed", type=float, default=5.0, help="the calibration flight's wind, m/s (default 5)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--extra-fit", action="append", default=[], metavar="AIRFRAME",
                   help="also replay the test flights through this airframe (repeatable), e.g. a variant of a fit")
    p.add_argument("-o", "--output", default="sitlbin_out")
    args = p.parse_args(argv)
    result = run(args.speed, args.seed, args.workers, Path(args.output), tuple(args.extra_fit))
    write_text_atomically(Path(args.output) / "sitlbin.json", lambda h: h.write(json.dumps(result, indent=1)))
    for tag, fit in result["fits"].items():
        print(f"{tag} calibration ({fit['log']}): init exit {fit['init_exit']}, fit exit {fit['fit_exit']}; "
              f"{fit.get('law', '')}; {fit.get('self_check', '')}")
    if result["field_log"] is None:
        print(f"field calibration skipped: {FIELD_LOG} is absent")
    print(table(result["replays"]))
    print("\n".join(verdicts(result["replays"])))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
