"""`dobwind report AIRFRAME LOG -o report.html`: one self-contained HTML page for a flight.

The airframe's summary, the estimate against the log's true wind (or against the autopilot's own wind
estimate, where it is active, in a ULog, DataFlash log or ROS 2 bag, on the log's own clock), the error
tables, the status counts by flag, and the analysis figures. Figures are
PNGs inlined as base64 data URIs and the style is inline, so the file opens anywhere with no server and
no network (in the spirit of PX4 Flight Review, which needs both)."""
from __future__ import annotations

import base64
import sys
import tempfile
from dataclasses import dataclass
from datetime import datetime, timezone
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from dobwind.model.airframe import Airframe
from dobwind.model.status import STATUS_BITS, STATUS_LANDED, STATUS_NO_DATA, STATUS_SUSPECT, accepted
from dobwind.model.kinds import Precision
from dobwind.model.signals import log_signals

ANALYSIS_FREQUENCIES_HZ = [0.1, 0.5, 1.0]


@dataclass(frozen=True)
class Figure:
    caption: str
    png_base64: str


@dataclass(frozen=True)
class Flight:
    """What the page shows about the replayed log."""
    log_name: str
    rows: int
    duration_s: float
    time_s: np.ndarray
    wind: np.ndarray            # NED, NaN where the row was not accepted
    status: np.ndarray
    truth: np.ndarray | None    # the log's true wind
    reference: tuple[str, np.ndarray, np.ndarray] | None  # (label, time, NED wind): the autopilot's estimate
    notes: tuple[str, ...]
    band: tuple | None = None   # (label, time, low, high): the autopilot's own 1-sigma around its speed
    truth_label: str = "true wind"  # the truth's name (an ArduPilot SITL log's: the simulator's wind)
    sitl: dict | None = None    # dobwind against the simulator's wind (replay/sitlcompare.py), SITL logs only
    # What the reader warns of (a file cut inside a message, a log that never flew): replay says it on
    # stderr; the page says it first among the notes, and `report` on stderr too.
    warnings: tuple[str, ...] = ()
    time_label: str = "time (s)"  # an autopilot log's: its own clock, which is no UTC (io/plots.py LOG_CLOCK_LABEL)


def _png(path: Path, caption: str) -> Figure:
    return Figure(caption, base64.b64encode(path.read_bytes()).decode("ascii"))


def airframe_rows(af: Airframe) -> list[tuple[str, str]]:
    obs = af.observer
    thrust = (f"{af.thrust.rotors} rotors, rpm (max {af.thrust.max_rpm:g} rev/min), scale {af.thrust.scale:g}"
              if log_signals(af).rotor_speeds else f"collective, scale {af.thrust.scale:g}")
    rows = [("name", af.name), ("mass", f"{af.mass_kg:g} kg"), ("thrust", thrust),
            *([("calibration", "uncalibrated prior ([calibration] status = \"prior\"): every estimate carries "
                               "UNCALIBRATED; the wind is a rough guess until `dobwind fit`")] if af.uncalibrated else []),
            ("observer", f"{obs.discretization}, gains {', '.join(f'{g:.4g}' for g in obs.gains)} kg/s, "
                         f"sample time {obs.sample_time_s:g} s, acceleration input '{obs.acceleration}'"),
            ("force-air model", af.force_air_model),
            ("low-pass schedule", ", ".join(f"{c:g} Hz at {s:g} m/s" for s, c in zip(af.filter.speeds_mps, af.filter.cutoffs_hz))),
            ("limits", f"max dt {af.limits.max_dt_s:g} s, max tilt {af.limits.max_tilt_deg:g} deg")]
    if af.envelope is not None:
        rows.append(("calibrated envelope", f"horizontal force up to {af.envelope.force_h_max_n:.3g} N, airflow up to "
                                            f"{af.envelope.airflow_h_max_mps:.3g} m/s"))
    return rows


def status_rows(status: np.ndarray) -> list[tuple[str, str, int, str]]:
    """(flag, kind, samples with it set, meaning); the trusted count first."""
    rows = [("none (status 0)", "trusted", int(np.sum(status == 0)), "accepted, settled, inside the calibration")]
    for bit in STATUS_BITS:
        rows.append((bit.name, "rejects" if bit.rejects else "quality", int(np.sum((status & bit.value) != 0)), bit.doc))
    for name, value, doc in (("NO_DATA", STATUS_NO_DATA, "replay: a topic had no data for this row"),
                             ("LANDED", STATUS_LANDED, "replay: on the ground, not fed to the estimator"),
                             ("SUSPECT", STATUS_SUSPECT, "replay: a plausibility check says the airframe does not "
                                                         "fit this flight (see the notes)")):
        count = int(np.sum((status & value) != 0))
        if count:
            rows.append((name, "replay", count, doc))
    return rows


