"""A time window of an autopilot log: the rows between two instants of the log's own clock (PX4: s since
boot; ArduPilot: TimeUS in s), as the reader gives them (issue #36: fit on one part of a flight, replay
the rest).

The window is cut after the log is read and resampled, never in the file: the resampling, the gap
tolerances and the airborne detection see the whole flight, so a row inside the window is the very row
the whole log's replay has. The rows kept are re-based (``log.time_s`` starts at 0 again, ``t0_s`` moves
by as much), so the clock of every row is unchanged and the code that assumes a log starting at 0 (the
warm-up, the segment windows) reads a window as it reads a log.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.logs import FlightLog
from dobwind.io.resample import AutopilotFlight


@dataclass(frozen=True)
class TimeWindow:
    """[start_s, end_s) on the log's own clock; an open side is +-inf."""
    start_s: float = -math.inf
    end_s: float = math.inf

    def __post_init__(self) -> None:
        if math.isnan(self.start_s) or math.isnan(self.end_s) or not self.start_s < self.end_s:
            raise ValueError(f"a time window needs start < end, not [{self.start_s}, {self.end_s})")

    def mask(self, clock_s: np.ndarray) -> np.ndarray:
        return (clock_s >= self.start_s) & (clock_s < self.end_s)

    def describe(self) -> str:
        start = "start" if math.isinf(self.start_s) else f"{self.start_s:.2f} s"
        end = "end" if math.isinf(self.end_s) else f"{self.end_s:.2f} s"
        return f"log time [{start}, {end})"


def window_flight(path: str, flight: AutopilotFlight, window: TimeWindow | None) -> AutopilotFlight:
    """The rows of ``flight`` inside ``window`` (None: the whole flight). A window holding no row is an
    input error naming the log."""
    if window is None:
        return flight
    clock = flight.log.time_s + flight.t0_s
    keep = window.mask(clock)
    if not keep.any():
        raise InputError(path, None, f"no row in the time window {window.describe()} (the log spans "
                         f"{clock[0]:.2f}-{clock[-1]:.2f} s)")
    shift = float(flight.log.time_s[np.argmax(keep)])
    columns = {k: v[keep] for k, v in flight.log.columns.items()}
    columns["t"] = columns["t"] - shift
    autopilot_wind = None
    if flight.autopilot_wind is not None:  # its own times are on the log's time axis: moved with it
        source, t_ref, w_ref = flight.autopilot_wind
        autopilot_wind = (source, t_ref - shift, w_ref)
    return dataclasses.replace(
        flight, log=FlightLog(flight.log.path, columns), no_data=flight.no_data[keep], landed=flight.landed[keep],
        bridged=None if flight.bridged is None else flight.bridged[keep], autopilot_wind=autopilot_wind,
        t0_s=flight.t0_s + shift, notes=flight.notes + (f"rows in {window.describe()} only",))
