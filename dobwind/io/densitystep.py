"""ArduCopter's air-density compensation, undone where the log shows its step in CTUN.ThO.

ArduCopter scales its motor outputs by the air's density: AP_Motors divides the throttle the controllers
ask for (logged as CTUN.ThO) by the density ratio (the air's density over the ISA sea-level 1.225 kg/m³),
and AP_Baro recomputes that ratio (from the baro's pressure and its ground temperature with the ISA lapse
rate) only once the baro altitude has moved 25 m from where it last computed it. In ArduCopter 4.1 the
ratio in force from boot is 1 and the first computation comes at the first 25 m of climb: from then on the
same motor outputs are logged as a lower ThO. On the ArduCopter SITL log of ../shared/data/field/ (ground
pressure 94.5 kPa and 25.5 °C: ratio 0.897) ThO drops from 0.383 to 0.347 at 117.2 s while every motor's
PWM stays at 1597. The learned hover throttle CTUN.ThH does not move (ArduCopter learns it only in level,
slow flight), so the thrust ThO / ThH × m g read 10 % low for the last 55 of the flight's 97 airborne
seconds, and a calibration took an average of the two parts as a thrust scale (1.063).

The reader therefore rebuilds the ratio ArduCopter used (BARO Alt, Press and GndTemp; 1 before the first
computation) and, where the log itself shows that first step in ThO (its median over a third of a second
after the instant against the third before, closer to the predicted ratio than to no step at all), reads the thrust
as ThO / ratio over the hover throttle learned before the step. A log whose ThO shows no such step (a
version that computes the ratio at boot, a flight that never climbs 25 m, a step too small to see) is read
as logged.

What is compared is ThO per unit of the thrust the IMU feels (-AccZ, the body-down specific force, which
the thrust dominates), when the log has the IMU: the compensation changes ThO and not the thrust, while a
manoeuvre at the same instant (levelling off at 25 m, a gust) changes both. On the field SITL log, away from
the step, ThO's own medians over 0.35 s either side differ by up to 8 % (5 % in one window of a hundred),
which a 10 % step must be told from; ThO per -AccZ by up to 2.6 %. Without an IMU, ThO alone is compared.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RECOMPUTE_M = 25.0            # AP_Baro: the altitude change after which the ratio is computed again
SEA_LEVEL_DENSITY = 1.225     # kg/m³, ISA
GAS_CONSTANT = 287.26         # J/(kg K), ArduPilot's ISA_GAS_CONSTANT
LAPSE_RATE = 0.0065           # K/m, ISA
KELVIN = 273.15
# Each side of the step, for ThO's medians: three samples of the usual 10 Hz CTUN. The compensation steps
# within two samples (the field log: 0.384, 0.358, 0.353 at 0.1 s spacing); a vehicle levelling off at the
# same instant changes its throttle by 5-10 % over one or two seconds, a few percent in this window, so a
# wider one would take such a change for the step on a version that has none.
WINDOW_S = 0.35
MIN_STEP = 0.02               # a smaller step is within a second's throttle changes: not judged, not undone
MIN_SAMPLES = 2               # ThO samples each side
RATIO_RANGE = (0.5, 1.3)      # ISA density ratios from about 5.5 km up to a cold day below sea level
# -AccZ below this share of g is no thrust to normalize by (a free fall, a sensor fault): such samples are
# left out of the normalized medians.
MIN_THRUST_G = 0.3
GRAVITY = 9.80665


def applied_ratio(alt_m: np.ndarray, pressure_pa: np.ndarray, ground_temp_c: np.ndarray) -> np.ndarray:
    """The density ratio in force at each baro sample under ArduCopter 4.1's rule: 1 until the altitude
    has moved 25 m from 0, then the ratio computed there, held until it moves 25 m from that altitude."""
    out = np.empty(len(alt_m))
    current, last = 1.0, 0.0
    for k, alt in enumerate(alt_m):
        if abs(alt - last) >= RECOMPUTE_M:
            temp_k = ground_temp_c[k] + KELVIN - LAPSE_RATE * alt
            current, last = pressure_pa[k] / (GAS_CONSTANT * temp_k) / SEA_LEVEL_DENSITY, float(alt)
        out[k] = current
    return out


@dataclass(frozen=True)
class DensityStep:
    """A step the log shows: from ``t_s`` the ratio in force is ``ratio`` (held between baro samples
    ``baro_t``), and ``hover_before`` the hover throttle ArduCopter had learned under a ratio of 1."""
    t_s: float
    predicted: float      # ThO after / before that the ratio change implies
    measured: float       # ThO's medians after / before
    baro_t: np.ndarray
    ratio: np.ndarray
    hover_before: float
    measure: str = "CTUN.ThO"   # what stepped: ThO, or ThO per unit of the IMU's -AccZ

    def thrust_terms(self, clock: np.ndarray, tho: np.ndarray, thh: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """ThO and ThH on ``clock`` in the units of a ratio of 1 (ThO / ratio; the hover throttle learned
        before the step, which a relearning afterwards would mix with the new units)."""
        k = np.clip(np.searchsorted(self.baro_t, clock, side="right") - 1, 0, len(self.baro_t) - 1)
        after = clock >= self.t_s
        return np.where(after, tho / self.ratio[k], tho), np.where(after, self.hover_before, thh)

    def note(self) -> str:
        return (f"ArduCopter's air-density compensation: its density ratio (BARO, recomputed every 25 m of "
                f"altitude) went from 1 to {self.ratio[np.searchsorted(self.baro_t, self.t_s)]:.3f} at "
                f"{self.t_s:.1f} s and {self.measure} stepped by {self.measured:.3f} with it (predicted "
                f"{self.predicted:.3f}): from then on the thrust is ThO / ratio over the hover throttle learned "
                f"before ({self.hover_before:.3f}), as the motors' outputs say")


def _median(t: np.ndarray, v: np.ndarray, lo: float, hi: float) -> float | None:
    inside = (t > lo) & (t < hi) & (v > 0)
    return float(np.median(v[inside])) if inside.sum() >= MIN_SAMPLES else None


def _throttle_measure(ctun: dict[str, np.ndarray], imu: dict[str, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray, str]:
    """(times, values, name) of what the step is looked for in: ThO per unit of the IMU's -AccZ at CTUN's
    instants where the IMU covers them and feels thrust, else ThO as logged."""
    if imu is None or len(imu["t"]) < 2:
        return ctun["t"], ctun["ThO"], "CTUN.ThO"
    inside = (ctun["t"] >= imu["t"][0]) & (ctun["t"] <= imu["t"][-1])
    felt = -np.interp(ctun["t"], imu["t"], imu["AccZ"])
    keep = inside & (felt > MIN_THRUST_G * GRAVITY)
    return ctun["t"][keep], ctun["ThO"][keep] / felt[keep], "CTUN.ThO per unit of the IMU's -AccZ"


def _change(ctun: dict[str, np.ndarray], imu: dict[str, np.ndarray] | None, t1: float) -> tuple[float | None, str]:
    """The measure's median over WINDOW_S after ``t1`` over its median before (None: too few samples)."""
    t, value, measure = _throttle_measure(ctun, imu)
    before = _median(t, value, t1 - WINDOW_S, t1)
    after = _median(t, value, t1, t1 + WINDOW_S)
    return (None if before is None or after is None else after / before), measure


