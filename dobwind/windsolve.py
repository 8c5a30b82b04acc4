"""`fit --wind unknown`: one steady wind per log (or per segment) estimated jointly with a drag law.

What is measured: the observer's external force f (heading frame), the ground velocity v and the
attitude. What is not: the wind w. The relative airflow is a = R(yaw) (w - v), and a drag law maps it to
force: f_h = l0 a_h + q0 |a_h| a_h + (q2c, q2s: the quadratic drag's fore-aft/lateral anisotropy) + o
(dobwind/dragfit.py's `basis`, the force-air home's horizontal drag basis; o the heading-frame force
offset). Unknowns: w per log or segment (north, east) and LAW; solved by nonlinear least squares (scipy,
soft-L1 loss: gusts are outliers of a steady model). On simulated box flights (`dobwind simulate box
--hold 6 --rate 10`, seeds 5, 6, 7, a 3 kg collective-thrust quad, 3-7 m/s winds) the isotropic law
(l0, q0, o) left 0.02-0.44 m/s of wind error and this one 0.11-0.22. A thrust-scale term is left out:
in steady flight the thrust's horizontal part balances the drag, so it only rescales the law. The
vertical wind is assumed zero on average (a steady updraft is indistinguishable from a thrust-scale
error), so the vertical law is left to the ordinary fit, which then calibrates on the winds found here.

The flight must identify the wind. A constant offset o turns with the vehicle and a constant wind does
not, so the headings must vary; a quadratic law in a speed that never changes sign makes wind and law
trade (f = q0 (w - v)^2 + ... is a quadratic in v with as many coefficients as unknowns), so the speeds
and directions must vary too. Both show in the Jacobian of the joint problem at the solution: its
column-scaled condition number, and each wind's 1-sigma from the covariance (residual variance inflated
for the residuals' correlation from sample to sample). That 1-sigma is statistical: the law's own misfit
to the vehicle adds a bias it does not see (up to 0.45 m/s on half a simulated box flight). A flight
that fails either, or spans too few headings or airflow directions (Coverage), is refused with what it
lacks, instead of a guess.

Samples: the calibration airframe's step (fit.calibration_run), rows it accepted at least a settling time
after any rejection and steady over the settling time before them (`steady`: in manoeuvres the filtered
force lags the airflow), decimated to about SAMPLE_RATE_HZ; the velocity is the step's delayed ground
velocity v_filt, delay-matched to the filtered force (as fit.heading_rows does).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dobwind import dragfit
from dobwind.errors import CheckFailed
from dobwind.fieldtruth import LogTime
from dobwind.logs import FlightLog, heading_yaw
from dobwind.model.airframe import Airframe
from dobwind.model.forceair import heading_force, wind_from_deg
from dobwind.model.status import accepted

SAMPLE_RATE_HZ = 5.0
LAW = ("l0", "q0", "ox", "oy", "q2c", "q2s")
LAW_BOUNDS = {"l0": (0.0, np.inf), "q0": (0.0, np.inf), "kappa": (-1.0, 1.0)}
MIN_HEADING_SECTORS = 3      # of 8 (45 deg each), see Coverage.lacking
MIN_AIRFLOW_SECTORS = 2
MAX_CONDITION = 1e4          # column-scaled Jacobian: beyond it some combination is not identified
MAX_WIND_SIGMA_MPS = 0.5     # each wind component's 1-sigma at the solution
MIN_SAMPLES_PER_WIND = 30
STEADY_SPEED_MPS = 0.3       # ground velocity change over a settling time that still counts as steady
STEADY_YAW_DEG = 5.0
START_SPEEDS_MPS = (0.0, 5.0, 12.0)   # starting winds (and 4 directions for the non-zero ones)


@dataclass(frozen=True)
class Samples:
    """Decimated heading-frame rows of every log, with the wind group each belongs to."""
    force_h: np.ndarray   # (N, 2) observed force, heading frame (x forward, y right)
    vel: np.ndarray       # (N, 2) delayed ground velocity, NED north/east
    cos_yaw: np.ndarray
    sin_yaw: np.ndarray
    thrust_h: np.ndarray  # (N, 2) nominal thrust vector's horizontal part, heading frame
    group: np.ndarray     # (N,) wind group index
    log_index: np.ndarray


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


@dataclass(frozen=True)
class JointSolution:
    groups: tuple[WindGroup, ...]
    law: dict[str, float]
    condition: float
    residual_rms_n: float
    notes: tuple[str, ...] = field(default_factory=tuple)


def _usable(t: np.ndarray, status: np.ndarray, settle_s: float) -> np.ndarray:
    """Accepted rows at least ``settle_s`` after the last rejection (the observer has settled)."""
    rejected = ~accepted(status)
    rejected[0] = True
    last = np.maximum.accumulate(np.where(rejected, t, -np.inf))
    return ~rejected & (t - last >= settle_s)


def steady(t: np.ndarray, log: FlightLog, window_s: float) -> np.ndarray:
    """Rows whose ground velocity and heading changed little over the last ``window_s`` (the observer's
    settling time): there the filtered force is the drag of the current airflow. In manoeuvres it lags,
    and that lag, not the wind, is what a fit on every row would explain (it read a 3.3 m/s wind as 4.9
    on a simulated box flight)."""
    vel = log.stack("vel_n", "vel_e")
    yaw = np.unwrap(np.nan_to_num(heading_yaw(log, log.stack("q_w", "q_x", "q_y", "q_z"))))
    before = np.searchsorted(t, t - window_s)
    inside = t - window_s >= t[0]
    dv = np.hypot(*(vel - vel[before]).T)
    dyaw = np.abs(yaw - yaw[before])
    with np.errstate(invalid="ignore"):
        return inside & (dv < STEADY_SPEED_MPS) & (dyaw < math.radians(STEADY_YAW_DEG))


def log_samples(af: Airframe, flights: list[tuple[str, LogTime]], segment_s: float | None) -> tuple[Samples, list[tuple[str, float, float]]]:
    """The decimated samples of every log and the wind groups' (path, start, end) in log time."""
    from dobwind.fit import calibration_run

    run = calibration_run(af, [flight.log for _, flight in flights])
    parts, spans = [], []
    for index, ((path, flight), force, v_filt, status) in enumerate(zip(flights, run.force_ned, run.v_filt, run.status)):
        log = flight.log
        t = log.time_s
        keep = _usable(t, status, run.model.settling_time_s) & np.isfinite(force).all(axis=1)
        keep &= steady(t, log, run.model.settling_time_s)
        step = dragfit.sample_step(dragfit.median_step(t, af), SAMPLE_RATE_HZ)
        keep &= (np.arange(len(t)) % step) == 0
        if not keep.any():
            continue
        part = _part(af, log, force, v_filt, keep)
        # Segments count from the log's first row, so that a segment boundary is where the user put it.
        label = np.floor((t[keep] - t[0]) / segment_s).astype(int) if segment_s else np.zeros(int(keep.sum()), int)
        for value in np.unique(label):
            inside = label == value
            spans.append((path, float(t[keep][inside][0] + flight.t0_s), float(t[keep][inside][-1] + flight.t0_s)))
            part.setdefault("group", np.zeros(len(label), int))[inside] = len(spans) - 1
        part["log_index"] = np.full(len(label), index)
        parts.append(part)
    if not parts:
        raise CheckFailed("--wind unknown: no accepted airborne rows in the logs")
    cat = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    return Samples(**cat), spans


