"""`dobwind inspect LOG`: what an autopilot (or CSV) log holds for the estimator, without resampling it
(docs/inspect-init.md).

One ``LogSummary`` per log: every stream the readers could use with its message count, median rate and
worst gap; the log's span and airborne time; the autopilot's own wind and whether it is active; the
parameters that matter; the vehicle (rotor count, airframe id); and, per input role, the stream replay
would read and what is missing. The format-specific parts live in inspect_ulog.py, inspect_dataflash.py
and inspect_other.py (ROS 2 bags, CSV); `dobwind init` (initframe.py) builds a starter airframe from it.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace
from typing import Any

import numpy as np

from dobwind.io.vehiclekind import MULTIROTORS_ONLY

# The input roles, in the order a user reads them. "thrust" is the collective setpoint, "rpm" the ESC
# telemetry: an airframe needs one of the two; "heading" falls back to the vehicle's own yaw.
ROLES = ("velocity", "acceleration", "specific_force", "attitude", "rpm", "thrust", "hover_thrust",
         "heading", "ground", "autopilot_wind")
# Roles without which replay refuses the log whatever the airframe says.
ESSENTIAL_ROLES = ("velocity", "attitude")
# A gap of more than this between consecutive samples (all streams pooled) splits a log into runs. A
# run beyond such a gap that lasts less than SPAN_MIN_RUN_S or holds fewer than SPAN_MIN_RUN_SAMPLES is a
# broken clock (a flipped bit in a timestamp reads 2.3e12 s; the same bit flipped in two messages seconds
# apart makes a run of two) and is left out of the span; a run that lasts is a flight: ArduPilot
# (LOG_DISARMED 0) logs nothing while disarmed and goes on in the same file at the next arming, so two
# flights minutes apart are two runs, and both are the log's.
SPAN_GAP_S = 60.0
SPAN_MIN_RUN_S = 1.0
SPAN_MIN_RUN_SAMPLES = 10


@dataclass(frozen=True)
class Stream:
    """One topic/message stream: how many messages and how regularly."""
    name: str
    count: int
    rate_hz: float | None       # 1 / the median interval (None: fewer than two messages)
    worst_gap_s: float | None   # the longest interval between consecutive messages
    start_s: float | None = None
    end_s: float | None = None


@dataclass(frozen=True)
class Role:
    """What replay would read for one input role: ``source`` (topic.field) or None with the reason."""
    role: str
    source: str | None
    stream: str | None = None   # the Stream it comes from (its rate)
    note: str = ""


@dataclass(frozen=True)
class AutopilotWind:
    source: str | None          # topic/message, None: not logged
    active: bool
    reason: str
    mean_speed_mps: float | None = None


@dataclass(frozen=True)
class Vehicle:
    rotors: int | None
    rotor_source: str
    airframe: str               # PX4 SYS_AUTOSTART / ArduPilot FRAME_CLASS, as text
    rpm_nonzero_airborne: bool  # ESC telemetry reads rpm > 0 on every rotor while airborne
    rpm_note: str = ""
    hover_thrust: float | None = None   # normalised (0..1) hover thrust, when the log has it
    hover_source: str = ""
    airborne_rpm_median: float | None = None
    airborne_rpm_max: float | None = None
    # Why the log is not a multirotor's (an ArduPlane banner, a PX4 MAV_TYPE of a plane or rover), as a
    # phrase; empty when it is one or the log does not say. init refuses such a log.
    not_multirotor: str = ""


@dataclass(frozen=True)
class LogSummary:
    path: str
    format: str                 # ulog, dataflash, rosbag, csv
    autopilot: str | None       # PX4, ArduPilot, or None
    start_s: float
    end_s: float
    airborne_s: float | None
    airborne_source: str
    airborne_intervals: tuple[tuple[float, float], ...]
    streams: tuple[Stream, ...]
    roles: tuple[Role, ...]
    parameters: dict[str, float]
    vehicle: Vehicle
    autopilot_wind: AutopilotWind
    notes: tuple[str, ...] = ()
    other_streams: tuple[str, ...] = field(default=())  # logged, but nothing the estimator reads
    # Samples (all streams pooled) whose timestamps lie outside [start_s, end_s] (bulk_span), and the
    # earliest and latest of them: a damaged clock's, not part of the span.
    outside_span: int = 0
    outside_span_s: tuple[float, float] | None = None
    # Where replay's NetCDF and profile take position and UTC from (anylog._position): position (a topic,
    # or None), utc (bool or None), time_source (the sentence the NetCDF's attribute carries).
    position: dict[str, Any] | None = None

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s

    def stream(self, name: str | None) -> Stream | None:
        return next((s for s in self.streams if s.name == name), None)

    def role(self, name: str) -> Role:
        return next(r for r in self.roles if r.role == name)

    def with_rpm_usability(self) -> "LogSummary":
        """The rpm role says when the ESC telemetry is logged but unusable (zeros in flight, as SITL logs
        it): without this, inspect listed "rpm ESC.RPM" and "no usable rpm" side by side."""
        if self.vehicle.rpm_nonzero_airborne or self.role("rpm").source is None:
            return self
        roles = tuple(replace(r, note=f"logged, not usable: {self.vehicle.rpm_note}") if r.role == "rpm" else r
                      for r in self.roles)
        return replace(self, roles=roles)

    def missing(self) -> list[str]:
        """Roles replay cannot fill, as sentences (the thrust need: rpm or the collective setpoint)."""
        out = [f"{r.role}: {r.note}" for r in self.roles if r.role in ESSENTIAL_ROLES and r.source is None]
        if self.vehicle.not_multirotor:
            out.insert(0, f"vehicle: not a multirotor ({self.vehicle.not_multirotor})")
        if self.role("rpm").source is None and self.role("thrust").source is None:
            out.append("thrust: neither ESC rpm nor a collective thrust setpoint")
        elif self.role("rpm").source is None and self.role("hover_thrust").source is None:
            out.append("hover_thrust: the collective setpoint cannot be scaled to newtons")
        if self.role("acceleration").source is None and self.role("specific_force").source is None:
            out.append('acceleration: none logged (observer.acceleration = "velocity" only)')
        return out

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["duration_s"] = self.duration_s
        out["roles"] = {r.role: {"source": r.source, "stream": r.stream, "note": r.note} for r in self.roles}
        out["missing"] = self.missing()
        out["airborne_intervals"] = [list(i) for i in self.airborne_intervals]
        return out


def stream_stats(name: str, t: np.ndarray) -> Stream:
    """Count, median rate and worst gap of a stream's timestamps (s); duplicate stamps are not gaps."""
    t = np.sort(np.asarray(t, dtype=float))
    if len(t) < 2:
        return Stream(name, len(t), None, None, float(t[0]) if len(t) else None, float(t[-1]) if len(t) else None)
    dt = np.diff(t)
    dt = dt[dt > 0]
    if len(dt) == 0:
        return Stream(name, len(t), None, None, float(t[0]), float(t[-1]))
    return Stream(name, len(t), float(1.0 / np.median(dt)), float(dt.max()), float(t[0]), float(t[-1]))


