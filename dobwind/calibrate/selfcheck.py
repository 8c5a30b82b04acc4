"""The fit checks itself: every calibration log replayed through the NEW airframe's step.

`fit` minimizes an error in its own terms (decimated samples, chunk means). What the user gets is the
step: observer, scheduled low-pass, force-air model, wind triangle. So after fitting, each calibration
log runs through that very step (the Python reference, which the C is verified against) and its
estimate is compared with the true wind, per segment (the log's `segment` column, else fixed windows)
and per log. The truth is delay-matched the way the drag fit does it: passed through the observer's and
the low-pass's response H (at the cutoff the schedule gives for the log's median estimated speed).

The verdict is a list of reasons not to trust the model, each with the threshold it broke. The
thresholds are named parameters (``Thresholds``); the ones on speed are relative to the calibrated
airflow speed range with an absolute floor, so one default serves a 3 m/s micro and a 15 m/s heavy lift.
"""
from __future__ import annotations

import math
import shutil

import numpy as np

from dobwind.calibrate import dragfit
from dobwind.calibrate.calstream import LogShape, LogSource, memory_source
from dobwind.calibrate.envelope import pooled_noise, pooled_scatter, segment_scatter
from dobwind.calibrate.reportparts import LogCheck, Segment, SelfCheck
from dobwind.harness.build import system_compiler
from dobwind.harness.cstep import CStep, compile_step
from dobwind.io.logs import FlightLog, step_inputs
from dobwind.model import reference
from dobwind.model.airframe import Airframe
from dobwind.model.errors import CheckFailed
from dobwind.model.status import accepted
from dobwind.model.step import StepModel, build_step
from dobwind.calibrate.thresholds import Thresholds  # noqa: F401 (re-exported: the check's parameters)
from dobwind.model.kinds import Precision

WARMUP_S = 5.0            # the observer and filter start up: not scored (as `replay`)
SEGMENT_SETTLE_S = 5.0    # a segment's first seconds are a transition: not scored (as `replay`), or the
                          # estimator's settling time when that is shorter (short calibration holds)
WINDOW_S = 10.0           # segments of a log without a `segment` column
MIN_SEGMENT_POINTS = 10
MIN_SPEED_FOR_DIRECTION_MPS = 1.0
# Segments whose mean true horizontal airflow speed AND true wind speed are below this are "low
# airflow": the drag law is at its flattest there and the low-pass (scheduled on the wind estimate) at
# its first cutoff, so the scatter of their estimate, per horizontal axis, is what still air reads as
# wind (dobwind/calibrate/hovernoise.py).
STILL_AIRFLOW_MPS = 1.0


def _wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def _segment_row(label: int, est: np.ndarray, true: np.ndarray) -> Segment:
    est_mean, true_mean = est.mean(axis=0), true.mean(axis=0)
    est_speed, true_speed = math.hypot(*est_mean[:2]), math.hypot(*true_mean[:2])
    direction = None
    if true_speed >= MIN_SPEED_FOR_DIRECTION_MPS:
        angle = math.atan2(est_mean[1], est_mean[0]) - math.atan2(true_mean[1], true_mean[0])
        direction = abs(_wrap_deg(math.degrees(angle)))
    return Segment(label, true_speed, est_speed - true_speed, direction, float(est_mean[2] - true_mean[2]), int(len(est)))


def _compiled(model: StepModel) -> CStep | None:
    """The compiled double-precision step when a C compiler is found: `verify` holds it to the
    reference bit for bit, and for a fitted body-frame law (about 1,700 instructions a step) it runs the
    250 Hz hour in 1.2 s with its compilation against the reference's 4.3 s. None without a compiler,
    or if the build fails (the reference is run instead)."""
    if shutil.which(system_compiler()) is None:
        return None
    try:
        return compile_step(model, Precision.DOUBLE)
    except (CheckFailed, OSError):
        return None


