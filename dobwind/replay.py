"""`dobwind replay`: the estimator over a whole log, with error metrics when the log has true wind."""
from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.logs import FlightLog, required_columns, read_log, step_inputs, write_estimates
from dobwind.model import reference
from dobwind.model.airframe import Airframe
from dobwind.model.reference import Trajectory
from dobwind.model.status import STATUS_LANDED, STATUS_NO_DATA, accepted, trusted
from dobwind.model.step import StepModel, build_step

WARMUP_S = 5.0           # the observer and filter start up: not scored
SEGMENT_SETTLE_S = 5.0   # the start of every segment (a transition) is not scored per segment
MIN_SPEED_FOR_DIRECTION = 1.0


def run_backend(model: StepModel, inputs: np.ndarray, backend: str, precision: str = "single") -> Trajectory:
    if backend == "python":
        return reference.run(model, inputs)
    from dobwind.harness.cstep import compile_step

    with tempfile.TemporaryDirectory(prefix="dobwind-replay-") as tmp:
        cstep = compile_step(model, precision, Path(tmp))
        if precision == "single":
            inputs = inputs.astype(np.float32).astype(np.float64)
        return cstep.run(inputs, keep_states=False)


def _wrap_deg(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def _from_deg(wind: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(-wind[:, 1], -wind[:, 0])) % 360.0


@dataclass(frozen=True)
class Errors:
    speed_mean: float
    speed_max: float
    direction_mean: float | None
    direction_max: float | None
    vertical_mean: float
    vertical_max: float
    count: int


def _stats(est: np.ndarray, true: np.ndarray) -> Errors:
    speed_err = np.abs(np.hypot(est[:, 0], est[:, 1]) - np.hypot(true[:, 0], true[:, 1]))
    vert_err = np.abs(est[:, 2] - true[:, 2])
    strong = np.hypot(true[:, 0], true[:, 1]) >= MIN_SPEED_FOR_DIRECTION
    dir_err = np.abs(_wrap_deg(_from_deg(est[strong]) - _from_deg(true[strong])))
    return Errors(float(speed_err.mean()), float(speed_err.max()),
                  float(dir_err.mean()) if dir_err.size else None, float(dir_err.max()) if dir_err.size else None,
                  float(vert_err.mean()), float(vert_err.max()), len(est))


def score(log: FlightLog, traj: Trajectory, model: StepModel) -> dict:
    """Errors against the log's true wind: per sample after the warm-up, and per segment (the means
    of estimate and truth over each segment after its transition), when the log has segments."""
    return score_wind(log, traj.outputs[:, model.outputs.slice("wind_ned")], traj.status)


def score_wind(log: FlightLog, wind: np.ndarray, status: np.ndarray) -> dict:
    """score() for any wind estimate (NED rows) with its status per row. Every accepted row after the
    warm-up is scored, quality-flagged ones included (a hold beyond the calibration is scored on purpose);
    ``trusted_share`` is the fraction of scored rows with status 0."""
    truth = log.true_wind
    assert truth is not None
    t = log.time_s
    valid = accepted(status) & (t >= t[0] + WARMUP_S)
    result: dict = {"rows": log.rows, "scored_rows": int(valid.sum()), "rejected_rows": int((~accepted(status)).sum())}
    if valid.any():
        result["trusted_share"] = float(np.mean(trusted(status[valid])))
    if not valid.any():
        return result
    result["per_sample"] = _stats(wind[valid], truth[valid]).__dict__
    result["mean_estimated_wind"] = {
        "horizontal_mps": float(np.mean(np.hypot(wind[valid, 0], wind[valid, 1]))),
        "vertical_mps": float(np.mean(np.abs(wind[valid, 2]))),
        "true_horizontal_mps": float(np.mean(np.hypot(truth[valid, 0], truth[valid, 1]))),
    }
    if log.has("segment"):
        seg = log.columns["segment"]
        rows = []
        # One sort instead of a mask per segment: an hour-long sweep has hundreds of segments.
        order = np.argsort(seg, kind="stable")
        labels, first = np.unique(seg[order], return_index=True)
        for s, lo, hi in zip(labels, first, np.r_[first[1:], len(order)]):
            members = order[lo:hi]
            start = t[members[0]]
            use = members[valid[members] & (t[members] >= start + SEGMENT_SETTLE_S)]
            if use.size < 10:
                continue
            est_mean, true_mean = wind[use].mean(axis=0), truth[use].mean(axis=0)
            est_speed, true_speed = math.hypot(*est_mean[:2]), math.hypot(*true_mean[:2])
            direction = (abs(float(_wrap_deg(_from_deg(est_mean[None])[0] - _from_deg(true_mean[None])[0])))
                         if true_speed >= MIN_SPEED_FOR_DIRECTION else None)
            rows.append({"segment": int(s), "true_speed": true_speed, "est_speed": est_speed,
                         "speed_error": est_speed - true_speed, "direction_error": direction,
                         "vertical_error": float(est_mean[2] - true_mean[2]), "samples": int(use.size)})
        if rows:
            speed = np.abs([r["speed_error"] for r in rows])
            dirs = np.array([r["direction_error"] for r in rows if r["direction_error"] is not None])
            vert = np.abs([r["vertical_error"] for r in rows])
            result["per_segment"] = {
                "segments": len(rows), "speed_mean": float(speed.mean()), "speed_max": float(speed.max()),
                "direction_mean": float(dirs.mean()) if dirs.size else None,
                "direction_max": float(dirs.max()) if dirs.size else None,
                "vertical_mean": float(vert.mean()), "vertical_max": float(vert.max()), "table": rows,
            }
    return result


def replay(af: Airframe, log_path: str, backend: str = "python", precision: str = "single"):
    model = build_step(af)
    log = read_log(log_path, required_columns(af))
    traj = run_backend(model, step_inputs(model, log), backend, precision)
    return model, log, traj


def replay_ulog(af: Airframe, path: str, backend: str = "python", precision: str = "single",
                rate_hz: float | None = None, topics: dict[str, str] | None = None):
    """An autopilot log (PX4 ULog, ArduPilot DataFlash, ROS 2 bag; by its name) through the estimator:
    (model, flight, trajectory); rows without data carry the NO_DATA status bit, rows on the ground
    LANDED, instead of the step's own rejection."""
    from dobwind.autopilot import read_autopilot

    model = build_step(af)
    flight = read_autopilot(path, af, rate_hz, topics)
    traj = run_backend(model, step_inputs(model, flight.log), backend, precision)
    # Rows that were not fed carry only replay's reasons, not the step's reaction to their NaN inputs.
    skipped = np.where(flight.no_data, STATUS_NO_DATA, 0) | np.where(flight.landed, STATUS_LANDED, 0)
    status = np.where(skipped != 0, skipped, traj.status)
    return model, flight, Trajectory(traj.states, traj.outputs, status)


def text_report(metrics: dict) -> str:
    lines = [f"rows {metrics['rows']}, scored {metrics['scored_rows']}, rejected {metrics['rejected_rows']}"]
    if "per_sample" in metrics:
        p = metrics["per_sample"]
        direction = ("n/a" if p["direction_mean"] is None else f"{p['direction_mean']:.2f} / {p['direction_max']:.2f} deg")
        lines.append(f"per sample:  speed error mean/max {p['speed_mean']:.3f} / {p['speed_max']:.3f} m/s, "
                     f"direction {direction}, vertical {p['vertical_mean']:.3f} / {p['vertical_max']:.3f} m/s")
        w = metrics["mean_estimated_wind"]
        lines.append(f"mean estimated wind: horizontal {w['horizontal_mps']:.3f} m/s (true {w['true_horizontal_mps']:.3f}), "
                     f"|vertical| {w['vertical_mps']:.3f} m/s")
    if "per_segment" in metrics:
        s = metrics["per_segment"]
        direction = ("n/a" if s["direction_mean"] is None else f"{s['direction_mean']:.2f} / {s['direction_max']:.2f} deg")
        lines.append(f"per segment ({s['segments']} segments, means after {SEGMENT_SETTLE_S:g} s): speed error mean/max "
                     f"{s['speed_mean']:.3f} / {s['speed_max']:.3f} m/s, direction {direction}, vertical "
                     f"{s['vertical_mean']:.3f} / {s['vertical_max']:.3f} m/s")
        lines.append("  segment  true m/s  est m/s  error m/s  dir err deg  vert err m/s")
        for r in s["table"][:40]:
            d = "-" if r["direction_error"] is None else f"{r['direction_error']:.2f}"
            lines.append(f"  {r['segment']:7d}  {r['true_speed']:8.2f}  {r['est_speed']:7.2f}  {r['speed_error']:+9.3f}  "
                         f"{d:>11s}  {r['vertical_error']:+12.3f}")
        if len(s["table"]) > 40:
            lines.append(f"  ... {len(s['table']) - 40} more segments (--json has them all)")
    return "\n".join(lines)


def write_output(path: str, log: FlightLog, traj: Trajectory) -> None:
    write_estimates(path, log.time_s, traj.outputs, traj.status)


replay_autopilot = replay_ulog  # every autopilot format goes through the same path
