"""`make accuracy`'s sample-rate study (#12: "the same flight at 50, 100, 250 and 500 Hz gives the same
model within noise").

One vehicle's calibration flight (sweep + vertical, one seed) is simulated at each rate, fitted with no
options, and one tunnel flight (the vehicle's own rate) is replayed through every fit. The tunnel flight
is the same for all, so its noise cancels between the rows: what differs is the model alone. "Within
noise" is judged against the fits' own word: the spread over rates of each calibrated hold's estimated
speed must stay within the hold error the fits predict for that tunnel (their hold-level CV for holds
that long, holdcv's note); a rate-dependent cleaning or filter would break it.
"""
from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from benchmarks.accuracy_run import CALIBRATION, Job, _cv_ratios, _fit, _json, _simulate, goal_metrics, run_child, simulated_rows

RATES_HZ = (50.0, 100.0, 250.0, 500.0)
RATE_VEHICLE = "px4quad"   # mixed drag, thrust shape and inflow error, x/y anisotropy; 50 Hz of its own
RATE_SEED = 1


@dataclass(frozen=True)
class RateJob:
    vehicle: str
    vehicle_dir: str
    rate_hz: float
    hold_s: float
    workdir: str
    tunnel_log: str

    def job(self) -> Job:
        """The benchmark's job for this folder (seed RATE_SEED: the same flight at every rate)."""
        return Job(self.vehicle, self.vehicle_dir, RATE_SEED, self.hold_s, self.workdir)


def run_rate(job: RateJob) -> dict[str, Any]:
    """Calibrate at ``job.rate_hz``, fit, replay the shared tunnel flight; failures are results."""
    Path(job.workdir).mkdir(parents=True, exist_ok=True)
    result: dict[str, Any] = {"rate_hz": job.rate_hz, "rows": 0}
    logs = []
    for scenario in CALIBRATION:
        log, child = _simulate(job.job(), scenario, job.hold_s, job.rate_hz)
        if child.exit_code != 0:
            result["error"] = f"simulate {scenario} at {job.rate_hz:g} Hz: exit {child.exit_code}: {child.last_stderr}"
            return result
        logs.append(log)
        result["rows"] += simulated_rows(child)
    fitted, result["fit"] = _fit(job.job(), logs)
    for log in logs:
        Path(log).unlink()
    if result["fit"]["exit_code"] != 0:
        result["error"] = f"fit: exit {result['fit']['exit_code']}: {result['fit']['message']}"
        return result
    replay = run_child(["replay", fitted, job.tunnel_log, "--backend", "c", "--json"], Path(job.workdir))
    parsed = _json(replay)
    if parsed is None:
        result["error"] = f"replay tunnel: exit {replay.exit_code}: {replay.last_stderr}"
        return result
    result["tunnel"] = goal_metrics("tunnel", parsed)
    _cv_ratios(result)
    return result


def spread(results: list[dict[str, Any]]) -> tuple[float | None, float | None]:
    """(largest spread over rates of a calibrated tunnel hold's estimated speed, largest predicted hold
    error among the fits), m/s; None when a rate failed."""
    if not results or any("error" in r for r in results):
        return None, None
    calibrated = min(r["fit"]["calibrated_speed_mps"] for r in results)
    speeds = results[0]["tunnel"]["hold_speeds"]
    inside = [i for i, s in enumerate(speeds) if s <= calibrated]
    errors = [[r["tunnel"]["hold_errors"][i] for r in results] for i in inside]
    predicted = [r["tunnel"]["predicted_rms_calibrated"] for r in results]
    if not errors or any(p is None for p in predicted):
        return None, None
    return max(max(e) - min(e) for e in errors), max(predicted)


def rate_study(vehicle_dir: Path, scratch: Path, hold_s: float, workers: int, vehicle: str = RATE_VEHICLE,
               rates_hz: tuple[float, ...] = RATES_HZ) -> dict[str, Any]:
    """The study's results, the spread and the prediction it is judged against (see the module's note)."""
    scratch.mkdir(parents=True, exist_ok=True)
    tunnel, child = _simulate(Job(vehicle, str(vehicle_dir), RATE_SEED, None, str(scratch)), "tunnel", None)
    if child.exit_code != 0:
        return {"vehicle": vehicle, "rates_hz": list(rates_hz), "rates": [],
                "error": f"simulate tunnel: exit {child.exit_code}: {child.last_stderr}"}
    jobs = [RateJob(vehicle, str(vehicle_dir), r, hold_s, str(scratch / f"rate_{r:g}"), tunnel) for r in rates_hz]
    if workers <= 1:
        results = [run_rate(j) for j in jobs]
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            results = list(pool.map(run_rate, jobs))
    largest, predicted = spread(results)
    return {"vehicle": vehicle, "rates_hz": list(rates_hz), "rates": results, "spread_mps": largest,
            "predicted_mps": predicted}


RATE_GOAL = "the same model at 50-500 Hz: spread of tunnel hold speeds <= the fits' predicted hold error"


def rate_lines(study: dict[str, Any]) -> tuple[list[str], dict[str, bool]]:
    lines = [f"Sample rate ({study['vehicle']}: one calibration flight simulated at "
             + ", ".join(f"{r:g}" for r in study["rates_hz"]) + " Hz, fitted with no options; one tunnel flight replayed "
             "through each fit)",
             f"  {'rate Hz':>8s}  {'rows':>9s}  {'model':>10s}  {'fit s':>6s}  {'fit MB':>6s}  {'hold CV':>7s}  "
             f"{'tun spd mean':>12s}  {'tun spd max':>11s}  {'tun dir mean':>12s}  {'tun dir max':>11s}"]
    if "error" in study:
        return lines + [f"  {study['error']}"], {RATE_GOAL: False}
    for r in study["rates"]:
        if "error" in r:
            lines.append(f"  {r['rate_hz']:8g}  {r['error']}")
            continue
        fit, tun = r["fit"], r["tunnel"]
        lines.append(f"  {r['rate_hz']:8g}  {r['rows']:9d}  {fit.get('model') or '-':>10s}  {fit['time_s']:6.0f}  "
                     f"{fit['peak_rss_mb']:6.0f}  {fit['cv_rmse_mps'] or float('nan'):7.3f}  "
                     f"{tun['speed_mean']:12.3f}  {tun['speed_max']:11.3f}  {tun['direction_mean']:12.2f}  "
                     f"{tun['direction_max']:11.2f}")
    largest, predicted = study["spread_mps"], study["predicted_mps"]
    ok = largest is not None and predicted is not None and largest <= predicted
    if largest is not None and predicted is not None:
        lines.append(f"  largest spread over rates of a calibrated tunnel hold's estimated speed: {largest:.3f} m/s; "
                     f"the fits' largest predicted hold error: {predicted:.3f} m/s")
    lines.append(f"  {'PASS' if ok else 'MISS'}  {RATE_GOAL}")
    return lines, {RATE_GOAL: ok}
