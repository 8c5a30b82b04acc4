"""The drag law's exponent: how fast its bluff-body terms grow with the airflow speed.

Newtonian drag grows as s^2. A drag coefficient that falls or rises with Reynolds number makes the force
grow slower or faster (effective exponents of about 1.8 to 2.2 over 0-10 m/s on small airframes). Inside
the calibrated range a quadratic law hides this by trading linear against quadratic drag, so its CV
hardly moves; beyond it the error grows with every m/s (0.2 m/s at 10 m/s on a 1.8 or 2.2 law calibrated
to 8.4 m/s). The hold-level scores see it: the top holds fitted from the slower ones and the hold-mean
errors of held-out blocks are lowest at the vehicle's exponent.

Only the body-frame law has one. There the law acts on the airflow the airframe meets; a heading-frame
law sees the vehicle's tilt too, which grows with the airflow, and its hold-level score falls with the
exponent on every simulated vehicle, whatever its true law (up to 2.4 on quadratic drag, whose tunnel
then reads 0.2 m/s high at 10 m/s).

The exponent is chosen after the parameter set: from 2 in steps of EXPONENT_STEP while the hold-level
score improves. The best is kept only if it beats 2 by EXPONENT_GAIN, on the top holds as well, and
the gain is significant: the held-out windows' squared errors, paired window by window (the same
samples, the same folds), must fall by EXPONENT_SIGMAS standard errors of the folds' mean differences.
Without the test, noise alone moved the choice off 2 on quadratic laws (the score wanders by 10-30 %
between neighbouring exponents). The set is then chosen again for the new exponent, and tested the
same way.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from dobwind.calibrate import dragfit, holdcv
from dobwind.calibrate.holdcv import hold_score
from dobwind.model.forceair import EXPONENT_RANGE

EXPONENT_STEP = 0.1
# Another exponent than 2 must lower the hold-level score by this share: a flat score (a quadratic law,
# or too little speed range to tell) keeps Newtonian drag.
EXPONENT_GAIN = 0.05
# ... and significantly: by this many standard errors of the CV folds' mean paired differences.
EXPONENT_SIGMAS = 2.0
# The exponents tried: 1.6 to 2.4, inside the range an airframe file accepts.
EXPONENT_LIMITS = (max(1.6, EXPONENT_RANGE[0]), min(2.4, EXPONENT_RANGE[1]))


@dataclass(frozen=True)
class ExponentChoice:
    exponent: float
    samples: dragfit.DragSamples          # as if sampled for that exponent (dragfit.with_exponent)
    choice: dragfit.DragChoice            # the law's set and coefficients for it
    hold: holdcv.HoldCV | None            # its hold-level CV (the family's scores)
    scores: dict[float, float] = field(default_factory=dict)  # hold-level score of each exponent tried


def _hold(samples: dragfit.DragSamples, active: tuple[str, ...]) -> holdcv.HoldCV | None:
    return holdcv.hold_cv(samples, dragfit.drag_fit_predict(active))


def _walk(samples: dragfit.DragSamples, active: tuple[str, ...], holds: dict[float, holdcv.HoldCV | None],
          scores: dict[float, float], direction: int) -> None:
    """Scores exponents from 2 in one direction while each improves on the last (the score is about
    unimodal in the exponent: one growth rate fits the holds best)."""
    current = 2.0
    while True:
        nxt = round(current + direction * EXPONENT_STEP, 6)
        if not EXPONENT_LIMITS[0] - 1e-9 <= nxt <= EXPONENT_LIMITS[1] + 1e-9:
            return
        holds[nxt] = _hold(dragfit.with_exponent(samples, nxt), active)
        scores[nxt] = hold_score(holds[nxt])
        if not scores[nxt] < scores[current]:
            return
        current = nxt


def choose_exponent(samples: dragfit.DragSamples, choice: dragfit.DragChoice,
                    usable: Callable[[dragfit.DragSamples, dragfit.DragChoice], bool],
                    hold: holdcv.HoldCV | None = None) -> ExponentChoice:
    """The exponent for ``choice``'s set (samples as sampled, exponent 2), and the law chosen again for
    it; 2 and ``choice`` itself unless another exponent's law scores EXPONENT_GAIN better and is
    ``usable`` (the step can invert it: fitfamily's check). ``hold``: the quadratic law's hold-level CV,
    when already made."""
    hold = _hold(samples, choice.active) if hold is None else hold
    scores = {2.0: hold_score(hold)}
    kept = ExponentChoice(2.0, samples, choice, hold, scores)
    if not math.isfinite(scores[2.0]):
        return kept
    holds = {2.0: hold}
    for direction in (-1, 1):
        _walk(samples, choice.active, holds, scores, direction)
    best = min(scores, key=lambda p: scores[p] if math.isfinite(scores[p]) else math.inf)
    if best == 2.0:
        return kept
    shifted = dragfit.with_exponent(samples, best)
    if not holdcv.significant_gain(hold, holds[best], EXPONENT_GAIN, EXPONENT_SIGMAS):
        return kept
    again = dragfit.choose_drag_law(shifted, holdcv.prefer_on_holds)
    if not usable(shifted, again):
        return kept
    hold_again = _hold(shifted, again.active)
    # The set chosen again must still beat the quadratic law (its windows are the same).
    if not holdcv.significant_gain(hold, hold_again, EXPONENT_GAIN, EXPONENT_SIGMAS):
        return kept
    return ExponentChoice(best, shifted, again, hold_again, scores)
