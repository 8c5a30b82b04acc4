"""A simulated stand-in flight (`dobwind simulate`'s CSV) written as an ArduCopter-4.1-like DataFlash log,
so that the SITL stand-in's flights go through everything an ArduPilot SITL log goes through: the DataFlash
reader and its 10 Hz slow-topic replay, the SITL truth from PARM SIM_WIND_* (`fit --truth sitl`, replay's
comparison), and ArduCopter's air-density step in CTUN.ThO (issue #36; docs/field-calibration.md, "The SITL
stand-in").

The messages, their fields and format characters are those of the field SITL log
(../shared/data/field/arducopter_sitl_wind10_from180.bin, ArduCopter V4.1.0-dev, read with pymavlink's
DFReader: FMT of each message), at its rates: XKF1, XKQ, XKF4, XKF2, CTUN, ATT, BARO, RCOU and ESC at 10 Hz
(the CSV's own rows, jitter included), IMU at 25 Hz (the specific force interpolated between the rows), EV
and PARM events, the firmware banner in MSG. Only the EKF core 0 and the barometer instance 0 are written.

What the conversion adds to the simulated flight, and why:
- ground before and after (GROUND_S each): level, still, motors at idle (ThO 0), with the EV events the
  reader takes for take-off (NOT_LANDED) and landing (LAND_COMPLETE_MAYBE, LAND_COMPLETE, DISARMED); the
  vehicle "takes off" at the height of the flight's first row, which is the barometer's zero;
- the barometer: BARO.Alt = the integral of -vel_d from that zero, its pressure from the ISA lapse rate at
  the field log's ground temperature and pressure (a SITL flown at Canberra's 584 m);
- CTUN.ThO = thrust / (m g) x ThH x the density ratio ArduCopter 4.1 applies: 1 from boot, then, once the
  barometer altitude has moved RECOMPUTE_M from where the ratio was last computed, P / (R T) / 1.225 with
  T = GndTemp + 273.15 - 0.0065 alt (written here from that rule, not from dobwind's reader, so that the
  reader's undoing of it is checked against an independent writing). A flight that never moves 25 m
  from its take-off height (the box) never steps;
- PARM: SIM_WIND_SPD/DIR the scenario's steady wind, SIM_WIND_T 1 (no altitude profile: the simulator's
  wind does not vary with height), SIM_WIND_TURB as given, MOT_THST_HOVER = ThH, FRAME_CLASS 1 with
  SERVO1..4_FUNCTION 33..36 (motors 1-4), the EKF3 drag fusion off as in the field log.
Nothing here is a SITL run: the vehicle's physics are the stand-in's (benchmarks/vehicles/arducopter.*).

    .venv/bin/python -m benchmarks.sitlconvert FLIGHT.csv --wind 5@37 [--turbulence 0] -o FLIGHT.bin
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
GRAVITY = 9.80665
GROUND_S = 8.0            # on the ground before take-off and after landing
BOOT_S = 60.0             # log time of the first row (ArduPilot's TimeUS counts from boot)
IMU_HZ = 25.0             # the field log's IMU rate
RECOMPUTE_M = 25.0        # AP_Baro: the altitude change after which the density ratio is computed again
GAS_CONSTANT = 287.26     # J/(kg K), ArduPilot's ISA_GAS_CONSTANT
LAPSE_RATE = 0.0065       # K/m
ISA_DENSITY = 1.225       # kg/m^3
# EV ids (ArduPilot LogEvent): what the field log writes around its flight.
EV_AUTO_ARMED, EV_NOT_LANDED, EV_LAND_MAYBE, EV_LAND_COMPLETE, EV_DISARMED = 15, 28, 17, 18, 11
BANNER = "ArduCopter V4.1.0-dev (0b517cfc)"   # the field log's, so that the reader takes it for a copter

# The field log's FMT of each message: format characters and columns (pymavlink DFReader, `formats`).
MESSAGES: dict[str, tuple[str, list[str]]] = {
    name: (fmt, cols.split(",")) for name, fmt, cols in (
        ("PARM", "QNf", "TimeUS,Name,Value"),
        ("MSG", "QZ", "TimeUS,Message"),
        ("EV", "QB", "TimeUS,Id"),
        ("XKF1", "QBccCfffffffccce", "TimeUS,C,Roll,Pitch,Yaw,VN,VE,VD,dPD,PN,PE,PD,GX,GY,GZ,OH"),
        ("XKQ", "QBffff", "TimeUS,C,Q1,Q2,Q3,Q4"),
        ("XKF2", "QBccccchhhhhhfff", "TimeUS,C,AX,AY,AZ,VWN,VWE,MN,ME,MD,MX,MY,MZ,IDX,IDY,IS"),
        ("XKF4", "QBcccccfffHBIHb", "TimeUS,C,SV,SP,SH,SM,SVT,errRP,OFN,OFE,FS,TS,SS,GPS,PI"),
        ("IMU", "QBffffffIIfBBHH", "TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz"),
        ("CTUN", "Qffffffefffhh", "TimeUS,ThI,ABst,ThO,ThH,DAlt,Alt,BAlt,DSAlt,SAlt,TAlt,DCRt,CRt"),
        ("ATT", "QccccCCCCB", "TimeUS,DesRoll,Roll,DesPitch,Pitch,DesYaw,Yaw,ErrRP,ErrYaw,AEKF"),
        ("BARO", "QBffcfIffB", "TimeUS,I,Alt,Press,Temp,CRt,SMS,Offset,GndTemp,Health"),
        ("RCOU", "QHHHHHHHHHHHHHH", "TimeUS," + ",".join(f"C{k}" for k in range(1, 15))),
        ("ESC", "QBeffcfcf", "TimeUS,Instance,RPM,Volt,Curr,Temp,CTot,MotTemp,Err"))}


@dataclass(frozen=True)
class SitlSetting:
    """What the converted log says of the simulator and the vehicle."""
    wind_speed_mps: float
    wind_from_deg: float
    turbulence: float = 0.0          # SIM_WIND_TURB (> 0 for a turbulent flight: the truth is its mean)
    mass_kg: float = 3.0
    hover_throttle: float = 0.37     # CTUN.ThH and MOT_THST_HOVER
    ground_pressure_pa: float = 94502.8   # the field log's BARO.Press and GndTemp on the ground
    ground_temp_c: float = 25.53
    density_step: bool = True        # False: ThO as if ArduCopter never compensated (a check's contrast)

    def parameters(self) -> dict[str, float]:
        return {"FRAME_CLASS": 1.0, "FRAME_TYPE": 0.0, **{f"SERVO{k}_FUNCTION": 32.0 + k for k in range(1, 5)},
                "MOT_THST_HOVER": self.hover_throttle, "MOT_THST_EXPO": 0.65,
                "EK3_DRAG_BCOEF_X": 0.0, "EK3_DRAG_BCOEF_Y": 0.0, "EK3_DRAG_MCOEF": 0.0,
                "SIM_WIND_SPD": self.wind_speed_mps, "SIM_WIND_DIR": self.wind_from_deg % 360.0,
                "SIM_WIND_TURB": self.turbulence, "SIM_WIND_T": 1.0, "SIM_WIND_T_ALT": 60.0,
                "SIM_WIND_T_COEF": 0.01, "SIM_WIND_DIR_Z": 0.0}


def pressure_at(alt_m: np.ndarray, setting: SitlSetting) -> np.ndarray:
    """The ISA troposphere's pressure above the ground with the ground's temperature (the barometric law)."""
    t0 = setting.ground_temp_c + 273.15
    return setting.ground_pressure_pa * (1.0 - LAPSE_RATE * alt_m / t0) ** (GRAVITY / (GAS_CONSTANT * LAPSE_RATE))


def density_ratio(alt_m: np.ndarray, setting: SitlSetting) -> np.ndarray:
    """ArduCopter 4.1's ratio at each barometer sample: 1 from boot; recomputed whenever the altitude is
    RECOMPUTE_M from where it was last computed (0 at boot), then held."""
    press = pressure_at(alt_m, setting)
    out, held, where = np.ones(len(alt_m)), 1.0, 0.0
    for k, alt in enumerate(alt_m):
        if abs(alt - where) >= RECOMPUTE_M:
            temp_k = setting.ground_temp_c + 273.15 - LAPSE_RATE * alt
            held, where = press[k] / (GAS_CONSTANT * temp_k) / ISA_DENSITY, alt
        out[k] = held
    return out if setting.density_step else np.ones(len(alt_m))


def euler_deg(q: np.ndarray) -> np.ndarray:
    """(roll, pitch, yaw 0..360) in degrees of body-to-NED quaternions (w, x, y, z), row by row."""
    w, x, y, z = q.T
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.column_stack([np.degrees(roll), np.degrees(pitch), np.degrees(yaw) % 360.0])


def timeline(cols: dict[str, np.ndarray], setting: SitlSetting) -> dict[str, np.ndarray]:
    """The flight with a still, level ground segment before and after, on the log's clock (s since boot),
    and the columns the messages need: airborne flag, altitude, density ratio, ThO."""
    t = np.asarray(cols["t"], dtype=float)
    n_pre = int(round(GROUND_S * 10.0))
    period = float(np.median(np.diff(t))) if len(t) > 1 else 0.1
    pre = BOOT_S + period * np.arange(n_pre)
    start = pre[-1] + period
    post = start + t[-1] + period * np.arange(1, n_pre + 1)
    clock = np.concatenate([pre, start + t - t[0], post])
    air = np.concatenate([np.zeros(n_pre, bool), np.ones(len(t), bool), np.zeros(n_pre, bool)])
    out = {"clock": clock, "airborne": air}
    out.update(_pad(cols, n_pre))
    climb = np.concatenate([[0.0], np.cumsum(-0.5 * (out["vel_d"][1:] + out["vel_d"][:-1]) * np.diff(clock))])
    out["alt"] = climb
    out["ratio"] = density_ratio(climb, setting)
    weight = setting.mass_kg * GRAVITY
    out["tho"] = np.where(air, out["thrust"] / weight * setting.hover_throttle * out["ratio"], 0.0)
    return out


def _pad(cols: dict[str, np.ndarray], n: int) -> dict[str, np.ndarray]:
    """The CSV's columns with n ground rows either side: still, level at the first/last heading, 1 g."""
    out = {}
    for name in ("vel_n", "vel_e", "vel_d", "sf_x", "sf_y", "thrust"):
        out[name] = np.concatenate([np.zeros(n), np.asarray(cols[name], float), np.zeros(n)])
    out["sf_z"] = np.concatenate([np.full(n, -GRAVITY), np.asarray(cols["sf_z"], float), np.full(n, -GRAVITY)])
    q = np.column_stack([cols[f"q_{c}"] for c in "wxyz"]).astype(float)
    yaw = np.asarray(cols["yaw_ref"], float)
    out["q"] = np.vstack([_level(q[0], n), q, _level(q[-1], n)])
    out["yaw_ref"] = np.concatenate([np.full(n, yaw[0]), yaw, np.full(n, yaw[-1])])
    return out


