"""`fit --truth sitl`: the wind an ArduPilot SITL simulator was told to blow, from the log's parameters.

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
  the mean wind only, approximate (said as a warning).
Parameters changed in flight (PARM messages later in the log) take effect at their time.
"""
from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass, field

import numpy as np

from dobwind.core.errors import InputError
from dobwind.calibrate.fieldtruth import LogTime, wind_from

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


def read_sitl_log(path: str) -> SitlLog:
    """The SIM_WIND_* parameters and the altitude of a DataFlash log; a log without SIM_WIND_SPD and
    SIM_WIND_DIR is not a SITL log with a known wind (InputError, exit 2)."""
    if not str(path).lower().endswith(".bin"):
        raise InputError(path, None, "--truth sitl needs an ArduPilot SITL DataFlash log (.bin)")
    from pymavlink import DFReader

    wanted = ["PARM"] + sorted({a[0] for a in ALTITUDES})
    params: dict[str, list[tuple[float, float]]] = {}
    alt: dict[str, list[tuple[float, float]]] = {a[0]: [] for a in ALTITUDES}
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            reader = DFReader.DFReader_binary(path, zero_time_base=False)
            while (msg := reader.recv_match(type=wanted)) is not None:
                _collect(msg.to_dict(), msg.get_type(), params, alt)
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    except Exception as exc:  # DFReader raises many kinds on corrupt files
        raise InputError(path, None, f"not a readable DataFlash log ({type(exc).__name__}: {str(exc)[:80]})") from None
    missing = [name for name in REQUIRED if name not in params]
    if missing:
        raise InputError(path, "parameter " + ", ".join(missing),
                         "missing: not an ArduPilot SITL log with a simulated wind (--truth sitl needs SIM_WIND_SPD "
                         "and SIM_WIND_DIR)")
    return _sitl_log(path, params, alt)


def _collect(row: dict, kind: str, params: dict, alt: dict) -> None:
    t = float(row["TimeUS"]) * 1e-6
    if kind == "PARM":
        name = str(row.get("Name", ""))
        if name.startswith("SIM_WIND"):
            params.setdefault(name, []).append((t, float(row["Value"])))
        return
    for message, fld, instance, sign, _ in ALTITUDES:
        if kind == message and fld in row and (instance is None or row.get(instance, 0) == 0):
            alt[message].append((t, sign * float(row[fld])))


def _sitl_log(path: str, params: dict, alt: dict) -> SitlLog:
    arrays = {name: (np.array([p[0] for p in rows]), np.array([p[1] for p in rows])) for name, rows in params.items()}
    for message, _, _, _, what in ALTITUDES:
        rows = sorted(alt[message])
        values = np.array([r[1] for r in rows])
        if len(rows) >= 2 and np.isfinite(values).all():
            return SitlLog(arrays, np.array([r[0] for r in rows]), values, what)
    raise InputError(path, "message BARO", "missing: --truth sitl needs the altitude the simulator's wind profile "
                     "uses (BARO, CTUN.BAlt, POS or XKF1)")


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
    horizontal = wind_from(speed * np.cos(tilt), v["SIM_WIND_DIR"])
    return np.column_stack([horizontal, -speed * np.sin(tilt)])


@dataclass(frozen=True)
class SitlTruth:
    """`--truth sitl`: each log's own SIM_WIND_* parameters (read once per log)."""
    logs: dict[str, SitlLog] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def _log(self, path: str) -> SitlLog:
        if path not in self.logs:
            self.logs[path] = log = read_sitl_log(path)
            turb = log.value("SIM_WIND_TURB", log.t_alt_s)
            if np.any(turb > 0):
                self.warnings.append(f"{path}: SIM_WIND_TURB {float(turb.max()):g} > 0: the simulator's turbulence is "
                                     "not in the log, the truth is its mean wind (approximate)")
        return self.logs[path]

    def wind(self, path: str, flight: LogTime) -> tuple[np.ndarray, np.ndarray]:
        log = self._log(path)
        return sitl_wind_ned(log, flight.clock_s), np.ones(flight.log.rows, dtype=bool)

    def _values(self, log: SitlLog) -> str:
        t = log.t_alt_s[-1:]
        values = ", ".join(f"{n} {float(log.value(n, t)[0]):g}" for n in (*REQUIRED, *DEFAULTS))
        return f"{values}; altitude {log.altitude_source}"

    def describe(self) -> str:
        parts = [f"{path}: {self._values(log)}" for path, log in self.logs.items()]
        return "ArduPilot SITL parameters (--truth sitl): " + "; ".join(parts)

    def describe_log(self, path: str) -> str:
        values = self._values(self.logs[path]) if path in self.logs else "not read"
        return f"the wind the simulator was told to blow, from the log's own parameters (--truth sitl): {values}"
