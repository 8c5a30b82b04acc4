"""Whether the acceleration the airframe takes is what leaves the noise at low airflow.

The observer's force is m p'' - m g e3 + u_f z_b, and p'' comes from one of three routes: an
acceleration input (NED, or the accelerometer's specific force) or the ground velocity's derivative.
White acceleration noise is flat down to zero frequency, so the low-pass at zero airflow passes a
share of it proportional to its cutoff (hovernoise.py) and nothing more can be done once the cutoff
is at its floor. The derivative of a velocity's noise has no power at zero frequency: its spectrum
grows with the square of the frequency, and a low cutoff keeps almost none of it. On a heavy, slow
vehicle with a noisy accelerometer the velocity route can therefore be several times quieter at low
airflow (a 6.8 kg hexacopter of the random family: still air 0.305 against 0.110 m/s, README).

Which route an airframe uses is part of its C interface (the input struct's fields follow it), so the
fit does not switch it. When the noise at low airflow is still above the target after the low-pass was
lowered, it replays the calibration logs once more with the same law and low-pass through the velocity
route, and says so when that is clearly quieter. The logged velocity is what the check measures; a
user whose autopilot's velocity is worse than the logged one keeps the acceleration input.
"""
from __future__ import annotations

import dataclasses
from typing import Any, Callable

from dobwind.hovernoise import HoverNoise
from dobwind.model.airframe import Airframe
from dobwind.selfcheck import SelfCheck

# The routes with an acceleration input (the others derive it from the velocity).
INPUT_ROUTES = ("ned", "specific_force")
# The velocity route is worth a warning when its noise at low airflow is below this share of the
# airframe route's: a third less, well beyond the scatter of the noise figure itself (its degrees of
# freedom are thousands of samples, but the segments' means take up part of it).
QUIETER_SHARE = 0.67


def velocity_route(af: Airframe) -> Airframe:
    """The airframe with its acceleration derived from the ground velocity (and so no acceleration bias
    to estimate); nothing else changed."""
    observer = dataclasses.replace(af.observer, acceleration="velocity", acceleration_bias_time_s=0.0)
    return dataclasses.replace(af, observer=observer)


def needs_route_check(af: Airframe, check: SelfCheck, hover: HoverNoise) -> bool:
    """An acceleration input, a noise figure at low airflow, and that figure above the target."""
    noise = check.still_noise_mps
    return (af.observer.acceleration in INPUT_ROUTES and noise is not None and hover.target_mps > 0
            and noise * hover.min_change > hover.target_mps)


def route_check(af: Airframe, check: SelfCheck, hover: HoverNoise,
                recheck: Callable[[Airframe], SelfCheck]) -> tuple[dict[str, Any], list[str]]:
    """({"acceleration", "still_noise_mps", "velocity_still_noise_mps", "velocity_passed",
    "velocity_reasons"} or {} when
    not checked, warnings). ``check``: the self-check of ``af``; ``recheck`` replays the calibration
    logs through another airframe. The velocity route is recommended only when it is quieter by
    QUIETER_SHARE and its self-check passes wherever the airframe's did."""
    if not needs_route_check(af, check, hover):
        return {}, []
    again = recheck(velocity_route(af))
    noise, quieter = check.still_noise_mps, again.still_noise_mps
    found = {"acceleration": af.observer.acceleration, "still_noise_mps": noise,
             "velocity_still_noise_mps": quieter, "velocity_passed": again.passed,
             "velocity_reasons": list(again.reasons)}
    if quieter is None or quieter >= QUIETER_SHARE * noise or (check.passed and not again.passed):
        return found, []
    source = "accelerometer" if af.observer.acceleration == "specific_force" else "acceleration input"
    return found, [f"the {source} (acceleration = \"{af.observer.acceleration}\") leaves {noise:.3f} m/s per axis of "
                   f"noise at low airflow; the same logs, law and low-pass with the acceleration derived from the "
                   f"logged ground velocity give {quieter:.3f} m/s: if the autopilot's velocity is as good as the "
                   "logged one, set [observer] acceleration = \"velocity\" in the airframe and fit again"]
