"""Is `fit --wind unknown`'s wind 1-sigma honest? Coverage on simulated flights whose wind is known.

For each vehicle of benchmarks/vehicles/ and each seed, the user's path in children,

    dobwind simulate box|outdoor --airframe A --vehicle V --seed S --wind C@D -o cal.csv
    dobwind init cal.csv --mass M -o start.toml

then the joint wind solve of `dobwind fit start.toml cal.csv --wind unknown` in this process
(dobwind/calibrate/windsolve.py: the same samples, solve and covariance), kept whether it would be
accepted or refused, so that the refused fits count too. Per wind component the normalised error
z = (true - found) / 1-sigma, with the true wind the simulator's mean wind over the fitted rows' span.
An honest 1-sigma has about 68 % of |z| within 1 and 95 % within 2. The 1-sigmas side by side:

    ls      the plain least-squares one (independent residuals)
    ar1cap  inflated by sqrt((1 + rho) / (1 - rho)), rho the lag-1 correlation capped at 0.95 (windsolve's)
    ar1     the same with rho uncapped (up to 0.999)
    its     inflated by sqrt(1 + 2 sum rho_k), the integral time scale (lags up to the first rho_k <= 0)
    hac     a Bartlett-window (Newey-West) sandwich over the residuals' scores, lags up to a quarter of the
            samples, as a ratio to its own lag-0 part
    fit     the one the fit prints now (windsolve.identification)

    .venv/bin/python -m benchmarks.windsigma [--vehicles ...] [--seeds 1 2 3] [--scenarios box]
        [--workers 2] [-o OUT_DIR]
"""
from __future__ import annotations

import argparse
import json
import math
import tomllib
import zlib
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.accuracy_run import run_child
from dobwind.io.atomic import write_text_atomically

VEHICLE_DIR = Path(__file__).resolve().parent / "vehicles"
SIGMAS = ("ls", "ar1cap", "ar1", "its", "hac", "fit")


def _wind(vehicle: str, seed: int) -> tuple[float, float]:
    """(speed, from_deg) drawn from the vehicle's name and the seed: 3-8 m/s from anywhere."""
    rng = np.random.default_rng([seed, zlib.crc32(vehicle.encode()), 7])
    return float(np.round(rng.uniform(3.0, 8.0), 1)), float(np.round(rng.uniform(0, 360)))


def _mass(vehicle: str) -> float:
    with open(VEHICLE_DIR / f"{vehicle}.vehicle.toml", "rb") as fh:
        return float(tomllib.load(fh)["mass"])


def _lag1(residual: np.ndarray, log_index: np.ndarray) -> float:
    """The residuals' lag-1 correlation within each log, both force components pooled (as windsolve)."""
    r = residual.reshape(-1, 2)
    same = log_index[1:] == log_index[:-1]
    return float(np.sum(r[1:][same] * r[:-1][same])) / float(np.sum(r * r))


def _ar1(rho: float, cap: float) -> float:
    """sqrt((1 + rho) / (1 - rho)), rho within [0, cap] (windsolve's reading, cap 0.95)."""
    rho = min(max(rho, 0.0), cap)
    return math.sqrt((1 + rho) / (1 - rho))


def _component_sigmas(x: np.ndarray, problem) -> dict[str, list[float]]:
    """Each wind component's 1-sigma (north, east of group 0) under each reading."""
    from dobwind.calibrate import windsolve

    data = problem.data(x)
    original = windsolve._inflation
    try:
        windsolve._inflation = lambda *_: 1.0
        plain = windsolve.wind_component_sigmas(x, problem)
    finally:
        windsolve._inflation = original
    fitted = windsolve.wind_component_sigmas(x, problem)
    rho = _lag1(data, problem.log_index())
    its = _integral_scale(data, problem.log_index())
    hac = _hac_ratio(x, problem)
    return {"ls": plain[:2].tolist(), "ar1cap": (plain[:2] * _ar1(rho, 0.95)).tolist(), "rho": [rho, rho],
            "ar1": (plain[:2] * _ar1(rho, 0.999)).tolist(), "its": (plain[:2] * its).tolist(),
            "hac": (plain[:2] * hac[:2]).tolist(), "fit": fitted[:2].tolist()}


