"""Whether thrust lag or topic timing explains the force `fit --wind unknown` leaves unexplained (issue #36;
the figures of docs/field-calibration.md, *Thrust lag and topic timing*):
``python -m tools.thrust_timing AIRFRAME LOG [--lags-ms ...] [--delays-ms ...] [--inject KIND:SECONDS]``.

The log is read as `fit` reads it (dobwind/calibrate/fieldtruth.py's ``flight_of``), then its thrust
columns (``thrust``, or ``rpm_*`` for a rotor-speed airframe) are passed through a first-order lag tau, or
its thrust or its attitude quaternion delayed by s (s > 0: the signal is taken s later than logged, as a
motor that follows its setpoint late would be), and the joint solve of dobwind/calibrate/windsolve.py is
run on it. For each change the table gives:

- fit band: the solve's own residual (measured minus predicted force, both through the observer and the
  0.15 Hz zero-phase low-pass of dobwind/calibrate/windrows.py), RMS and the robust scale (MAD) the
  refusal prints; this part is what biases the wind;
- observer band: the same residual without the low-pass (the observer's own bandwidth), RMS;
- vertical: the down force at the fit band after a least-squares fit of thrust scale, vertical drag and
  an offset (thrustscale's regressors), RMS; the thrust's magnitude shows most here;
- the wind found and its 1-sigma (the solve's identification test; the limit is 0.5 m/s); with
  ``--known`` the wind is given row by row (a SITL log's simulated wind, a simulated log's columns) and
  only the law fitted (no wind, no 1-sigma).

``--inject KIND:SECONDS`` first applies a known change (e.g. ``qdelay:-0.05``, the attitude logged
50 ms late) to check that the measurement finds one where it exists (a simulated log, whose thrust and
attitude are on time). A log with wind columns (a simulated one) also gets the wind's error against their
mean. Outside the package: a measurement, not a feature.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from dobwind.calibrate import dragfit, windrows, windsolve
from dobwind.calibrate.fieldtruth import LogTime, flight_of
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import Airframe, load_airframe
from dobwind.model.signals import log_signals

QUATERNION = ("q_w", "q_x", "q_y", "q_z")
KINDS = ("lag", "delay", "qdelay")   # thrust first-order lag, thrust delay, attitude delay
LABELS = {"lag": "thrust lag", "delay": "thrust delay", "qdelay": "attitude delay"}


def _filled(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x with every NaN replaced by the last finite value before it, or the first finite one at the
    start; the NaN mask): the filters below must not spread a ground row's NaN over the flight. The fill
    is the drag fit's own (dragfit._forward_fill), carrying the first finite value into the rows before it."""
    x = np.asarray(x, dtype=float)
    bad = ~np.isfinite(x)
    if bad.all():
        return x.copy(), bad
    return dragfit._forward_fill(x, ~bad, x[int(np.argmax(~bad))]), bad


def first_order_lag(t: np.ndarray, x: np.ndarray, tau_s: float) -> np.ndarray:
    """x through 1 / (1 + tau s), starting at rest at x's first value, exact for an input linear between
    the samples (first-order hold): a ramp comes out tau late, whatever the step. tau 0: x itself."""
    if tau_s <= 0:
        return np.asarray(x, dtype=float).copy()
    v, bad = _filled(x)
    y = np.empty_like(v)
    y[0] = v[0]
    for k in range(1, len(v)):
        dt = float(t[k] - t[k - 1])
        a = math.exp(-dt / tau_s)
        g = tau_s / dt * (1.0 - a)   # the hold's weight: a ramp's exact response
        y[k] = a * y[k - 1] + (1.0 - g) * v[k] + (g - a) * v[k - 1]
    y[bad] = np.nan
    return y


def delayed(t: np.ndarray, x: np.ndarray, delay_s: float) -> np.ndarray:
    """x(t - delay) by linear interpolation (held at the ends); NaN rows stay NaN."""
    v, bad = _filled(x)
    y = np.interp(np.asarray(t, dtype=float) - delay_s, t, v)
    y[bad] = np.nan
    return y


