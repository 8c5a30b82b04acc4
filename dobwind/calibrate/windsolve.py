"""`fit --wind unknown`: one steady wind per log (or per segment) estimated jointly with a drag law.

What is measured: the observer's external force f (heading frame), the ground velocity v and the
attitude. What is not: the wind w. The relative airflow is a = R(yaw) (w - v), and a drag law maps it to
force: f_h = l0 a_h + q0 |a_h| a_h + (q2c, q2s: the quadratic drag's fore-aft/lateral anisotropy) + o
(dobwind/calibrate/dragfit.py's `basis`, the force-air home's horizontal drag basis; o the heading-frame force
offset). Unknowns: w per log or segment (north, east) and LAW; solved by nonlinear least squares (scipy,
soft-L1 loss: gusts are outliers of a steady model), with priors on the offset and the law (Prior).
On simulated box flights (`dobwind simulate box --hold 6 --rate 10`, seeds 5-9, a 3 kg
collective-thrust quad, 4-7 m/s winds) the winds came out 0.03-0.08 m/s off. A thrust-scale term
(kappa) free in this horizontal problem ran to 0.8 on the SITL log and dragged the wind with it; instead
it comes from the vertical force balance (dobwind/calibrate/thrustscale.py) and is fixed here, and only
when a nested-model test says the horizontal force needs it (a starter 20 % off: yes; a right one: no,
and the solution is the one without it). The
vertical wind is assumed zero on average (a steady updraft is indistinguishable from a thrust-scale
error), so the vertical law is left to the ordinary fit, which then calibrates on the winds found here.

The flight must identify the wind. A constant offset o turns with the vehicle and a constant wind does
not, so the headings must vary; a quadratic law in a speed that never changes sign makes wind and law
trade (f = q0 (w - v)^2 + ... is a quadratic in v with as many coefficients as unknowns), so the speeds
and directions must vary too (a back-and-forth at one heading whose airflow reverses pins the
along-track wind through the |a| a kink, not the cross-track one). Both show in the Jacobian of the
joint problem at the solution: its column-scaled condition number, and each wind's 1-sigma from the
covariance (residual variance inflated for the residuals' correlation from sample to sample). That
1-sigma is statistical: the law's own misfit to the vehicle adds a bias it does not see (1.0 m/s on a
simulated 8 kg box flight). A flight that fails either, or spans too few headings or airflow
directions (Coverage), is refused with what it lacks, instead of a guess.

Samples (dobwind/calibrate/windrows.py): every row the calibration airframe's step (fit.calibration_run) accepted
at least a settling time after any rejection, steady or not, decimated to about 5 Hz; the law's force
is passed through the step's own observer filters before the comparison, so no lag remains.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from dobwind.calibrate import dragfit, thrustscale, windrows
from dobwind.core.errors import CheckFailed
from dobwind.calibrate.fieldtruth import LogTime
from dobwind.io.logs import FlightLog, heading_yaw
from dobwind.model.airframe import Airframe
from dobwind.model.forceair import wind_from_deg
from dobwind.calibrate.thrustscale import ThrustScale, VerticalRows
from dobwind.calibrate.windrows import LogRows
from dobwind.model.status import accepted
from dobwind.model.signals import log_signals

LAW = ("l0", "q0", "ox", "oy", "q2c", "q2s")
LAW_BOUNDS = {"l0": (0.0, np.inf), "q0": (0.0, np.inf), "kappa": (-1.0, 1.0)}
MIN_HEADING_SECTORS = 3      # of 8 (45 deg each), see Coverage.lacking
MIN_AIRFLOW_SECTORS = 2
MAX_CONDITION = 1e4          # column-scaled Jacobian: beyond it some combination is not identified
MAX_WIND_SIGMA_MPS = 0.5     # each wind component's 1-sigma at the solution
MIN_SAMPLES_PER_WIND = 30
START_SPEEDS_MPS = (0.0, 5.0, 12.0)   # starting winds (and 4 directions for the non-zero ones)
OFFSET_PRIOR_DEG = 1.0       # the force offset's prior 1-sigma, as the force of this tilt (see Prior)
THRUST_PRIOR = 0.2           # the thrust scale's prior 1-sigma (init's hover-thrust calibration)
LAW_PRIOR_SPREAD = 3.0       # the drag terms' prior 1-sigma, this many times the starter's value


@dataclass(frozen=True)
class WindGroup:
    """One steady wind: which log, its time span in the log's own clock, the wind found and its 1-sigma."""
    path: str
    t_start_s: float
    t_end_s: float
    wind_ne: tuple[float, float]
    sigma_mps: float
    samples: int

    @property
    def speed_mps(self) -> float:
        return math.hypot(*self.wind_ne)

    @property
    def from_deg(self) -> float:
        return float(wind_from_deg(self.wind_ne[0], self.wind_ne[1]))

    def direction_text(self) -> str:
        """The direction's 1-sigma, for the user: a sideways error of sigma_mps (the larger component's)
        turns a wind of speed_mps by atan(sigma / speed): 14 deg at 1.75 m/s with 0.45 m/s (the 37 s PX4
        drag-fusion field log), which a speed's 1-sigma alone does not make plain. Statistical, as sigma_mps:
        a misfit of the law adds a bias it does not show (docs/field-calibration.md)."""
        if not self.sigma_mps < self.speed_mps:
            return "direction not determined (the 1-sigma reaches the speed)"
        return f"direction 1-sigma {math.degrees(math.atan2(self.sigma_mps, self.speed_mps)):.0f} deg"


