"""The estimator's settling time, from the airframe alone: how long after a step in the external
force (or after a gap, when the held state meets a changed force) the output takes to stay within 2 %
of the new value.

It is baked into the step as a constant (the SETTLING status bit), so it must not need the step
itself: the observer and the low-pass are both first order, and their cascade's step response is
computed here directly at the nominal sample time. The slowest axis (smallest gain) and the slowest
scheduled cutoff are used, so the figure is an upper bound over axes and wind speeds.
"""
from __future__ import annotations

import math

from dobwind.model.airframe import Airframe
from dobwind.model.discretization import first_order

SETTLING_BAND = 0.02  # the usual 2 % band, as `dobwind analyze` reports it
MAX_SAMPLES = 1_000_000
THRESHOLD_PHASE = 0.5618  # of a nominal sample, after the last sample outside the band


def settling_time_s(af: Airframe, band: float = SETTLING_BAND) -> float:
    """Time (s) after which the unit step response of observer then low-pass stays within ``band``."""
    dt = af.observer.sample_time_s
    c = first_order(af.observer.discretization, min(af.observer.gains) / af.mass_kg, dt)
    pole, b0, b1 = float(c.pole), float(c.b0), float(c.b1)
    alpha = -math.expm1(-2 * math.pi * min(af.filter.cutoffs_hz) * dt)
    if not (abs(pole) < 1 and 0 < alpha <= 1):
        return math.inf  # an unstable design never settles; generate refuses it anyway
    # Twenty of the slower time constant is far past any 2 % crossing of a stable first-order pair.
    slowest = max(dt / max(1 - abs(pole), 1e-12), dt / alpha)
    # Capped: a design this slow (hours at 100 Hz) is not flown; the figure is then a lower bound.
    n = min(int(math.ceil(20 * slowest / dt)) + 2, MAX_SAMPLES)
    # The step's observer, y(k) = pole y(k-1) + b0 x(k) + b1 x(k-1), then the low-pass, which takes the
    # new value, on a unit step; the recursions in the order scipy.signal.lfilter evaluates them, written
    # out because importing scipy.signal for them cost more than a whole replay's parsing (issue #13).
    last, observed, filtered = -1, 0.0, 0.0
    for k in range(n):  # a few thousand samples for a flown design
        observed = b0 + (b1 + pole * observed) if k else b0
        filtered = alpha * observed + (1 - alpha) * filtered
        if abs(filtered - 1.0) > band:
            last = k
    # Sample k (from 0) is the (k+1)-th accepted sample, reached after (k+1) dt of accepted time: the
    # last one outside the band is at (last + 1) dt, the first inside for good at (last + 2) dt. The
    # threshold is put between them, off the half: a log at the nominal rate, or at 2, 4, 5 or 10 times
    # it or a fraction like that, then never lands a sample on it, where a float and a double sum of
    # the same dt's would disagree on the SETTLING bit.
    return float((last + 1 + THRESHOLD_PHASE) * dt)
