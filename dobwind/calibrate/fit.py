"""`dobwind fit`: the force-air model (and force offset) from logs with true wind.

1. The airframe's observer runs over each log (filter fixed at its highest cutoff: calibration
   wants short settling, not smoothing); forces go to the heading frame.
2. The true relative airflow (true wind minus ground velocity) goes to the same frame.
3. Cleaning: samples within one settling time after any yaw or airflow change are dropped (the usual
   outliers: transients after each yaw or wind-speed step); the steady rest is averaged in 2 s chunks;
   chunks far from their nearest neighbours are dropped, as in the paper.
4. The force offset is the mean force where the relative airflow is near zero.
5. Least squares for the horizontal speed and the vertical airflow on the terms (the airframe's, or
   the subset of a candidate library with the best cross-validation grouped by calibration hold and
   extrapolation to the top holds from the rest).
Data that cannot determine direction-dependent terms (too few airflow directions) or several terms
(too few speeds) gets a warning and a simpler, direction-independent model instead of wild numbers.
"""
from __future__ import annotations

import copy
import dataclasses
import itertools
import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy.spatial import cKDTree

from dobwind.calibrate.calpoints import POINT_KEYS, PointsReducer
from dobwind.calibrate.dragfit import median_step
from dobwind.calibrate.envelope import calibration_envelope, uncertainty_table
from dobwind.calibrate.reportparts import (AccelerationRoute, FamilyScores, HoldCvBySpeed, LowPassChange, SelfCheck,
                                          family_dict, part_dict)
from dobwind.calibrate.runmeans import RunVerdict
from dobwind.core.errors import CheckFailed, InputError
from dobwind.io.logs import TRUTH_BOUNDS, TRUTH_COLUMNS, FlightLog, heading_yaw, read_log, required_columns, step_inputs
from dobwind.model import forceair, reference
from dobwind.model.airframe import Airframe, FilterSchedule, ForceAirModel
from dobwind.model.status import accepted
from dobwind.model.step import StepModel
from dobwind.model.terms import parse_term

ZERO_AIRFLOW_MPS = 0.3
MIN_POINTS = 8
FOLDS = 5
EXTRAPOLATION_SHARE = 0.9

# Horizontal candidates: sqrt(fh), a constant, and sqrt(fh) times cos, sin, cos^2 and cos*sin of the
# force angle (sin^2 would repeat fh^0.5 - cos^2). All grow like sqrt(fh): body drag is quadratic at
# speed, and the model is used beyond the calibration's top speed (the paper calibrates to 8 m/s and
# measures to 10). With fh (or faster) terms in the library, fits on 0-8 m/s were a little better
# and, depending on the noise draw, missed the 10 m/s hold by up to 0.3 m/s, even with the
# extrapolation check below.
HORIZONTAL_CANDIDATES = ("fh^0.5", "1", "m*fh^-0.5", "n*fh^-0.5", "m^2*fh^-1.5", "m*n*fh^-1.5")
# fh terms let the vertical model absorb the thrust change that horizontal airflow causes (inflow).
VERTICAL_CANDIDATES = ("fz", "fz*abs(fz)", "fz*abs(fz)^-0.5", "fh", "fh^2")
DIRECTION_FREE = ("fh^0.5", "fh")


@dataclass
class Points:
    """Calibration points: chunk means in the heading frame."""
    m: np.ndarray
    n: np.ndarray
    fz: np.ndarray
    speed_h: np.ndarray   # true horizontal relative airflow speed
    air_z: np.ndarray     # true vertical relative airflow, down
    air_angle: np.ndarray  # direction of the horizontal airflow in the heading frame, rad
    group: np.ndarray     # calibration hold

    def select(self, keep: np.ndarray) -> "Points":
        return Points(*(getattr(self, f.name)[keep] for f in dataclasses.fields(self)))

    def __len__(self) -> int:
        return len(self.m)