@dataclass(frozen=True)
class JointSolution:
    groups: tuple[WindGroup, ...]
    law: dict[str, float]
    condition: float
    residual_rms_n: float
    notes: tuple[str, ...] = field(default_factory=tuple)
    thrust_scale: ThrustScale | None = None   # the vertical balance's estimate and whether it was used


def _usable(t: np.ndarray, status: np.ndarray, settle_s: float) -> np.ndarray:
    """Accepted rows at least ``settle_s`` after the last rejection (the observer has settled)."""
    rejected = ~accepted(status)
    rejected[0] = True
    last = np.maximum.accumulate(np.where(rejected, t, -np.inf))
    return ~rejected & (t - last >= settle_s)


def log_samples(af: Airframe, flights: list[tuple[str, LogTime]],
                segment_s: float | None) -> tuple[list[LogRows], list[tuple[str, float, float]], list[VerticalRows]]:
    """Every log's accepted rows (windrows.LogRows), the wind groups' (path, start, end) in log time, and
    each log's rows for the vertical balance (thrustscale.VerticalRows)."""
    from dobwind.calibrate.fit import calibration_run

    run = calibration_run(af, [flight.log for _, flight in flights])
    logs, spans, verticals, seen = [], [], [], 0
    for (path, flight), force, status in zip(flights, run.force_ned, run.status):
        log = flight.log
        t = log.time_s
        ok = accepted(status) & np.isfinite(force[:, :2]).all(axis=1)
        ok &= np.isfinite(log.stack("vel_n", "vel_e")).all(axis=1)
        seen += int(ok.sum())
        fitted = _usable(t, status, run.model.settling_time_s)[ok]
        fitted &= (np.arange(int(ok.sum())) % windrows.decimation(t)) == 0
        if not fitted.any():
            continue
        times = t[ok]
        # Segments count from the log's first row, so that a segment boundary is where the user put it.
        label = np.floor((times - t[0]) / segment_s).astype(int) if segment_s else np.zeros(len(times), int)
        used = np.unique(label[fitted])
        # a row in a segment without fitted rows takes the last earlier group's wind (it only feeds the
        # filter that the next fitted rows see)
        group = len(spans) + np.clip(np.searchsorted(used, label, side="right") - 1, 0, len(used) - 1)
        for value in used:
            inside = times[(label == value) & fitted]
            spans.append((path, float(inside[0] + flight.t0_s), float(inside[-1] + flight.t0_s)))
        rows, vertical = _rows(run.airframe, log, force[ok], ok, group, fitted, float(np.median(np.diff(times))))
        logs.append(rows)
        verticals.append(vertical)
    if not logs:
        # replay counts the settling rows as accepted ("5 valid"): say why none of them is used
        raise CheckFailed(f"--wind unknown: no airborne row of the logs is accepted and settled ({seen} accepted, none "
                          f"{run.model.settling_time_s:.2g} s after the first row or a rejection): fly longer")
    return logs, spans, verticals


