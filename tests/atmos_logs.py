"""Synthetic ArduPilot DataFlash flights with a position track and GPS time, for the NetCDF, profile and
many-logs tests (issue #35). The estimator's inputs come from `dobwind simulate`; the position track is
made up on its own (a climb at CLIMB_MPS from home, drifting north-east), so the tests can pin where
and when each estimate row is in closed form."""
from __future__ import annotations

import datetime as dt
from pathlib import Path

import numpy as np

from dobwind.model.airframe import load_airframe
from dobwind.simulate.simulate import simulate
from tests.dataflash_writer import write_dataflash
from tests.helpers import M300

BOOT_US = 1_000_000          # the log clock at the simulation's t = 0
LAT0, LON0, ALT0 = 47.25, 8.5, 420.0
DLAT_PER_S, DLON_PER_S = 1e-5, 2e-5
CLIMB_MPS = 2.0
GPS_WEEK, GPS_MS0 = 2254, 162_819_200  # GPS time at the simulation's t = 0
# UTC of GPS_WEEK/GPS_MS0 worked out by hand, independently of dobwind: the GPS epoch plus the weeks and
# milliseconds, less the 18 leap seconds GPS time has been ahead of UTC since 2017-01-01.
UTC0 = dt.datetime(1980, 1, 6, tzinfo=dt.timezone.utc) + dt.timedelta(weeks=GPS_WEEK, milliseconds=GPS_MS0) \
    - dt.timedelta(seconds=18)

MESSAGES = {
    "XKF1": ("QBffff", ["TimeUS", "C", "VN", "VE", "VD", "PD"]),
    "XKQ": ("QBffff", ["TimeUS", "C", "Q1", "Q2", "Q3", "Q4"]),
    "PSCN": ("Qf", ["TimeUS", "AN"]), "PSCE": ("Qf", ["TimeUS", "AE"]), "PSCD": ("Qf", ["TimeUS", "AD"]),
    "ESC": ("QBf", ["TimeUS", "Instance", "RPM"]),
    "ATT": ("Qf", ["TimeUS", "DesYaw"]),
    "EV": ("QB", ["TimeUS", "Id"]),
    # Lat/Lng as doubles in degrees ("d"): what DFReader hands back for ArduPilot's scaled "L" fields too.
    "POS": ("Qddff", ["TimeUS", "Lat", "Lng", "Alt", "RelHomeAlt"]),
    "GPS": ("QBBIHddf", ["TimeUS", "I", "Status", "GMS", "GWk", "Lat", "Lng", "Alt"]),
}


def flight(hold_s: float = 2.0, seed: int = 3):
    af = load_airframe(M300)
    return af, simulate(af, "tunnel", seed=seed, hold_s=hold_s, rate_hz=50.0)


def track(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(lat, lon, alt, height above home) at simulation time t."""
    return LAT0 + DLAT_PER_S * t, LON0 + DLON_PER_S * t, ALT0 + CLIMB_MPS * t, CLIMB_MPS * t


EKF_ORIGIN_BELOW_HOME_M = 3.0  # XKF1.PD is relative to the EKF origin, which need not be the take-off point


def write_log(path: Path, cols: dict, position: bool = True, gps_time: bool = True, local: bool = True,
              airborne: bool = True) -> Path:
    """position: POS and GPS carry a fix; gps_time: GPS has week and milliseconds; local: XKF1.PD is
    logged (NaN otherwise); airborne: ArduPilot's NOT_LANDED event at the start (else LAND_COMPLETE: a
    log that never flew)."""
    rows = [("EV", {"TimeUS": BOOT_US, "Id": 10}), ("EV", {"TimeUS": BOOT_US, "Id": 28 if airborne else 18})]
    for k, t in enumerate(cols["t"]):
        us = BOOT_US + int(round(t * 1e6))
        pd = -(EKF_ORIGIN_BELOW_HOME_M + track(t)[3]) if local else float("nan")
        rows.append(("XKF1", {"TimeUS": us, "C": 0, "VN": cols["vel_n"][k], "VE": cols["vel_e"][k],
                              "VD": cols["vel_d"][k], "PD": pd}))
        rows.append(("XKQ", {"TimeUS": us, "C": 0, **{f"Q{i + 1}": cols[f"q_{c}"][k] for i, c in enumerate("wxyz")}}))
        for name, field, key in (("PSCN", "AN", "acc_n"), ("PSCE", "AE", "acc_e"), ("PSCD", "AD", "acc_d")):
            rows.append((name, {"TimeUS": us, field: cols[key][k]}))
        for i in range(4):
            rows.append(("ESC", {"TimeUS": us, "Instance": i, "RPM": cols[f"rpm_{i + 1}"][k]}))
        rows.append(("ATT", {"TimeUS": us, "DesYaw": np.degrees(cols["yaw_ref"][k])}))
        if k % 5 == 0:  # position and GPS at 10 Hz, as ArduPilot logs them
            lat, lon, alt, height = track(t)
            if position:
                rows.append(("POS", {"TimeUS": us, "Lat": lat, "Lng": lon, "Alt": alt, "RelHomeAlt": height}))
            rows.append(("GPS", {"TimeUS": us, "I": 0, "Status": 3 if gps_time else 1, "GMS": GPS_MS0 + round(t * 1e3),
                                 "GWk": GPS_WEEK if gps_time else 0, "Lat": lat if position else 0.0,
                                 "Lng": lon if position else 0.0, "Alt": alt}))
    return write_dataflash(path, MESSAGES, rows)