@dataclass(frozen=True)
class FitReport:
    """What `fit` measured and chose, as `fit --json` prints it (docs/fit-report.md; its schema is
    docs/schemas/fit-report.schema.json). Built once per step of the fit: a step that adds to it
    makes a new report (dataclasses.replace), it is never changed in place."""
    points: int = 0
    outliers_removed: int = 0
    zero_airflow_points: int = 0
    thrust_scale: float = 1.0
    force_offset_n: tuple[float, float, float] = (0.0, 0.0, 0.0)
    horizontal_terms: list[str] = field(default_factory=list)
    horizontal_coefficients: list[float] = field(default_factory=list)
    horizontal_rmse_mps: float = math.nan
    horizontal_cv_rmse_mps: float | None = None
    horizontal_extrapolation_rmse_mps: float | None = None  # fitted below the top holds, tested on them
    vertical_terms: list[str] = field(default_factory=list)
    vertical_coefficients: list[float] = field(default_factory=list)
    vertical_rmse_mps: float | None = None
    vertical_cv_rmse_mps: float | None = None
    vertical_extrapolation_rmse_mps: float | None = None
    # The RMS of the true vertical airflow over the fit's samples: what predicting zero vertical airflow
    # scores, the figure the vertical CV must beat for the law to be used (fitfamily.vertical_warning).
    vertical_zero_rmse_mps: float | None = None
    # (vertical CV / zero)^2 from the per-block sums, and its standard error over the CV blocks: the law is
    # used when the share is below 1 by more than two standard errors (dobwind/calibrate/verticalskill.py).
    vertical_unexplained_share: float | None = None
    vertical_unexplained_share_se: float | None = None
    directions: int = 0
    speeds: int = 0
    model: str = "polynomial"
    drag: dict[str, float] = field(default_factory=dict)  # the drag law's numbers by name, as written; empty: polynomial
    # Every family tried, by name (drag, drag-body, polynomial); None: fitted but not scored (too few samples).
    families: dict[str, FamilyScores | None] = field(default_factory=dict)
    samples: int = 0
    # Hold-level CV (dobwind/calibrate/holdcv.py): RMS of held-out hold-mean speed errors; what replay's per-hold
    # speed errors follow. horizontal_cv_rmse_mps stays the family's raw (per-sample or per-chunk) CV.
    hold_cv_speed_mps: float | None = None
    hold_cv_by_speed: HoldCvBySpeed | None = None
    hold_extrapolation_speed_mps: float | None = None    # top blocks held out, hold-mean speed error
    self_check: SelfCheck | None = None                  # None (printed {}): not checked yet
    # The low-pass's first cutoff when the fit lowered it for the noise at low airflow (hovernoise.py);
    # None (printed {}) when it was kept.
    low_pass: LowPassChange | None = None
    # When the noise at low airflow stayed above the target with an acceleration input, the fit with that
    # input blended with the velocity's derivative (accelroute.py); None (printed {}) when not tried.
    acceleration_route: AccelerationRoute | None = None
    # Drag-law sets whose fitted law decreased somewhere (dragfit.choose_drag_law): never chosen, with where.
    not_increasing: list[str] = field(default_factory=list)
    # drag families: the hold-level score (m/s) of each exponent tried (dobwind/calibrate/dragexponent.py)
    exponent_scores: dict[str, float] = field(default_factory=dict)
    # drag families: whether the law was fitted on the logs' means (dobwind/calibrate/runmeans.py), and per log its
    # mean horizontal airflow error under the law, its weight and whether it looks like an outlier.
    anchored: bool = False
    runs: list[RunVerdict] = field(default_factory=list)
    excluded_logs: list[str] = field(default_factory=list)   # left out by --exclude-outliers
    hold_cv_without_outliers_mps: float | None = None  # the hold-level CV without the flagged logs (runmeans)
    warnings: list[str] = field(default_factory=list)
    # Why hold_cv_speed_mps measures nothing: folds whose held-out predictions diverged, each such sample
    # counted as the clip (dobwind/calibrate/cvdiverge.py); None when the figure is a measured error.
    hold_cv_diverged: str | None = None

    def as_dict(self) -> dict[str, Any]:
        """The fields in declaration order as plain JSON values, nested values copied (the schema's
        properties; each nested part prints itself, reportparts.py)."""
        out = {f.name: copy.deepcopy(getattr(self, f.name)) for f in dataclasses.fields(self)}
        out.update(families={name: family_dict(scores) for name, scores in self.families.items()},
                   hold_cv_by_speed=None if self.hold_cv_by_speed is None else self.hold_cv_by_speed.as_dict(),
                   self_check=part_dict(self.self_check), low_pass=part_dict(self.low_pass),
                   acceleration_route=part_dict(self.acceleration_route),
                   runs=[dataclasses.asdict(run) for run in self.runs])
        return out