def _rows(cal: Airframe, log: FlightLog, force: np.ndarray, ok: np.ndarray, group: np.ndarray, fitted: np.ndarray,
          dt: float) -> tuple[LogRows, VerticalRows]:
    q = log.stack("q_w", "q_x", "q_y", "q_z")
    yaw = heading_yaw(log, q)[ok]
    rpm = log.stack(*log_signals(cal).rpm_columns())[ok] if log_signals(cal).rotor_speeds else None
    thrust = log.columns["thrust"][ok] if "thrust" in log.columns else None
    t_ned = np.nan_to_num(dragfit.thrust_ned(cal, rpm, thrust, q[ok]))
    times = log.time_s[ok]
    path = windrows.observer_path(cal, np.diff(times, prepend=times[0]))
    sos = windrows.smoothing(dt)
    rows = LogRows(windrows.smooth(sos, force[:, :2]), log.stack("vel_n", "vel_e")[ok], np.cos(yaw), np.sin(yaw),
                   t_ned[:, :2], group, fitted, path, sos)
    vel_d = np.nan_to_num(log.columns["vel_d"][ok]) if "vel_d" in log.columns else np.zeros(len(times))
    return rows, thrustscale.vertical_rows(cal, times, np.nan_to_num(force[:, 2]), t_ned[:, 2], vel_d, fitted, dt)


@dataclass(frozen=True)
class Prior:
    """The law's prior, as extra residuals: value and 1-sigma per parameter (the starter's law, loosely).
    Needed for the force offset: with the heading constant, a linear drag term's l0 R w and a constant
    offset o are the same force (l0 w ~ o), and only a turning vehicle separates them. A level multirotor
    has no reason for a steady horizontal force in still air beyond a small thrust-axis or attitude bias,
    so the offset's prior is zero with the force of OFFSET_PRIOR_DEG of tilt as its 1-sigma; the wind's
    1-sigma then includes what that allows (the covariance has the prior rows), instead of the offset
    silently absorbing the wind."""
    mean: np.ndarray
    sigma: np.ndarray


def prior(af: Airframe) -> Prior:
    drag = af.drag
    tilt = af.mass_kg * af.gravity_mps2 * math.tan(math.radians(OFFSET_PRIOR_DEG))
    mean = {"l0": 0.0, "q0": 0.0, "ox": 0.0, "oy": 0.0, "q2c": 0.0, "q2s": 0.0, "q1c": 0.0, "kappa": 0.0}
    spread = {p: math.inf for p in LAW} | {"ox": tilt, "oy": tilt, "kappa": THRUST_PRIOR}
    if drag is not None and drag.l0 > 0 and drag.q0 > 0:
        # the starter's drag terms within a factor of about 1 + LAW_PRIOR_SPREAD (weak: the data decide);
        # a starter without a positive drag law (a polynomial airframe) gives no prior on them
        mean |= {"l0": drag.l0, "q0": drag.q0}
        spread |= {"l0": LAW_PRIOR_SPREAD * drag.l0, "q0": LAW_PRIOR_SPREAD * drag.q0,
                   "q2c": LAW_PRIOR_SPREAD * drag.q0, "q2s": LAW_PRIOR_SPREAD * drag.q0,
                   "q1c": LAW_PRIOR_SPREAD * drag.q0}
    return Prior(np.array([mean[p] for p in LAW]), np.array([spread[p] for p in LAW]))


@dataclass(frozen=True)
class Problem:
    logs: list[LogRows]
    groups: int
    prior: Prior
    scale_n: float   # the data residuals' expected scale (N): prior rows are weighted against it
    kappa: float = 0.0   # the thrust-scale error, fixed (thrustscale: from the vertical balance, or 0)

    def data(self, x: np.ndarray) -> np.ndarray:
        winds = x[:2 * self.groups].reshape(self.groups, 2)
        law = dict(zip(LAW, x[2 * self.groups:])) | {"kappa": self.kappa}
        return np.concatenate([windrows.residual(rows, winds, law).ravel() for rows in self.logs])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        law = x[2 * self.groups:]
        return np.r_[self.data(x), self.scale_n * (law - self.prior.mean) / self.prior.sigma]

    def log_index(self) -> np.ndarray:
        return np.concatenate([np.full(int(rows.fitted.sum()), k) for k, rows in enumerate(self.logs)])


