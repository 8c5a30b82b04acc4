"""The self-check's limits on its own (``dobwind.calibrate.selfcheck`` re-exports them).

The command line needs the defaults for its help text whatever the command; importing the check
itself for them pulled in the drag fit, scipy.signal and matplotlib (about 2 s under load) before
every `replay` or `simulate`.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Thresholds:
    """When a fitted model is not to be trusted. Speed limits: share * calibrated speed range, at least
    the floor. Chosen so that a good fit on every benchmark vehicle passes with a wide margin (README)."""
    cv_share: float = 0.06           # the honest (hold-level) CV
    replay_share: float = 0.06       # each log's training replay: RMS of its per-segment speed errors
    floor_mps: float = 0.15
    direction_deg: float = 10.0      # each log's mean per-segment direction error
    # A WARNING, not a refusal (selfcheck.direction_tail_warnings): a log whose segments at
    # direction_tail_speed_mps of wind or faster read the direction more than direction_tail_deg off on
    # more than 1 - direction_tail_share of them. The mean above hides a law that is right along the body
    # axes and 10-20 deg off between them (docs/calibration.md, "The fit checks itself"). 8 deg is twice
    # the tunnel goal's worst direction error (4 deg): a turbulent SITL calibration's scatter (4.2 deg)
    # stays under it, and the benchmark family's fits (at most 1.2 deg) far under.
    direction_tail_deg: float = 8.0
    direction_tail_share: float = 0.9
    direction_tail_speed_mps: float = 3.0
    max_coefficient: float = 1e6     # any model coefficient, in its SI units
    # Logs the fit itself flagged as outliers (dobwind/calibrate/runmeans.py, a minority of them only): replayed and
    # reported, but not held to the per-log replay limits. Set by the fit, never by the user.
    outlier_logs: tuple[str, ...] = ()
    # Why the hold-level CV judged measures nothing (held-out predictions diverged: cvdiverge.summary), said
    # instead of its figure. Set by the fit, never by the user.
    cv_diverged: str | None = None

    def speed_limit_mps(self, share: float, speed_range_mps: float) -> float:
        return max(self.floor_mps, share * speed_range_mps)