class _WindRun:
    """The step (compiled, else the reference) over one log's consecutive blocks, its state carried:
    (wind rows, status) of each block, the numbers of one pass."""

    def __init__(self, model: StepModel, step: CStep | None) -> None:
        self.model, self.step, self.wind = model, step, model.outputs.slice("wind_ned")
        self.rolled = reference.rolled_step(model) if step is None else None
        self.state = step.initial_state() if step is not None else None
        self.previous_t: float | None = None

    def run(self, log: FlightLog) -> tuple[np.ndarray, np.ndarray]:
        inputs = step_inputs(self.model, log, self.previous_t)
        self.previous_t = float(log.time_s[-1])
        if self.step is not None:
            traj = self.step.run(inputs, self.state, keep_states=False)
            wind = traj.outputs[:, self.wind]
        else:
            traj = reference.run_columns(self.model, inputs, slice(None), self.wind, self.state, self.rolled)
            wind = traj.outputs
        self.state = traj.states[-1].copy()
        return wind, traj.status


def _segment_labels(log: FlightLog, t0: float) -> np.ndarray:
    if log.has("segment"):
        return log.columns["segment"].astype(np.int64)
    return np.floor((log.time_s - t0) / WINDOW_S).astype(np.int64)


# A scored segment: its row, the scatter of its speed and vertical errors, and (at low airflow only) of
# its north and east errors.
_Scored = tuple[Segment, tuple[float, int], tuple[float, int], list[tuple[float, int]]]


