"""The low-pass at zero airflow, chosen from the noise the fit's self-check measured there.

Near zero airflow a drag law is at its flattest, so a newton of force noise is the most metres per
second of airflow, and the estimated wind speed (a magnitude) turns that noise into a steady reading:
for per-axis noise sigma, still air reads about 1.25 sigma (the mean of a Rayleigh distribution). The
scheduled low-pass is the paper's remedy: a lower cutoff at low speed. Which cutoff a vehicle needs
depends on its sensors, its mass and its sample rate, which the calibration flight shows and the
airframe file's author may not know.

So after the self-check has replayed the calibration logs, its per-axis horizontal scatter on segments
flown at low airflow (``selfcheck.STILL_AIRFLOW_MPS``) is compared with a target. When it is above, the
schedule's first cutoff is lowered and the self-check runs again on the new airframe. After the
observer, the force noise is close to white well below its bandwidth, and a first-order low-pass passes
a variance proportional to its cutoff: the cutoff that meets the target is f (target / sigma)^2. A
floor bounds the lag (a time constant of 1 / (2 pi floor)), and the airframe's own cutoffs are never
raised. The delay-matched ground velocity goes through the same low-pass, so a lower cutoff adds no
error in manoeuvres in still air; it slows only the response to a change of the wind itself.

The scatter is measured about each segment's own mean, which takes up more of the noise the slower
the low-pass is, while a wind reading sees it all. The self-check divides each low-airflow segment's
scatter by the share of the variance a segment that long keeps for noise correlated over the first
cutoff's time constant (selfcheck.within_share): at 0.15 Hz, 0.53 for 3 s scored, 0.67 for 5 s.
One approximation remains, on the side of lowering too little: the rule's square assumes the law is
linear near zero airflow (a law growing like the square root of the force passes the noise as the
cutoff's fourth root). The second pass starts from the noise measured at the first cutoff chosen, and
the still-air flights of the benchmark are the measure that counts (README).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the command line reads the defaults for its help: no CasADi import for that
    from dobwind.model.airframe import FilterSchedule


@dataclass(frozen=True)
class HoverNoise:
    """target_mps: per-axis horizontal noise of the wind estimate at low airflow (0 keeps the airframe's
    schedule); floor_hz: the lowest first cutoff chosen; rounds: self-check passes after the first."""
    target_mps: float = 0.07
    floor_hz: float = 0.05
    rounds: int = 2
    # Below this share of the current cutoff a new one is worth a further self-check pass.
    min_change: float = 0.95


def quieter_schedule(schedule: FilterSchedule, noise_mps: float | None, cfg: HoverNoise) -> FilterSchedule | None:
    """The schedule with its first cutoff lowered to meet ``cfg.target_mps``, or None to keep it (no
    figure, noise within the target, a one-point schedule, or a change too small to matter)."""
    if cfg.target_mps <= 0 or noise_mps is None or not math.isfinite(noise_mps) or noise_mps <= 0 \
            or len(schedule.cutoffs_hz) < 2:
        return None
    current = schedule.cutoffs_hz[0]
    # Three significant digits: the airframe file stays readable, and the self-check runs on the value
    # that is written.
    wanted = max(cfg.floor_hz, float(f"{current * (cfg.target_mps / noise_mps) ** 2:.3g}"))
    if wanted >= current * cfg.min_change:
        return None
    return dataclasses.replace(schedule, cutoffs_hz=(wanted,) + tuple(schedule.cutoffs_hz[1:]))