def retimed(log: FlightLog, af: Airframe, kind: str, seconds: float) -> FlightLog:
    """The log with its thrust columns lagged or delayed, or its attitude delayed (renormalised)."""
    cols = dict(log.columns)
    t = log.time_s
    signals = log_signals(af)
    thrust = list(signals.rpm_columns()) if signals.rotor_speeds else ["thrust"]
    if kind == "lag":
        cols |= {c: first_order_lag(t, cols[c], seconds) for c in thrust}
    elif kind == "delay":
        cols |= {c: delayed(t, cols[c], seconds) for c in thrust}
    elif kind == "qdelay":
        q = np.column_stack([delayed(t, cols[c], seconds) for c in QUATERNION])
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        cols |= {c: q[:, i] for i, c in enumerate(QUATERNION)}
    else:
        raise ValueError(f"unknown change {kind!r} (one of {', '.join(KINDS)})")
    return FlightLog(log.path, cols)


@dataclass(frozen=True)
class Row:
    kind: str
    seconds: float
    band_rms_n: float
    band_mad_n: float
    observer_rms_n: float
    vertical_n: float
    sigma_mps: float
    wind_ne: tuple[float, float]


def _vertical_rms(rows: windsolve.VerticalRows) -> float:
    """The fit band's down force about thrust scale, vertical drag and an offset, RMS (N)."""
    a = np.column_stack([rows.columns[rows.fitted], np.ones(int(rows.fitted.sum()))])
    y = rows.force_d[rows.fitted]
    coef, *_ = np.linalg.lstsq(a, y, rcond=None)
    return float(np.sqrt(np.mean((y - a @ coef) ** 2)))


def _samples(af: Airframe, path: str, flight: LogTime) -> tuple[list, list, np.ndarray, np.ndarray]:
    """windsolve.log_samples; the horizontal force before the low-pass (the first call of
    windrows.smooth per log, see windsolve._rows); and which of the log's rows they are (its ``ok``)."""
    raw: list[np.ndarray] = []
    used: list[np.ndarray] = []
    smooth, rows_of = windrows.smooth, windsolve._rows

    def recording(sos: np.ndarray, force: np.ndarray) -> np.ndarray:
        raw.append(np.array(force))
        return smooth(sos, force)

    def remembering(cal, log, force, ok, *rest):
        used.append(ok)
        return rows_of(cal, log, force, ok, *rest)

    windrows.smooth, windsolve._rows = recording, remembering
    try:
        logs, _, verticals = windsolve.log_samples(af, [(path, flight)], None)
    finally:
        windrows.smooth, windsolve._rows = smooth, rows_of
    return logs, verticals, raw[0], used[0]


def _solution(af: Airframe, logs: list, verticals: list, known: bool):
    """(problem, x, wind 1-sigma): the joint solve, or with the wind known (the rows' velocity made
    relative to it already) only the law at zero wind (the filtered force is linear in it:
    windsolve._linear_law) and no 1-sigma (NaN)."""
    if not known:
        problem, result, _ = windsolve._solve_with_thrust_scale(af, logs, 1, verticals)
        return problem, result.x, float(windsolve.identification(result.x, problem)[1][0])
    problem = windsolve._problem(af, logs, 1)
    winds = np.zeros((1, 2))
    return problem, np.r_[winds.ravel(), windsolve._linear_law(problem, winds)], math.nan


def measure(af: Airframe, path: str, flight: LogTime, kind: str, seconds: float,
            known: np.ndarray | None = None) -> Row:
    """The joint solve on the retimed log, or with ``known`` ((N, 2) north/east wind on the log's rows)
    the law alone at that wind; its residuals (module text)."""
    changed = LogTime(retimed(flight.log, af, kind, seconds), flight.t0_s)
    logs, verticals, raw, ok = _samples(af, path, changed)
    if known is not None:
        # the airflow is w - v: the ground velocity less the known wind is the airflow at zero wind
        logs = [dataclasses.replace(logs[0], vel=logs[0].vel - known[ok])]
    problem, x, sigma = _solution(af, logs, verticals, known is not None)
    data = problem.data(x)
    rows = logs[0]
    winds = x[:2].reshape(1, 2)
    law = dict(zip(windsolve.LAW, x[2:])) | {"kappa": problem.kappa}
    predicted = windrows.through_observer(rows.path, windrows.law_force_ne(rows, winds, law))
    wide = (raw - predicted)[rows.fitted]
    found = (float(winds[0, 0]), float(winds[0, 1])) if known is None else (math.nan, math.nan)
    return Row(kind, seconds, float(np.sqrt(np.mean(data ** 2))),
               1.4826 * float(np.median(np.abs(data - np.median(data)))), float(np.sqrt(np.mean(wide ** 2))),
               _vertical_rms(verticals[0]), sigma, found)