def intervals(t: np.ndarray, airborne: np.ndarray, end_s: float) -> tuple[tuple[float, float], ...]:
    """Airborne intervals from a held state: sample i's state lasts until sample i + 1 (the last one
    until ``end_s``)."""
    t = np.asarray(t, dtype=float)
    edges = np.r_[t, max(end_s, t[-1])] if len(t) else np.array([])
    out: list[tuple[float, float]] = []
    for i, up in enumerate(np.asarray(airborne, dtype=bool)):
        if not up or edges[i + 1] <= edges[i]:
            continue
        if out and out[-1][1] == edges[i]:
            out[-1] = (out[-1][0], float(edges[i + 1]))
        else:
            out.append((float(edges[i]), float(edges[i + 1])))
    return tuple(out)


@dataclass(frozen=True)
class Span:
    """The span of the bulk of a log's samples and the samples outside it (bulk_span)."""
    start_s: float
    end_s: float
    outside: int = 0
    outside_s: tuple[float, float] | None = None   # the earliest and latest timestamp outside
    samples: int = 0

    def note(self) -> str | None:
        if not self.outside or self.outside_s is None:
            return None
        share = 100.0 * self.outside / max(self.samples, 1)
        return (f"time: {self.outside} of {self.samples} samples ({share:.2g} %) lie outside the span, at "
                f"{self.outside_s[0]:.6g} .. {self.outside_s[1]:.6g} s, beyond a gap of more than {SPAN_GAP_S:g} s "
                "with no sample: a damaged clock; the span is that of the bulk of the samples")

    def clip(self, spans: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
        """Airborne intervals cut to the span: a ground state stamped far outside it does not fly for days."""
        out = ((max(a, self.start_s), min(b, self.end_s)) for a, b in spans)
        return tuple((a, b) for a, b in out if b > a)


def bulk_span(t: np.ndarray) -> Span:
    """The span from the first to the last run of samples (sorted, all streams pooled, split at gaps above
    SPAN_GAP_S) that lasts SPAN_MIN_RUN_S and holds SPAN_MIN_RUN_SAMPLES, else the run that holds most of
    the samples, else all of them (no run to trust: a clock in other units is not a damaged one): one wild
    timestamp (2.3e12 s from a flipped bit) no longer sets the end, a second flight still does. Non-finite
    stamps are ignored."""
    t = np.sort(np.asarray(t, dtype=float))
    t = t[np.isfinite(t)]
    if len(t) == 0:
        return Span(float("nan"), float("nan"))
    bounds = np.r_[0, np.flatnonzero(np.diff(t) > SPAN_GAP_S) + 1, len(t)]
    first, last = bounds[:-1], bounds[1:] - 1  # each run's first and last sample
    lasting = np.flatnonzero((t[last] - t[first] >= SPAN_MIN_RUN_S) & (last - first + 1 >= SPAN_MIN_RUN_SAMPLES))
    if len(lasting):
        lo, hi = int(first[lasting[0]]), int(last[lasting[-1]]) + 1
    else:  # a short log: the run with most of the samples; none (t in us: every row a run of one): all
        k = int(np.argmax(last - first))
        lo, hi = (int(first[k]), int(last[k]) + 1) if 2 * (last[k] - first[k] + 1) > len(t) else (0, len(t))
    rest = np.r_[t[:lo], t[hi:]]
    return Span(float(t[lo]), float(t[hi - 1]), len(rest),
                (float(rest.min()), float(rest.max())) if len(rest) else None, len(t))


def inside(t: np.ndarray, spans: tuple[tuple[float, float], ...]) -> np.ndarray:
    """True where t lies in one of the spans [start, end): at the end the state has changed."""
    t = np.asarray(t, dtype=float)
    mask = np.zeros(len(t), dtype=bool)
    for a, b in spans:
        mask |= (t >= a) & (t < b)
    return mask


def total(spans: tuple[tuple[float, float], ...]) -> float:
    return float(sum(b - a for a, b in spans))


def drag_fusion_reason(filter_name: str, on: bool, configured: bool, off_because: str, names: str) -> str:
    """What the parameters say of the autopilot filter's drag fusion. A log without any of the parameters
    (older firmware, another filter, parameters not logged) says nothing, and "off" would claim what was
    not read."""
    if on:
        return f"{filter_name} drag fusion is on"
    if configured:
        return f"{filter_name} drag fusion is off ({off_because})"
    return f"{filter_name} drag fusion unknown (no {names} in the log's parameters)"


def wind_activity(source: str | None, t: np.ndarray | None, north: np.ndarray | None, east: np.ndarray | None,
                  why: str = "") -> AutopilotWind:
    """An autopilot's wind estimate is active when it is logged and not identically zero: PX4 and
    ArduPilot keep publishing zeros (or nothing) when no wind state is being estimated."""
    if source is None or t is None or north is None or east is None or len(t) == 0:
        return AutopilotWind(None, False, "not logged" + (f" ({why})" if why else ""))
    speed = np.hypot(north, east)
    finite = speed[np.isfinite(speed)]
    if len(finite) == 0 or np.all(finite == 0):
        return AutopilotWind(source, False, "logged but all zero (no wind state estimated)"
                             + (f"; {why}" if why else ""))
    return AutopilotWind(source, True, "logged and nonzero" + (f"; {why}" if why else ""), float(np.mean(finite)))


def _fmt(value: float | None, unit: str = "", digits: int = 3) -> str:
    return "-" if value is None else f"{value:.{digits}g}{unit}"


def text_report(s: LogSummary) -> str:
    lines = [f"{s.path}: {s.format}" + (f" ({s.autopilot})" if s.autopilot else ""),
             f"  span {s.start_s:.2f} .. {s.end_s:.2f} s ({s.duration_s:.1f} s"
             + (f"; {s.outside_span} sample{'s' * (s.outside_span != 1)} outside it" if s.outside_span else "") + "); airborne "
             + (f"{s.airborne_s:.1f} s" if s.airborne_s is not None else "unknown") + f" ({s.airborne_source})",
             "  streams (messages, median rate, worst gap):"]
    for st in s.streams:
        lines.append(f"    {st.name:<44} {st.count:>7}  {_fmt(st.rate_hz, ' Hz', 4):>9}  {_fmt(st.worst_gap_s, ' s'):>9}")
    if s.other_streams:
        lines.append(f"  also logged ({len(s.other_streams)}, not read): " + ", ".join(s.other_streams[:12])
                     + (" ..." if len(s.other_streams) > 12 else ""))
    lines.append("  inputs replay would use:")
    for r in s.roles:
        rate = s.stream(r.stream).rate_hz if s.stream(r.stream) else None
        used = r.source if r.source else "MISSING"
        lines.append(f"    {r.role:<15} {used}" + (f" ({_fmt(rate, ' Hz', 3)})" if rate else "")
                     + (f"; {r.note}" if r.note else ""))
    v = s.vehicle
    lines.append(f"  vehicle: {v.airframe}; rotors {v.rotors if v.rotors else 'unknown'} ({v.rotor_source})")
    if v.not_multirotor:
        lines.append(f"  NOT A MULTIROTOR: {v.not_multirotor}; {MULTIROTORS_ONLY}")
    lines.append("  rotor speeds: " + ("rpm > 0 on every rotor while airborne" if v.rpm_nonzero_airborne
                                       else "no usable rpm") + (f" ({v.rpm_note})" if v.rpm_note else ""))
    if v.hover_thrust is not None:
        lines.append(f"  hover thrust: {v.hover_thrust:.3f} ({v.hover_source})")
    w = s.autopilot_wind
    lines.append(f"  autopilot wind: {'ACTIVE' if w.active else 'inactive'}"
                 + (f" from {w.source}" if w.source else "") + f": {w.reason}"
                 + (f"; mean {w.mean_speed_mps:.2f} m/s" if w.mean_speed_mps is not None else ""))
    if s.position is not None:
        lines.append(f"  position and UTC (replay -o .nc, profile): position {s.position['position'] or 'none'}; "
                     + ("UTC from " if s.position["utc"] else "") + s.position["time_source"])
    if s.parameters:
        lines.append("  parameters: " + ", ".join(f"{k} {v:g}" for k, v in s.parameters.items()))
    missing = s.missing()
    lines.append("  missing: " + ("; ".join(missing) if missing else "nothing"))
    lines += [f"  note: {n}" for n in s.notes]
    return "\n".join(lines)
