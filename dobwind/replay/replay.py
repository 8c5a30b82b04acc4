"""`dobwind replay`: the estimator over a whole log, with error metrics when the log has true wind.

The backends are ``dobwind.replay.backends``, the error metrics ``dobwind.replay.scoring``; this module runs a log
through them and reports."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, TextIO

import numpy as np

from dobwind.replay.backends import Runner, run_backend
from dobwind.replay.rejections import breakdown, count_rejections
from dobwind.io.csvchunks import BLOCK_BYTES
from dobwind.io.logs import (TRUTH_BOUNDS, FlightLog, estimate_rows, estimate_writer, iter_log, read_log,
                          required_columns, step_inputs, write_estimates)
from dobwind.model.airframe import Airframe
from dobwind.model.reference import Trajectory
from dobwind.model.status import STATUS_LANDED, STATUS_NO_DATA, accepted
from dobwind.model.step import StepModel, build_step
from dobwind.replay.scoring import (MIN_SPEED_FOR_DIRECTION, SEGMENT_SETTLE_S, UNIT_KEYS, WARMUP_S,  # noqa: F401 (re-exported)
                             WindScore, with_unit_keys)
from dobwind.model.kinds import Precision


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
    scorer = WindScore()
    scorer.add(log.time_s, wind, truth, status, log.columns.get("segment"))
    return scorer.result()


def replay(af: Airframe, log_path: str, backend: str = "python", precision: Precision = Precision.SINGLE):
    """The whole log in memory: (model, log, trajectory). The command streams with ``replay_stream``."""
    model = build_step(af)
    log = read_log(log_path, required_columns(af), TRUTH_BOUNDS)  # true wind bounded as fit bounds it
    traj = run_backend(model, step_inputs(model, log), backend, precision)
    return model, log, traj


@dataclass(frozen=True)
class Streamed:
    model: StepModel
    metrics: dict                 # replay's metrics (rows and rejected rows when the log has no true wind)
    scored: bool                  # the log had true wind
    series: WindSeries | None     # time, estimate, truth and status of every row, when asked for (plots)
    findings: tuple = ()          # plausibility findings (dobwind.replay.plausibility), warnings only: rows are written


@dataclass(frozen=True)
class WindSeries:
    t: np.ndarray
    wind: np.ndarray
    truth: np.ndarray | None


def replay_stream(af: Airframe, log_path: str, backend: str = "python", precision: Precision = Precision.SINGLE,
                  output: TextIO | None = None, keep_series: bool = False,
                  progress: Callable[[int], None] | None = None, block_bytes: int = BLOCK_BYTES) -> Streamed:
    """replay() in bounded memory: the log is read, stepped, scored and written chunk by chunk."""
    model = build_step(af)
    runner = Runner(model, backend, precision)
    writer = estimate_writer(output) if output is not None else None
    scorer, counts = WindScore(), {"rows": 0, "rejected_rows": 0}
    kept: list[tuple[np.ndarray, ...]] = []
    previous_t: float | None = None
    truth = None
    rejections: dict[str, int] = {}  # rows per rejection bit (dobwind/replay/rejections.py)
    estimated = False  # an accepted row was written: later rows keep the step's held estimate
    from dobwind.replay.plausibility import FlightSeries, StreamedChecks

    checks = StreamedChecks(af)
    # True wind beyond +-100 m/s is an export error (1e308 overflowed the scoring's sums): refused in one
    # line, as fit refuses it (dobwind/io/logs.py, TRUE_WIND_MAX_MPS).
    for chunk in iter_log(log_path, required_columns(af), block_bytes, progress, TRUTH_BOUNDS):
        log = chunk.log
        traj = runner.run(step_inputs(model, log, previous_t))
        checks.add(FlightSeries.replayed(log, traj.outputs[:, model.outputs.slice("force_ned")],
                                         traj.outputs[:, model.outputs.slice("wind_ned")], traj.status), log)
        previous_t = float(log.time_s[-1])
        wind, truth = traj.outputs[:, model.outputs.slice("wind_ned")], log.true_wind
        if truth is not None:
            scorer.add(log.time_s, wind, truth, traj.status, log.columns.get("segment"))
        counts["rows"] += log.rows
        counts["rejected_rows"] += int((~accepted(traj.status)).sum())
        rejections = count_rejections(traj.status, rejections)
        if writer is not None:
            writer.write(estimate_rows(log.time_s, traj.outputs, traj.status, estimated))
        estimated = estimated or bool(accepted(traj.status).any())
        if keep_series:
            kept.append((log.time_s, wind, truth))
    series = None
    if keep_series:
        series = WindSeries(np.concatenate([k[0] for k in kept]), np.concatenate([k[1] for k in kept]),
                            None if truth is None else np.concatenate([k[2] for k in kept]))
    metrics = {**(scorer.result() if truth is not None else counts), "rejections": rejections}
    return Streamed(model, metrics, truth is not None, series, tuple(checks.findings()))


def replay_ulog(af: Airframe, path: str, backend: str = "python", precision: Precision = Precision.SINGLE,
                rate_hz: float | None = None, topics: dict[str, str] | None = None, bridge_gaps: bool = True):
    """An autopilot log (PX4 ULog, ArduPilot DataFlash, ROS 2 bag; by its name) through the estimator:
    (model, flight, trajectory); rows without data carry the NO_DATA status bit, rows on the ground
    LANDED, instead of the step's own rejection. ``bridge_gaps``: short silences do not restart the
    settling (dobwind/io/bridge.py); False replays as before it (every NO_DATA row rejected)."""
    from dobwind.io.autopilot import read_autopilot
    from dobwind.io.bridge import hold_bridged

    model = build_step(af)
    flight = read_autopilot(path, af, rate_hz, topics, bridge_gaps=bridge_gaps)
    traj = run_backend(model, step_inputs(model, flight.log), backend, precision)
    # Rows that were not fed carry only replay's reasons, not the step's reaction to their NaN inputs.
    # Bridged rows were fed (the observer runs on) but are NO_DATA too, with the estimate from before.
    skipped = np.where(flight.no_data, STATUS_NO_DATA, 0) | np.where(flight.landed, STATUS_LANDED, 0)
    status = np.where(skipped != 0, skipped, traj.status)
    outputs = traj.outputs if flight.bridged is None else hold_bridged(traj.outputs, flight.bridged)
    flight, status = _plausibility(af, model, path, flight, outputs, status)
    return model, flight, Trajectory(traj.states, outputs, status)


def _plausibility(af: Airframe, model: StepModel, path: str, flight, outputs: np.ndarray, status: np.ndarray):
    """Replay's plausibility checks (dobwind.replay.plausibility): SUSPECT on the rows concerned, a warning
    (stderr) and a note per finding."""
    import dataclasses

    from dobwind.replay.plausibility import FlightSeries, acceleration_input, check_flight, mark

    log = flight.log
    series = FlightSeries.replayed(log, outputs[:, model.outputs.slice("force_ned")],
                                   outputs[:, model.outputs.slice("wind_ned")], status)
    findings = check_flight(af, series)
    findings += [f for f in (acceleration_input(af, log, status),) if f is not None]
    if not findings:
        return flight, status
    return dataclasses.replace(
        flight, findings=tuple(findings),
        notes=flight.notes + tuple(f"plausibility ({f.check}): {f.message}: status SUSPECT on {int(f.rows.sum())} "
                                   "rows" for f in findings),
        warnings=flight.warnings + tuple(f"{path}: {f.message}" for f in findings)), mark(status, findings)


def autopilot_summary(name: str, log_path: str, backend: str, model: StepModel, flight, traj: Trajectory) -> dict:
    """What `replay` reports for an autopilot log (no true wind): rows, status counts, the mean estimated
    horizontal wind, and the comparison with the autopilot's own wind when the log has one."""
    from dobwind.model.status import describe
    from dobwind.io.ulog import compare_with_px4

    log = flight.log
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    valid = accepted(traj.status)  # quality-flagged samples are estimates too; status_counts shows the flags
    summary = {"airframe": name, "log": log_path, "backend": backend, "rows": log.rows,
               "valid_rows": int(valid.sum()), "duration_s": float(log.time_s[-1]), "log_t0_s": flight.t0_s,
               "notes": list(flight.notes),
               "warnings": list(flight.warnings),
               "status_counts": {describe(int(s)): int((traj.status == s).sum()) for s in np.unique(traj.status)},
               "mean_wind_speed_h_mps": float(np.mean(np.hypot(wind[valid, 0], wind[valid, 1]))) if valid.any() else None,
               "outputs_finite": bool(np.all(np.isfinite(traj.outputs)))}
    summary["plausibility"] = [f.as_dict() for f in flight.findings]
    if flight.px4_wind is not None:
        summary["px4"] = compare_with_px4(log.time_s, wind, valid, flight.px4_wind, flight.autopilot_wind_variance)
    if flight.sitl is not None:  # an ArduPilot SITL log: the wind its simulator was told to blow
        from dobwind.model.airframe import VERTICAL_FALLBACK
        from dobwind.replay.sitlcompare import sitl_summary

        summary["sitl_wind"] = sitl_summary(flight.sitl, log.time_s + flight.t0_s, wind, traj.status,
                                            model.airframe.vertical_law != VERTICAL_FALLBACK)[0]
    return summary


