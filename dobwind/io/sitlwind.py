"""The wind an ArduPilot SITL simulator was told to blow, from a DataFlash log's parameters: the truth
`fit --truth sitl` calibrates on (dobwind/calibrate/sitlwind.py) and `replay` and `report` compare with
(dobwind/replay/sitlcompare.py). Pure: it works on the messages the DataFlash reader loaded.

ArduPilot's SITL (libraries/AP_HAL_SITL/SITL_State.cpp, _simulator_servos; libraries/SITL/SIM_Aircraft.cpp,
update_wind), as read for this module:
- the wind speed at the vehicle depends on ``altitude = AP::baro().get_altitude()``, the primary
  barometer's altitude above its ground calibration (the take-off point), which the log records as
  BARO.Alt (instance 0). That, not the EKF's height, is what the simulator used, so it is read first;
  CTUN.BAlt (the same barometer, logged at the controller's rate), POS.RelHomeAlt and -XKF1.PD (EKF
  heights above home and origin, within decimetres of it) stand in for logs without BARO;
- SIM_WIND_T = 0 (square law): below SIM_WIND_T_ALT the speed is SIM_WIND_SPD * sqrt(max(alt / T_ALT, 0));
  SIM_WIND_T = 2 (linear): SIM_WIND_SPD + (alt - T_ALT) * SIM_WIND_T_COEF; SIM_WIND_T = 1: no profile.
  The speed is never negative;
- the simulator's airflow is ``velocity_ef + wind_ef`` with wind_ef = speed * (cos DIR cos DIR_Z,
  sin DIR cos DIR_Z, sin DIR_Z): the air moves along -wind_ef, so SIM_WIND_DIR is where the wind blows
  FROM (clockwise from north) and SIM_WIND_DIR_Z = 90 is a pure updraft;
- SIM_WIND_TURB > 0 adds a random turbulence whose realisation the log does not hold: the truth is then
  the mean wind only, approximate.
Parameters changed in flight (PARM messages later in the log) take effect at their time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dobwind.core.errors import InputError
from dobwind.model.forceair import wind_from_ne

REQUIRED = ("SIM_WIND_SPD", "SIM_WIND_DIR")
# ArduPilot's defaults for the optional ones (SITL.cpp's parameter table).
DEFAULTS = {"SIM_WIND_TURB": 0.0, "SIM_WIND_T": 0.0, "SIM_WIND_T_ALT": 60.0, "SIM_WIND_T_COEF": 0.01,
            "SIM_WIND_DIR_Z": 0.0}
PROFILE_SQRT, PROFILE_NONE, PROFILE_LINEAR = 0, 1, 2
# Altitude sources, best first: (message, field, instance field, sign, what it is).
ALTITUDES = (("BARO", "Alt", "I", 1.0, "BARO.Alt (the barometer altitude SITL's wind profile uses)"),
             ("CTUN", "BAlt", None, 1.0, "CTUN.BAlt (barometer altitude)"),
             ("POS", "RelHomeAlt", None, 1.0, "POS.RelHomeAlt (EKF height above home, not the barometer SITL uses)"),
             ("XKF1", "PD", "C", -1.0, "-XKF1.PD (EKF height above origin, not the barometer SITL uses)"))
# The DataFlash messages the truth needs (dobwind/io/dataflash.py loads them beside its own).
MESSAGES = ("PARM", *sorted({a[0] for a in ALTITUDES}))


@dataclass(frozen=True)
class SitlLog:
    """What the truth needs of one SITL log: each parameter's (times, values) and the altitude."""
    parameters: dict[str, tuple[np.ndarray, np.ndarray]]
    t_alt_s: np.ndarray
    altitude_m: np.ndarray
    altitude_source: str

    def value(self, name: str, t: np.ndarray) -> np.ndarray:
        """The parameter in force at each time (its first value before it was first logged)."""
        if name not in self.parameters:
            return np.full(len(t), DEFAULTS[name])
        times, values = self.parameters[name]
        return values[np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(values) - 1)]

    def final_parameters(self) -> dict[str, float]:
        """Every SIM_WIND_* parameter as it stands at the end of the log (defaults where not logged)."""
        t = self.t_alt_s[-1:]
        return {name: float(self.value(name, t)[0]) for name in (*REQUIRED, *DEFAULTS)}

    def turbulent(self) -> bool:
        """SIM_WIND_TURB > 0 at some time: the truth is the simulator's mean wind only."""
        return bool(np.any(self.value("SIM_WIND_TURB", self.t_alt_s) > 0))