def _level(q: np.ndarray, n: int) -> np.ndarray:
    """n rows of a level attitude with the heading of q."""
    yaw = np.radians(euler_deg(q[None, :])[0, 2])
    return np.tile([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)], (n, 1))


def _us(t_s: float) -> int:
    return int(round(t_s * 1e6))


def _events(tl: dict[str, np.ndarray], setting: SitlSetting) -> list[tuple[int, str, dict]]:
    """Banner, parameters, arming, take-off and landing (the field log's EV sequence, trimmed)."""
    t0, clock, air = tl["clock"][0], tl["clock"], tl["airborne"]
    first, last = clock[np.flatnonzero(air)[0]], clock[np.flatnonzero(air)[-1]]
    rows = [(_us(t0) - 2, "MSG", {"Message": BANNER}), (_us(t0) - 2, "MSG", {"Message": "Frame: QUAD/PLUS"})]
    rows += [(_us(t0) - 1, "PARM", {"Name": k, "Value": v}) for k, v in setting.parameters().items()]
    rows += [(_us(first) - 200_000, "EV", {"Id": EV_AUTO_ARMED}), (_us(first) - 1, "EV", {"Id": EV_NOT_LANDED}),
             (_us(last) + 1, "EV", {"Id": EV_LAND_MAYBE}), (_us(last) + 300_000, "EV", {"Id": EV_LAND_COMPLETE}),
             (_us(last) + 600_000, "EV", {"Id": EV_DISARMED})]
    return rows