def error_rows(metrics: dict[str, Any]) -> list[tuple[str, str, str, str]]:
    """(what, mean, max, unit) from score()'s per-sample and per-segment blocks."""
    def fmt(v: float | None, digits: int = 3) -> str:
        return "-" if v is None else f"{v:.{digits}f}"

    rows = []
    for block, label in (("per_sample", "every sample after the warm-up"), ("per_segment", "segment means")):
        if block not in metrics:
            continue
        b = metrics[block]
        rows += [(f"horizontal speed, {label}", fmt(b["speed_mean"]), fmt(b["speed_max"]), "m/s"),
                 (f"direction, {label}", fmt(b["direction_mean"], 2), fmt(b["direction_max"], 2), "deg"),
                 (f"vertical, {label}", fmt(b["vertical_mean"]), fmt(b["vertical_max"]), "m/s")]
    return rows


# The autopilot comparison (ulog.compare_with_px4) as the page shows it: key -> (what it is, unit).
COMPARISON_ROWS = {
    "overlap_rows": ("rows where both estimate", "rows"),
    "active_share": ("share of the autopilot's samples that are active", "%"),
    "mean_vector_difference_mps": ("mean of |ours - theirs|, row by row", "m/s"),
    "difference_of_means_mps": ("|mean ours - mean theirs|", "m/s"),
    "mean_difference_ne_mps": ("mean of ours - theirs (north, east)", "m/s"),
    "mean_speed_difference_mps": ("mean speed difference (ours - theirs)", "m/s"),
    "mean_wind_ours_ne_mps": ("our mean wind (north, east)", "m/s"),
    "mean_wind_theirs_ne_mps": ("the autopilot's mean wind (north, east)", "m/s"),
    "mean_wind_ours_speed_mps": ("speed of our mean wind", "m/s"),
    "mean_wind_ours_from_deg": ("direction our mean wind blows from, clockwise from north", "deg"),
    "mean_wind_theirs_speed_mps": ("speed of the autopilot's mean wind", "m/s"),
    "mean_wind_theirs_from_deg": ("direction the autopilot's mean wind blows from, clockwise from north", "deg"),
    "direction_difference_deg": ("ours - theirs, wrapped to [-180, 180)", "deg"),
    "variance_north_m2s2": ("the autopilot's own variance, north", "m²/s²"),
    "variance_east_m2s2": ("the autopilot's own variance, east", "m²/s²"),
    "sigma_h_mps": ("the autopilot's own horizontal 1-sigma", "m/s"),
}


# dobwind against an ArduPilot SITL log's simulated wind (replay/sitlcompare.py): key -> (what it is, unit).
SITL_ROWS = {
    "compared_rows": ("rows compared", "rows"),
    "mean_speed_mps": ("dobwind's mean horizontal speed", "m/s"),
    "true_mean_speed_mps": ("the simulator's mean horizontal speed", "m/s"),
    "speed_difference_mps": ("mean speed difference (dobwind - simulator)", "m/s"),
    "from_deg": ("dobwind's mean wind, from (clockwise from north)", "deg"),
    "true_from_deg": ("the simulator's mean wind, from", "deg"),
    "direction_difference_deg": ("direction difference (dobwind - simulator)", "deg"),
    "mean_vector_error_mps": ("mean of |dobwind - simulator|, row by row (horizontal)", "m/s"),
    "mean_up_mps": ("dobwind's mean vertical wind, up", "m/s"),
    "true_mean_up_mps": ("the simulator's mean vertical wind, up", "m/s"),
}


def figure_rows(block: dict[str, Any], names: dict[str, tuple[str, str]]) -> list[tuple[str, str, str, str]]:
    """(what, JSON key, value, unit) for each figure ``names`` lists that ``block`` holds, in its order;
    counts as integers, other numbers to 3 decimals, differences with their sign."""
    def fmt(key: str, value: Any) -> str:
        if isinstance(value, int):
            return str(value)
        return f"{value:+.3f}" if "difference" in key else f"{value:.3f}"

    return [(what, key, fmt(key, block[key]), unit) for key, (what, unit) in names.items() if block.get(key) is not None]