def sitl_parameters(msgs: dict[str, list[dict]]) -> dict[str, list[tuple[float, float]]]:
    """Each SIM_WIND_* parameter's (time s, value) in log order, from the PARM messages."""
    params: dict[str, list[tuple[float, float]]] = {}
    for row in msgs.get("PARM", []):
        name, value = str(row.get("Name", "")), row.get("Value")
        # A PARM without a time (older firmware) is set from the start; one whose value is no number (a
        # damaged FMT) says nothing.
        if name.startswith("SIM_WIND") and isinstance(value, (int, float)):
            params.setdefault(name, []).append((float(row.get("TimeUS", 0)) * 1e-6, float(value)))
    return params


def sitl_from_messages(path: str, msgs: dict[str, list[dict]]) -> SitlLog | None:
    """The SITL truth of a loaded DataFlash log; None when it has no SIM_WIND_SPD and SIM_WIND_DIR (not a
    SITL log with a simulated wind). A SITL log without any altitude message is an InputError (exit 2)."""
    params = sitl_parameters(msgs)
    if any(name not in params for name in REQUIRED):
        return None
    arrays = {name: (np.array([p[0] for p in rows]), np.array([p[1] for p in rows])) for name, rows in params.items()}
    for message, fld, instance, sign, what in ALTITUDES:
        rows = sorted((float(r["TimeUS"]) * 1e-6, sign * float(r[fld])) for r in msgs.get(message, [])
                      if fld in r and (instance is None or r.get(instance, 0) == 0))
        values = np.array([r[1] for r in rows])
        if len(rows) >= 2 and np.isfinite(values).all():
            return SitlLog(arrays, np.array([r[0] for r in rows]), values, what)
    raise InputError(path, "message BARO", "missing: the simulator's wind needs the altitude its profile uses "
                     "(BARO, CTUN.BAlt, POS or XKF1)")


def profile_speed(speed: np.ndarray, altitude_m: np.ndarray, kind: np.ndarray, t_alt_m: np.ndarray,
                  coef: np.ndarray) -> np.ndarray:
    """SITL's wind speed at an altitude (module docstring), element by element."""
    with np.errstate(invalid="ignore", divide="ignore"):
        sqrt_law = np.where(altitude_m < t_alt_m, speed * np.sqrt(np.maximum(altitude_m / t_alt_m, 0.0)), speed)
    linear = speed + (altitude_m - t_alt_m) * coef
    out = np.where(kind == PROFILE_SQRT, sqrt_law, np.where(kind == PROFILE_LINEAR, linear, speed))
    return np.maximum(out, 0.0)


def sitl_wind_ned(log: SitlLog, t_s: np.ndarray) -> np.ndarray:
    """(N, 3) the simulator's mean wind (NED, the air's velocity) at the log times ``t_s``."""
    v = {name: log.value(name, t_s) for name in (*REQUIRED, *DEFAULTS)}
    altitude = np.interp(t_s, log.t_alt_s, log.altitude_m)
    speed = profile_speed(v["SIM_WIND_SPD"], altitude, np.round(v["SIM_WIND_T"]), v["SIM_WIND_T_ALT"],
                          v["SIM_WIND_T_COEF"])
    tilt = np.radians(v["SIM_WIND_DIR_Z"])
    horizontal = wind_from_ne(speed * np.cos(tilt), v["SIM_WIND_DIR"])
    return np.column_stack([horizontal, -speed * np.sin(tilt)])


def describe(log: SitlLog) -> str:
    """The parameters at the end of the log and the altitude source, in one phrase."""
    values = ", ".join(f"{name} {value:g}" for name, value in log.final_parameters().items())
    return f"{values}; altitude {log.altitude_source}"