def _part(af: Airframe, log: FlightLog, force: np.ndarray, v_filt: np.ndarray, keep: np.ndarray) -> dict:
    q = log.stack("q_w", "q_x", "q_y", "q_z")[keep]
    yaw = heading_yaw(log, log.stack("q_w", "q_x", "q_y", "q_z"))[keep]
    c, s = np.cos(yaw), np.sin(yaw)
    f = np.column_stack(heading_force(force[keep].T, c, s, (0.0, 0.0, 0.0)))
    rpm = log.stack(*[f"rpm_{i + 1}" for i in range(af.thrust.rotors)])[keep] if af.thrust.source == "rpm" else None
    thrust = log.columns["thrust"][keep] if "thrust" in log.columns else None
    t_ned = dragfit.thrust_ned(af, rpm, thrust, q)
    t_h = np.column_stack(heading_force(t_ned.T, c, s, (0.0, 0.0, 0.0)))
    return {"force_h": f[:, :2], "vel": v_filt[keep][:, :2], "cos_yaw": c, "sin_yaw": s, "thrust_h": t_h[:, :2]}


def _design(samples: Samples, winds: np.ndarray) -> np.ndarray:
    """(N, 2, len(LAW)) heading-frame force per unit of each law parameter at these winds."""
    air_ned = winds[samples.group] - samples.vel
    c, s = samples.cos_yaw, samples.sin_yaw
    air_c = np.column_stack(heading_force(np.column_stack([air_ned, np.zeros(len(c))]).T, c, s, (0.0, 0.0, 0.0)))
    full = dragfit.basis(air_c)[:, :2, :]
    columns = [samples.thrust_h if p == "kappa" else full[:, :, dragfit.PARAMETERS.index(p)] for p in LAW]
    return np.stack(columns, axis=2)