def _term_matrix(terms: list[str], m: np.ndarray, n: np.ndarray, fz: np.ndarray) -> np.ndarray:
    """Term values through the same CasADi grammar the step uses."""
    return forceair.term_matrix([parse_term(t) for t in terms], m, n, fz)


def read_calibration_logs(af: Airframe, log_paths: list[str], still_air: bool = False,
                          log_reader: Callable[[str, Airframe], FlightLog] | None = None) -> list[FlightLog]:
    """Logs with the true wind; ``still_air``: logs flown in still air, whose wind columns may be absent
    (taken as zero: the relative airflow is minus the ground velocity); ``log_reader``: reads each log with
    its truth another way (an autopilot log and a known wind, dobwind/calibrate/fieldtruth.py)."""
    from dobwind.io.autopilot import is_autopilot_log, read_autopilot

    if log_reader is not None:
        return [log_reader(path, af) for path in log_paths]

    if not still_air:
        needed = required_columns(af) + [(c, "the true wind (fit needs it)") for c in TRUTH_COLUMNS]
        for path in log_paths:
            if is_autopilot_log(path):  # autopilot logs carry no true wind
                raise InputError(path, "wind_n", "an autopilot log has no true wind: give it with --wind SPEED@FROM, "
                                 "--truth FILE.csv, --truth sitl or --wind unknown (or --still-air)")
        return [read_log(path, needed, TRUTH_BOUNDS) for path in log_paths]
    logs = []
    for path in log_paths:
        # Autopilot logs: rows without data or on the ground are NaN, which the step rejects.
        log = read_autopilot(path, af).log if is_autopilot_log(path) else read_log(path, required_columns(af))
        zero = np.zeros(log.rows)
        logs.append(FlightLog(log.path, {**log.columns, **{c: zero for c in TRUTH_COLUMNS}}))
    return logs


def calibration_airframe(af: Airframe) -> Airframe:
    """The airframe with its filter fixed at the highest cutoff: calibration wants short settling."""
    return dataclasses.replace(af, filter=FilterSchedule((0.0,), (max(af.filter.cutoffs_hz),)))


@dataclass(frozen=True)
class CalibrationRun:
    """The calibration airframe's step over each log, reduced to what calibration reads: the drag-law
    samples (fitfamily.drag_samples) and the polynomial family's first cleaning pass run the same
    airframe over the same logs, so fit_airframe runs it once for both."""
    airframe: Airframe                  # calibration_airframe of the airframe it was run for
    model: StepModel
    logs: tuple[FlightLog, ...]
    force_ned: tuple[np.ndarray, ...]   # per log (N, 3): the step's force_ned output
    v_filt: tuple[np.ndarray, ...]      # per log (N, 3): its delayed ground velocity state
    status: tuple[np.ndarray, ...]      # per log (N,)

    def serves(self, af: Airframe, logs: list[FlightLog]) -> bool:
        """Whether this run is the one ``af`` would make over ``logs`` (the same log objects)."""
        return (calibration_airframe(af) == self.airframe and len(logs) == len(self.logs)
                and all(a is b for a, b in zip(logs, self.logs)))


def calibration_run(af: Airframe, logs: list[FlightLog]) -> CalibrationRun:
    """The step of ``calibration_airframe(af)`` over every log (the Python reference)."""
    from dobwind.model.step import build_step

    cal = calibration_airframe(af)
    model = build_step(cal)
    force, v_filt, status = [], [], []
    for log in logs:
        traj = reference.run_columns(model, step_inputs(model, log), model.state.slice("v_filt"),
                                     model.outputs.slice("force_ned"))
        force.append(traj.outputs)
        v_filt.append(traj.states)
        status.append(traj.status)
    return CalibrationRun(cal, model, tuple(logs), tuple(force), tuple(v_filt), tuple(status))