def find_step(baro: dict[str, np.ndarray] | None, ctun: dict[str, np.ndarray],
              imu: dict[str, np.ndarray] | None = None) -> tuple[DensityStep | None, list[str]]:
    """The step (or None) and what to say. ``baro``: times ``t`` (s) and Alt, Press, GndTemp of the primary
    barometer; ``ctun``: ``t``, ThO, ThH; ``imu``: ``t`` and AccZ (m/s², body down) of the IMU, or None."""
    if baro is None or len(baro["t"]) < 2:
        return None, []
    ratio = applied_ratio(baro["Alt"], baro["Press"], baro["GndTemp"])
    changed = np.flatnonzero(ratio != 1.0)
    if len(changed) == 0 or not np.isfinite(ratio[changed[0]]):
        return None, []
    t1, predicted = float(baro["t"][changed[0]]), float(ratio[changed[0]])
    if abs(1.0 - predicted) < MIN_STEP or not RATIO_RANGE[0] <= predicted <= RATIO_RANGE[1]:
        return None, []  # nothing to see, or a barometer no flight reads (a damaged log's values)
    measured, measure = _change(ctun, imu, t1)
    if measured is None and imu is not None:  # the IMU felt no thrust around the instant: ThO alone
        measured, measure = _change(ctun, None, t1)
    if measured is None:
        return None, []
    if abs(measured - predicted) >= abs(1.0 - measured):
        return None, [f"ArduCopter's density ratio from BARO would have stepped to {predicted:.3f} at {t1:.1f} s, "
                      f"but {measure} changed by {measured:.3f} there: the thrust is read as logged"]
    pre = ctun["t"] < t1
    hover = float(ctun["ThH"][pre][-1]) if pre.any() else float(ctun["ThH"][0])
    step = DensityStep(t1, predicted, measured, np.asarray(baro["t"], dtype=float), ratio, hover, measure)
    return step, [step.note()]
