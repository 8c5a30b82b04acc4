"""Where and when a log was flown: the global position track and the log clock's UTC offset.

The estimator's readers (ulog.py, dataflash.py, rosbag.py) resample what the step needs; position
and absolute time are only for the outputs an atmospheric scientist reads (CF-NetCDF, profiles), so
they are read here, separately, and put on the estimate rows by ``on_rows``.

- PX4 ULog: vehicle_global_position (lat, lon in degrees, alt in m above mean sea level); the take-off
  altitude from home_position.alt; UTC from vehicle_gps_position.time_utc_usec against its timestamp.
- ArduPilot DataFlash: POS (Lat, Lng, Alt above mean sea level, RelHomeAlt: height above home, which
  ArduPilot sets where it arms), else GPS instance 0 (Lat, Lng, Alt); UTC from GPS.GWk/GMS (GPS time,
  less the leap seconds in force) against the message's TimeUS, on rows with a 3-D fix or better.
- CSV logs: the optional columns lat, lon (degrees) and alt (m above mean sea level); no UTC.
- ROS 2 bags: no position is read (said in a note).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dobwind.core.errors import InputError

GPS_EPOCH_UNIX_S = 315964800.0  # 1980-01-06 00:00:00 UTC
# (first Unix second from which it holds, GPS - UTC in s): the leap seconds since GPS time began
# that a GPS week/millisecond stamp must lose to become UTC (IERS bulletin C; none announced since 2017).
GPS_LEAP_SECONDS = ((0.0, 13.0), (1136073600.0, 14.0), (1230768000.0, 15.0), (1341100800.0, 16.0),
                    (1435708800.0, 17.0), (1483228800.0, 18.0))
ARDUPILOT_3D_FIX = 3
# A position sample older than this around an estimate row leaves the row without position (NaN):
# GPS-rate tracks are 5-10 Hz, so two missed seconds mean the receiver or the estimator stopped.
MAX_POSITION_GAP_S = 2.0
# PX4 sets time_utc_usec to 0 until the receiver knows the time; anything before 2001 is not a fix.
MIN_UTC_S = 978307200.0
# The ground a flight stands on: the landed rows this close before its take-off (or after its landing).
# A few seconds: enough samples for GPS noise to average, short enough that a vehicle carried to another
# spot between two flights in one log is measured from where it took off.
GROUND_S = 5.0
# A landed stretch between two airborne ones shorter than this is a flicker of the land detector (PX4's
# maybe_landed or ground_contact in a slow descent, a bounce at take-off), not a stop: taken as a new
# ground it would measure the rest of the flight from the altitude of the flicker, or from one noisy fix.
MIN_STOP_S = 2.0
# What the position and UTC are read from: the ULog topics and the DataFlash messages.
GEO_TOPICS = ("vehicle_global_position", "vehicle_gps_position", "home_position", "vehicle_local_position")
GEO_MESSAGES = ("POS", "GPS", "XKF1", "NKF1")


@dataclass(frozen=True)
class Track:
    t_s: np.ndarray              # the log's own clock, s (strictly increasing)
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    alt_m: np.ndarray            # above mean sea level
    source: str                  # the message or topic it came from
    home_alt_m: np.ndarray | None = None  # per sample, when the log says where home (take-off) is


@dataclass(frozen=True)
class LocalHeight:
    """The estimator's own up position (relative to its origin): a height when there is no global fix."""
    t_s: np.ndarray
    up_m: np.ndarray
    source: str


@dataclass(frozen=True)
class Geo:
    track: Track | None
    utc_offset_s: float | None   # log clock + this = Unix seconds, UTC
    time_source: str             # where the UTC offset came from, or why there is none
    notes: tuple[str, ...] = ()
    local: LocalHeight | None = None


@dataclass(frozen=True)
class RowPosition:
    """The track on the estimate rows (NaN where it has no sample nearby)."""
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    alt_m: np.ndarray
    height_m: np.ndarray         # above the take-off point
    height_source: str


def read_geo(path: str, columns: dict[str, np.ndarray] | None = None) -> Geo:
    """Position and UTC of the log at ``path`` (its kind by its name, as replay decides). ``columns``:
    a CSV log's columns, already read."""
    from dobwind.io.autopilot import log_kind

    kind = log_kind(path)
    if kind == "ulog":
        return _ulog_geo(path)
    if kind == "dataflash":
        return _dataflash_geo(path)
    if kind == "rosbag":
        return Geo(None, None, "no GPS time read from ROS 2 bags", ("no position read from ROS 2 bags",))
    return _csv_geo(columns or {})


