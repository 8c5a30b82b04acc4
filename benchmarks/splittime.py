"""A held-out check of a field calibration on one ArduPilot SITL log (issue #36), `fieldcal --split-time`.

The issue's goal (calibrated on one SITL flight, replayed against others) needs several flights; with one
log the fair proxy is to split it in time: fit on one half of the airborne time against the wind the
simulator was given (`fit --truth sitl`, dobwind/calibrate/sitlwind.py), replay the whole log through
the fitted airframe and compare each half with that wind. The half the fit never saw tells whether the
model carries beyond its own rows; the training half is the reference. Then the other way round.

The halves are cut at the median airborne instant, on the log's own clock, by the reader's time window
(dobwind/io/timewindow.py), so the fit sees the rows replay would give it and nothing else. A fit that
refuses (its self-check, or too little data) is a result: its reasons are reported, and the model it
would have written is replayed anyway under ``forced`` (what `fit --force` gives), never as a pass.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import sys
import tempfile

import numpy as np

from dobwind.calibrate.fieldtruth import LogTime, truth_reader
from dobwind.calibrate.sitlwind import SitlTruth, read_sitl_log, sitl_wind_ned
from dobwind.core.errors import CheckFailed, InputError
from dobwind.io.autopilot import read_autopilot
from dobwind.io.logs import FlightLog
from dobwind.io.timewindow import TimeWindow
from dobwind.model.airframe import Airframe, load_airframe
from dobwind.model.forceair import wind_from_deg
from dobwind.model.status import accepted, describe, trusted
from dobwind.replay.replay import replay_ulog, sitl_truth
from dobwind.replay.scoring import wrap_deg

HALVES = ("first", "second")


def airborne_split_s(af: Airframe, log: str) -> float:
    """The log-clock instant with half the airborne rows before it (the replay's airborne rows)."""
    flight = read_autopilot(log, af, bridge_gaps=True)
    airborne = (flight.log.time_s + flight.t0_s)[~flight.landed]
    if len(airborne) < 2:
        raise CheckFailed(f"{log}: fewer than two airborne rows, nothing to split")
    return float(airborne[len(airborne) // 2])


def halves(split_s: float) -> dict[str, TimeWindow]:
    return {"first": TimeWindow(-math.inf, split_s), "second": TimeWindow(split_s, math.inf)}


@dataclasses.dataclass(frozen=True)
class WindowFit:
    """One fit on a window: the airframe it gives (written or, refused, what --force would write)."""
    airframe: Airframe | None
    refused: str | None       # None: the self-check passed
    self_check: dict | None   # per-log figures of the fit's own self-check


def fit_window(af: Airframe, log: str, window: TimeWindow, model: str = "auto") -> WindowFit:
    """`fit START LOG --truth sitl` on the rows of ``window`` only, in-process."""
    from dobwind.calibrate.fitfamily import fit_airframe
    from dobwind.model.airframe import parse_airframe
    from dobwind.model.airframe_toml import dump_airframe

    try:
        new, report, _ = fit_airframe(af, [log], model=model, log_reader=truth_reader(SitlTruth(), None, window),
                                      direction_shape=SitlTruth.direction_shape)
    except CheckFailed as exc:  # too little to fit at all: nothing to replay
        return WindowFit(None, str(exc), None)
    # Through the TOML text as `fit` writes it and `replay` loads it, rounding included; `fit` refuses to
    # write a text the loader would refuse (cli/fit.py, refuse_out_of_range), and so does this.
    try:
        fitted = parse_airframe(dump_airframe(new), f"fitted on {window.describe()}")
    except InputError as exc:
        return WindowFit(None, f"the fitted airframe would be refused: {exc}", None)
    check = report.self_check
    refused = None if check.passed else "; ".join(check.reasons)
    record = {"passed": bool(check.passed), "reasons": list(check.reasons), "family": report.model,
              "law": fitted.force_air_model, "replay_speed_rms_mps": [c.speed_rms_mps for c in check.logs]}
    if report.model == "polynomial":  # its steady points (the drag families count samples, not points)
        record.update(points=report.points, airflow_directions_of_12=report.directions, airflow_speeds=report.speeds)
    return WindowFit(fitted, refused, record)


def half_figures(wind: np.ndarray, truth: np.ndarray, status: np.ndarray, rows: np.ndarray) -> dict:
    """The estimate against the truth over ``rows`` (one half's airborne rows): over the accepted rows
    (quality-flagged included, as replay's mean) and over the trusted ones."""
    ok, good = accepted(status) & rows, trusted(status) & rows
    untrusted = status[rows & ~good]
    mix = {describe(int(s)): int((untrusted == s).sum()) for s in np.unique(untrusted)}
    return {"airborne_rows": int(rows.sum()), "trusted_rows": int(good.sum()), "accepted_rows": int(ok.sum()),
            "untrusted_status": dict(sorted(mix.items(), key=lambda kv: -kv[1])),
            "accepted": _errors(wind[ok], truth[ok]), "trusted": _errors(wind[good], truth[good])}


def _errors(wind: np.ndarray, truth: np.ndarray) -> dict | None:
    """Mean horizontal speed error (estimate - truth) and the angle between the mean vectors."""
    if len(wind) == 0:
        return None
    est, true = wind[:, :2].mean(axis=0), truth[:, :2].mean(axis=0)
    est_from, true_from = float(wind_from_deg(*est)), float(wind_from_deg(*true))
    return {"rows": len(wind), "truth_mean_speed_mps": float(np.mean(np.hypot(truth[:, 0], truth[:, 1]))),
            "speed_error_mps": float(np.mean(np.hypot(wind[:, 0], wind[:, 1])) - np.mean(np.hypot(truth[:, 0], truth[:, 1]))),
            "estimate_from_deg": est_from, "truth_from_deg": true_from,
            "direction_error_deg": abs(float(wrap_deg(est_from - true_from)))}


def flight_figures(log: FlightLog, truth: np.ndarray, rows: np.ndarray) -> dict:
    """What the vehicle did over ``rows``: ground and vertical speed, speed through the (true) air, and
    where the airflow met it: the median angle of its motion through the air off the nose (0: nose
    first, the airflow from ahead; 180: from behind)."""
    vel = log.stack("vel_n", "vel_e", "vel_d")[rows]
    through_air = vel[:, :2] - truth[rows, :2]
    w, x, y, z = (log.columns[f"q_{c}"][rows] for c in "wxyz")
    yaw = np.degrees(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
    off_nose = (np.degrees(np.arctan2(through_air[:, 1], through_air[:, 0])) - yaw + 180.0) % 360.0 - 180.0
    return {"ground_speed_mps": float(np.mean(np.hypot(vel[:, 0], vel[:, 1]))),
            "climb_rate_mps": float(-np.mean(vel[:, 2])),
            "air_speed_h_mps": float(np.mean(np.hypot(through_air[:, 0], through_air[:, 1]))),
            "airflow_off_nose_median_deg": float(np.median(np.abs(off_nose))),
            "heading_median_deg": float(np.median(yaw) % 360.0)}


def replay_halves(af: Airframe, log: str, windows: dict[str, TimeWindow]) -> dict[str, dict]:
    """The whole log replayed through ``af``; each window's airborne rows scored against SITL's wind."""
    model, flight, traj = replay_ulog(af, log)
    clock = LogTime(flight.log, flight.t0_s).clock_s
    truth = sitl_truth(flight)  # the DataFlash reader loaded the SITL parameters with the log
    if truth is None:  # it found no usable SITL wind: the truth's own reader says what is missing (exit 2)
        truth = sitl_wind_ned(read_sitl_log(log), clock)
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    airborne = ~flight.landed
    halves_rows = {name: airborne & w.mask(clock) for name, w in windows.items()}
    return {name: {**half_figures(wind, truth, traj.status, rows), "flight": flight_figures(flight.log, truth, rows)}
            for name, rows in halves_rows.items()}


def split_check(af: Airframe, log: str, model: str = "auto", order: tuple[str, ...] = HALVES) -> list[dict]:
    """Fitted on each half in ``order``: the fit's verdict and the figures of both halves, the held-out
    one named. ``af``: the starting airframe (dobwind init's prior)."""
    split = airborne_split_s(af, log)
    windows = halves(split)
    rows = []
    for trained in order:
        fit = fit_window(af, log, windows[trained], model)
        held_out = next(h for h in HALVES if h != trained)
        row = {"log": log, "split_s": split, "fitted_on": trained, "window": windows[trained].describe(),
               "refused": fit.refused, "self_check": fit.self_check}
        if fit.airframe is not None:
            figures = replay_halves(fit.airframe, log, windows)
            key = "forced" if fit.refused else "result"
            row[key] = {"held_out": {"half": held_out, **figures[held_out]},
                        "training": {"half": trained, **figures[trained]}}
        rows.append(row)
    return rows


def run_split_time(log: str, mass_kg: float) -> dict:
    """`dobwind init LOG --mass KG`, then split_check on the starter; the starter's own replay per half
    beside it (what the fit must beat; its rows carry UNCALIBRATED, so none is trusted)."""
    from dobwind.cli.app import main as dobwind

    with tempfile.TemporaryDirectory() as tmp:
        start = os.path.join(tmp, "start.toml")
        with contextlib.redirect_stdout(sys.stderr):  # init's summary: stdout stays the JSON
            code = dobwind(["init", log, "--mass", f"{mass_kg:g}", "-o", start])
        if code != 0:  # init has said why in one stderr line; its exit code (2: e.g. a bad --mass) stands
            raise SystemExit(code)
        starter = load_airframe(start)
    fits = split_check(starter, log)
    prior = replay_halves(starter, log, halves(fits[0]["split_s"]))
    return {"log": log, "mass_kg": mass_kg, "split_s": fits[0]["split_s"], "init_prior": prior, "fits": fits}