def _line(row: Row, weight_n: float, truth: tuple[float, float] | None) -> str:
    error = "" if truth is None else f" {math.hypot(row.wind_ne[0] - truth[0], row.wind_ne[1] - truth[1]):.2f} |"
    return (f"| {LABELS[row.kind]} {1000 * row.seconds:+.0f} ms | {row.band_rms_n:.3f} ({row.band_rms_n / weight_n:.2%}) "
            f"| {row.band_mad_n:.3f} | {row.observer_rms_n:.3f} ({row.observer_rms_n / weight_n:.2%}) | "
            f"{row.vertical_n:.3f} | {row.sigma_mps:.2f} | {row.wind_ne[0]:+.2f}, {row.wind_ne[1]:+.2f} |{error}")


def _known_wind(spec: str | None, path: str, flight: LogTime) -> np.ndarray | None:
    """(N, 2) the known north/east wind on the log's rows (``--known``), or None."""
    if spec is None:
        return None
    if spec == "sitl":
        from dobwind.calibrate.sitlwind import SitlTruth

        return SitlTruth().wind(path, flight)[0][:, :2]
    if spec == "columns":
        return np.column_stack([flight.log.columns["wind_n"], flight.log.columns["wind_e"]])
    return np.tile([float(v) for v in spec.split(",")], (flight.log.rows, 1))


def _arguments() -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="python -m tools.thrust_timing", description=__doc__.split("\n\n")[0])
    p.add_argument("airframe")
    p.add_argument("log")
    p.add_argument("--lags-ms", type=float, nargs="*", default=[0, 10, 20, 40, 60, 80, 120])
    p.add_argument("--delays-ms", type=float, nargs="*", default=[-100, -50, -20, 20, 50, 100])
    p.add_argument("--inject", help="KIND:SECONDS applied first (KIND: lag, delay, qdelay)")
    p.add_argument("--known", help="the wind is known, fit only the law: 'sitl' (an ArduPilot SITL log's "
                   "SIM_WIND_*), 'columns' (a simulated log's wind_n, wind_e) or N,E m/s")
    return p.parse_args()


def main() -> None:
    args = _arguments()
    af = load_airframe(args.airframe)
    flight = flight_of(args.log, af, None)
    if args.inject:
        kind, seconds = args.inject.split(":")
        flight = LogTime(retimed(flight.log, af, kind, float(seconds)), flight.t0_s)
    cols = flight.log.columns
    truth = (float(np.nanmean(cols["wind_n"])), float(np.nanmean(cols["wind_e"]))) if "wind_n" in cols else None
    plan = [("lag", ms / 1000) for ms in args.lags_ms]
    plan += [(kind, ms / 1000) for kind in ("delay", "qdelay") for ms in args.delays_ms]
    weight = af.mass_kg * af.gravity_mps2
    print(f"{args.log}: weight {weight:.1f} N" + (f", true mean wind {truth[0]:+.2f}, {truth[1]:+.2f} m/s" if truth else ""))
    print("| change | fit band RMS N (of weight) | fit band MAD N | observer band RMS N (of weight) | vertical N "
          "| wind 1-sigma m/s | wind N, E m/s |" + (" wind error m/s |" if truth else ""))
    print("|---|---|---|---|---|---|---|" + ("---|" if truth else ""))
    known = _known_wind(args.known, args.log, flight)
    for kind, seconds in plan:
        print(_line(measure(af, args.log, flight, kind, seconds, known), weight, truth), flush=True)


if __name__ == "__main__":
    main()