class _Segments:
    """Scored rows per segment label, a segment's rows dropped once it is scored: when its label
    changes (a label seen again after that makes the caller score the log with every segment kept)."""

    def __init__(self, settle_s: float, keep_all: bool, still_tau_s: float = 0.0) -> None:
        self.settle, self.keep_all, self.still_tau = settle_s, keep_all, still_tau_s
        self.start: dict[int, float] = {}
        self.rows: dict[int, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
        self.done: dict[int, _Scored] = {}
        self.current: int | None = None
        self.recurred = False

    def add(self, labels: np.ndarray, t: np.ndarray, usable: np.ndarray, wind: np.ndarray, truth: np.ndarray,
            airflow_h: np.ndarray) -> None:
        """``airflow_h``: the true horizontal airflow speed of each row."""
        change = np.flatnonzero(np.r_[True, labels[1:] != labels[:-1]])
        for lo, hi in zip(change, np.r_[change[1:], len(labels)]):
            label = int(labels[lo])
            if label != self.current and not self.keep_all:
                self._score(self.current)
            if label in self.done:
                self.recurred = True
            self.current = label
            begun = self.start.setdefault(label, float(t[lo]))
            use = np.flatnonzero(usable[lo:hi] & (t[lo:hi] >= begun + self.settle)) + lo
            self.rows.setdefault(label, []).append((wind[use], truth[use], airflow_h[use], t[use]))

    def finish(self) -> list[_Scored]:
        """Per scored segment in label order: its row, and its speed and vertical error scatter."""
        for label in list(self.rows):
            self._score(label)
        return [self.done[label] for label in sorted(self.done)]

    def _score(self, label: int | None) -> None:
        pieces = self.rows.pop(label, None)
        if pieces is None:
            return
        wind, truth, airflow_h, t = (np.concatenate([p[i] for p in pieces]) for i in (0, 1, 2, 3))
        if len(wind) >= MIN_SEGMENT_POINTS:
            errors_h = np.hypot(wind[:, 0], wind[:, 1]) - np.hypot(truth[:, 0], truth[:, 1])
            errors_up = truth[:, 2] - wind[:, 2]  # NED down: up is its negative
            row = _segment_row(label, wind, truth)
            share = within_share(float(t[-1] - t[0]), self.still_tau)
            still = ([_scaled(segment_scatter(wind[:, 0] - truth[:, 0]), share),
                      _scaled(segment_scatter(wind[:, 1] - truth[:, 1]), share)]
                     if max(float(np.mean(airflow_h)), row.true_speed_mps) < STILL_AIRFLOW_MPS else [])
            self.done[label] = (row, segment_scatter(errors_h), segment_scatter(errors_up), still)


def within_share(duration_s: float, tau_s: float) -> float:
    """The share of a noise's variance that a segment's scatter about its own mean keeps, for noise
    correlated over ``tau_s`` (white noise through a first-order low-pass: tau = 1 / (2 pi cutoff)) and a
    segment ``duration_s`` long: 1 - (2 tau / T) (1 - (tau / T) (1 - exp(-T / tau))), the expected
    sample variance of such a process. The rest went into the segment's mean, which the scatter does not
    see but a wind reading does."""
    if tau_s <= 0 or duration_s <= 0:
        return 1.0
    r = tau_s / duration_s
    return max(1.0 - 2 * r * (1 - r * (1 - math.exp(-1 / r))), 0.05)


def _scaled(scatter: tuple[float, int], share: float) -> tuple[float, int]:
    return scatter[0] / share, scatter[1]


def _median_speed(model: StepModel, step: CStep | None, source: LogSource) -> float:
    """The median estimated horizontal wind speed over the log (a first pass: it sets the cutoff of the
    truth's delay matching). Its speeds are kept for the median only, 8 bytes a row."""
    run = _WindRun(model, step)
    speeds = [np.hypot(wind[:, 0], wind[:, 1]) for wind, _ in (run.run(block) for block in source.blocks())]
    speed = np.concatenate(speeds)
    return float(np.median(speed)) if len(speed) else 0.0


def check_source(af: Airframe, source: LogSource, shape: LogShape, fit_samples: int, settle_s: float | None = None,
                 model: StepModel | None = None, keep_all: bool = False) -> LogCheck:
    """check_log over a log read a block at a time (two passes: the median speed, then the scores)."""
    model = model if model is not None else build_step(af)
    settle = settle_s if settle_s is not None else min(SEGMENT_SETTLE_S, model.settling_time_s)
    step = _compiled(model)
    cutoff = float(np.interp(_median_speed(model, step, source), af.filter.speeds_mps, af.filter.cutoffs_hz))
    filters = [dragfit._BlockFilter(*dragfit.observer_filter(af, shape.dt_s, cutoff, axis)) for axis in range(3)]
    # The noise at low airflow passes the schedule's first cutoff: its correlation time is 1 / (2 pi f).
    still_tau = 1 / (2 * math.pi * af.filter.cutoffs_hz[0]) if af.filter.cutoffs_hz[0] > 0 else 0.0
    run, segments, t0 = _WindRun(model, step), _Segments(settle, keep_all, still_tau), None
    for log in source.blocks():
        wind, status = run.run(log)
        true_wind = log.true_wind
        truth = np.empty_like(true_wind)
        for axis in range(3):  # the true wind through H, the response the estimate went through
            truth[:, axis] = filters[axis](np.nan_to_num(true_wind)[:, axis])
        t = log.time_s
        t0 = float(t[0]) if t0 is None else t0
        usable = accepted(status) & (t >= t0 + WARMUP_S) & np.isfinite(true_wind).all(axis=1)
        airflow_h = np.hypot(*(true_wind[:, :2] - log.stack("vel_n", "vel_e")).T)
        segments.add(_segment_labels(log, t0), t, usable, wind, truth, airflow_h)
        if segments.recurred and not keep_all:
            return check_source(af, source, shape, fit_samples, settle_s, model, keep_all=True)
    return _log_check(source.path, shape.rows, fit_samples, segments.finish())


def direction_chord_mps(true_speed_mps: float, direction_error_deg: float) -> float:
    """The distance a direction error alone puts between two winds of the true speed: 2 v sin(angle / 2)."""
    return 2.0 * true_speed_mps * math.sin(math.radians(direction_error_deg) / 2.0)


def _log_check(path: str, rows: int, fit_samples: int,
               scored: list[_Scored]) -> LogCheck:
    segment_rows = [row for row, _, _, _ in scored]
    noise_h, noise_dof = pooled_scatter([h for _, h, _, _ in scored])
    noise_up, _ = pooled_scatter([up for _, _, up, _ in scored])
    still, still_dof = pooled_scatter([axis for _, _, _, still in scored for axis in still])
    figures: dict[str, float | None] = {}
    if segment_rows:
        speed = np.array([r.speed_error_mps for r in segment_rows])
        judged = [r for r in segment_rows if r.direction_error_deg is not None]
        dirs = [r.direction_error_deg for r in judged]
        chords = [direction_chord_mps(r.true_speed_mps, r.direction_error_deg) for r in judged]
        figures = {"speed_rms_mps": float(np.sqrt(np.mean(speed ** 2))), "speed_max_mps": float(np.max(np.abs(speed))),
                   "direction_mean_deg": float(np.mean(dirs)) if dirs else None,
                   "direction_max_deg": float(np.max(dirs)) if dirs else None,
                   "direction_mean_mps": float(np.mean(chords)) if chords else None}
    return LogCheck(path, rows, fit_samples, int(sum(r.points for r in segment_rows)), segment_rows, **figures,
                    noise_h_mps=noise_h, noise_up_mps=noise_up, noise_dof=noise_dof, still_noise_mps=still,
                    still_dof=still_dof)


def check_log(af: Airframe, log: FlightLog, fit_samples: int, settle_s: float | None = None,
              model: StepModel | None = None, block_rows: int | None = None) -> LogCheck:
    """One calibration log through the airframe's step (``model``, built from ``af`` when not given):
    per-segment and per-log errors. A segment is scored from ``settle_s`` after its start (default: see
    SEGMENT_SETTLE_S). ``block_rows``: the log is run and scored that many rows at a time (the same
    figures)."""
    shape = LogShape(log.rows, dragfit.median_step(log.time_s, af))
    return check_source(af, memory_source(log, block_rows or log.rows), shape, fit_samples, settle_s, model)


def coefficients(af: Airframe) -> dict[str, float]:
    """Every fitted number of the model, by name."""
    values = {f"horizontal[{t}]": c for t, c in zip(af.horizontal.term_texts, af.horizontal.coefficients)}
    values.update({f"vertical[{t}]": c for t, c in zip(af.vertical.term_texts, af.vertical.coefficients)})
    if af.drag is not None:
        values.update({f"drag.{k}": float(getattr(af.drag, k)) for k in af.drag.keys()})
    values.update({f"force_offset[{i}]": v for i, v in enumerate(af.observer.force_offset_n)})
    values["thrust.scale"] = af.thrust.scale
    return values


def blown_up(af: Airframe, limit: float) -> list[str]:
    """Coefficients that are non-finite or absurdly large (the data could not determine them)."""
    bad = [f"{k} = {v:g}" for k, v in coefficients(af).items() if not (math.isfinite(v) and abs(v) <= limit)]
    if not (math.isfinite(af.thrust.scale) and af.thrust.scale > 0):
        bad.append(f"thrust.scale = {af.thrust.scale:g} (must be > 0)")
    return bad


def direction_fails(check: LogCheck, limit_deg: float, replay_limit_mps: float) -> bool:
    """A log's direction fails when its mean error is over the limit in degrees AND, as a distance at the
    true speeds, over the speed tolerance. In a light wind an angle is a small distance: 17 deg at 1.75 m/s
    is 0.52 m/s, about what the speed tolerance already allows along the wind, so the degrees alone would
    refuse a model for estimator noise that the speed check accepts. From about replay_limit / tan(limit)
    (2.4 m/s at the defaults) upward the degrees decide, as before."""
    if check.direction_mean_deg is None or check.direction_mean_deg <= limit_deg:
        return False
    return check.direction_mean_mps is None or check.direction_mean_mps > replay_limit_mps


def direction_tail_deg(check: LogCheck, share: float, min_speed_mps: float) -> float | None:
    """The direction error that ``share`` of the log's segments at ``min_speed_mps`` or faster stay within
    (the lower of the two segment errors around that rank: a tail it reports is met by that many
    segments); None without such a segment."""
    errors = sorted(r.direction_error_deg for r in check.segments
                    if r.direction_error_deg is not None and r.true_speed_mps >= min_speed_mps)
    if not errors:
        return None
    return float(errors[max(0, math.ceil(share * len(errors)) - 1)])


def direction_tail_warnings(logs: list[LogCheck], limits: Thresholds) -> list[str]:
    """A warning per log whose direction errors at speed have a tail over limits.direction_tail_deg. The
    refusal judges the MEAN (direction_fails): a law that is right along the body axes and 15-20 deg off
    between them (a drag law whose terms cannot follow the body's drag there: before the per-axis pair,
    the strongly per-axis bodies of benchmarks/anisovehicles) averages under the limit, and its user
    would fly it unwarned."""
    warnings = []
    for check in logs:
        tail = direction_tail_deg(check, limits.direction_tail_share, limits.direction_tail_speed_mps)
        if tail is not None and tail > limits.direction_tail_deg:
            warnings.append(f"{check.log}: training replay direction error {tail:.1f} deg or more on at least "
                            f"{1 - limits.direction_tail_share:.0%} of its segments at "
                            f"{limits.direction_tail_speed_mps:g} m/s or faster (warned above "
                            f"{limits.direction_tail_deg:g} deg; the worst {check.direction_max_deg or tail:.1f} deg): the "
                            f"law misreads some airflow directions, which the mean limit does not refuse (a body "
                            f"whose drag varies with the airflow direction in a way the law's terms do not "
                            f"follow: docs/calibration.md); expect wind directions that far off")
    return warnings


def verdict(af: Airframe, logs: list[LogCheck], cv_mps: float | None, speed_range_mps: float,
            limits: Thresholds) -> SelfCheck:
    cv_limit = limits.speed_limit_mps(limits.cv_share, speed_range_mps)
    replay_limit = limits.speed_limit_mps(limits.replay_share, speed_range_mps)
    reasons = [f"coefficient {c} (limit |c| <= {limits.max_coefficient:g})" for c in blown_up(af, limits.max_coefficient)]
    if cv_mps is None or not math.isfinite(cv_mps):
        reasons.append("no cross-validation figure (the data has too few blocks to test the model on unseen flight)")
    elif cv_mps > cv_limit and limits.cv_diverged:
        reasons.append(f"hold-level CV not measured (limit {cv_limit:.3f} m/s): {limits.cv_diverged}")
    elif cv_mps > cv_limit:
        reasons.append(f"hold-level CV {cv_mps:.3f} m/s > {cv_limit:.3f} m/s{dragfit.diverged(cv_mps)}")
    for check in logs:
        if check.fit_samples == 0:
            reasons.append(f"{check.log}: contributed no usable sample to the fit")
        if check.log in limits.outlier_logs:
            continue  # the fit's own outlier (runmeans): reported beside the table, not judged
        if check.speed_rms_mps is None:
            reasons.append(f"{check.log}: no scorable segment in the training replay")
        elif check.speed_rms_mps > replay_limit:
            reasons.append(f"{check.log}: training replay speed error RMS {check.speed_rms_mps:.3f} m/s "
                           f"> {replay_limit:.3f} m/s")
        if direction_fails(check, limits.direction_deg, replay_limit):
            distance = ("" if check.direction_mean_mps is None else
                        f" ({check.direction_mean_mps:.3f} m/s at the true speeds > {replay_limit:.3f} m/s)")
            reasons.append(f"{check.log}: training replay direction error mean {check.direction_mean_deg:.2f} deg "
                           f"> {limits.direction_deg:g} deg{distance}")
    noise_h = pooled_noise([(c.noise_h_mps, c.noise_dof) for c in logs])
    noise_up = pooled_noise([(c.noise_up_mps, c.noise_dof) for c in logs])
    still = pooled_noise([(c.still_noise_mps, c.still_dof) for c in logs]) if any(c.still_dof for c in logs) else None
    return SelfCheck(not reasons, reasons, cv_mps, speed_range_mps, cv_limit, replay_limit, limits.direction_deg, logs,
                     noise_h, noise_up, still, list(limits.outlier_logs), direction_tail_warnings(logs, limits),
                     limits.cv_diverged)


def self_check(af: Airframe, logs: list[FlightLog], fit_samples: list[int], cv_mps: float | None,
               speed_range_mps: float, limits: Thresholds = Thresholds()) -> SelfCheck:
    """Replay every calibration log through ``af`` and judge the fit (see the module docstring)."""
    model = build_step(af)
    checks = [check_log(af, log, count, model=model) for log, count in zip(logs, fit_samples)]
    return verdict(af, checks, cv_mps, speed_range_mps, limits)


def self_check_sources(af: Airframe, sources: list[LogSource], shapes: list[LogShape], fit_samples: list[int],
                       cv_mps: float | None, speed_range_mps: float, limits: Thresholds = Thresholds()) -> SelfCheck:
    """self_check over logs read a block at a time."""
    model = build_step(af)
    checks = [check_source(af, source, shape, count, model=model)
              for source, shape, count in zip(sources, shapes, fit_samples)]
    return verdict(af, checks, cv_mps, speed_range_mps, limits)


WORST_SEGMENTS_SHOWN = 5


def _segment_lines(segments: list[Segment]) -> list[str]:
    worst = sorted(segments, key=lambda r: -abs(r.speed_error_mps))[:WORST_SEGMENTS_SHOWN]
    lines = []
    for r in worst:
        d = "-" if r.direction_error_deg is None else f"{r.direction_error_deg:.2f}"
        lines.append(f"      segment {r.segment:5d}: true {r.true_speed_mps:6.2f} m/s, speed error "
                     f"{r.speed_error_mps:+.3f} m/s, direction error {d} deg, vertical error "
                     f"{r.vertical_error_mps:+.3f} m/s, {r.points} points")
    return lines


def text_table(check: SelfCheck) -> str:
    """The self-check (as stored in the fit report) for people: per log, and its worst segments."""
    cv = "n/a" if check.cv_mps is None else f"{check.cv_mps:.3f}"
    figure = f"{cv} m/s (limit {check.cv_limit_mps:.3f})"
    if check.cv_diverged:  # the clip's mixture is no figure (Thresholds.cv_diverged)
        figure = f"not measured: held-out predictions diverged, the FAIL line says where (limit {check.cv_limit_mps:.3f} m/s)"
    lines = [f"self-check: every calibration log replayed through the new airframe's step; calibrated speed "
             f"range {check.speed_range_mps:.2f} m/s; hold-level CV {figure}",
             f"  limits per log: segment speed error RMS <= {check.replay_limit_mps:.3f} m/s, mean direction "
             f"error <= {check.direction_limit_deg:g} deg (or <= {check.replay_limit_mps:.3f} m/s as a distance at the "
             "true speeds)"]
    for c in check.logs:
        speed = "n/a" if c.speed_rms_mps is None else f"{c.speed_rms_mps:.3f} / {c.speed_max_mps:.3f} m/s"
        direction = "n/a" if c.direction_mean_deg is None else f"{c.direction_mean_deg:.2f} / {c.direction_max_deg:.2f} deg"
        if c.direction_mean_mps is not None:
            direction += f" (mean {c.direction_mean_mps:.3f} m/s)"
        outlier = " (the fit's outlier: not judged)" if c.log in check.outlier_logs else ""
        lines.append(f"  {c.log}: {c.fit_samples} fit samples, {c.points_kept} of {c.rows} points kept "
                     f"in {len(c.segments)} segments; speed error RMS / max {speed}; direction mean / max "
                     f"{direction}{outlier}")
        lines += _segment_lines(c.segments)
    lines.append(f"  observer noise (sample scatter about each segment's mean error): {check.noise_h_mps:.3f} m/s "
                 f"horizontal speed, {check.noise_up_mps:.3f} m/s vertical; the sigma outputs include it")
    if check.still_noise_mps is not None:
        lines.append(f"  at low airflow (segments under {STILL_AIRFLOW_MPS:g} m/s): {check.still_noise_mps:.3f} m/s "
                     "per horizontal axis")
    lines.extend(f"  warning: {warning}" for warning in check.warnings)
    lines.append("self-check: " + ("PASS" if check.passed else "FAIL: " + "; ".join(check.reasons)))
    return "\n".join(lines)