def _slow_rows(tl: dict[str, np.ndarray], setting: SitlSetting) -> list[tuple[int, str, dict]]:
    """The 10 Hz messages, one set per row of the timeline."""
    rows = []
    euler = euler_deg(tl["q"])
    press = pressure_at(tl["alt"], setting)
    pos_d = -tl["alt"]
    for k, t in enumerate(tl["clock"]):
        us, (roll, pitch, yaw) = _us(t), euler[k]
        rows.append((us, "XKF1", {"C": 0, "Roll": roll, "Pitch": pitch, "Yaw": yaw, "VN": tl["vel_n"][k],
                                  "VE": tl["vel_e"][k], "VD": tl["vel_d"][k], "PD": pos_d[k], "OH": 584.0 + tl["alt"][k]}))
        rows.append((us, "XKQ", {"C": 0, **{f"Q{i + 1}": tl["q"][k, i] for i in range(4)}}))
        rows.append((us, "XKF2", {"C": 0, "VWN": 0.0, "VWE": 0.0}))  # the field log's: no wind state
        rows.append((us, "XKF4", {"C": 0, "SS": 113471, "TS": 16, "PI": 0}))
        rows.append((us, "CTUN", {"ThO": tl["tho"][k], "ThH": setting.hover_throttle, "Alt": tl["alt"][k],
                                  "DAlt": tl["alt"][k], "BAlt": tl["alt"][k], "CRt": -100 * tl["vel_d"][k]}))
        rows.append((us, "ATT", {"DesRoll": roll, "Roll": roll, "DesPitch": pitch, "Pitch": pitch,
                                 "DesYaw": np.degrees(tl["yaw_ref"][k]) % 360.0, "Yaw": yaw, "AEKF": 3}))
        rows.append((us, "BARO", {"I": 0, "Alt": tl["alt"][k], "Press": press[k], "Temp": 34.13, "SMS": us // 1000,
                                  "GndTemp": setting.ground_temp_c, "Health": 1}))
        # The motors' output is the thrust itself (ThO / ratio): the density compensation leaves PWM alone.
        pwm = 1000.0 + (1000.0 * tl["tho"][k] / tl["ratio"][k] if tl["airborne"][k] else 0.0)
        rows.append((us, "RCOU", {f"C{c}": pwm for c in range(1, 5)}))
        rows += [(us, "ESC", {"Instance": m}) for m in range(4)]  # SITL's ESC telemetry: 0 rpm throughout
    return rows


