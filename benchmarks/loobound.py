"""How slowly, and how fast, ANY convex drag law could read a held-out tunnel run, before any fit.

Leave-one-out on a few tunnel runs asks whether a law fitted on the other runs reads the held-out
run's mean airflow near its nominal speed. Whether some law of a family can do that at all follows
from the runs' mean forces alone. Along the tunnel's fixed direction the drag family is
F(s) = l s + q s^p (and sums of such terms) with l, q >= 0. For p >= 2 the force per m/s,
h(s) = F(s) / s = l + q s^(p-1), is nondecreasing and CONVEX in s, and h(0) = l = F'(0). The other
runs bound h at a few speeds:

- a training run k of mean force F_k (offset removed) logged at s_k and read within tol of it (the
  leave-one-out goal asks that of each training run): F(s_k - tol) <= F_k <= F(s_k + tol), so
  h(s_k - tol) <= F_k / (s_k - tol) (an upper point) and h(s_k + tol) >= F_k / (s_k + tol) (a lower one);
- the zero-airflow run's within-run slope g (its figure-8 sweeps the airflow about zero): for an odd
  law F(s) = s h(|s|) the least-squares slope through zero is E[s^2 h(|s|)] / E[s^2] >= h(0), so
  h(0) <= g (an upper point at zero).

A convex h lies under every chord between two upper points, and above the line through an upper
point and a lower point beyond them (on either side); a nondecreasing h lies above every lower point
before it. A law meeting those reads the held-out run (mean force F*) at r with F(r) = F*, so
r L(r) <= F* <= r U(r) for the envelopes L and U: the reading lies between the smallest r with
r U(r) >= F* ("slowest") and the largest r with r L(r) <= F* ("fastest"). The goal is out of reach
for the whole family when the slowest reading is above the logged speed + tol or the fastest below
it - tol. Not covered: a law whose h is concave somewhere (a knee: linear drag that stops growing),
or an exponent below 2 (l + q s^0.5 is concave). ``zero_slope_needed`` is how steep at zero airflow a
law would have to be for some law to read the held-out run and the training runs within tol, and
``excess_force_n`` how much of the held-out run's mean force (N) is above the most any law under the
bounds gives at its speed + tol (what a force offset of its own would have to remove).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from benchmarks.runconsistency import MIN_SAMPLES, ZERO_AIRFLOW_MPS, RunForce

# The leave-one-out goal of issue #31: a held-out run, and each training run, within this of its speed (m/s).
GOAL_MPS = 0.5
GRID_MPS = 1e-3          # the readings are found on this grid of speeds (m/s)
REACH = 3.0              # the fastest reading is searched up to this multiple of the fastest run's speed
SLOPE_SEARCH_N_PER_MPS = (0.0, 20.0)   # bisection interval of zero_slope_needed

Point = tuple[float, float]   # (speed m/s, force per m/s N/(m/s))


@dataclass(frozen=True)
class Bounds:
    """Upper and lower points on h from the training runs (and the zero-airflow slope)."""
    upper: tuple[Point, ...]
    lower: tuple[Point, ...]


@dataclass(frozen=True)
class HeldOutBound:
    """One held-out run: its logged speed, the slowest and fastest readings any convex law meeting the
    others' bounds allows (nan: no bound that way), and the least zero-airflow slope with which some
    convex law reads it and the training runs within tol (nan: none up to the search's top)."""
    name: str
    speed_mps: float
    slowest_mps: float
    fastest_mps: float
    zero_slope_needed: float
    excess_force_n: float             # the run's mean force above the most any such law gives at speed + tol
    left_out: tuple[str, ...] = ()    # training runs not used (as a fit that flags them would)

    @property
    def training_consistent(self) -> bool:
        """Some convex law reads every training run within tol (else the slowest reading passes the fastest)."""
        return not self.slowest_mps > self.fastest_mps

    @property
    def beyond_goal(self) -> bool:
        """No law of the family reads the run within tol: every one reads it too fast, or every one too slow."""
        return not _reachable(self.speed_mps, self.slowest_mps, self.fastest_mps, GOAL_MPS)


def zero_airflow_slope(force_h: np.ndarray, airflow: np.ndarray) -> float | None:
    """The within-run slope of the horizontal force on the horizontal airflow (N per m/s; one slope for
    both axes, a mean per axis) of a run at zero mean airflow; None for a faster run, with fewer than
    MIN_SAMPLES finite samples, or without a sweep. The air pushes the vehicle along the airflow, so a
    drag law's slope is positive."""
    keep = np.isfinite(force_h).all(axis=1) & np.isfinite(airflow).all(axis=1)
    force, air = force_h[keep], airflow[keep, :2]
    if len(air) < MIN_SAMPLES or np.hypot(*air.mean(axis=0)) >= ZERO_AIRFLOW_MPS:
        return None
    da, df = air - air.mean(axis=0), force - force.mean(axis=0)
    spread = float(np.sum(da * da))
    return float(np.sum(da * df)) / spread if spread > 0 else None


def _line(a: Point, b: Point, speeds: np.ndarray) -> np.ndarray:
    return a[1] + (b[1] - a[1]) * (speeds - a[0]) / (b[0] - a[0])


def upper_envelope(bounds: Bounds, speeds: np.ndarray) -> np.ndarray:
    """The lowest of: each upper point at and before its speed (h nondecreasing), and the chord between
    two upper points over the speeds between them (h convex); inf beyond the last upper point."""
    envelope = np.full(len(speeds), math.inf)
    for a in bounds.upper:
        envelope = np.where(speeds <= a[0], np.minimum(envelope, a[1]), envelope)
        for b in bounds.upper:
            if b[0] > a[0]:
                inside = (speeds >= a[0]) & (speeds <= b[0])
                envelope[inside] = np.minimum(envelope[inside], _line(a, b, speeds[inside]))
    return envelope


def lower_envelope(bounds: Bounds, speeds: np.ndarray) -> np.ndarray:
    """The highest of: each lower point at and beyond its speed (h nondecreasing), the line through an
    upper point and a later lower point beyond the latter, and the line through a lower point and a later
    upper point before the former (h convex); zero (l, q >= 0) elsewhere."""
    envelope = np.zeros(len(speeds))
    for b in bounds.lower:
        envelope = np.where(speeds >= b[0], np.maximum(envelope, b[1]), envelope)
        for a in bounds.upper:
            if a[0] < b[0]:      # upper before lower: h rises at least that fast beyond the lower point
                envelope = np.where(speeds >= b[0], np.maximum(envelope, _line(a, b, speeds)), envelope)
            elif a[0] > b[0]:    # lower before upper: h was at least that high before the lower point
                envelope = np.where(speeds <= b[0], np.maximum(envelope, _line(b, a, speeds)), envelope)
    return envelope


def readings(force_n: float, bounds: Bounds, top_mps: float) -> tuple[float, float]:
    """(slowest, fastest) speed at which a convex law within the bounds can reach the force ``force_n``:
    the smallest r with r U(r) >= force_n and the largest r with r L(r) <= force_n, r up to ``top_mps``
    (nan: none below ``top_mps``, no bound that way)."""
    speeds = np.arange(GRID_MPS, top_mps + GRID_MPS / 2, GRID_MPS)
    reach_up = speeds * upper_envelope(bounds, speeds)
    reach_low = speeds * lower_envelope(bounds, speeds)
    up, low = np.flatnonzero(reach_up >= force_n), np.flatnonzero(reach_low <= force_n)
    slowest = float(speeds[up[0]]) if len(up) else math.nan
    fastest = float(speeds[low[-1]]) if len(low) and low[-1] < len(speeds) - 1 else math.nan
    return slowest, fastest


def training_bounds(training: list[RunForce], zero_slope: float | None, tol: float = GOAL_MPS) -> Bounds:
    """The points on h that reading every training run within tol, and the zero-airflow slope, imply."""
    upper = [(r.speed_mps - tol, r.force_n / (r.speed_mps - tol)) for r in training if r.speed_mps > tol]
    lower = [(r.speed_mps + tol, r.force_n / (r.speed_mps + tol)) for r in training]
    return Bounds(tuple(upper + ([(0.0, zero_slope)] if zero_slope is not None else [])), tuple(lower))


def _bound(run: RunForce, training: list[RunForce], zero_slope: float | None, top_mps: float,
           tol: float) -> tuple[float, float]:
    return readings(run.force_n, training_bounds(training, zero_slope, tol), top_mps)


def _reachable(speed_mps: float, slowest: float, fastest: float, tol: float) -> bool:
    """Some convex law reads the training runs and this one within tol (a nan is no bound that way)."""
    return not (slowest > fastest or slowest > speed_mps + tol or fastest < speed_mps - tol)


def zero_slope_needed(run: RunForce, training: list[RunForce], top_mps: float, tol: float = GOAL_MPS) -> float:
    """The least zero-airflow slope h(0) whose bounds let some convex law read ``run`` and the training
    runs within tol (bisection: a higher h(0) only loosens both envelopes); nan when even the search's
    top does not."""
    def reachable(slope: float) -> bool:
        return _reachable(run.speed_mps, *_bound(run, training, slope, top_mps, tol), tol)

    low, high = SLOPE_SEARCH_N_PER_MPS
    if reachable(low):
        return low
    if not reachable(high):
        return math.nan
    while high - low > 1e-3:
        mid = (low + high) / 2
        low, high = (low, mid) if reachable(mid) else (mid, high)
    return high


def held_out_bounds(runs: list[RunForce], zero_slope: float | None, left_out: tuple[str, ...] = (),
                    tol: float = GOAL_MPS) -> list[HeldOutBound]:
    """Each run held out in turn against the others' bounds (without the ``left_out`` ones)."""
    top = REACH * max((r.speed_mps for r in runs), default=0.0)
    found = []
    for run in runs:
        if run.name in left_out:
            continue
        training = [r for r in runs if r is not run and r.name not in left_out]
        slowest, fastest = _bound(run, training, zero_slope, top, tol)
        reach = run.speed_mps + tol
        most = reach * float(upper_envelope(training_bounds(training, zero_slope, tol), np.array([reach]))[0])
        found.append(HeldOutBound(run.name, run.speed_mps, slowest, fastest,
                                  zero_slope_needed(run, training, top, tol), max(run.force_n - most, 0.0), left_out))
    return found


def lines(bounds: list[HeldOutBound], zero_slope: float | None) -> list[str]:
    """The table the realdata check prints."""
    shown = "none" if zero_slope is None else f"{zero_slope:.2f} N/(m/s)"
    out = [f"  h(0) <= the zero-airflow run's within-run slope, {shown}; each training run read within {GOAL_MPS} m/s",
           "  held out     logged m/s  slowest  fastest  h(0) needed  force over N  trained without"]
    for b in bounds:
        flag = ("  no convex law reads every training run within the goal" if not b.training_consistent
                else "  BEYOND the goal for every convex law" if b.beyond_goal else "")
        out.append(f"  {b.name:12s} {b.speed_mps:10.2f}  {b.slowest_mps:7.2f}  {b.fastest_mps:7.2f}  "
                   f"{b.zero_slope_needed:11.2f}  {b.excess_force_n:12.2f}  {', '.join(b.left_out) or '-'}{flag}")
    return out