def calibration_points(af: Airframe, logs: list[FlightLog], dynamic: bool = False,
                       run: CalibrationRun | None = None) -> tuple[Points, float]:
    """Chunk means from every log, and the settling time used for cleaning. ``dynamic`` keeps
    manoeuvring flight too (only yaw changes and rejected samples are cut), in shorter chunks. ``run``:
    the calibration run, when already made (used only if it is ``af``'s over ``logs``)."""
    run = run if run is not None and run.serves(af, logs) else calibration_run(af, logs)
    settle = run.model.settling_time_s + 1.0
    chunks: list[dict[str, float]] = []
    group_base = 0
    for log, force, v_filt, status in zip(logs, run.force_ned, run.v_filt, run.status):
        reducer = PointsReducer(settle, median_step(log.time_s, af), log.rows, dynamic, group_base)
        reducer.add(*heading_rows(log, force, v_filt, status))
        log_chunks, group_base = reducer.finish()
        chunks += log_chunks
    if not chunks:
        raise CheckFailed(no_steady_data(settle))
    return points_from(chunks), settle


def no_steady_data(settle_s: float) -> str:
    return (f"no steady calibration data in the logs (holds must last longer than {settle_s:.1f} s after each yaw "
            "or wind change)")


def points_from(chunks: list[dict[str, float]]) -> Points:
    """Points from chunk means (calpoints.PointsReducer's), in their order."""
    return Points(*(np.array([ch[k] for ch in chunks]) for k in POINT_KEYS))


def heading_rows(log: FlightLog, force: np.ndarray, v_filt: np.ndarray,
                 status: np.ndarray) -> tuple[np.ndarray, ...]:
    """What the cleaning reads of a log's rows: time, heading-frame force and true relative airflow,
    yaw and the step's acceptance."""
    q = log.stack("q_w", "q_x", "q_y", "q_z")
    yaw = heading_yaw(log, q)
    c, s = np.cos(yaw), np.sin(yaw)
    f_c = np.column_stack(forceair.heading_force(force.T, c, s, (0.0, 0.0, 0.0)))
    # The estimator adds the ground velocity after the observer and low-pass (delay matching), so
    # the truth it should reproduce is the true wind minus that same delayed velocity.
    rel = log.true_wind - v_filt
    rel_c = np.column_stack(forceair.heading_force(rel.T, c, s, (0.0, 0.0, 0.0)))
    return log.time_s, f_c, rel_c, yaw, accepted(status)


def remove_outliers(points: Points, k: int = 8) -> tuple[Points, int]:
    """Nearest-neighbour cleaning: a point far from its k neighbours in (m, n, speed) is dropped."""
    if len(points) <= k + 2:
        return points, 0
    features = np.column_stack([points.m, points.n, points.speed_h])
    features = (features - features.mean(axis=0)) / np.maximum(features.std(axis=0), 1e-9)
    dist, _ = cKDTree(features).query(features, k=k + 1)
    score = dist[:, 1:].mean(axis=1)
    median = np.median(score)
    mad = np.median(np.abs(score - median)) * 1.4826
    keep = score <= median + 5 * max(mad, 1e-9)
    return points.select(keep), int((~keep).sum())


def _lstsq(a: np.ndarray, y: np.ndarray) -> np.ndarray:
    scale = np.maximum(np.abs(a).max(axis=0), 1e-12)
    coef, *_ = np.linalg.lstsq(a / scale, y, rcond=1e-10)
    return coef / scale


def _grouped_cv_rmse(a: np.ndarray, y: np.ndarray, groups: np.ndarray, folds: int = FOLDS) -> float:
    unique = np.unique(groups)
    if len(unique) < 2:
        return math.nan
    fold_of = {g: i % folds for i, g in enumerate(np.random.default_rng(0).permutation(unique))}
    fold = np.array([fold_of[g] for g in groups])
    errors = []
    for k in range(min(folds, len(unique))):
        test = fold == k
        if test.all() or not test.any():
            continue
        coef = _lstsq(a[~test], y[~test])
        errors.append((a[test] @ coef - y[test]) ** 2)
    return float(math.sqrt(np.concatenate(errors).mean())) if errors else math.nan