def _unique_increasing(t: np.ndarray, *values: np.ndarray) -> tuple[np.ndarray, ...]:
    order = np.argsort(t, kind="stable")
    t = t[order]
    keep = np.r_[True, np.diff(t) > 0]
    return (t[keep], *(v[order][keep] for v in values))


def _track(t, lat, lon, alt, source: str, home=None) -> Track | None:
    t, lat, lon, alt, *rest = _unique_increasing(np.asarray(t, float), np.asarray(lat, float),
                                                  np.asarray(lon, float), np.asarray(alt, float),
                                                  *([] if home is None else [np.asarray(home, float)]))
    # A receiver without a fix reports 0, 0: no vehicle flies at null island, so it is no position.
    good = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90) & (np.abs(lon) <= 360) & ((lat != 0) | (lon != 0))
    if good.sum() < 2:
        return None
    return Track(t[good], lat[good], lon[good], alt[good], source, rest[0][good] if rest else None)


def gps_to_unix(week: np.ndarray, ms: np.ndarray) -> np.ndarray:
    """GPS week and millisecond of week -> Unix seconds, UTC (leap seconds removed)."""
    gps = GPS_EPOCH_UNIX_S + np.asarray(week, float) * 604800.0 + np.asarray(ms, float) * 1e-3
    leap = np.zeros_like(gps)
    for since, offset in GPS_LEAP_SECONDS:
        leap = np.where(gps - offset >= since, offset, leap)
    return gps - leap


def _dataflash_messages(path: str) -> dict[str, list[dict]]:
    """POS, GPS and the EKF's local position, read by the DataFlash reader's own loader: it silences
    pymavlink at the descriptor level (its compiled indexer prints a "bad header" line per skipped byte
    of a damaged log to descriptor 2, which Python's redirect_stdout does not catch) and turns every
    DFReader failure into one InputError naming the file."""
    from dobwind.io.dataflash import load_messages  # the replay's reader: pymavlink only when needed

    return load_messages(path, GEO_MESSAGES)


def _column(rows: list[dict], name: str) -> np.ndarray:
    return np.array([r.get(name, np.nan) for r in rows], dtype=float)


def _dataflash_geo(path: str) -> Geo:
    return dataflash_geo(_dataflash_messages(path))


def dataflash_geo(msgs: dict[str, list[dict]]) -> Geo:
    """The Geo of a DataFlash log from its GEO_MESSAGES rows as the DataFlash loader reads them (each
    message's rows are the same whatever else is read with them: `dobwind inspect` reads these with its own)."""
    gps = [r for r in msgs["GPS"] if r.get("I", 0) == 0]
    notes: list[str] = []
    track = None
    pos = msgs["POS"]
    if pos and all(k in pos[0] for k in ("Lat", "Lng", "Alt")):
        home = _column(pos, "Alt") - _column(pos, "RelHomeAlt") if "RelHomeAlt" in pos[0] else None
        track = _track(_column(pos, "TimeUS") * 1e-6, _column(pos, "Lat"), _column(pos, "Lng"), _column(pos, "Alt"),
                       "POS", home)
    if track is None and gps and all(k in gps[0] for k in ("Lat", "Lng", "Alt")):
        fixed = [r for r in gps if r.get("Status", ARDUPILOT_3D_FIX) >= ARDUPILOT_3D_FIX]
        track = _track(_column(fixed, "TimeUS") * 1e-6, _column(fixed, "Lat"), _column(fixed, "Lng"),
                       _column(fixed, "Alt"), "GPS") if fixed else None
    if track is None:
        notes.append("no global position in the log (neither POS nor GPS with a fix)")
    ekf = [r for r in msgs["XKF1"] if r.get("C", 0) == 0] or msgs["NKF1"]  # core 0 (EKF3) or EKF2's one
    local = _local(_column(ekf, "TimeUS") * 1e-6, -_column(ekf, "PD"), "XKF1.PD (EKF core 0)") if ekf else None
    timed = [r for r in gps if r.get("Status", 0) >= ARDUPILOT_3D_FIX and r.get("GWk", 0) > 0 and "GMS" in r]
    if not timed:
        return Geo(track, None, "no GPS time in the log (no GPS message with a 3-D fix and a week number)",
                   tuple(notes), local)
    unix = gps_to_unix(_column(timed, "GWk"), _column(timed, "GMS"))
    offset = float(np.median(unix - _column(timed, "TimeUS") * 1e-6))
    return Geo(track, offset, f"GPS.GWk/GMS ({len(timed)} messages with a 3-D fix)", tuple(notes), local)


