"""Which reader a log needs (by its name), and the PX4-style wind file (`replay --px4-wind`)."""
from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from dobwind.io.atomic import write_text_atomically
from dobwind.io.logsuffix import DATAFLASH_SUFFIXES, ROSBAG_SUFFIXES, ULOG_SUFFIXES
from dobwind.core.errors import InputError
from dobwind.model.airframe import Airframe
from dobwind.model.status import DT_TOLERANCE
from dobwind.io.resample import AutopilotFlight
from dobwind.io.timewindow import TimeWindow, window_flight



def log_kind(path: str) -> str:
    """'ulog', 'dataflash', 'rosbag' or 'csv'. A folder is a ROS 2 bag (rosbags opens bag folders)."""
    name = str(path).lower()
    if name.endswith(ULOG_SUFFIXES):
        return "ulog"
    if name.endswith(DATAFLASH_SUFFIXES):
        return "dataflash"
    if name.endswith(ROSBAG_SUFFIXES) or Path(path).is_dir():
        return "rosbag"
    return "csv"


def is_autopilot_log(path: str) -> bool:
    return log_kind(path) != "csv"


def read_autopilot(path: str, af: Airframe, rate_hz: float | None = None,
                   topics: dict[str, str] | None = None, bridge_gaps: bool = False,
                   window: TimeWindow | None = None) -> AutopilotFlight:
    """``bridge_gaps``: feed short silences interpolated (dobwind/io/bridge.py), as replay does; off, every
    NO_DATA row has NaN inputs (what fit's samples rely on). ``window``: only the rows in that span of the
    log's clock, cut after the whole log is read (dobwind/io/timewindow.py)."""
    _refuse_slow_rate(af, rate_hz)
    return _never_airborne(path, window_flight(path, _read_whole(path, af, rate_hz, topics, bridge_gaps), window))


def _refuse_slow_rate(af: Airframe, rate_hz: float | None) -> None:
    """--rate whose step is longer than the airframe's limits.max_dt: the step would reject every instant as
    BAD_DT, and replay "succeeded" with 0 valid rows (`--rate 1` on a max_dt of 0.1 s)."""
    if rate_hz is None or 1.0 / rate_hz <= af.limits.max_dt_s * (1 + DT_TOLERANCE):
        return
    raise InputError("--rate", None, f"{rate_hz:g} Hz steps {1.0 / rate_hz:g} s, longer than the airframe's "
                     f"limits.max_dt ({af.limits.max_dt_s:g} s): the step would reject every instant (BAD_DT); give at "
                     f"least {1.0 / af.limits.max_dt_s:.3g} Hz")


def _never_airborne(path: str, flight: AutopilotFlight) -> AutopilotFlight:
    """A log (or window) on the ground throughout (a pre-arm or bench log) says so: every row is LANDED and
    nothing is estimated, which the status counts alone leave the user to work out."""
    if not (flight.log.rows and np.all(flight.landed)):
        return flight
    span = float(flight.log.time_s[-1] - flight.log.time_s[0])
    said = (f"{path}: never airborne in its {span:.1f} s (every instant on the ground, status LANDED): no wind is "
            "estimated from it",)
    return dataclasses.replace(flight, warnings=flight.warnings + said)


def _read_whole(path: str, af: Airframe, rate_hz: float | None, topics: dict[str, str] | None,
                bridge_gaps: bool) -> AutopilotFlight:
    kind = log_kind(path)
    if kind == "ulog":
        from dobwind.io.ulog import read_ulog

        return read_ulog(path, af, rate_hz, bridge_gaps)
    if kind == "dataflash":
        from dobwind.io.dataflash import read_dataflash

        return read_dataflash(path, af, rate_hz, bridge_gaps)
    from dobwind.io.rosbag import read_rosbag

    return read_rosbag(path, af, rate_hz, topics or {}, bridge_gaps)


PX4_WIND_COLUMNS = ("timestamp", "windspeed_north", "windspeed_east", "variance_north", "variance_east", "status")


def px4_wind_rows(flight: AutopilotFlight, wind: np.ndarray, sigma_h: np.ndarray, status: np.ndarray,
                  accepted: np.ndarray) -> np.ndarray:
    """What PX4's `wind` message holds, per accepted row: timestamp in microseconds on the log's own
    clock, north/east wind (m/s) and their variances (m²/s²). The step gives one horizontal 1-sigma,
    so each axis gets sigma_h² (an isotropic error); an unknown sigma (-1: no [uncertainty] table)
    gives NaN variances, never a fake confidence."""
    t_us = np.round((flight.log.time_s + flight.t0_s) * 1e6)
    var = np.where(sigma_h >= 0, sigma_h * sigma_h, np.nan)
    rows = np.column_stack([t_us, wind[:, 0], wind[:, 1], var, var, status])
    return rows[accepted]


def write_px4_wind(path: str | Path, rows: np.ndarray) -> None:
    def write(handle) -> None:
        handle.write("# dobwind wind in the fields of PX4's wind message (uORB); timestamp in us on the log's clock\n")
        handle.write(",".join(PX4_WIND_COLUMNS) + "\n")
        np.savetxt(handle, rows, fmt=["%d", "%.6g", "%.6g", "%.6g", "%.6g", "%d"], delimiter=",")

    write_text_atomically(path, write)
