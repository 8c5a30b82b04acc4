"""Numeric command-line options bounded to ranges a flight-software engineer would expect.

Each option is checked while the command line is parsed, before anything is read or allocated, so a
rate of 1e6 Hz or a hold of 1e9 s is one stderr line (exit 2) instead of a memory exhaustion.
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Bound:
    low: float
    high: float
    unit: str = ""
    integer: bool = False

    def text(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        if self.integer:
            return f"{int(self.low)} to {int(self.high)}{unit}"
        return f"{self.low:g} to {self.high:g}{unit}"

    def __call__(self, text: str) -> float | int:
        """argparse ``type=``: the parsed value, or ArgumentTypeError (one line naming the option)."""
        try:
            value: float | int = int(text) if self.integer else float(text)
        except ValueError:
            kind = "a whole number" if self.integer else "a number"
            raise argparse.ArgumentTypeError(f"expected {kind} from {self.text()}, got {text!r}") from None
        # NaN fails both comparisons, so it is refused here too.
        if not (self.low <= value <= self.high) or (isinstance(value, float) and not math.isfinite(value)):
            raise argparse.ArgumentTypeError(f"must be from {self.text()}, got {text!r}")
        return value


SEED = Bound(0, 2**32 - 1, integer=True)
SIMULATE_RATE = Bound(1.0, 500.0, "Hz")
SIMULATE_HOLD = Bound(0.1, 600.0, "s")  # short holds are for quick tests; calibration wants several seconds
SIMULATE_MAX_ROWS = 2_000_000  # fit needs about 2 KB per row of such a log; a 500 Hz calibration sweep with 7 s holds is 1.1 M
VERIFY_STEPS = Bound(100, 2_000_000, "steps", integer=True)
ULOG_RATE = Bound(1.0, 1000.0, "Hz")
FREQUENCY = Bound(1e-4, 1e4, "Hz")        # then also below the airframe's Nyquist frequency
BANDWIDTH = Bound(1e-3, 1e4, "Hz")        # then also below the airframe's Nyquist frequency
MAX_FREQUENCIES = 50
ERROR_SHARE = Bound(0.001, 10.0)          # fit self-check: share of the calibrated airflow speed range
ERROR_FLOOR = Bound(0.0, 100.0, "m/s")
DIRECTION_LIMIT = Bound(0.1, 180.0, "deg")
HOVER_NOISE = Bound(0.0, 10.0, "m/s")     # fit: noise target at low airflow; 0 keeps the airframe's low-pass


# `analyze --bandwidth`: a force bandwidth in Hz, or a target in wind units at an airspeed.
WIND_NOISE_TARGET = Bound(1e-4, 100.0, "m/s")
WIND_LAG_TARGET = Bound(1e-4, 1000.0, "s")
AIRSPEED = Bound(0.0, 100.0, "m/s")
FORCE_NOISE = Bound(1e-9, 1e6, "N")
MAX_AIRSPEEDS = 20


@dataclass(frozen=True)
class WindTargetSpec:
    kind: str            # "noise" or "lag"
    value: float
    airspeed_mps: float


class DesignTargetType:
    """argparse ``type=`` of --bandwidth: "0.5" (Hz, a float as before), "noise=0.2@5" (m/s of wind noise
    at 5 m/s airspeed) or "lag=0.6@5" (s of ramp lag at 5 m/s)."""

    def text(self) -> str:
        return (f"{BANDWIDTH.text()}; or noise=M/S@AIRSPEED ({WIND_NOISE_TARGET.text()}) or lag=S@AIRSPEED "
                f"({WIND_LAG_TARGET.text()}), airspeed {AIRSPEED.text()}")

    def __call__(self, text: str) -> float | WindTargetSpec:
        kind, sep, rest = text.partition("=")
        if not sep:
            return BANDWIDTH(text)
        value, at, speed = rest.partition("@")
        if kind not in ("noise", "lag") or not at:
            raise argparse.ArgumentTypeError(f"expected Hz, noise=M/S@AIRSPEED or lag=S@AIRSPEED, got {text!r}")
        bound = WIND_NOISE_TARGET if kind == "noise" else WIND_LAG_TARGET
        return WindTargetSpec(kind, float(bound(value)), float(AIRSPEED(speed)))


DESIGN_TARGET = DesignTargetType()