def _residual(x: np.ndarray, samples: Samples, groups: int) -> np.ndarray:
    winds, law = x[:2 * groups].reshape(groups, 2), x[2 * groups:]
    return (samples.force_h - np.einsum("nap,p->na", _design(samples, winds), law)).ravel()


def _linear_law(samples: Samples, winds: np.ndarray) -> np.ndarray:
    a = _design(samples, winds).reshape(-1, len(LAW))
    scale = np.maximum(np.abs(a).max(axis=0), 1e-12)
    law, *_ = np.linalg.lstsq(a / scale, samples.force_h.ravel(), rcond=None)
    law = law / scale
    for k, p in enumerate(LAW):
        low, high = LAW_BOUNDS.get(p, (-np.inf, np.inf))
        law[k] = min(max(law[k], low + 1e-6), high - 1e-6)
    return law


def solve(samples: Samples, groups: int):
    """The joint least squares from several starting winds (the same for every group); the best."""
    from scipy.optimize import least_squares

    lower = np.r_[np.full(2 * groups, -60.0), [LAW_BOUNDS.get(p, (-np.inf, np.inf))[0] for p in LAW]]
    upper = np.r_[np.full(2 * groups, 60.0), [LAW_BOUNDS.get(p, (-np.inf, np.inf))[1] for p in LAW]]
    scale = max(float(np.median(np.abs(samples.force_h))), 1e-3)
    best = None
    for speed in START_SPEEDS_MPS:
        for angle in (np.arange(4) * math.pi / 2 + math.pi / 4 if speed else [0.0]):
            winds = np.tile([speed * math.cos(angle), speed * math.sin(angle)], (groups, 1))
            x0 = np.r_[winds.ravel(), np.clip(_linear_law(samples, winds), lower[2 * groups:], upper[2 * groups:])]
            x0 = np.clip(x0, lower + 1e-9, upper - 1e-9)
            result = least_squares(_residual, x0, bounds=(lower, upper), loss="soft_l1", f_scale=0.2 * scale,
                                   args=(samples, groups), x_scale="jac", max_nfev=200)
            if best is None or result.cost < best.cost:
                best = result
    return best


def _inflation(residual: np.ndarray, log_index: np.ndarray) -> float:
    """sqrt((1 + rho) / (1 - rho)) for the residuals' lag-1 correlation rho (an AR(1) reading of their
    dependence): the factor by which the independent-sample 1-sigma understates the true one."""
    r = residual.reshape(-1, 2)
    same = log_index[1:] == log_index[:-1]
    num = float(np.sum(r[1:][same] * r[:-1][same]))
    den = float(np.sum(r * r))
    rho = min(max(num / den, 0.0), 0.95) if den > 0 else 0.0
    return math.sqrt((1 + rho) / (1 - rho))


def raw_jacobian(x: np.ndarray, samples: Samples, groups: int) -> np.ndarray:
    """The residuals' Jacobian at ``x`` by central differences (least_squares' own is the robust loss's
    reweighted one, which hides how well the data pin each parameter down)."""
    columns = []
    for k in range(len(x)):
        h = 1e-5 * max(1.0, abs(float(x[k])))
        up, down = x.copy(), x.copy()
        up[k] += h
        down[k] -= h
        columns.append((_residual(up, samples, groups) - _residual(down, samples, groups)) / (2 * h))
    return -np.column_stack(columns)