def comparison_rows(comparison: dict[str, Any]) -> list[tuple[str, str, str, str]]:
    """(what, JSON key, value, unit) for each figure the comparison holds, in COMPARISON_ROWS' order;
    numbers to 3 decimals (a raw float's 16 digits claim a precision the estimate does not have)."""
    def fmt(key: str, value: Any) -> str:
        if value is None:  # a mean wind too weak to have a direction
            return "-"
        if key == "active_share":
            return f"{100 * value:.1f}"
        if isinstance(value, (list, tuple)):
            return ", ".join(f"{v:+.3f}" for v in value)
        return str(value) if isinstance(value, int) else f"{value:.3f}"

    return [(what, key, fmt(key, comparison[key]), unit) for key, (what, unit) in COMPARISON_ROWS.items()
            if key in comparison]


def render(af: Airframe, airframe_path: str, flight: Flight, metrics: dict[str, Any] | None,
           comparison: dict[str, Any] | None, figures: list[Figure], analysis: dict[str, Any]) -> str:
    import jinja2

    source = resources.files("dobwind.report").joinpath("report.html.j2").read_text(encoding="utf-8")
    template = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined,
                                  trim_blocks=True, lstrip_blocks=True).from_string(source)
    from dobwind.core.version import package_version

    valid = accepted(flight.status)
    return template.render(
        title=f"{af.name}: wind estimate over {flight.log_name}", version=package_version(),
        created=datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"), airframe_path=airframe_path,
        airframe=airframe_rows(af), flight=flight, accepted=int(valid.sum()),
        notes=tuple(f"warning: {w}" for w in flight.warnings) + flight.notes,
        errors=error_rows(metrics) if metrics else [], metrics=metrics, comparison=comparison,
        comparison_rows=comparison_rows(comparison) if comparison else [],
        sitl=flight.sitl, sitl_rows=figure_rows(flight.sitl, SITL_ROWS) if flight.sitl else [],
        status=status_rows(flight.status), figures=figures, analysis=analysis)


def analysis_summary(report: dict[str, Any]) -> dict[str, Any]:
    obs = report["observer"][0]
    ramp = report.get("ramp") or {}
    return {"stable": report["stable"], "bandwidth_hz": obs.get("bandwidth_hz"),
            "settling_s": obs.get("settling_time_s"), "lag_reduction_s": ramp.get("lag_reduction_s")}


def build_figures(af: Airframe, flight: Flight, work: Path) -> tuple[list[Figure], dict[str, Any]]:
    """The replay figure and the analysis figures, drawn into ``work`` and read back as base64."""
    from dobwind.analysis.report import analyze, write_plots
    from dobwind.io.plots import published, replay_plot

    others = [flight.reference] if flight.reference is not None else []
    replay_png = work / "replay.png"
    what = flight.truth_label if flight.truth is not None else (flight.reference[0] if flight.reference else "no reference")
    replay_plot(flight.time_s, published(flight.wind, af.vertical_law), flight.truth,
                f"{af.name}: estimated wind over {flight.log_name}",
                str(replay_png), others, status=flight.status, band=flight.band, truth_label=flight.truth_label,
                time_label=flight.time_label)
    figures = [_png(replay_png, f"Estimated wind against {what}: horizontal speed, direction (from), vertical (up), on "
                                "the log's own clock; grey: no estimate, amber: estimated but not trusted")]
    report, systems = analyze(af, ANALYSIS_FREQUENCIES_HZ)
    captions = {"bode.png": "Observer and scheduled low-pass, frozen at each schedule breakpoint (axis x)",
                "discretizations.png": "The observer alone under the four discretizations, same gains",
                "ramp.png": "A wind ramp to 10 m/s: scheduled against fixed low-pass"}
    for path in write_plots(report, systems, work / "analysis"):
        figures.append(_png(path, captions.get(path.name, path.name)))
    return figures, analysis_summary(report)


def scratch() -> tempfile.TemporaryDirectory:
    return tempfile.TemporaryDirectory(prefix="dobwind-report-")


def load_flight(af: Airframe, log_path: str, backend: str, precision: Precision) -> tuple[Flight, dict | None, dict | None]:
    """Replays the log: (the flight, score() against the truth or None, the autopilot comparison or None)."""
    from dobwind.replay.replay import replay, score

    from dobwind.io.autopilot import is_autopilot_log

    name = Path(log_path).name
    if is_autopilot_log(log_path):
        return _autopilot_flight(af, log_path, name, backend, precision)
    model, log, traj = replay(af, log_path, backend, precision)
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    valid = accepted(traj.status)
    metrics = score(log, traj, model) if log.true_wind is not None else None
    flight = Flight(name, log.rows, float(log.time_s[-1] - log.time_s[0]), log.time_s,
                    np.where(valid[:, None], wind, np.nan), traj.status, log.true_wind, None, (),
                    warnings=_csv_warnings(af, log_path, model, log, traj))
    return flight, metrics, None


