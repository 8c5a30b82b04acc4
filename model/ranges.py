"""Physical and single-precision ranges of every airframe value (docs/formats.md, "Ranges").

The loader checks each number against its range before anything is built, so that neither the
CasADi model, the analysis nor the C printer meets a value it cannot represent: a generated
single-precision step holds every constant as a float, and a value outside these ranges is either
not a flying vehicle or would overflow or vanish in a float. The reasons are written beside each
range because docs/formats.md repeats them for users.
"""
from __future__ import annotations

from dataclasses import dataclass

# IEEE 754 binary32: the largest finite value and the smallest normal one. A folded constant below
# FLT_MIN would be subnormal (losing digits) or zero in the single-precision step.
FLT_MAX = 3.4028234663852886e38
FLT_MIN = 1.1754943508222875e-38


@dataclass(frozen=True)
class Range:
    low: float
    high: float
    unit: str
    low_open: bool = False   # low itself excluded
    high_open: bool = False  # high itself excluded
    zero_allowed: bool = False  # 0 is accepted although it is below ``low`` (an "off" value)

    def contains(self, value: float) -> bool:
        if self.zero_allowed and value == 0.0:
            return True
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below

    def describe(self) -> str:
        left = "(" if self.low_open else "["
        right = ")" if self.high_open else "]"
        unit = f" {self.unit}" if self.unit else ""
        zero = "0 or " if self.zero_allowed else ""
        return f"{zero}in {left}{self.low:g}, {self.high:g}{right}{unit}"


# The smallest nonzero magnitude of a value that may be 0: physically zero, yet a normal float with
# eight decades to spare, so that the C literal neither vanishes nor loses digits.
TINY = 1e-30

# Dotted key -> range. Magnitude ranges (``coefficients``) apply to |value|.
RANGES: dict[str, Range] = {
    # 5 g (the lightest flying micro quadrotors are about 20 g) to 10 t (beyond any multirotor).
    "mass": Range(0.005, 1e4, "kg"),
    # From small moons (Ceres 0.28) to far beyond any planet's surface (Earth 9.81, Jupiter's clouds 24.8).
    "gravity": Range(0.1, 100.0, "m/s^2"),
    # A calibration that changes the thrust curve more than tenfold means the curve itself is wrong.
    "thrust.scale": Range(0.1, 10.0, ""),
    # Large rotors turn a few hundred rpm; the step refuses any input beyond 1e6 (NONFINITE).
    "thrust.max_rpm": Range(10.0, 1e6, "rev/min"),
    # One rotor's thrust at max_rpm is their sum: 1e6 N is a hundred tonnes.
    "thrust.coefficients": Range(0.0, 1e6, "N"),
    # 10 kHz to 1 Hz; the step rejects dt below 1e-5 s.
    "observer.sample_time": Range(1e-4, 1.0, "s"),
    # kg/s: below 1e-3 even the lightest vehicle's observer (m / gain = 5 s at 5 g) would be slower than
    # the wind it tracks; the pole test refuses gains too stiff for the sample time.
    "observer.gains": Range(1e-3, 1e7, "kg/s"),
    # The weight of the heaviest vehicle in range at the highest gravity (1e4 kg x 100 m/s^2).
    "observer.force_offset": Range(TINY, 1e6, "N", zero_allowed=True),
    # Off (0), or from the sample time to a day.
    "observer.acceleration_bias_time": Range(1e-4, 86400.0, "s", zero_allowed=True),
    # Hurricane winds are 70 m/s; no multirotor flies in 100.
    "filter.speeds": Range(TINY, 100.0, "m/s", zero_allowed=True),
    # A time constant of 160 s is the slowest useful wind smoothing; the top is checked against Nyquist.
    "filter.cutoffs": Range(1e-3, 5000.0, "Hz"),
    # The sample time to 10 s: a longer gap is a restart, not a step.
    "limits.max_dt": Range(1e-4, 10.0, "s"),
    "limits.max_tilt_deg": Range(1.0, 90.0, "deg", high_open=True),
    # Force-air coefficients: m/s per N^p. Zero drops the term; fitted values are 1e-3..10, and with
    # |p| <= 4 and forces up to 1e6 N every product c * term stays inside single precision.
    "force_air.coefficients": Range(TINY, 1e6, "", zero_allowed=True),
    # Drag-law coefficients (N per (m/s)^k): a hundred tonnes at 1 m/s.
    "force_air.drag": Range(TINY, 1e6, "", zero_allowed=True),
    "envelope.force_h_max": Range(TINY, 1e6, "N"),
    "envelope.force_z": Range(TINY, 1e6, "N", zero_allowed=True),
    "envelope.airflow_h_max": Range(TINY, 1000.0, "m/s"),
    "uncertainty.speeds": Range(TINY, 1000.0, "m/s", zero_allowed=True),
    "uncertainty.sigma": Range(TINY, 1000.0, "m/s", zero_allowed=True),
}

NAME_MAX_CHARS = 64            # symbols stay readable, file names far below the usual 255-byte limit
MAX_THRUST_COEFFICIENTS = 8    # a 7th-degree thrust curve already over-fits any thrust-stand data
MAX_TERMS = 32                 # per force-air table
MAX_FACTOR_POWER = 4.0         # |p| of one factor: drag is F ~ v^2, the paper's surface is quadratic
MAX_TERM_DEGREE = 8.0          # sum of |p| over a term's factors
MIN_SPEED_GAP_MPS = 0.01       # filter breakpoints closer than 1 cm/s make a slope of 1/gap


def single_precision_ok(value: float) -> bool:
    """A constant a float holds without overflow and without becoming subnormal (0 is exact)."""
    return value == 0.0 or FLT_MIN <= abs(value) <= FLT_MAX
