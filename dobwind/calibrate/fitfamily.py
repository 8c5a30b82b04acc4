"""`dobwind fit`: both force-air families fitted, scored alike, the better one chosen, then checked by
replaying every calibration log through the new airframe's step."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from dobwind.calibrate import accelroute, blendnoise, calstream, dragexponent, dragfit, holdcv, runmeans, verticalskill
from dobwind.io.csvchunks import BLOCK_BYTES
from dobwind.calibrate.directionshape import DirectionShape
from dobwind.calibrate.envelope import calibration_envelope, uncertainty_table, with_observer_noise
from dobwind.core.errors import CheckFailed
from dobwind.calibrate.hovernoise import HoverNoise, quieter_schedule
from dobwind.calibrate.fit import (CalibrationRun, FitReport, Points, PointsOf, calibration_points, calibration_run, fit_polynomial,
                         no_steady_data, points_from, read_calibration_logs)
from dobwind.io.logs import FlightLog
from dobwind.model.signals import log_signals
from dobwind.model.airframe import CALIBRATED, VERTICAL_FALLBACK, Airframe, ForceAirModel
from dobwind.calibrate.reportparts import FamilyScores, HoldScores, LowPassChange
from dobwind.calibrate.selfcheck import SelfCheck, Thresholds, self_check, self_check_sources
from dobwind.model.kinds import DragFrame

LogReader = Callable[[str, Airframe], FlightLog]  # a calibration log's path -> the log with its true wind

MODELS = ("auto", "drag", "drag-heading", "drag-body", "polynomial")
# --model -> the drag-law frames it fits (both drag frames are scored alike and the better one is kept).
DRAG_FRAMES_OF = {"auto": (DragFrame.HEADING, DragFrame.BODY), "drag": (DragFrame.HEADING, DragFrame.BODY), "drag-heading": (DragFrame.HEADING,),
                  "drag-body": (DragFrame.BODY,), "polynomial": ()}
FAMILY_OF_FRAME = {DragFrame.HEADING: "drag", DragFrame.BODY: "drag-body"}
UNSCORED = FamilyScores()  # a family fitted but not scored (under 100 samples) is ranked as having no figure


def drag_samples(af: Airframe, logs: list[FlightLog], frames: tuple[DragFrame, ...] = (DragFrame.HEADING,),
                 run: CalibrationRun | None = None) -> tuple[dict[str, dragfit.DragSamples], list[int]]:
    """Decimated per-sample calibration data from every log for each drag-law frame (the same samples
    and blocks in each), and how many samples each log gave. ``run``: the calibration run of ``af``
    over ``logs``, when already made."""
    run = run if run is not None and run.serves(af, logs) else calibration_run(af, logs)
    cal, model = run.airframe, run.model
    parts: dict[str, list] = {frame: [] for frame in frames}
    shapes = [calstream.LogShape(log.rows, dragfit.median_step(log.time_s, cal)) for log in logs]
    rate_hz = calstream.sample_rate_hz(shapes)
    for log, shape, force, status in zip(logs, shapes, run.force_ned, run.status):
        reducer = calstream.DragReducer(cal, model.settling_time_s, shape.dt_s, frames, rate_hz)
        reducer.add(log, force, status)
        for frame in frames:
            parts[frame].append(reducer.result(frame))
    counts = [len(p["time"]) for p in parts[frames[0]]]
    return {frame: dragfit.merge(parts[frame], frame) for frame in frames}, counts


def drag_airframe(af: Airframe, choice: dragfit.DragChoice, samples: dragfit.DragSamples) -> Airframe:
    """The airframe with the chosen law, its offset and thrust scale, the calibrated envelope (for the
    step's EXTRAPOLATED bit) and the residuals' size over speed (for its sigma outputs)."""
    values = dict(zip(samples.parameters, (float(v) for v in choice.theta)))
    thrust = dataclasses.replace(af.thrust, scale=af.thrust.scale * (1 - values["kappa"]))
    observer = dataclasses.replace(af.observer, force_offset_n=(values["ox"], values["oy"], 0.0))
    law = dragfit.law_of(choice.theta, samples.frame, samples.exponent)
    if law.frame == DragFrame.BODY:
        # The fit's rotor term uses the nominal thrust; the step's, the scaled one (a factor 1 - kappa).
        law = dataclasses.replace(law, lr=law.lr / math.sqrt(1 - values["kappa"]))
    predicted = dragfit.predicted_airflow(samples, choice.theta)
    force = dragfit.heading_forces(samples, choice.theta)
    speed_true = np.hypot(samples.airflow[:, 0], samples.airflow[:, 1])
    speed_predicted = np.hypot(predicted[:, 0], predicted[:, 1])
    return dataclasses.replace(
        af, thrust=thrust, observer=observer, drag=law,
        horizontal=ForceAirModel((), ()), vertical=ForceAirModel((), ()),
        envelope=calibration_envelope(np.hypot(force[:, 0], force[:, 1]), force[:, 2], speed_predicted),
        uncertainty=uncertainty_table(speed_true, speed_predicted, -samples.airflow[:, 2], -predicted[:, 2]))


def _none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _family_scores(cv: tuple[float, float], extrapolation: float,
                   hold: holdcv.HoldCV | None) -> FamilyScores:
    """cv_h_mps: per-sample vector error (selects the terms); hold: hold-mean speed errors on the
    same folds, what replay's per-hold speed errors follow (dobwind/calibrate/holdcv.py)."""
    held = None if hold is None else HoldScores(_none(hold.rms_mps), hold.band_table(), _none(hold.extrapolation_mps),
                                                hold.diverged_text())
    return FamilyScores(cv_h_mps=_none(cv[0]), cv_v_mps=_none(cv[1]), extrapolation_h_mps=_none(extrapolation),
                        score_mps=_none(dragfit.combined(cv[0], extrapolation)), hold=held)


def _polynomial_scores(fitted: Airframe, samples: dragfit.DragSamples) -> FamilyScores:
    fit_predict = dragfit.polynomial_fit_predict(list(fitted.horizontal.terms), list(fitted.vertical.terms),
                                                 fitted.observer.force_offset_n)
    scores = _family_scores(dragfit.grouped_cv(samples, fit_predict), dragfit.extrapolation_error(samples, fit_predict),
                            holdcv.hold_cv(samples, fit_predict))
    return dataclasses.replace(scores, vertical_skill=_skill(samples, fit_predict))


def _skill(samples: dragfit.DragSamples, fit_predict: dragfit.FitPredict) -> verticalskill.VerticalSkill | None:
    """The vertical law's skill on the grouped CV's folds (the same ones: fold_splits is deterministic)."""
    return verticalskill.vertical_skill(*verticalskill.block_errors(samples, fit_predict))


@dataclass(frozen=True)
class _Calibration:
    """What the fit reads of its logs, however they were read: each drag-law frame's merged samples, the
    samples per log, the polynomial family's points of any airframe, and the self-check's replay."""
    by_frame: dict[DragFrame, dragfit.DragSamples]
    per_log: list[int]
    points_of: PointsOf
    check: Callable[[Airframe, float | None, float, Thresholds], SelfCheck]


def _whole_logs(af: Airframe, log_paths: list[str], frames: tuple[DragFrame, ...], dynamic: bool,
                still_air: bool, log_reader: LogReader | None = None) -> _Calibration:
    """Every log read whole and reduced in one block (the reference the streamed fit is held to)."""
    logs = read_calibration_logs(af, log_paths, still_air, log_reader)
    run = calibration_run(af, logs)  # one reference pass for the drag samples and the polynomial family
    by_frame, per_log = drag_samples(af, logs, frames, run)
    return _Calibration(by_frame, per_log, lambda airframe: calibration_points(airframe, logs, dynamic, run),
                        lambda new, cv, speed, limits: self_check(new, logs, per_log, cv, speed, limits))


def _streamed_logs(af: Airframe, log_paths: list[str], frames: tuple[DragFrame, ...], dynamic: bool, still_air: bool,
                   points: bool, block_bytes: int, log_reader: LogReader | None = None) -> _Calibration:
    """Every log read ``block_bytes`` at a time, once for its shape, once for the calibration step (drag
    samples and chunk means together), again for the points of a rescaled airframe and for the
    self-check: the numbers of _whole_logs, with nothing kept at the logs' full rate. The decimated
    samples are capped (dragfit.MAX_SAMPLES); the polynomial family's chunk means, a few per hold, still
    grow with the logs' length."""
    sources = calstream.calibration_sources(af, log_paths, still_air, block_bytes, log_reader)
    shapes = [calstream.log_shape(source, af) for source in sources]
    first = calstream.reduce_logs(af, sources, shapes, frames, dynamic, points)
    per_log = [len(part["time"]) for part in first.samples[frames[0]]]
    by_frame = {frame: dragfit.merge(first.samples.pop(frame), frame) for frame in frames}  # one copy kept
    chunks = {af: (first.chunks, first.settle_s)}

    def points_of(airframe: Airframe) -> tuple[Points, float]:
        if airframe not in chunks:
            reduced = calstream.reduce_logs(airframe, sources, shapes, (), dynamic, True)
            chunks[airframe] = (reduced.chunks, reduced.settle_s)
        found, settle = chunks[airframe]
        if not found:
            raise CheckFailed(no_steady_data(settle))
        return points_from(found), settle

    return _Calibration(by_frame, per_log, points_of, lambda new, cv, speed, limits: self_check_sources(
        new, sources, shapes, per_log, cv, speed, limits))


@dataclass(frozen=True)
class FitOptions:
    """The fit's choices besides the airframe and the logs, passed to both of fit_airframe's fits (its
    signature holds the defaults)."""
    terms: str
    dynamic: bool
    model: str
    still_air: bool
    limits: Thresholds
    block_bytes: int | None
    hover: HoverNoise
    log_reader: LogReader | None = None  # each log with its truth read another way (dobwind/calibrate/fieldtruth.py)
    # The drag law's direction shape where the flight does not identify it (dobwind/calibrate/directionshape.py).
    direction_shape: DirectionShape | None = None


def fit_airframe(af: Airframe, log_paths: list[str], terms: str = "auto", dynamic: bool = False,
                 model: str = "auto", still_air: bool = False, limits: Thresholds = Thresholds(),
                 block_bytes: int | None = BLOCK_BYTES,
                 hover: HoverNoise = HoverNoise(),
                 log_reader: LogReader | None = None,
                 direction_shape: DirectionShape | None = None) -> tuple[Airframe, FitReport, Points | None]:
    """Both families fitted and scored, the better one chosen, then the self-check (report.self_check;
    the caller refuses to write a model that failed it unless forced), and the low-pass at zero airflow
    lowered when the noise there is above ``hover.target_mps`` (dobwind/calibrate/hovernoise.py). When it stays
    above with an acceleration input, the fit runs again with that input blended with the velocity's
    derivative and keeps the better (dobwind/calibrate/accelroute.py). The logs are read ``block_bytes`` at a time
    (None: each whole, in memory; the same airframe)."""
    # What fit writes is calibrated: a prior (dobwind init's [calibration] status) stops being one here,
    # and the self-check replays the new airframe without the UNCALIBRATED bit.
    af = dataclasses.replace(af, calibration=CALIBRATED)
    options = FitOptions(terms, dynamic, model, still_air, limits, block_bytes, hover)
    # ``log_reader``: how each log is read with its true wind when not from its own columns (an autopilot
    # log and a known wind: dobwind/calibrate/fieldtruth.py).
    options = dataclasses.replace(options, log_reader=log_reader, direction_shape=direction_shape)
    new, report, points, check = _fit_once(af, log_paths, options)
    new, report, points, check = _maybe_blend(af, log_paths, options, (new, report, points, check))
    report = dataclasses.replace(report, self_check=check)
    # The self-check's replay measured the observer noise; the sigma outputs add it to the residuals (#10).
    new = dataclasses.replace(new, uncertainty=with_observer_noise(new.uncertainty, check.noise_h_mps, check.noise_up_mps))
    return new, report, points


Fit = tuple[Airframe, FitReport, "Points | None"]
FitChecked = tuple[Airframe, FitReport, "Points | None", SelfCheck]


def _maybe_blend(af: Airframe, log_paths: list[str], options: FitOptions, first: FitChecked) -> FitChecked:
    """``first`` (the fit of ``af``), or the fit with its acceleration input blended with the velocity's
    derivative when that is tried and kept (accelroute.py)."""
    new, report, _, check = first
    lowered = report.low_pass is not None
    noise = None
    if log_signals(new).measured_acceleration and (lowered or accelroute.needs_blend_check(
            new, check, options.hover)) and options.log_reader is None:
        noise = blendnoise.logs_sensor_noise(log_paths, new.observer.acceleration)
    ratio = accelroute.predicted_ratio(new, noise)
    if not accelroute.tries_blend(new, check, options.hover, lowered, ratio):
        return first
    # The blend is fitted at the first fit's low-pass, not lowered further (hover rounds 0): it is judged
    # at the same cutoff, and it never buys its quiet with a slower response to a wind change. Every
    # family is fitted again: the noise decides between them (a 50 Hz vehicle with a noisy accelerometer
    # chose the polynomial family unblended, and read its tunnel 0.12 m/s off when held to it blended).
    time_s = accelroute.blend_time(new, noise)
    start = accelroute.blended(dataclasses.replace(af, filter=new.filter), time_s)
    same = dataclasses.replace(options, hover=dataclasses.replace(options.hover, rounds=0))
    try:
        other = _fit_once(start, log_paths, same)
    except CheckFailed as exc:
        report = dataclasses.replace(
            report, acceleration_route=accelroute.blend_record(af, check, None, False, str(exc), ratio, time_s),
            warnings=[*report.warnings, accelroute.failed_blend_warning(str(exc), time_s)])
        return new, report, first[2], check
    kept = accelroute.keeps_blend(check, other[3], predicted=ratio is not None)
    record = accelroute.blend_record(af, check, other[3], kept, ratio=ratio, time_s=time_s)
    if not kept:
        return new, dataclasses.replace(report, acceleration_route=record), first[2], check
    blend_report = dataclasses.replace(other[1], acceleration_route=record)
    if report.low_pass is not None:  # lowered on the first fit: from the airframe's figure to the blend's, at that cutoff
        blend_report = dataclasses.replace(blend_report, low_pass=dataclasses.replace(
            report.low_pass, still_noise_mps=(report.low_pass.still_noise_mps[0], other[3].still_noise_mps)))
    return other[0], blend_report, other[2], other[3]


def refit_without_outliers(first: Fit, log_paths: list[str], fit: Callable[[list[str]], Fit]) -> Fit:
    """``first`` (the fit on every log) again without the logs it flagged as outliers (runmeans), by
    ``fit`` on the rest; ``first`` itself when none is flagged or none would be left. The new report
    names the logs left out (excluded_logs and a warning)."""
    excluded = runmeans.outlier_logs(first[1].runs)
    kept = [log for log in log_paths if log not in excluded]
    if not excluded or not kept:
        return first
    new, report, points = fit(kept)
    warning = (f"--exclude-outliers: fitted without {', '.join(excluded)} (flagged as outliers by the fit "
               "on every log); the self-check replays only the logs kept")
    return new, dataclasses.replace(report, excluded_logs=excluded, warnings=[*report.warnings, warning]), points


def _fit_once(af: Airframe, log_paths: list[str],
              options: FitOptions) -> tuple[Airframe, FitReport, Points | None, SelfCheck]:
    """One fit of ``af``'s route: the families, the choice, the self-check and the low-pass at zero
    airflow; the airframe, its report, its points and its last self-check."""
    terms, dynamic, model, still_air = options.terms, options.dynamic, options.model, options.still_air
    limits, block_bytes, hover = options.limits, options.block_bytes, options.hover
    frames = DRAG_FRAMES_OF[model]
    if block_bytes is None:
        calibration = _whole_logs(af, log_paths, frames or (DragFrame.HEADING,), dynamic, still_air, options.log_reader)
    else:
        calibration = _streamed_logs(af, log_paths, frames or (DragFrame.HEADING,), dynamic, still_air,
                                     model in ("polynomial", "auto"), block_bytes, options.log_reader)
    by_frame, per_log = calibration.by_frame, calibration.per_log
    samples = by_frame.get(DragFrame.HEADING, next(iter(by_frame.values())))
    families, scores, failures = _drag_families(af, by_frame, frames, len(samples), options.direction_shape)
    if model in ("polynomial", "auto"):
        try:
            fitted, report, points = fit_polynomial(af, [], terms, dynamic, points_of=calibration.points_of)
            families["polynomial"] = (fitted, report, points)
            scores["polynomial"] = _polynomial_scores(fitted, samples) if len(samples) >= 100 else None
        except CheckFailed as exc:
            # Not an error when a drag family was fitted: the paper's family needs steady holds, which an
            # ordinary flight has few of; the warning says why it was not among the candidates.
            failures.append(f"polynomial family not fitted: {exc}")
    if not families:
        raise CheckFailed("; ".join(failures) or "no model could be fitted")
    chosen = choose_family(list(families), scores)
    new, report, points = families[chosen]
    report, vertical = _chosen_report(report, chosen, scores, samples, failures)
    # Unidentified, the vertical law is not used: the step publishes zero vertical wind and flags it.
    new = dataclasses.replace(new, vertical_law=VERTICAL_FALLBACK if vertical else "fitted")
    report = dataclasses.replace(report, runs=[dataclasses.replace(run, log=log_paths[run.log]) for run in report.runs],
                                 warnings=[*report.warnings, *(f"{log_paths[index]}: contributed no usable sample"
                                                               for index, count in enumerate(per_log) if count == 0)])
    speed_range = _speed_range(samples, points)
    cv = report.hold_cv_speed_mps if report.hold_cv_speed_mps is not None else report.horizontal_cv_rmse_mps
    exempt = (runmeans.exempt_outliers(report.runs, report.anchored)
              if report.hold_cv_without_outliers_mps is not None else [])
    if exempt:  # the fit's own outliers: judged on the logs that agree (runmeans.exempt_outliers)
        cv = report.hold_cv_without_outliers_mps
        limits = dataclasses.replace(limits, outlier_logs=tuple(exempt))
        report = dataclasses.replace(report, warnings=[*report.warnings, runmeans.exempt_warning(report.runs, exempt)])
    elif report.hold_cv_speed_mps is not None:
        limits = _diverged_cv(limits, scores.get(chosen))
    check = calibration.check(new, cv, speed_range, limits)
    new, check, low_pass, quiet_warnings = _quiet_hover(
        new, check, hover, lambda af_: calibration.check(af_, cv, speed_range, limits))
    check = _short_flight(check, samples)
    return new, dataclasses.replace(report, low_pass=low_pass,
                                    warnings=[*report.warnings, *quiet_warnings, *check.warnings]), points, check


def _diverged_cv(limits: Thresholds, scores: FamilyScores | None) -> Thresholds:
    """The limits with why the chosen family's hold-level CV measures nothing (folds whose held-out
    predictions diverged: dobwind/calibrate/cvdiverge.py), for the self-check to say instead of its figure."""
    hold = None if scores is None else scores.hold
    if hold is None or hold.diverged is None:
        return limits
    return dataclasses.replace(limits, cv_diverged=hold.diverged)


def _short_flight(check: SelfCheck, samples: dragfit.DragSamples) -> SelfCheck:
    """A refusal whose cross-validation failed (or could not be made) on fewer blocks than the CV's folds
    says so, with what would do: the flight is short, which the CV figure alone does not tell."""
    clause = dragfit.few_blocks(samples)
    cv_failed = check.cv_mps is None or not math.isfinite(check.cv_mps) or check.cv_mps > check.cv_limit_mps
    if check.passed or clause is None or not cv_failed:
        return check
    return dataclasses.replace(check, reasons=[*check.reasons, clause])


def _chosen_report(report: FitReport, chosen: str, scores: dict[str, FamilyScores | None], samples: dragfit.DragSamples,
                   failures: list[str]) -> tuple[FitReport, str | None]:
    """The chosen family's report with the choice, every family's scores, the chosen one's hold-level
    figures and the warnings about the data (the other families' failures first); and the vertical
    warning, when the vertical law is not identified (None when it is)."""
    hold = (scores.get(chosen) or UNSCORED).hold
    window_s = None if hold is None else hold.by_speed.window_s
    sparse = holdcv.sparse_windows(window_s, float(np.median(samples.rates_hz()))) if len(samples) else None
    air_z = samples.airflow[:, 2] if len(samples) else np.zeros(0)
    skill = (scores.get(chosen) or UNSCORED).vertical_skill
    vertical = vertical_warning(report.vertical_cv_rmse_mps, air_z, skill)
    warnings = [*report.warnings, *failures, *([sparse] if sparse else []),
                *([vertical + VERTICAL_FALLBACK_NOTE] if vertical else [])]
    return dataclasses.replace(report, model=chosen, families=scores, samples=len(samples),
                               vertical_zero_rmse_mps=zero_rmse(air_z),
                               vertical_unexplained_share=None if skill is None else skill.share,
                               vertical_unexplained_share_se=None if skill is None else skill.share_se,
                               hold_cv_speed_mps=None if hold is None else hold.cv_speed_mps,
                               hold_cv_by_speed=None if hold is None else hold.by_speed,
                               hold_extrapolation_speed_mps=None if hold is None else hold.extrapolation_speed_mps,
                               hold_cv_diverged=None if hold is None else hold.diverged,
                               warnings=warnings), vertical


VERTICAL_FALLBACK_NOTE = (f'; the fitted airframe says force_air.vertical_law = "{VERTICAL_FALLBACK}": its '
                          "step publishes zero vertical wind with sigma_up -1, and its C header says "
                          "VERTICAL_ESTIMATED 0 (docs/c-api.md)")


def zero_rmse(air_z_mps: np.ndarray) -> float | None:
    """The RMS of the true vertical airflow: the error of predicting zero (None without samples)."""
    return float(np.sqrt(np.mean(np.square(air_z_mps)))) if len(air_z_mps) else None


def vertical_warning(cv_v_mps: float | None, air_z_mps: np.ndarray,
                     skill: verticalskill.VerticalSkill | None = None) -> str | None:
    """A warning when the chosen vertical law is not identified: it predicts held-out vertical airflow no
    better than zero does, or beats zero by less than the CV blocks' own scatter (``skill``, verticalskill.py:
    a law that wins on one block of climbs and loses on the rest). The logs then do not identify it (level
    flight, or a thrust model whose error swamps the vertical drag), and the step, which inverts that law,
    turns the thrust error into vertical wind."""
    zero_mps = zero_rmse(air_z_mps)
    if cv_v_mps is None or zero_mps is None:
        return None
    figures = (f"grouped CV {cv_v_mps:.3f} m/s{dragfit.diverged(cv_v_mps)}, RMS of the true vertical airflow "
               f"{zero_mps:.3f} m/s")
    advice = "these logs do not identify it and the vertical wind is unreliable (fly climbs and descents; check the thrust model)"
    if cv_v_mps >= zero_mps:
        return f"the vertical law predicts held-out vertical airflow no better than zero does ({figures}): {advice}"
    if skill is None or skill.identified:
        return None
    return (f"the vertical law beats zero vertical airflow by less than the scatter over the CV blocks ({figures}; "
            f"it leaves {skill.share:.2f} of the vertical mean square unexplained, standard error {skill.share_se:.2f} "
            f"over {skill.blocks} blocks, and {verticalskill.SE_MULTIPLE:g} standard errors above it is "
            f"{skill.upper:.2f}, not below 1): {advice}")


Family = tuple[Airframe, FitReport, "Points | None"]
# Families whose per-sample scores lie within this share of the best tie (choose_family).
FAMILY_TIE = 0.02
# The family a tie goes to. The body-frame law acts on the airflow the airframe meets: an error of the
# thrust model (inflow, the curve) lies along body z there, where the heading frame tilts part of it into
# the horizontal force, more with every m/s. So it extrapolates: on the random vehicles the heading-frame
# law won such ties on its hold means (by up to 30 %) four times in four, and read the tunnel's 10 m/s
# hold, beyond the 8.4 m/s calibration, 0.11-0.51 m/s off, against 0.04-0.14 for the body-frame law.
TIE_PREFERRED = "drag-body"


def _hold_level(scores: FamilyScores) -> float:
    cv = None if scores.hold is None else scores.hold.cv_speed_mps
    extra = None if scores.hold is None else scores.hold.extrapolation_speed_mps
    if cv is None:
        return math.inf
    return dragfit.combined(cv, math.nan if extra is None else extra)


def choose_family(names: list[str], scores: dict[str, FamilyScores | None]) -> str:
    """Families fitted on the run means (a "run_loss" score): the lowest of it. Else the family with the
    lowest per-sample score (CV and extrapolation of the airflow). Among those
    within FAMILY_TIE of it: the body-frame drag law when it is one of them (TIE_PREFERRED); else the
    lowest hold-level score when it is FAMILY_TIE below the first's. The per-sample score carries each
    sample's noise, so two frames of one vehicle often tie on it while their hold means, which replay's
    per-hold errors follow, differ (0.066 against 0.060 m/s on a 1.8-exponent vehicle)."""
    ranked = {k: scores.get(k) or UNSCORED for k in names}
    anchored = [k for k in names if ranked[k].run_loss is not None]
    if anchored:
        # Fitted on the run means (runmeans.py): the per-sample scores measure the within-log scatter
        # those fits do not let outvote the means, so the families are ranked as each fit ranked its
        # own starts, by the robust loss of the logs' mean errors (on the four Neural-Fly runs the
        # per-sample score took the body frame, 4.07 against 4.62 m/s, whose law left the zero-wind
        # run 0.59 m/s off; the heading frame's left each kept run within 0.35 m/s).
        return min(anchored, key=lambda k: ranked[k].run_loss)  # type: ignore[arg-type, return-value]
    per_sample = {k: ranked[k].score_mps or math.inf for k in names}
    best = min(names, key=lambda k: per_sample[k])
    if not math.isfinite(per_sample[best]):
        return best
    tied = [k for k in names if per_sample[k] <= per_sample[best] * (1 + FAMILY_TIE)]
    if TIE_PREFERRED in tied:
        return TIE_PREFERRED
    challenger = min(tied, key=lambda k: (_hold_level(ranked[k]), per_sample[k]))
    # A tie on the hold level too keeps the per-sample choice (the demo's m300: polynomial 0.054 against
    # drag-body 0.054 m/s; switching read its outdoor flight 0.145 instead of 0.077 m/s).
    if _hold_level(ranked[challenger]) < (1 - FAMILY_TIE) * _hold_level(ranked[best]):
        return challenger
    return best


def _drag_families(af: Airframe, by_frame: dict[DragFrame, dragfit.DragSamples], frames: tuple[DragFrame, ...],
                   samples: int, shape: DirectionShape | None = None
                   ) -> tuple[dict[str, Family], dict[str, FamilyScores | None], list[str]]:
    """Each drag frame's law chosen and scored, the body frame's with its exponent (dragexponent):
    (fitted families, their scores, why a family was not). ``shape``: the direction shape tied to q0 where
    the flight does not identify the harmonics (dragfit.shape_if_unidentified)."""
    families: dict[str, Family] = {}
    scores: dict[str, FamilyScores | None] = {}
    failures: list[str] = []
    for frame in frames:
        family = FAMILY_OF_FRAME[frame]
        if samples < 100:
            failures.append(f"{family} family: only {samples} usable samples (need 100)")
            continue
        # Logs whose means a per-sample fit cannot meet are fitted on their means (dobwind/calibrate/runmeans.py);
        # asked of the law the fit fits, so after the tie (an isotropic law misses tracks a tied one meets).
        by_frame[frame] = dragfit.anchor_on_runs(dragfit.shape_if_unidentified(by_frame[frame], shape))
        choice = dragfit.choose_drag_law(by_frame[frame], holdcv.prefer_on_holds)
        reason = _uninvertible(by_frame[frame], choice)
        if reason is not None:
            failures.append(f"{family} family: {reason}")
            continue
        hold = holdcv.hold_cv(by_frame[frame], dragfit.drag_fit_predict(choice.active))
        picked = dragexponent.ExponentChoice(2.0, by_frame[frame], choice, hold)
        if frame == DragFrame.BODY:  # the heading frame's exponent would absorb the tilt (dragexponent's note)
            picked = dragexponent.choose_exponent(by_frame[frame], choice,
                                                  lambda s, c: _uninvertible(s, c) is None, hold)
        families[family], scores[family] = _drag_family(af, picked)
    return families, scores, failures


def _drag_family(af: Airframe, picked: dragexponent.ExponentChoice) -> tuple[Family, FamilyScores]:
    fitted = drag_airframe(af, picked.choice, picked.samples)
    report = dataclasses.replace(_drag_report(picked.choice, picked.samples, fitted),
                                 exponent_scores={f"{p:g}": s for p, s in sorted(picked.scores.items())})
    flagged = [run.log for run in report.runs if run.outlier]  # log indices here
    if runmeans.exempt_outliers(report.runs, report.anchored):
        # The hold-level CV the self-check judges when it leaves the flagged logs out (fitfamily._fit_once).
        keep = ~np.isin(picked.samples.log_index, flagged)
        hold = holdcv.hold_cv(picked.samples.select(keep), dragfit.drag_fit_predict(picked.choice.active))
        report = dataclasses.replace(report, hold_cv_without_outliers_mps=hold.rms_mps if hold is not None else None)
    scores = _family_scores((picked.choice.cv_h_mps, picked.choice.cv_v_mps), picked.choice.extrapolation_h_mps,
                            picked.hold)
    run_loss = runmeans.cauchy_loss(np.array([run.error_mps for run in report.runs])) if report.anchored else None
    skill = _skill(picked.samples, dragfit.drag_fit_predict(picked.choice.active))
    return (fitted, report, None), dataclasses.replace(scores, run_loss=run_loss, exponent=picked.exponent,
                                                       vertical_skill=skill)


def _uninvertible(samples: dragfit.DragSamples, choice: dragfit.DragChoice) -> str | None:
    """Why the step could not invert the chosen law, or None: a horizontal law that decreases somewhere
    (every set's did), or no vertical drag at all (lz = qz = 0: the vertical airflow is then undefined)."""
    where = dragfit.decreasing_at(samples, choice.theta)
    if where is not None:
        dropped = "; ".join(choice.dropped)
        return f"the fitted law decreases at {where}" + (f" (and so did {dropped})" if dropped else "")
    values = dict(zip(samples.parameters, choice.theta))
    if not values["lz"] + values["qz"] > 0:
        return "no vertical drag (lz = qz = 0): the calibration did not move the air vertically enough"
    return None


def _quiet_hover(af: Airframe, check: SelfCheck, hover: HoverNoise,
                 recheck: Callable[[Airframe], SelfCheck]) -> tuple[Airframe, SelfCheck, LowPassChange | None, list[str]]:
    """The airframe with its first low-pass cutoff lowered until the self-check's noise at low airflow
    meets the target (at most ``hover.rounds`` more self-check passes), that last check, what changed
    (None when nothing did) and warnings. A lower cutoff settles more slowly: a schedule that turns a
    passing self-check into a failing one (short holds left with nothing to score, lag at wind changes)
    is not taken, nor one whose check no longer finds a low-airflow segment to measure."""
    before_hz, before_mps = af.filter.cutoffs_hz[0], check.still_noise_mps
    warnings: list[str] = []
    for _ in range(hover.rounds):
        schedule = quieter_schedule(af.filter, check.still_noise_mps, hover)
        if schedule is None:
            break
        lowered = dataclasses.replace(af, filter=schedule)
        again = recheck(lowered)
        if (check.passed and not again.passed) or again.still_noise_mps is None:
            why = "; ".join(again.reasons) if again.still_noise_mps is not None else "no low-airflow segment is left"
            warnings.append(f"the low-pass at zero airflow was not lowered below {af.filter.cutoffs_hz[0]:.3g} Hz (noise "
                            f"at low airflow {check.still_noise_mps:.3f} m/s, --hover-noise {hover.target_mps:g}): at "
                            f"{schedule.cutoffs_hz[0]:.3g} Hz the self-check fails ({why})")
            break
        if again.still_noise_mps >= check.still_noise_mps:
            # Slower, and no quieter: what is left at low airflow is not noise the low-pass removes (a
            # real tunnel run's slow wander read 0.81 -> 1.08 m/s from 0.2 to 0.05 Hz). Not taken.
            warnings.append(f"the low-pass at zero airflow was not lowered below {af.filter.cutoffs_hz[0]:.3g} Hz: at "
                            f"{schedule.cutoffs_hz[0]:.3g} Hz the noise at low airflow is {again.still_noise_mps:.3f} "
                            f"m/s, not below {check.still_noise_mps:.3f} (slow error, not noise)")
            break
        af, check = lowered, again
    noise = check.still_noise_mps
    if noise is not None and 0 < hover.target_mps < noise * hover.min_change \
            and af.filter.cutoffs_hz[0] <= hover.floor_hz and not warnings:
        warnings.append(f"the noise at low airflow is {noise:.3f} m/s per axis with the low-pass at zero airflow at "
                        f"its floor, {hover.floor_hz:g} Hz (--hover-noise {hover.target_mps:g})")
    if af.filter.cutoffs_hz[0] == before_hz:
        return af, check, None, warnings
    change = LowPassChange((before_hz, af.filter.cutoffs_hz[0]), (before_mps, check.still_noise_mps), hover.target_mps)
    return af, check, change, warnings


def _speed_range(samples: dragfit.DragSamples, points: Points | None) -> float:
    """The largest true horizontal airflow speed calibrated on (m/s)."""
    if len(samples):
        return float(np.max(np.hypot(samples.airflow[:, 0], samples.airflow[:, 1])))
    return float(np.max(points.speed_h)) if points is not None and len(points) else 0.0


def _drag_report(choice: dragfit.DragChoice, samples: dragfit.DragSamples, fitted: Airframe) -> FitReport:
    values = dict(zip(samples.parameters, (float(v) for v in choice.theta)))
    # As written to the airframe (the rotor term on the scaled thrust), with the offsets and kappa.
    drag = {**{k: values[k] for k in samples.parameters}, **{
        k: v for k, v in fitted.drag.as_dict().items() if k != "frame"}}  # type: ignore[union-attr]
    return FitReport(points=len(samples), thrust_scale=fitted.thrust.scale, drag=drag,
                     force_offset_n=(values["ox"], values["oy"], 0.0),
                     horizontal_rmse_mps=choice.rmse_h_mps, horizontal_cv_rmse_mps=_none(choice.cv_h_mps),
                     horizontal_extrapolation_rmse_mps=_none(choice.extrapolation_h_mps),
                     vertical_rmse_mps=choice.rmse_v_mps, vertical_cv_rmse_mps=_none(choice.cv_v_mps),
                     not_increasing=list(choice.dropped), anchored=samples.anchor,
                     warnings=_directions_warning(choice, samples),
                     runs=dragfit.run_verdicts(samples, choice.active, choice.theta))


def _directions_warning(choice: dragfit.DragChoice, samples: dragfit.DragSamples) -> list[str]:
    """What the law assumes about the directions the flight did not calibrate: isotropy, or the shape
    tied to its quadratic term (dobwind/calibrate/directionshape.py)."""
    if choice.directions is None:
        return []
    shape = samples.direction_shape
    # Shaped only when the law has a quadratic term: a set without q0, or q0 dropped for its sign, is isotropic.
    shaped = shape is not None and choice.theta[samples.parameters.index("q0")] > 0
    instead = f"its quadratic term takes the shape of {shape.text()}" if shaped else "an isotropic law instead"
    return [f"drag law: no direction harmonics (anisotropy) fitted, {instead}: {choice.directions.text()}; "
            "fly more headings relative to the wind to calibrate them"]