def autopilot_plot(path: str, title: str, flight, wind: np.ndarray, status: np.ndarray) -> None:
    """replay --plot for an autopilot log: on the log's own clock, status shading, the autopilot's wind
    only where it is active."""
    from dobwind.io.plots import LOG_CLOCK_LABEL, replay_plot

    ref, band = reference_lines(flight)
    clock = flight.log.time_s + flight.t0_s
    replay_plot(clock, np.where(accepted(status)[:, None], wind, np.nan), sitl_truth(flight), title, path,
                [] if ref is None else [ref], status=status, band=band, truth_label=SITL_LABEL,
                time_label=LOG_CLOCK_LABEL)


SITL_LABEL = "simulator wind (SIM_WIND_*)"


def sitl_truth(flight) -> np.ndarray | None:
    """The simulator's wind on every row of an ArduPilot SITL log (NED), None for any other log."""
    if flight.sitl is None:
        return None
    from dobwind.io.sitlwind import sitl_wind_ned

    return sitl_wind_ned(flight.sitl, flight.log.time_s + flight.t0_s)


def reference_lines(flight):
    """The autopilot's wind for a figure, on the log's clock and only where active, and the band of its
    own 1-sigma (PX4's variances), each None when there is nothing to draw."""
    from dobwind.io.resample import active_reference, speed_band

    if flight.autopilot_wind is None:
        return None, None
    source, t_ref, w_ref = flight.autopilot_wind
    label = source if " " in source else f"PX4 ({source})"
    ref = active_reference(label, (source, t_ref + flight.t0_s, w_ref))
    band = speed_band(flight.autopilot_wind, flight.autopilot_wind_variance, flight.t0_s)
    return ref, None if band is None else (f"{label} +-1 sigma (its variances)", *band)