def _csv_warnings(af: Airframe, log_path: str, model, log, traj) -> tuple[str, ...]:
    """What `replay` says of the same CSV log on stderr: its plausibility findings (a thrust model that is not
    the vehicle's, a yaw_ref in degrees: dobwind/replay/plausibility.py, logconventions.py) and a rejection of
    most rows with its likely cause. The page's status counts stay replay's: a CSV's rows are not marked."""
    from dobwind.replay.plausibility import FlightSeries, StreamedChecks
    from dobwind.replay.rejections import count_rejections, rejection_warning

    checks = StreamedChecks(af)
    checks.add(FlightSeries.replayed(log, traj.outputs[:, model.outputs.slice("force_ned")],
                                     traj.outputs[:, model.outputs.slice("wind_ned")], traj.status), log)
    said = [f"{log_path}: {f.message}" for f in checks.findings()]
    rejected = rejection_warning(log_path, log.rows, int((~accepted(traj.status)).sum()), count_rejections(traj.status),
                                 af.limits.max_dt_s)
    return tuple(said + ([rejected] if rejected else []))


def _autopilot_flight(af: Airframe, log_path: str, name: str, backend: str, precision: Precision) -> tuple[Flight, None, dict | None]:
    """Any autopilot log (ULog, DataFlash, ROS 2 bag) on its own clock (seconds since boot, TimeUS,
    the bag's clock), the autopilot's wind only where it is active, and the comparison with it."""
    from dobwind.io.plots import LOG_CLOCK_LABEL
    from dobwind.replay.replay import SITL_LABEL, reference_lines, replay_ulog
    from dobwind.io.ulog import compare_with_px4

    model, ap, traj = replay_ulog(af, log_path, backend, precision)
    log = ap.log
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    valid = accepted(traj.status)
    reference, band = reference_lines(ap)
    comparison = None
    if ap.autopilot_wind is not None:
        comparison = compare_with_px4(log.time_s, wind, valid, ap.autopilot_wind, ap.autopilot_wind_variance)
    t = log.time_s + ap.t0_s
    sitl, truth = None, None
    if ap.sitl is not None:  # an ArduPilot SITL log: the wind its simulator was told to blow
        from dobwind.model.airframe import VERTICAL_FALLBACK
        from dobwind.replay.sitlcompare import sitl_summary

        sitl, truth = sitl_summary(ap.sitl, t, wind, traj.status, af.vertical_law != VERTICAL_FALLBACK)
    flight = Flight(name, log.rows, float(log.time_s[-1] - log.time_s[0]), t, np.where(valid[:, None], wind, np.nan),
                    traj.status, truth, reference, tuple(ap.notes), band, SITL_LABEL, sitl, tuple(ap.warnings),
                    LOG_CLOCK_LABEL)
    return flight, None, comparison


def flight_report(af: Airframe, airframe_path: str, log_path: str, backend: str = "python",
                  precision: Precision = Precision.SINGLE) -> tuple[str, str]:
    """(the HTML page, a one-line summary for the terminal)."""
    flight, metrics, comparison = load_flight(af, log_path, backend, precision)
    with scratch() as work:
        figures, analysis = build_figures(af, flight, Path(work))
    page = render(af, airframe_path, flight, metrics, comparison, figures, analysis)
    for warning in flight.warnings:
        sys.stderr.write(f"dobwind report: warning: {warning}\n")
    if metrics and "per_sample" in metrics:
        summary = f"speed error mean {metrics['per_sample']['speed_mean']:.3f} m/s over {metrics['scored_rows']} samples"
    elif flight.sitl and flight.sitl.get("compared_rows"):
        summary = (f"mean vector error to the simulator's wind {flight.sitl['mean_vector_error_mps']:.3f} m/s, mean speed "
                   f"{flight.sitl['speed_difference_mps']:+.3f} m/s, direction {flight.sitl['direction_difference_deg']:+.3f} "
                   f"deg over {flight.sitl['compared_rows']} {flight.sitl['rows_used']} rows")
    elif comparison and comparison.get("overlap_rows"):
        summary = f"mean vector difference to {comparison['topic']} {comparison['mean_vector_difference_mps']:.3f} m/s"
    elif comparison and comparison.get("active") is False:
        summary = f"{comparison['topic']} is all zero (the autopilot was not estimating wind): no reference"
    else:
        summary = "no reference wind to score against"
    return page, f"{len(figures)} figures; {summary}"
