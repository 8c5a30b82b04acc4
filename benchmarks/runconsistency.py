"""Whether calibration runs' logged airflow agrees with their forces, before any law is fitted.

A tunnel run may log a nominal speed rather than an anemometer's reading at the vehicle. When a fit
cannot reproduce its own runs, the question is whether ANY law of the drag family could. Along the
tunnel's fixed direction such a law is l s + q s^p with p >= 1 (the direction harmonics are constants
there); with l, q >= 0, as the fit keeps its isotropic terms, it is convex in the airflow speed and
zero at zero airflow. (A body-frame law adds the tilt, which grows with the airflow; the paper's
polynomial, speed as a function of force, need not invert a convex law at all.) For such a law F / s
never falls as s rises, and F'(s) >= F(s) / s at every speed. A run's bound uses its mean force F
along its mean airflow and its least-squares slope F' within the run (the vehicle's own manoeuvres
sweep the airflow about the mean): for a least-squares slope with an intercept, mean F <= mean s x slope
is the same as E[F] / E[s] <= E[F s] / E[s^2], and the right-hand side weights the same ratio F / s by
s^2 instead of s, towards the faster samples, where it is no smaller. So the run's mean airflow speed is bounded
from below:

    s >= F / F'

and F / s cannot decrease from one run to a faster one. Both need no fit, only the force offset, which
is taken from a run at zero mean airflow (a figure-8 about zero airflow averages its drag out). A run
whose logged speed is below its bound, or a pair out of order, cannot be reproduced by a drag law with
that offset: the fit has to trade it off against the others.

The bound can be wrong, too high, in three cases: a sweep that crosses zero airflow (|s| is not s
there); airflow noise or lag that the force does not share, which flattens the slope (0.3 m/s of such
noise on a +-1 m/s sweep at 4 m/s raises a bound of 2.8 to 3.3 m/s); and a vertical airflow that moves
the horizontal force, which the argument above, on s alone, leaves out (the regression below holds it
as a separate column). TOLERANCE allows a slope about 9 % too flat before a run is flagged.

The force and the airflow are the drag fit's own samples (dobwind/calibrate/dragfit.py): both already passed
through the observer's and the low-pass's response, so the slope is not biased by the observer's lag.
The slope is regressed on the horizontal and the vertical airflow together, since a figure-8 in a
vertical plane moves both and the vertical airflow also moves the horizontal force.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# A run whose mean airflow is below this is a zero-airflow run (the offset's source), m/s.
ZERO_AIRFLOW_MPS = 1.0
# A logged speed this share below its bound is flagged; the slope's scatter is a few per cent.
TOLERANCE = 0.1
# Fewer finite samples than this in a run give no figures (a cut log's mean is not its run's).
MIN_SAMPLES = 10


@dataclass(frozen=True)
class RunForce:
    """One run's figures: logged mean airflow speed (m/s), mean force along it (N, offset removed),
    its slope within the run (N per m/s), and the lower bound on the speed that implies (m/s)."""
    name: str
    speed_mps: float
    force_n: float
    slope_n_per_mps: float
    bound_mps: float

    @property
    def below_bound(self) -> bool:
        return self.bound_mps > (1 + TOLERANCE) * self.speed_mps


def _finite(force_h: np.ndarray, airflow: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    keep = np.isfinite(force_h).all(axis=1) & np.isfinite(airflow).all(axis=1)
    return force_h[keep], airflow[keep]


def zero_airflow_offset(force_h: np.ndarray, airflow: np.ndarray) -> np.ndarray | None:
    """The heading-frame horizontal force offset (2,) from the samples of one run, when its mean
    horizontal airflow is under ZERO_AIRFLOW_MPS and it has MIN_SAMPLES finite samples; else None."""
    force_h, airflow = _finite(force_h, airflow)
    if len(airflow) < MIN_SAMPLES or np.hypot(*airflow[:, :2].mean(axis=0)) >= ZERO_AIRFLOW_MPS:
        return None
    return force_h.mean(axis=0)


def run_force(name: str, force_h: np.ndarray, airflow: np.ndarray, offset: np.ndarray) -> RunForce | None:
    """The run's mean force along its mean airflow and the slope of that force on the airflow along it
    (heading frame: force_h (N, 2) in N, airflow (N, 3) in m/s); None at zero mean airflow, with fewer
    than MIN_SAMPLES finite samples, or when the regression has no finite slope."""
    force_h, airflow = _finite(force_h, airflow)
    if len(airflow) < MIN_SAMPLES:
        return None
    mean = airflow[:, :2].mean(axis=0)
    speed = float(np.hypot(*mean))
    if speed < ZERO_AIRFLOW_MPS:
        return None
    along = mean / speed
    force = (force_h - offset) @ along
    design = np.column_stack([airflow[:, :2] @ along, airflow[:, 2], np.ones(len(airflow))])
    slope = float(np.linalg.lstsq(design, force, rcond=None)[0][0])
    if not math.isfinite(slope):
        return None
    mean_force = float(force.mean())
    # A force that does not grow with the airflow within the run bounds nothing: no speed reproduces it.
    bound = mean_force / slope if slope > 0 else math.inf
    return RunForce(name, speed, mean_force, slope, bound)


def out_of_order(runs: list[RunForce]) -> list[tuple[str, str]]:
    """Pairs (slower, faster) whose force per m/s decreases with the speed (a convex law's cannot): each
    run against the slower run of the highest force per m/s, so that a fall spread over several runs is
    found too; runs of the same speed are not compared."""
    pairs = []
    for run in sorted(runs, key=lambda r: r.speed_mps):
        slower = [r for r in runs if r.speed_mps < run.speed_mps]
        if not slower:
            continue
        top = max(slower, key=lambda r: (r.force_n / r.speed_mps, -r.speed_mps, r.name))
        if run.force_n / run.speed_mps < (1 - TOLERANCE / 2) * top.force_n / top.speed_mps:
            pairs.append((top.name, run.name))
    return pairs


def check_runs(names: list[str], force_h: list[np.ndarray], airflow: list[np.ndarray]) -> tuple[list[RunForce], np.ndarray | None]:
    """Every run's figures with the offset of the first zero-airflow run ([] and None without one)."""
    offset = next((o for o in (zero_airflow_offset(f, a) for f, a in zip(force_h, airflow)) if o is not None), None)
    if offset is None:
        return [], None
    runs = [run_force(n, f, a, offset) for n, f, a in zip(names, force_h, airflow)]
    return [r for r in runs if r is not None], offset


def lines(runs: list[RunForce], offset: np.ndarray | None) -> list[str]:
    """The table the realdata check prints."""
    if offset is None:
        return [f"  no run at zero mean airflow with {MIN_SAMPLES} finite samples: no force offset, no bound"]
    out = [f"  force offset from the zero-airflow run: [{offset[0]:.2f}, {offset[1]:.2f}] N",
           "  run          logged m/s  mean force N  N per m/s  slope N/(m/s)  bound m/s"]
    for r in runs:
        flag = "  BELOW its bound" if r.below_bound else ""
        out.append(f"  {r.name:12s} {r.speed_mps:10.2f}  {r.force_n:12.2f}  {r.force_n / r.speed_mps:9.2f}  "
                   f"{r.slope_n_per_mps:13.2f}  {r.bound_mps:9.2f}{flag}")
    out += [f"  {a} -> {b}: force per m/s falls with the speed" for a, b in out_of_order(runs)]
    return out