def _extrapolation_rmse(a: np.ndarray, y: np.ndarray, groups: np.ndarray) -> float:
    """RMSE on the holds at the top of the calibrated range (mean |target| at least EXTRAPOLATION_SHARE
    of the largest hold's) when the model is fitted on the rest: how the model behaves a little
    beyond what it was calibrated on, where it will be used."""
    unique, inverse = np.unique(groups, return_inverse=True)
    level = np.bincount(inverse, np.abs(y)) / np.bincount(inverse)
    top = level[inverse] >= EXTRAPOLATION_SHARE * level.max()
    if top.all() or (~top).sum() < a.shape[1] + 2:
        return math.nan
    coef = _lstsq(a[~top], y[~top])
    return float(np.sqrt(np.mean((a[top] @ coef - y[top]) ** 2)))


def selection_score(a: np.ndarray, y: np.ndarray, groups: np.ndarray) -> float:
    """Interpolation (grouped CV) and extrapolation errors, equally weighted."""
    cv, extra = _grouped_cv_rmse(a, y, groups), _extrapolation_rmse(a, y, groups)
    return cv if math.isnan(extra) else math.sqrt((cv * cv + extra * extra) / 2)


def select_terms(candidates: tuple[str, ...], p: Points, target: np.ndarray, max_terms: int = 6) -> tuple[list[str], float]:
    """Every subset of up to max_terms candidates is scored (selection_score); the smallest subset
    within 2 % of the best score wins. (Greedy forward selection stalls where a term
    helps only together with another, e.g. the inflow terms fh and fh^2 of the vertical model.)"""
    full = _term_matrix(list(candidates), p.m, p.n, p.fz)
    best_by_size: dict[int, tuple[float, tuple[int, ...]]] = {}
    for size in range(1, min(max_terms, len(candidates)) + 1):
        for cols in itertools.combinations(range(len(candidates)), size):
            score = selection_score(full[:, cols], target, p.group)
            if math.isfinite(score) and score < best_by_size.get(size, (math.inf, ()))[0]:
                best_by_size[size] = (score, cols)
    if not best_by_size:
        return [candidates[0]], math.nan
    best = min(score for score, _ in best_by_size.values())
    size = min(k for k, (score, _) in best_by_size.items() if score <= best * 1.02)
    score, cols = best_by_size[size]
    return [candidates[c] for c in cols], score


def _opposing_directions(points: Points) -> bool:
    """Airflow seen from at least two opposite sides: enough to locate a horizontal force offset."""
    moving = points.speed_h >= 0.5
    bins = set(np.floor((np.degrees(points.air_angle[moving]) % 360) / 45).astype(int).tolist())
    return any((b + 4) % 8 in bins for b in bins)


def _offset_from_directions(points: Points) -> tuple[float, float]:
    """The horizontal offset that best makes the force (minus it) point along the airflow, with a
    direction-free speed model fitted inside (variable projection)."""
    from scipy.optimize import minimize

    target = np.column_stack([points.speed_h * np.cos(points.air_angle), points.speed_h * np.sin(points.air_angle)])

    def residual(offset: np.ndarray) -> float:
        m, n = points.m - offset[0], points.n - offset[1]
        a = _term_matrix(list(DIRECTION_FREE), m, n, points.fz)
        speed = np.maximum(a @ _lstsq(a, points.speed_h), 0.0)
        along = forceair.along_force_scale(speed, m * m + n * n)  # the step's own direction guard
        predicted = np.column_stack([along * m, along * n])
        return float(np.sum((predicted - target) ** 2))

    result = minimize(residual, np.zeros(2), method="Nelder-Mead", options={"xatol": 1e-4, "fatol": 1e-9})
    return float(result.x[0]), float(result.x[1])


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _least_squares(terms: list[str], points: Points,
                   target: np.ndarray) -> tuple[list[float], float, float | None, float | None]:
    """Coefficients, RMSE, grouped CV RMSE and top-hold extrapolation RMSE (None where undefined)."""
    a = _term_matrix(terms, points.m, points.n, points.fz)
    coef = _lstsq(a, target)
    rmse = float(np.sqrt(np.mean((a @ coef - target) ** 2)))
    return ([float(c) for c in coef], rmse, _finite_or_none(_grouped_cv_rmse(a, target, points.group)),
            _finite_or_none(_extrapolation_rmse(a, target, points.group)))


def _zero_airflow(points: Points) -> np.ndarray:
    return (points.speed_h < ZERO_AIRFLOW_MPS) & (np.abs(points.air_z) < ZERO_AIRFLOW_MPS)