def _local(t: np.ndarray, up: np.ndarray, source: str) -> LocalHeight | None:
    t, up = _unique_increasing(t, up)
    good = np.isfinite(up)
    return LocalHeight(t[good], up[good], source) if good.sum() >= 2 else None


def _ulog_geo(path: str) -> Geo:
    from dobwind.io.ulog import open_ulog

    ulog, _ = open_ulog(path, GEO_TOPICS)
    return ulog_geo(ulog)


def ulog_geo(ulog) -> Geo:  # type: ignore[no-untyped-def]
    """The Geo of a ULog from pyulog's parse of (at least) GEO_TOPICS: only their data is read, never the
    parse's corruption flags, so any parse that read the whole file gives the same (`dobwind inspect`
    takes it from its own parse)."""
    topics = {d.name: d.data for d in ulog.data_list if d.multi_id == 0 and d.name in GEO_TOPICS}
    notes: list[str] = []
    track = None
    gpos = topics.get("vehicle_global_position")
    if gpos is not None and all(k in gpos for k in ("lat", "lon", "alt")):
        track = _track(np.asarray(gpos["timestamp"], float) * 1e-6, gpos["lat"], gpos["lon"], gpos["alt"],
                       "vehicle_global_position")
    if track is None:
        notes.append("no global position in the log (no vehicle_global_position topic with a fix)")
    home = topics.get("home_position")
    if track is not None and home is not None and "alt" in home and len(home["alt"]):
        # The home in force at each sample (held, not interpolated): PX4 sets it at every arming, so a
        # log of several flights measures each one from its own take-off point.
        t_home = np.asarray(home["timestamp"], float) * 1e-6
        idx = np.clip(np.searchsorted(t_home, track.t_s, side="right") - 1, 0, len(t_home) - 1)
        track = Track(track.t_s, track.lat_deg, track.lon_deg, track.alt_m, track.source,
                      np.asarray(home["alt"], float)[idx])
    lpos = topics.get("vehicle_local_position")
    local = (_local(np.asarray(lpos["timestamp"], float) * 1e-6, -np.asarray(lpos["z"], float),
                    "vehicle_local_position.z") if lpos is not None and "z" in lpos else None)
    gps = topics.get("vehicle_gps_position")
    if gps is None or "time_utc_usec" not in gps:
        return Geo(track, None, "no GPS time in the log (no vehicle_gps_position.time_utc_usec)", tuple(notes), local)
    utc = np.asarray(gps["time_utc_usec"], float) * 1e-6
    stamp = np.asarray(gps["timestamp"], float) * 1e-6
    good = utc > MIN_UTC_S
    if not good.any():
        return Geo(track, None, "no GPS time in the log (time_utc_usec never set)", tuple(notes), local)
    offset = float(np.median(utc[good] - stamp[good]))
    return Geo(track, offset, f"vehicle_gps_position.time_utc_usec ({int(good.sum())} messages)", tuple(notes), local)


def _csv_geo(columns: dict[str, np.ndarray]) -> Geo:
    none = "no UTC in CSV logs: time is the log's own t column"
    if not all(k in columns for k in ("t", "lat", "lon", "alt")):
        return Geo(None, None, none, ("no global position in the log (no lat, lon, alt columns)",))
    track = _track(columns["t"], columns["lat"], columns["lon"], columns["alt"], "lat, lon, alt columns")
    notes = () if track is not None else ("no global position in the log (lat, lon, alt columns hold no fix)",)
    return Geo(track, None, none, notes)


def _near_sample(t_src: np.ndarray, t: np.ndarray) -> np.ndarray:
    """True where t lies within the track and between samples at most MAX_POSITION_GAP_S apart."""
    idx = np.searchsorted(t_src, t, side="right")
    inside = (idx > 0) & (t <= t_src[-1])
    prev = t_src[np.clip(idx - 1, 0, len(t_src) - 1)]
    nxt = t_src[np.clip(idx, 0, len(t_src) - 1)]
    return inside & ((nxt - prev <= MAX_POSITION_GAP_S) | (t == prev))