def identification(x: np.ndarray, samples: Samples, groups: int) -> tuple[float, np.ndarray]:
    """(column-scaled condition number, each group's largest wind-component 1-sigma in m/s) at ``x``:
    the covariance sigma^2 (J^T J)^-1 with sigma the residuals' robust scale (MAD), inflated for their
    correlation from sample to sample."""
    jac = raw_jacobian(x, samples, groups)
    residual = _residual(x, samples, groups)
    norms = np.linalg.norm(jac, axis=0)
    if not np.all(norms > 0):
        return math.inf, np.full(groups, math.inf)
    singular = np.linalg.svd(jac / norms, compute_uv=False)
    condition = float(singular[0] / singular[-1]) if singular[-1] > 0 else math.inf
    if not math.isfinite(condition):
        return condition, np.full(groups, math.inf)
    sigma = 1.4826 * float(np.median(np.abs(residual - np.median(residual))))
    scaled_inverse = np.linalg.inv((jac / norms).T @ (jac / norms))
    cov = scaled_inverse / np.outer(norms, norms) * sigma * sigma
    wind_sigma = np.sqrt(np.maximum(np.diag(cov)[:2 * groups], 0.0)).reshape(groups, 2).max(axis=1)
    return condition, wind_sigma * _inflation(residual, samples.log_index)


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


def coverage(samples: Samples, winds: np.ndarray) -> Coverage:
    air = winds[samples.group] - samples.vel
    moving = np.hypot(air[:, 0], air[:, 1]) > 0.5
    ground = np.hypot(samples.vel[:, 0], samples.vel[:, 1])
    return Coverage(_sectors(samples.cos_yaw, samples.sin_yaw), _sectors(air[moving, 0], air[moving, 1]),
                    (float(np.percentile(ground, 5)), float(np.percentile(ground, 95))))


def estimate_winds(af: Airframe, flights: list[tuple[str, LogTime]], segment_s: float | None = None) -> JointSolution:
    """The joint solution, or CheckFailed (exit 1) naming what the flight lacks."""
    samples, spans = log_samples(af, flights, segment_s)
    groups = len(spans)
    counts = np.bincount(samples.group, minlength=groups)
    if counts.min() < MIN_SAMPLES_PER_WIND:
        worst = int(np.argmin(counts))
        raise CheckFailed(f"--wind unknown: {spans[worst][0]} gives only {counts[worst]} steady samples for a wind "
                          f"(need {MIN_SAMPLES_PER_WIND}: legs of constant velocity and heading longer than the "
                          f"observer's settling time{', or a longer --segment-s' if segment_s else ''}); nothing written")
    result = solve(samples, groups)
    winds = result.x[:2 * groups].reshape(groups, 2)
    condition, sigma = identification(result.x, samples, groups)
    spanned = coverage(samples, winds)
    what = spanned.text()
    if spanned.lacking() or condition > MAX_CONDITION or not np.all(sigma <= MAX_WIND_SIGMA_MPS):
        worst = int(np.argmax(np.nan_to_num(sigma, nan=math.inf)))
        raise CheckFailed(
            f"--wind unknown: the flight does not identify the wind and the force-air law together (wind 1-sigma "
            f"{sigma[worst]:.2g} m/s for {spans[worst][0]}, limit {MAX_WIND_SIGMA_MPS:g}; Jacobian condition "
            f"{condition:.3g}, limit {MAX_CONDITION:g}): {what}; fly several headings and speeds (boxes, circles, "
            "back and forth in more than one direction); nothing written")
    found = tuple(WindGroup(path, start, end, (float(w[0]), float(w[1])), float(s), int(n))
                  for (path, start, end), w, s, n in zip(spans, winds, sigma, counts))
    law = dict(zip(LAW, (float(v) for v in result.x[2 * groups:])))
    rms = float(np.sqrt(np.mean(result.fun ** 2)))
    return JointSolution(found, law, condition, rms, (what,))


@dataclass(frozen=True)
class GroupWinds:
    """The winds found, as a truth (fieldtruth.Truth): each log's groups, steady over their spans (rows
    before the first group's start and after the last's end take the nearest group's wind)."""
    solution: JointSolution

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