PointsOf = Callable[[Airframe], tuple[Points, float]]  # an airframe -> calibration_points over the logs


def fit_polynomial(af: Airframe, logs: list[FlightLog], terms: str = "auto", dynamic: bool = False,
                   run: CalibrationRun | None = None, points_of: PointsOf | None = None) -> tuple[Airframe, FitReport, Points]:
    """The paper's family from steady chunks (or manoeuvres with ``dynamic``); ``run``: the calibration
    run of ``af`` over ``logs``, when already made; ``points_of``: calibration_points of any airframe over
    the logs, made another way (then ``logs`` is not read)."""
    points_of = points_of or (lambda airframe: calibration_points(airframe, logs, dynamic, run))
    af, points, report = _calibrated_points(af, points_of)
    h_terms, report = _horizontal_terms(af, points, terms, report)
    coefficients, rmse, cv, extrapolation = _least_squares(h_terms, points, points.speed_h)
    report = dataclasses.replace(report, horizontal_coefficients=coefficients, horizontal_rmse_mps=rmse,
                                 horizontal_cv_rmse_mps=cv, horizontal_extrapolation_rmse_mps=extrapolation)
    vertical, report = _vertical_model(af, points, terms, report)
    horizontal = ForceAirModel(tuple(parse_term(t) for t in h_terms), tuple(report.horizontal_coefficients))
    if not all(math.isfinite(c) for c in report.horizontal_coefficients + report.vertical_coefficients):
        raise CheckFailed("the least-squares fit gave non-finite coefficients")
    # drag=None: the tables are the law now. A drag-family starter (`dobwind init` writes one) kept its
    # drag law otherwise, and the step, which runs the drag law whenever there is one, ignored the fit.
    new = dataclasses.replace(af, horizontal=horizontal, vertical=vertical, drag=None,
                              observer=dataclasses.replace(af.observer, force_offset_n=tuple(report.force_offset_n)))
    # The calibrated range and the residuals' size, for the step's EXTRAPOLATED bit and sigma outputs.
    pred_h = np.maximum(_term_matrix(h_terms, points.m, points.n, points.fz) @ np.asarray(horizontal.coefficients), 0)
    pred_z = _term_matrix(list(vertical.term_texts), points.m, points.n, points.fz) @ np.asarray(vertical.coefficients)
    new = dataclasses.replace(new, envelope=calibration_envelope(np.hypot(points.m, points.n), points.fz, pred_h),
                              uncertainty=uncertainty_table(points.speed_h, pred_h, -points.air_z, -pred_z))
    return new, report, points


def _calibrated_points(af: Airframe, points_of: PointsOf) -> tuple[Airframe, Points, FitReport]:
    """The thrust scale and the force offset from zero-airflow data, then the cleaned calibration points
    with the offset removed. Returns the airframe with the new thrust scale and the report so far."""
    raw, _ = points_of(af)
    zero = _zero_airflow(raw)
    zero_airflow_points = int(zero.sum())
    warnings = []
    if zero.sum() >= 3:
        # Level hover in still air: the true thrust holds the weight, so the vertical force seen there
        # is a thrust-curve scale error. Calibrated as a scale it stays along the body axis when the
        # vehicle tilts, which a heading-frame offset cannot do.
        weight = af.mass_kg * af.gravity_mps2
        scale = af.thrust.scale * weight / (weight + float(raw.fz[zero].mean()))
        af = dataclasses.replace(af, thrust=dataclasses.replace(af.thrust, scale=scale))
        raw, _ = points_of(af)
        zero = _zero_airflow(raw)
    else:
        warnings.append("no zero-airflow data: the thrust scale is kept from the airframe")
    if zero.sum() >= 3:
        offset = (float(raw.m[zero].mean()), float(raw.n[zero].mean()), float(raw.fz[zero].mean()))
    elif _opposing_directions(raw):
        horizontal = _offset_from_directions(raw)
        offset = (horizontal[0], horizontal[1], af.observer.force_offset_n[2])
        warnings.append("no zero-airflow data: the horizontal force offset comes from the airflow directions "
                        "(the air moves along the force minus the offset); the vertical one is kept")
    else:
        offset = af.observer.force_offset_n
        warnings.append("no zero-airflow data: the force offset is kept from the airframe")
    shifted = Points(raw.m - offset[0], raw.n - offset[1], raw.fz - offset[2], raw.speed_h, raw.air_z,
                     raw.air_angle, raw.group)
    points, outliers_removed = remove_outliers(shifted)
    if len(points) < MIN_POINTS:
        raise CheckFailed(f"only {len(points)} calibration point{'' if len(points) == 1 else 's'} (steady holds) after "
                          f"cleaning (need {MIN_POINTS})")

    moving = points.speed_h >= 1.0
    bins = np.floor((np.degrees(points.air_angle[moving]) % 360) / 30).astype(int)
    levels = np.round(points.speed_h / 0.5)
    report = FitReport(points=len(points), outliers_removed=outliers_removed, zero_airflow_points=zero_airflow_points,
                       thrust_scale=af.thrust.scale, force_offset_n=offset,
                       directions=int(sum(np.sum(bins == b) >= 3 for b in range(12))),
                       speeds=int(sum(np.sum(levels == v) >= 3 for v in np.unique(levels))), warnings=warnings)
    return af, points, report