def _linear_law(problem: Problem, winds: np.ndarray) -> np.ndarray:
    """The law that best fits at these winds (the filtered force is linear in it), within its bounds."""
    zero = np.r_[winds.ravel(), np.zeros(len(LAW))]
    base = problem.data(zero)
    columns = []
    for k in range(len(LAW)):
        x = zero.copy()
        x[2 * problem.groups + k] = 1.0
        columns.append(problem.data(x) - base)
    a = -np.column_stack(columns)
    scale = np.maximum(np.abs(a).max(axis=0), 1e-12)
    law, *_ = np.linalg.lstsq(a / scale, base, rcond=None)
    law = law / scale
    for k, p in enumerate(LAW):
        low, high = LAW_BOUNDS.get(p, (-np.inf, np.inf))
        law[k] = min(max(law[k], low + 1e-6), high - 1e-6)
    return law


def _loss(priors: int):
    """Soft-L1 on the data (gusts are outliers of a steady wind), plain squares on the last ``priors``
    residuals: a prior that the robust loss could shrug off would let the offset absorb the wind again."""
    def loss(z: np.ndarray) -> np.ndarray:
        rho = np.empty((3, len(z)))
        t = 1 + z[:-priors]
        rho[0, :-priors] = 2 * (np.sqrt(t) - 1)
        rho[1, :-priors] = 1 / np.sqrt(t)
        rho[2, :-priors] = -0.5 * t ** -1.5
        rho[0, -priors:], rho[1, -priors:], rho[2, -priors:] = z[-priors:], 1.0, 0.0
        return rho
    return loss


def solve(problem: Problem):
    """The joint least squares from several starting winds (the same for every group); the best."""
    from scipy.optimize import least_squares

    groups = problem.groups
    lower = np.r_[np.full(2 * groups, -60.0), [LAW_BOUNDS.get(p, (-np.inf, np.inf))[0] for p in LAW]]
    upper = np.r_[np.full(2 * groups, 60.0), [LAW_BOUNDS.get(p, (-np.inf, np.inf))[1] for p in LAW]]
    best = None
    for speed in START_SPEEDS_MPS:
        for angle in (np.arange(4) * math.pi / 2 + math.pi / 4 if speed else [0.0]):
            winds = np.tile([speed * math.cos(angle), speed * math.sin(angle)], (groups, 1))
            x0 = np.r_[winds.ravel(), _linear_law(problem, winds)]
            x0 = np.clip(x0, lower + 1e-9, upper - 1e-9)
            result = least_squares(problem, x0, bounds=(lower, upper), loss=_loss(len(LAW)), f_scale=problem.scale_n,
                                   x_scale="jac", max_nfev=200)
            if best is None or result.cost < best.cost:
                best = result
    return best


def _inflation(residual: np.ndarray, log_index: np.ndarray) -> float:
    """sqrt((1 + rho) / (1 - rho)) for the residuals' lag-1 correlation rho (an AR(1) reading of their
    dependence): the factor by which the independent-sample 1-sigma understates the true one. rho is
    0.95 or more on every simulated flight, so the cap makes this a fixed x6.24; with it the 1-sigma
    covered as a 1-sigma should on simulated box flights (71 % within 1, 95 % within 2) and was somewhat
    large on turbulent ones, where the uncapped reading (x21-x32) would refuse every flight
    (benchmarks/windsigma.py, docs/field-calibration.md)."""
    r = residual.reshape(-1, 2)
    same = log_index[1:] == log_index[:-1]
    num = float(np.sum(r[1:][same] * r[:-1][same]))
    den = float(np.sum(r * r))
    rho = min(max(num / den, 0.0), 0.95) if den > 0 else 0.0
    return math.sqrt((1 + rho) / (1 - rho))


def raw_jacobian(x: np.ndarray, problem: Problem) -> np.ndarray:
    """The residuals' Jacobian at ``x`` by central differences (least_squares' own is the robust loss's
    reweighted one, which hides how well the data pin each parameter down)."""
    columns = []
    for k in range(len(x)):
        h = 1e-5 * max(1.0, abs(float(x[k])))
        up, down = x.copy(), x.copy()
        up[k] += h
        down[k] -= h
        columns.append((problem(up) - problem(down)) / (2 * h))
    return -np.column_stack(columns)