def on_rows(track: Track, t: np.ndarray, landed: np.ndarray | None = None) -> RowPosition:
    """The track interpolated onto the estimate rows ``t`` (the log's own clock), with the height above
    the take-off point (_ground_altitude: the ground each flight stood on before its take-off, else the
    log's home, else where it landed, else the track's first altitude)."""
    ok = _near_sample(track.t_s, t)
    lat = np.where(ok, np.interp(t, track.t_s, track.lat_deg), np.nan)
    lon_unwrapped = np.unwrap(track.lon_deg, period=360.0)  # a flight across the antimeridian stays continuous
    lon = (np.interp(t, track.t_s, lon_unwrapped) + 180.0) % 360.0 - 180.0
    lon = np.where(ok, lon, np.nan)
    alt = np.where(ok, np.interp(t, track.t_s, track.alt_m), np.nan)
    home = None
    if track.home_alt_m is not None:
        before = np.clip(np.searchsorted(track.t_s, t, side="right") - 1, 0, len(track.t_s) - 1)
        home = track.home_alt_m[before]  # held: a new home is a step, not a ramp
    ground, how = _ground_altitude(alt, landed, t, home)
    return RowPosition(lat, lon, alt, alt - ground, f"{track.source} {how}")


def local_height_on_rows(local: LocalHeight, t: np.ndarray, landed: np.ndarray | None = None) -> tuple[np.ndarray, str]:
    """Height above take-off from the estimator's up position, when the log has no global position."""
    ok = _near_sample(local.t_s, t)
    up = np.where(ok, np.interp(t, local.t_s, local.up_m), np.nan)
    ground, how = _ground_altitude(up, landed, t)
    return up - ground, f"{local.source} (no global position): {how.replace('altitude', 'up position')}"


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, stop) of each run of equal values in ``mask``."""
    edges = np.flatnonzero(np.diff(mask.astype(np.int8))) + 1
    bounds = np.r_[0, edges, len(mask)]
    return list(zip(bounds[:-1].tolist(), bounds[1:].tolist()))


def _ground_altitude(alt: np.ndarray, landed: np.ndarray | None, t: np.ndarray,
                     home: np.ndarray | None = None) -> tuple[np.ndarray, str]:
    """Per row, the altitude of the ground its flight took off from, and how it was found. Each flight (a
    run of airborne rows) is measured from the ground just before it (the median over the last GROUND_S
    of the landed rows there); else from the log's home (per row, ``home``); else, when the log begins in
    the air, from the ground just after it landed; else from the first position. The ground comes first
    because a home need not be on it: PX4 re-homed the x500 field log during its climb-out, 1.7 m above
    the ground it took off from, and its flight read -2 m at the landing. And the first position is no
    take-off point: the drag-fusion PX4 log began 6 m up and read -6 m at its landing. Landed rows are
    measured from their own ground (median), or home."""
    finite = np.isfinite(alt)
    first = float(alt[np.flatnonzero(finite)[0]]) if finite.any() else float("nan")
    landed = None if landed is None else _without_flickers(np.asarray(landed, bool), t)
    runs = _runs(landed) if landed is not None and landed.any() else [(0, len(alt))]
    ground, used = np.full(len(alt), np.nan), set()
    for k, (a, b) in enumerate(runs):
        on_ground = landed is not None and bool(landed[a])
        prev = nxt = float("nan")
        if on_ground:
            prev = _median(alt[a:b])
        elif landed is not None and landed.any():
            prev = _median(alt[runs[k - 1][0]:a][t[runs[k - 1][0]:a] >= t[a - 1] - GROUND_S]) if k else np.nan
            nxt = _median(alt[b:runs[k + 1][1]][t[b:runs[k + 1][1]] <= t[b] + GROUND_S]) if k + 1 < len(runs) else np.nan
        for name, level in (("before", prev), ("home", home[a:b] if home is not None else np.nan),
                            ("after", nxt), ("first", first)):
            if np.all(np.isfinite(level)):
                ground[a:b] = level
                used.add(name if not on_ground else "before")
                break
    return ground, _ground_text(used, finite.any())


def _without_flickers(landed: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``landed`` with each landed run shorter than MIN_STOP_S between airborne rows taken as airborne."""
    out = landed.copy()
    for a, b in _runs(landed):
        if landed[a] and 0 < a and b < len(landed) and t[b - 1] - t[a] < MIN_STOP_S:
            out[a:b] = False
    return out


def _ground_text(used: set[str], any_altitude: bool) -> str:
    if not any_altitude:
        return "no altitude"
    for name, text in (("first", "altitude above the log's first position (no take-off in the log)"),
                       ("after", "altitude above the ground where it landed (the log begins in the air)"),
                       ("home", "altitude above home (no ground before the take-off in the log)")):
        if name in used:
            return text
    return "altitude above the ground before take-off"


def _median(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else float("nan")