def _imu_rows(tl: dict[str, np.ndarray]) -> list[tuple[int, str, dict]]:
    """IMU instance 0 at 25 Hz: the specific force interpolated between the 10 Hz rows."""
    t = np.arange(tl["clock"][0], tl["clock"][-1], 1.0 / IMU_HZ)
    acc = [np.interp(t, tl["clock"], tl[f"sf_{a}"]) for a in "xyz"]
    return [(_us(tk), "IMU", {"I": 0, "AccX": acc[0][k], "AccY": acc[1][k], "AccZ": acc[2][k], "T": 29.2, "GH": 1,
                              "AH": 1, "GHz": 1000, "AHz": 1000}) for k, tk in enumerate(t)]


def convert(cols: dict[str, np.ndarray], setting: SitlSetting, out: Path) -> Path:
    """Write the flight ``cols`` (a `dobwind simulate` CSV's columns) as a DataFlash log at ``out``."""
    sys.path.insert(0, str(ROOT))  # tests/ is not installed (as tools/bench_slow_ulog.py imports it)
    from tests.dataflash_writer import write_dataflash

    tl = timeline(cols, setting)
    rows = _events(tl, setting) + _slow_rows(tl, setting) + _imu_rows(tl)
    rows.sort(key=lambda r: r[0])  # stable: a row's messages keep their order at one instant
    tmp = out.with_name(out.name + ".part")
    write_dataflash(tmp, MESSAGES, [(name, {"TimeUS": us, **fields}) for us, name, fields in rows])
    tmp.replace(out)  # atomically: an interrupted conversion leaves no half log under the final name
    return out


def read_flight_csv(path: str) -> dict[str, np.ndarray]:
    from benchmarks.fieldcross import _columns
    return _columns(path)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("flight", help="a `dobwind simulate` CSV of the stand-in vehicle")
    p.add_argument("--wind", required=True, metavar="SPEED@FROM", help="the scenario's steady wind: SIM_WIND_SPD/DIR")
    p.add_argument("--turbulence", type=float, default=0.0, help="SIM_WIND_TURB (default 0)")
    p.add_argument("--no-density-step", action="store_true", help="ThO without ArduCopter's density compensation")
    p.add_argument("-o", "--output", required=True)
    args = p.parse_args(argv)
    try:
        speed, from_deg = (float(x) for x in args.wind.split("@"))
    except ValueError:
        print(f"sitlconvert: --wind: {args.wind!r} is not SPEED@FROM (e.g. 5@37)", file=sys.stderr)
        return 2
    setting = SitlSetting(speed, from_deg, args.turbulence, density_step=not args.no_density_step)
    try:
        cols = read_flight_csv(args.flight)
        missing = [c for c in ("t", "vel_n", "vel_e", "vel_d", "sf_x", "sf_y", "sf_z", "q_w", "q_x", "q_y", "q_z",
                               "thrust", "yaw_ref") if c not in cols]
    except (OSError, ValueError, IndexError) as exc:
        print(f"sitlconvert: {args.flight}: not a readable `dobwind simulate` CSV ({exc})", file=sys.stderr)
        return 2
    if missing:
        print(f"sitlconvert: {args.flight}: column(s) {', '.join(missing)} missing (a `dobwind simulate` CSV has them)",
              file=sys.stderr)
        return 2
    convert(cols, setting, Path(args.output))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