def identification(x: np.ndarray, problem: Problem) -> tuple[float, np.ndarray]:
    """(column-scaled condition number, each group's largest wind-component 1-sigma in m/s) at ``x``
    (wind_covariance)."""
    condition, sigma = wind_covariance(x, problem)
    return condition, sigma.reshape(problem.groups, 2).max(axis=1)


def wind_component_sigmas(x: np.ndarray, problem: Problem) -> np.ndarray:
    """Every wind component's 1-sigma (group 0 north, east, group 1 north, ...) in m/s at ``x``."""
    return wind_covariance(x, problem)[1]


def wind_covariance(x: np.ndarray, problem: Problem) -> tuple[float, np.ndarray]:
    """(column-scaled condition number, every wind component's 1-sigma in m/s) at ``x``: the covariance
    sigma^2 (J^T J)^-1 with sigma the data residuals' robust scale (MAD), the prior rows weighted against
    ``problem.scale_n`` rescaled to that sigma, and the result inflated for the data residuals'
    correlation from sample to sample."""
    groups = problem.groups
    data = problem.data(x)
    sigma = 1.4826 * float(np.median(np.abs(data - np.median(data))))
    weights = np.r_[np.ones(len(data)), np.full(len(LAW), sigma / problem.scale_n)]
    jac = raw_jacobian(x, problem) * weights[:, None]
    norms = np.linalg.norm(jac, axis=0)
    if not np.all(norms > 0):
        return math.inf, np.full(2 * groups, math.inf)
    singular = np.linalg.svd(jac / norms, compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else math.inf
    if not math.isfinite(condition):
        return condition, np.full(2 * groups, math.inf)
    scaled_inverse = np.linalg.inv((jac / norms).T @ (jac / norms))
    cov = scaled_inverse / np.outer(norms, norms) * sigma * sigma
    wind_sigma = np.sqrt(np.maximum(np.diag(cov)[:2 * groups], 0.0))
    return condition, wind_sigma * _inflation(data, problem.log_index())


@dataclass(frozen=True)
class Coverage:
    """What the flight spanned at its samples: 45-deg sectors of heading and of airflow direction (of
    airflow above 0.5 m/s, with the winds found) and the ground speed's 5th and 95th percentiles."""
    heading_sectors: int
    airflow_sectors: int
    ground_speed_mps: tuple[float, float]

    def lacking(self) -> bool:
        """Too few headings to tell a force offset (it turns with the vehicle) from a wind (it does not),
        or too few airflow directions to tell the wind's direction from the law's anisotropy: the Jacobian
        test alone can pass on such a flight, through the law's nonlinearity at next to no airflow."""
        return self.heading_sectors < MIN_HEADING_SECTORS or self.airflow_sectors < MIN_AIRFLOW_SECTORS

    def text(self) -> str:
        low, high = self.ground_speed_mps
        return (f"headings in {self.heading_sectors} of 8 45-deg sectors (need {MIN_HEADING_SECTORS}), airflow from "
                f"{self.airflow_sectors} of 8 (need {MIN_AIRFLOW_SECTORS}), ground speed {low:.1f}-{high:.1f} m/s")


def _sectors(north: np.ndarray, east: np.ndarray) -> int:
    return len(np.unique(np.floor(np.degrees(np.arctan2(east, north)) % 360 / 45) % 8))


def coverage(logs: list[LogRows], winds: np.ndarray) -> Coverage:
    """What the fitted rows spanned, with the winds found."""
    vel = np.concatenate([rows.vel[rows.fitted] for rows in logs])
    group = np.concatenate([rows.group[rows.fitted] for rows in logs])
    cos_yaw = np.concatenate([rows.cos_yaw[rows.fitted] for rows in logs])
    sin_yaw = np.concatenate([rows.sin_yaw[rows.fitted] for rows in logs])
    air = winds[group] - vel
    moving = np.hypot(air[:, 0], air[:, 1]) > 0.5
    ground = np.hypot(vel[:, 0], vel[:, 1])
    return Coverage(_sectors(cos_yaw, sin_yaw), _sectors(air[moving, 0], air[moving, 1]),
                    (float(np.percentile(ground, 5)), float(np.percentile(ground, 95))))


def flight_time_needed_s(sigma_mps: float, limit_mps: float, span_s: float) -> float:
    """The flight time at which a wind 1-sigma of ``sigma_mps`` over ``span_s`` would reach ``limit_mps``,
    when more of the same flight adds independent information: the 1-sigma of a mean falls as
    1/sqrt(duration) (gusts and other random force errors; a bias of the law would not average out)."""
    return span_s * max(sigma_mps / limit_mps, 1.0) ** 2


def _advice(spanned: Coverage, sigma_mps: float, span_s: float) -> str:
    """What to change: the flight pattern, or (when it spanned enough) the flight's length: the drag signal
    is lost in force the law cannot explain (gusts, thrust-model or timing errors)."""
    if spanned.lacking() or spanned.ground_speed_mps[1] < 2.0:
        return "fly several headings and speeds (boxes, circles, back and forth in more than one direction)"
    needed = flight_time_needed_s(sigma_mps, MAX_WIND_SIGMA_MPS, span_s)
    longer = (f"about {needed:.0f} s of such flight instead of {span_s:.0f} s would bring the 1-sigma to "
              f"{MAX_WIND_SIGMA_MPS:g} m/s if that force is gusts (it averages out as 1/sqrt(time))"
              if math.isfinite(needed) and needed > span_s else "longer legs at steady speed")
    return (f"the headings and speeds vary, but the force the drag law cannot explain hides the wind: {longer}; "
            "or a wind measured another way (--wind SPEED@FROM, --truth)")


def _span_text(span: tuple[str, float, float], groups: int) -> str:
    """A wind's log, and its time span when there is more than one wind (segments or several logs)."""
    path, start, end = span
    return path if groups == 1 else f"{path} t {start:.1f}-{end:.1f} s"


def _each_wind(spans: list[tuple[str, float, float]], sigma: np.ndarray, joint: bool) -> str:
    """With several winds (logs or segments), which of them the flight identified and which not: a wind
    is identified when its 1-sigma is within the limit and the flight as a whole passes the coverage and
    Jacobian tests (``joint``); one wind needs no list, the sentence before names it."""
    if len(spans) < 2:
        return ""
    verdicts = [f"{_span_text(span, len(spans))} {value:.2g} m/s "
                + ("identified" if joint and value <= MAX_WIND_SIGMA_MPS else "NOT identified")
                for span, value in zip(spans, sigma)]
    return "; each wind's 1-sigma: " + ", ".join(verdicts)


def _problem(af: Airframe, logs: list[LogRows], groups: int, kappa: float = 0.0) -> Problem:
    # the data residuals' scale: a few percent of the weight (gusts, thrust-model error), not below 0.05 N
    scale = max(0.02 * af.mass_kg * af.gravity_mps2, 0.05)
    return Problem(logs, groups, prior(af), scale, kappa)


def _solve_with_thrust_scale(af: Airframe, logs: list[LogRows], groups: int, verticals: list[VerticalRows] | None):
    """The wind solve with the thrust scale 1 (kappa 0), and, when the vertical balance gives a clearly
    non-zero kappa, again with it: kept only when it passes thrustscale's nested-model test."""
    plain = _problem(af, logs, groups)
    result = solve(plain)
    scale = thrustscale.estimate(verticals) if verticals else ThrustScale(0.0, math.inf, False)
    if not thrustscale.worth_trying(scale):
        return plain, result, scale
    scaled = _problem(af, logs, groups, scale.kappa)
    other = solve(scaled)
    without = plain.data(result.x)
    scale = thrustscale.nested_test(scale, without, scaled.data(other.x), _inflation(without, plain.log_index()))
    return (scaled, other, scale) if scale.used else (plain, result, scale)


def estimate_winds(af: Airframe, flights: list[tuple[str, LogTime]], segment_s: float | None = None,
                   thrust_scale: bool = True) -> JointSolution:
    """The joint solution, or CheckFailed (exit 1) naming what the flight lacks. ``thrust_scale``: estimate
    the thrust scale from the vertical balance (thrustscale; used only when significant) or keep it."""
    logs, spans, verticals = log_samples(af, flights, segment_s)
    groups = len(spans)
    counts = np.bincount(np.concatenate([rows.group[rows.fitted] for rows in logs]), minlength=groups)
    if counts.min() < MIN_SAMPLES_PER_WIND:
        worst = int(np.argmin(counts))
        raise CheckFailed(f"--wind unknown: {spans[worst][0]} gives only {counts[worst]} settled airborne samples for "
                          f"a wind (need {MIN_SAMPLES_PER_WIND} at {windrows.SAMPLE_RATE_HZ:g} Hz: a longer flight"
                          f"{', or a longer --segment-s' if segment_s else ''}); nothing written")
    problem, result, scale = _solve_with_thrust_scale(af, logs, groups, verticals if thrust_scale else None)
    winds = result.x[:2 * groups].reshape(groups, 2)
    condition, sigma = identification(result.x, problem)
    spanned = coverage(logs, winds)
    what = spanned.text()
    data = problem.data(result.x)
    misfit = 1.4826 * float(np.median(np.abs(data - np.median(data))))
    joint = not spanned.lacking() and condition <= MAX_CONDITION
    if not joint or not np.all(sigma <= MAX_WIND_SIGMA_MPS):
        worst = int(np.argmax(np.nan_to_num(sigma, nan=math.inf)))
        raise CheckFailed(
            f"--wind unknown: the flight does not identify the wind and the force-air law together (wind 1-sigma "
            f"{sigma[worst]:.2g} m/s for {_span_text(spans[worst], groups)}, limit {MAX_WIND_SIGMA_MPS:g}; Jacobian condition "
            f"{condition:.3g}, limit {MAX_CONDITION:g}; force the law leaves unexplained {misfit:.2g} N, "
            f"{misfit / (af.mass_kg * af.gravity_mps2):.1%} of the weight): {what}; {_advice(spanned, float(sigma[worst]), spans[worst][2] - spans[worst][1])}; "
            f"{scale.text()}{_each_wind(spans, sigma, joint)}; nothing written")
    found = tuple(WindGroup(path, start, end, (float(w[0]), float(w[1])), float(s), int(n))
                  for (path, start, end), w, s, n in zip(spans, winds, sigma, counts))
    law = dict(zip(LAW, (float(v) for v in result.x[2 * groups:]))) | {"kappa": scale.applied}
    rms = float(np.sqrt(np.mean(data ** 2)))
    return JointSolution(found, law, condition, rms, (what, scale.text()), scale)


@dataclass(frozen=True)
class GroupWinds:
    """The winds found, as a truth (fieldtruth.Truth): each log's groups, steady over their spans (rows
    before the first group's start and after the last's end take the nearest group's wind)."""
    solution: JointSolution
    # fit's report says the self-check's "true" wind is this estimate (fieldfit.truth_lines)
    ESTIMATED: ClassVar[bool] = True

    def wind(self, path: str, flight: LogTime) -> tuple[np.ndarray, np.ndarray]:
        mine = [g for g in self.solution.groups if g.path == path]
        t = flight.clock_s
        if not mine:
            return np.zeros((len(t), 3)), np.zeros(len(t), dtype=bool)
        starts = np.array([g.t_start_s for g in mine])
        index = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(mine) - 1)
        ne = np.array([g.wind_ne for g in mine])[index]
        return np.column_stack([ne, np.zeros(len(t))]), np.ones(len(t), dtype=bool)

    def describe(self) -> str:
        parts = [f"{g.path} t {g.t_start_s:.1f}-{g.t_end_s:.1f} s: {g.speed_mps:.2f} m/s from {g.from_deg:.0f} deg "
                 f"(1-sigma {g.sigma_mps:.2f})" for g in self.solution.groups]
        return ("estimated jointly with the force-air law (--wind unknown; mean vertical wind assumed zero): "
                + "; ".join(parts))

    def describe_log(self, path: str) -> str:
        # Every wind here passed the identification tests (estimate_winds refuses otherwise), so each is
        # called identified; the 1-sigma says how well.
        mine = [f"t {g.t_start_s:.1f}-{g.t_end_s:.1f} s {g.speed_mps:.2f} m/s from {g.from_deg:.0f} deg, 1-sigma "
                f"{g.sigma_mps:.2f} m/s" for g in self.solution.groups if g.path == path]
        if not mine:
            return "no wind estimated for this log (--wind unknown): its rows were not used"
        return (f"not a known wind: estimated from this flight jointly with the law (--wind unknown, mean vertical "
                f"wind taken as zero), identified (1-sigma within {MAX_WIND_SIGMA_MPS:g} m/s)"
                + (f" in all {len(mine)} segments: " if len(mine) > 1 else ": ") + "; ".join(mine))