def _integral_scale(residual: np.ndarray, log_index: np.ndarray) -> float:
    """sqrt(1 + 2 sum rho_k) over lags up to the first non-positive autocorrelation."""
    r = residual.reshape(-1, 2)
    den = float(np.sum(r * r))
    total = 1.0
    for k in range(1, len(r) // 2):
        same = log_index[k:] == log_index[:-k]
        rho = float(np.sum(r[k:][same] * r[:-k][same])) / den
        if rho <= 0:
            break
        total += 2 * rho
    return math.sqrt(total)


def _hac_ratio(x: np.ndarray, problem) -> np.ndarray:
    """sqrt(Bartlett-HAC sandwich variance / the same sandwich with lag 0 only), per parameter."""
    from dobwind.calibrate import windsolve

    data = problem.data(x)
    jac = windsolve.raw_jacobian(x, problem)
    n = len(data)
    jd, jp = jac[:n], jac[n:]
    g = (jd * data[:, None]).reshape(-1, 2, jd.shape[1]).sum(axis=1)
    idx = problem.log_index()
    lags = max(1, len(g) // 4)
    white = g.T @ g
    meat = white.copy()
    for k in range(1, lags + 1):
        same = idx[k:] == idx[:-k]
        gk = g[k:][same].T @ g[:-k][same]
        meat += (1 - k / (lags + 1)) * (gk + gk.T)
    sigma2 = float(np.mean(data ** 2))
    w = np.sqrt(sigma2) / problem.scale_n
    a = jd.T @ jd + (w * jp).T @ (w * jp)
    prior_meat = sigma2 * (w * jp).T @ (w * jp)
    ai = np.linalg.inv(a)
    hac = np.diag(ai @ (meat + prior_meat) @ ai)
    plain = np.diag(ai @ (white + prior_meat) @ ai)
    return np.sqrt(np.maximum(hac, 0) / plain)


def _true_wind(csv: Path, span: tuple[float, float]) -> np.ndarray:
    from dobwind.io.logs import read_log

    log = read_log(str(csv))
    inside = (log.time_s >= span[0]) & (log.time_s <= span[1])
    return np.array([np.nanmean(log.columns["wind_n"][inside]), np.nanmean(log.columns["wind_e"][inside])])


def _write(path: Path, text: str) -> None:
    write_text_atomically(path, lambda handle: handle.write(text))


def run_job(job: tuple[str, int, str, str]) -> dict[str, Any]:
    """One flight's row, written beside its files (a rerun of the same output folder reuses it)."""
    vehicle, seed, scenario, out = job
    work = Path(out) / f"{vehicle}-{scenario}-{seed}"
    done = work / "row.json"
    if done.is_file():
        return json.loads(done.read_text())
    row = _run(vehicle, seed, scenario, work)
    _write(done, json.dumps(row) + "\n")
    return row


def _run(vehicle: str, seed: int, scenario: str, work: Path) -> dict[str, Any]:
    work.mkdir(parents=True, exist_ok=True)
    speed, from_deg = _wind(vehicle, seed)
    row: dict[str, Any] = {"vehicle": vehicle, "seed": seed, "scenario": scenario, "wind": f"{speed:g}@{from_deg:g}"}
    csv = work / "cal.csv"
    sim = run_child(["simulate", scenario, "--airframe", f"{VEHICLE_DIR / vehicle}.airframe.toml", "--vehicle",
                     f"{VEHICLE_DIR / vehicle}.vehicle.toml", "--seed", str(seed), "--wind", f"{speed:g}@{from_deg:g}",
                     "-o", str(csv)], work)
    init = run_child(["init", str(csv), "--mass", f"{_mass(vehicle):g}", "-o", str(work / "start.toml")], work)
    if sim.exit_code or init.exit_code:
        return row | {"error": sim.last_stderr or init.last_stderr}
    return row | _solve(work / "start.toml", csv)


def _solve(start: Path, csv: Path) -> dict[str, Any]:
    from dobwind.calibrate import windsolve
    from dobwind.calibrate.fieldtruth import flight_of
    from dobwind.core.errors import CheckFailed
    from dobwind.model.airframe import load_airframe

    af = load_airframe(str(start))
    flights = [(str(csv), flight_of(str(csv), af, None))]
    try:
        logs, spans, verticals = windsolve.log_samples(af, flights, None)
    except CheckFailed as exc:
        return {"error": str(exc)}
    problem, result, _ = windsolve._solve_with_thrust_scale(af, logs, len(spans), verticals)
    condition, _ = windsolve.identification(result.x, problem)
    found = result.x[:2]
    true = _true_wind(csv, spans[0][1:])
    sigmas = _component_sigmas(result.x, problem)
    spanned = windsolve.coverage(logs, result.x[:2].reshape(1, 2))
    identified = not spanned.lacking() and condition <= windsolve.MAX_CONDITION
    return {"found": found.tolist(), "true": true.tolist(), "sigma": sigmas, "identified": identified,
            "z": {k: ((true - found) / np.array(v)).tolist() for k, v in sigmas.items() if k != "rho"}}


def table(rows: list[dict[str, Any]]) -> str:
    ok = [r for r in rows if "z" in r]
    lines = [f"{len(ok)} fits ({2 * len(ok)} wind components), {len(rows) - len(ok)} failed before the solve", "",
             "| 1-sigma | within 1 | within 2 | within 3 | median |z| | accepted (max 1-sigma <= 0.5) | accepted and |err| <= 2 sigma |",
             "|---|---|---|---|---|---|---|"]
    for name in SIGMAS:
        if any(name not in r["z"] for r in ok):
            continue
        z = np.abs(np.array([r["z"][name] for r in ok])).ravel()
        accepted = [r for r in ok if r["identified"] and max(r["sigma"][name]) <= 0.5]
        right = [r for r in accepted if max(np.abs(r["z"][name])) <= 2]
        lines.append(f"| {name} | {np.mean(z <= 1):.0%} | {np.mean(z <= 2):.0%} | {np.mean(z <= 3):.0%} | "
                     f"{np.median(z):.2f} | {len(accepted)}/{len(ok)} | {len(right)}/{len(accepted)} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--vehicles", nargs="*", default=sorted(f.name.split(".")[0] for f in VEHICLE_DIR.glob("*.vehicle.toml")))
    p.add_argument("--seeds", nargs="*", type=int, default=[1, 2, 3])
    p.add_argument("--scenarios", nargs="*", default=["box"], choices=["box", "outdoor"])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("-o", "--output", default="windsigma_out")
    args = p.parse_args(argv)
    out = Path(args.output)
    jobs = [(v, s, sc, str(out)) for sc in args.scenarios for s in args.seeds for v in args.vehicles]
    with ProcessPoolExecutor(args.workers) as pool:
        rows = list(pool.map(run_job, jobs))
    _write(out / "windsigma.json", json.dumps(rows, indent=1) + "\n")
    text = table(rows)
    _write(out / "windsigma.md", text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