def _horizontal_terms(af: Airframe, points: Points, terms: str, report: FitReport) -> tuple[list[str], FitReport]:
    """The horizontal model's terms: chosen or the airframe's, narrowed when the data cannot support them;
    the report with them and the reasons they were narrowed."""
    warnings = list(report.warnings)
    if terms == "auto":
        candidates = HORIZONTAL_CANDIDATES if report.directions >= 4 else DIRECTION_FREE
        h_terms, _ = select_terms(candidates, points, points.speed_h)
    else:
        h_terms = list(af.horizontal.term_texts)
    if report.directions < 4 and any(parse_term(t).variables & {"m", "n"} for t in h_terms):
        warnings.append(f"airflow from only {report.directions} direction(s) of 12 (30 deg bins): "
                        "fitting a direction-independent model (fh^0.5, fh) instead of " + ", ".join(h_terms))
        h_terms = list(DIRECTION_FREE)
    if report.speeds < 3 and len(h_terms) > 1:
        warnings.append(f"only {report.speeds} distinct airflow speed(s): fitting the one-term model "
                        "speed = c * fh^0.5 (quadratic drag)")
        h_terms = ["fh^0.5"]
    return h_terms, dataclasses.replace(report, horizontal_terms=h_terms, warnings=warnings)


def _vertical_model(af: Airframe, points: Points, terms: str, report: FitReport) -> tuple[ForceAirModel, FitReport]:
    """The vertical model fitted, or kept from the airframe when the data hardly move vertically; the
    report with it. A drag-family starter (`dobwind init`'s prior) has no vertical table to keep: it is
    fitted then, with a warning (the family's vertical check may still fall back to zero)."""
    vertical = af.vertical
    vertical_span = float(np.ptp(points.air_z))
    if vertical_span < 1.0 and vertical.terms:
        warning = (f"vertical airflow spans only {vertical_span:.2f} m/s in the data: the vertical model "
                   "is kept from the airframe (fly climbs and descents to calibrate it)")
        return vertical, dataclasses.replace(report, warnings=[*report.warnings, warning],
                                             vertical_terms=list(vertical.term_texts),
                                             vertical_coefficients=list(vertical.coefficients))
    if vertical_span < 1.0:
        report = dataclasses.replace(report, warnings=[*report.warnings, (
            f"vertical airflow spans only {vertical_span:.2f} m/s in the data: the airframe has no polynomial "
            "vertical model to keep, so it is fitted on that span (fly climbs and descents to calibrate it)")])
    v_terms = (select_terms(VERTICAL_CANDIDATES, points, points.air_z, max_terms=4)[0]
               if terms == "auto" or not vertical.terms else list(vertical.term_texts))
    coefficients, rmse, cv, extrapolation = _least_squares(v_terms, points, points.air_z)
    vertical = ForceAirModel(tuple(parse_term(t) for t in v_terms), tuple(coefficients))
    return vertical, dataclasses.replace(report, vertical_terms=v_terms, vertical_coefficients=coefficients,
                                         vertical_rmse_mps=rmse, vertical_cv_rmse_mps=cv,
                                         vertical_extrapolation_rmse_mps=extrapolation)
