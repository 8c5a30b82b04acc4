"""Whether the acceleration input is what leaves the noise at low airflow, and the blend that removes it.

The observer's force is m p'' - m g e3 + u_f z_b, and p'' comes from one of three routes: an
acceleration input (NED, or the accelerometer's specific force) or the ground velocity's derivative.
White acceleration noise is flat down to zero frequency, so the low-pass at zero airflow passes a
share of it proportional to its cutoff (hovernoise.py), and nothing more can be done once the cutoff
is at its floor. The derivative of a velocity's noise has no power at zero frequency: its spectrum
grows with the square of the frequency, and a low cutoff keeps almost none of it.

The velocity-aided bias estimate of an acceleration input (``acceleration_bias_time`` T, step.py) is
a complementary filter: p'' = a - LP_T(a - v') = HP_T(a) + LP_T(v'). With T short, the acceleration's
low frequencies come from the velocity and its high ones from the accelerometer. Behind a first-order
low-pass at fc, a high-pass at fh = 1 / (2 pi T) leaves fc / (fc + fh) of the white noise's variance:
at the 0.05 Hz floor and T = 0.5 s (fh = 0.32 Hz), 14 %, so 37 % of its RMS. The input struct the
autopilot fills does not change (the velocity is an input of every route); only the state gains the
bias. On a heavy, slow vehicle with a noisy accelerometer that is the difference between meeting the
still-air goal and not (a 6.9 kg hexacopter of the random family: still air 0.305 against 0.139 m/s,
README), and a 25 kg one 0.207 against 0.114 m/s.

So when the noise at low airflow is still above the target after the low-pass was lowered, the fit is
run once more on the airframe with T = BLEND_TIME_S, and the blend is kept when its self-check passes
and it is clearly quieter, or passes where the first fit failed. ``--hover-noise 0`` keeps the airframe as
written, as it keeps its low-pass.
"""
from __future__ import annotations

import dataclasses
from typing import Any

from dobwind.calibrate.hovernoise import HoverNoise
from dobwind.model.airframe import Airframe
from dobwind.calibrate.selfcheck import SelfCheck
from dobwind.model.signals import log_signals

# The blend's time constant, s: crossover at 0.32 Hz, six times the low-pass floor (hovernoise.py), so the
# accelerometer's noise below it is mostly replaced. The two paths sum to the true acceleration at every
# frequency, so the crossover need not sit below the observer's bandwidth (0.5 Hz on the m300); what a
# shorter T costs is more of the velocity derivative's noise, whose spectrum rises with frequency.
BLEND_TIME_S = 0.5
# The blend is kept when its noise at low airflow is below this share of the airframe's. Both figures
# come from the same logs, so most of their scatter is shared and a paired difference of 10 % is real;
# below that the airframe's observer is kept as written. Chosen after a first share of 0.67 left two
# random vehicles unblended at ratios 0.74 and 0.82, where the blend did better or the same on every
# goal (README): a share is a guard against noise in the figure, not a judgement of the blend.
QUIETER_SHARE = 0.9


def blended(af: Airframe) -> Airframe:
    """The airframe whose acceleration input is blended with the velocity's derivative below
    1 / (2 pi BLEND_TIME_S); nothing else changed."""
    return dataclasses.replace(af, observer=dataclasses.replace(af.observer, acceleration_bias_time_s=BLEND_TIME_S))


def needs_blend_check(af: Airframe, check: SelfCheck, hover: HoverNoise) -> bool:
    """An acceleration input not blended at BLEND_TIME_S or faster, a noise figure at low airflow, and
    that figure above the target."""
    obs, noise = af.observer, check.still_noise_mps
    already = 0.0 < obs.acceleration_bias_time_s <= BLEND_TIME_S
    return (log_signals(af).measured_acceleration and not already and noise is not None and hover.target_mps > 0
            and noise * hover.min_change > hover.target_mps)


def keeps_blend(check: SelfCheck, again: SelfCheck) -> bool:
    """The blended fit (``again``) is kept over the airframe's (``check``) when its self-check passes and
    it is clearly quieter at low airflow, or when it passes where the airframe's failed (a fit that can
    be trusted beats one that cannot). A blend that fails is never kept, even over a first fit that
    failed too: a self-check fails for reasons the blend does not touch (a log with no usable sample),
    and the observer the user wrote is not changed on a fit that cannot be trusted."""
    if not again.passed:
        return False
    if not check.passed:
        return True
    noise, quieter = check.still_noise_mps, again.still_noise_mps
    return noise is not None and quieter is not None and quieter < QUIETER_SHARE * noise


def failed_blend_warning(reason: str) -> str:
    """The warning when the blended fit itself could not be made: the user asked for less noise than the
    first fit reached, and only the report line would otherwise say why nothing more was done."""
    return (f"the acceleration blend (acceleration_bias_time {BLEND_TIME_S:g} s) could not be fitted ({reason}); "
            "the airframe's acceleration input is kept as written")


def blend_record(af: Airframe, check: SelfCheck, again: SelfCheck | None, kept: bool,
                 failure: str = "") -> dict[str, Any]:
    """What the report keeps of the comparison (``again`` None: the blended fit itself failed)."""
    return {"acceleration": af.observer.acceleration, "bias_time_s": [af.observer.acceleration_bias_time_s, BLEND_TIME_S],
            "still_noise_mps": [check.still_noise_mps, None if again is None else again.still_noise_mps],
            "blend_passed": None if again is None else again.passed,
            "blend_reasons": [failure] if again is None else list(again.reasons), "kept": kept}
