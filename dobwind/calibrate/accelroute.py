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

The self-check's figure comes from a few short low-airflow segments, about their own means: a fit can
meet the target there and still read 0.11 m/s of wind in a minute of still air (the benchmark's 25 kg
hexacopter, README). So the blend is also tried whenever the low-pass had to be lowered at all, if the
sensors' noise, read off the logs (blendnoise.py), predicts its acceleration noise clearly below the
airframe's route; and a blend the prediction backs is kept unless the replay measures it more than
NOISIER_SHARE noisier (a tie on a noisy figure goes to the closed form). A noiseless acceleration input
predicts an infinite ratio: the blend is then never tried, whatever the replay's figure.
"""
from __future__ import annotations

import dataclasses
import math

from dobwind.calibrate.blendnoise import SensorNoise, blend_rms_ratio, quietest_blend_time
from dobwind.calibrate.hovernoise import HoverNoise
from dobwind.model.airframe import Airframe
from dobwind.calibrate.reportparts import AccelerationRoute, SelfCheck
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
# A blend the sensors' noise predicts quieter is kept unless its measured noise at low airflow is above
# this share of the airframe's (the same paired-difference guard, the other way).
NOISIER_SHARE = 1.1


# The longest blend time the sensors' noise may ask for (a noisy velocity beside a quiet accelerometer):
# beyond it the blend's corner nears the low-pass floor and there is little left to replace.
LONGEST_BLEND_TIME_S = 5.0


def blended(af: Airframe, time_s: float = BLEND_TIME_S) -> Airframe:
    """The airframe whose acceleration input is blended with the velocity's derivative below
    1 / (2 pi ``time_s``); nothing else changed."""
    return dataclasses.replace(af, observer=dataclasses.replace(af.observer, acceleration_bias_time_s=time_s))


def blend_time(af: Airframe, noise: SensorNoise | None) -> float:
    """The blend's time constant: the quietest for the sensors' noise behind ``af``'s first cutoff
    (blendnoise.quietest_blend_time), kept between BLEND_TIME_S and LONGEST_BLEND_TIME_S; BLEND_TIME_S
    without a noise figure. Shorter than BLEND_TIME_S, the velocity's derivative would carry the
    acceleration up to near the observer's own bandwidth (1 Hz on the m300), past which the
    derivative's noise rises fastest and an autopilot's velocity may lag its accelerometer."""
    if noise is None:
        return BLEND_TIME_S
    quietest = quietest_blend_time(noise, af.filter.cutoffs_hz[0], observer_hz(af))
    return min(LONGEST_BLEND_TIME_S, max(BLEND_TIME_S, quietest))


def observer_hz(af: Airframe) -> float:
    """The observer's horizontal bandwidth: gain / mass rad/s per axis (step.py), in Hz."""
    gain = (af.observer.gains[0] + af.observer.gains[1]) / 2.0
    return gain / af.mass_kg / (2.0 * math.pi)


def needs_blend_check(af: Airframe, check: SelfCheck, hover: HoverNoise) -> bool:
    """An acceleration input not blended at BLEND_TIME_S or faster, a noise figure at low airflow, and
    that figure above the target."""
    obs, noise = af.observer, check.still_noise_mps
    already = 0.0 < obs.acceleration_bias_time_s <= BLEND_TIME_S
    return (log_signals(af).measured_acceleration and not already and noise is not None and hover.target_mps > 0
            and noise * hover.min_change > hover.target_mps)


def predicted_ratio(af: Airframe, noise: SensorNoise | None) -> float | None:
    """The blend's acceleration noise (RMS) over ``af``'s own route behind its first cutoff, predicted
    from the sensors' noise (blendnoise.py); None without an acceleration input or a noise figure."""
    if noise is None or not log_signals(af).measured_acceleration:
        return None
    return blend_rms_ratio(noise, af.filter.cutoffs_hz[0], af.observer.acceleration_bias_time_s, blend_time(af, noise),
                           observer_hz(af))


def tries_blend(af: Airframe, check: SelfCheck, hover: HoverNoise, lowered: bool, ratio: float | None) -> bool:
    """Whether the fit runs again blended: never when the sensors predict the blend no quieter (``ratio``
    at or above QUIETER_SHARE, a noiseless acceleration input among them); else when the noise at low
    airflow stayed above the target (needs_blend_check), or when the low-pass had to be lowered
    (``lowered``) and the prediction says the blend is quieter."""
    if ratio is not None and not ratio < QUIETER_SHARE:
        return False
    if needs_blend_check(af, check, hover):
        return True
    already = 0.0 < af.observer.acceleration_bias_time_s <= BLEND_TIME_S
    return lowered and ratio is not None and not already and hover.target_mps > 0


def keeps_blend(check: SelfCheck, again: SelfCheck, predicted: bool = False) -> bool:
    """The blended fit (``again``) is kept over the airframe's (``check``) when its self-check passes and
    it is clearly quieter at low airflow, or when it passes where the airframe's failed (a fit that can
    be trusted beats one that cannot). A blend that fails is never kept, even over a first fit that
    failed too: a self-check fails for reasons the blend does not touch (a log with no usable sample),
    and the observer the user wrote is not changed on a fit that cannot be trusted. ``predicted``: the
    sensors' noise predicts the blend quieter; it is then kept unless measured NOISIER_SHARE noisier."""
    if not again.passed:
        return False
    if not check.passed:
        return True
    noise, quieter = check.still_noise_mps, again.still_noise_mps
    if noise is None or quieter is None:
        return False
    return quieter <= NOISIER_SHARE * noise if predicted else quieter < QUIETER_SHARE * noise


def failed_blend_warning(reason: str, time_s: float = BLEND_TIME_S) -> str:
    """The warning when the blended fit itself could not be made: the user asked for less noise than the
    first fit reached, and only the report line would otherwise say why nothing more was done."""
    return (f"the acceleration blend (acceleration_bias_time {time_s:.3g} s) could not be fitted ({reason}); "
            "the airframe's acceleration input is kept as written")


def blend_record(af: Airframe, check: SelfCheck, again: SelfCheck | None, kept: bool,
                 failure: str = "", ratio: float | None = None, time_s: float = BLEND_TIME_S) -> AccelerationRoute:
    """What the report keeps of the comparison (``again`` None: the blended fit itself failed; ``ratio``:
    the predicted RMS ratio of the acceleration noise, None when not predicted)."""
    return AccelerationRoute(
        acceleration=af.observer.acceleration, bias_time_s=(af.observer.acceleration_bias_time_s, time_s),
        still_noise_mps=(check.still_noise_mps, None if again is None else again.still_noise_mps),
        blend_passed=None if again is None else again.passed,
        blend_reasons=[failure] if again is None else list(again.reasons), kept=kept, predicted_ratio=ratio)