def autopilot_wind_lines(px4: dict | None) -> list[str]:
    """The text lines comparing with the autopilot's own wind (compare_with_px4's dict)."""
    if not px4:
        return []
    label = px4["topic"] if " " in px4["topic"] else f"PX4 {px4['topic']}"  # ArduPilot/ROS name themselves
    if px4.get("active") is False:
        return [f"{label}: all zero, the autopilot was not estimating wind (no comparison)"]
    if not px4.get("overlap_rows"):
        return [f"{label}: no overlap with valid estimates"]
    lines = [f"{label}: mean vector difference {px4['mean_vector_difference_mps']:.2f} m/s (difference of the means "
             f"{px4['difference_of_means_mps']:.2f} m/s), mean speed difference (ours - theirs) "
             f"{px4['mean_speed_difference_mps']:+.2f} m/s over {px4['overlap_rows']} instants"]
    if "mean_wind_ours_speed_mps" in px4:
        lines.append(f"  mean wind: ours {_speed_from(px4, 'ours')}, theirs {_speed_from(px4, 'theirs')}"
                     + ("" if px4["direction_difference_deg"] is None
                        else f"; direction {px4['direction_difference_deg']:+.0f} deg"))
    if "sigma_h_mps" in px4:
        lines.append(f"  its own variances there: north {px4['variance_north_m2s2']:.3g}, east {px4['variance_east_m2s2']:.3g} "
                     f"m²/s² (horizontal 1-sigma {px4['sigma_h_mps']:.2f} m/s)")
    return lines


def _speed_from(px4: dict, who: str) -> str:
    """'S m/s from D deg' of one mean wind of compare_with_px4's dict (no direction below 0.1 m/s)."""
    speed, from_deg = px4[f"mean_wind_{who}_speed_mps"], px4[f"mean_wind_{who}_from_deg"]
    return f"{speed:.2f} m/s" + ("" if from_deg is None else f" from {from_deg:.0f} deg")


def text_report(metrics: dict) -> str:
    lines = [f"rows {metrics['rows']}, scored {metrics['scored_rows']}, rejected {metrics['rejected_rows']}"
             + breakdown(metrics.get("rejections", {}))]
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


def write_output(path: str, log: FlightLog, traj: Trajectory, t0_s: float = 0.0) -> None:
    """The estimate CSV; ``t0_s`` puts `t` on the log's own clock (AutopilotFlight.t0_s)."""
    write_estimates(path, log.time_s, traj.outputs, traj.status, t0_s)


replay_autopilot = replay_ulog  # every autopilot format goes through the same path
