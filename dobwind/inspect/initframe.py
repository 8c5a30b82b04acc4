"""`dobwind init LOG --mass KG -o NEW.toml`: a starter airframe for the vehicle that flew a log.

Everything but the mass comes from the log (dobwind/inspect/loginspect.py): the thrust source, the rotor count,
the sample time and max_dt from the rates actually logged, the observer gain from a bandwidth those
rates support (analysis/design.py), the acceleration input. The force-air law is a PRIOR scaled from
typical multirotors, so the file says `[calibration] status = "prior"` and every estimate made with it
carries the UNCALIBRATED status bit until `dobwind fit` calibrates it.
"""
from __future__ import annotations

import math
import os
import re
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

from dobwind.io.aplayout import LAYOUT_NOTE
from dobwind.core.errors import InputError
from dobwind.io.accelcheck import AccelCheck, check_log
from dobwind.inspect.anylog import inspect_log
from dobwind.inspect.loginspect import ESSENTIAL_ROLES, LogSummary
from dobwind.io.vehiclekind import MULTIROTORS_ONLY
from dobwind.model.airframe import Airframe, PRIOR, STANDARD_GRAVITY, VERTICAL_FALLBACK, parse_airframe
from dobwind.model.airframe_toml import airframe_document, dumps
from dobwind.model.ranges import NAME_MAX_CHARS, RANGES
from dobwind.model.signals import log_signals
from dobwind.model.kinds import DragFrame

# Observer rates a starter airframe picks from (Hz): the usual logging rates of PX4 and ArduPilot.
COMMON_RATES_HZ = (10.0, 20.0, 25.0, 50.0, 100.0)
# A logged rate counts as a common rate this far below it (timing jitter: 9.9 Hz logs are 10 Hz logs).
RATE_JITTER = 0.05
# max_dt: at least this many sample times, and this many of the slowest needed stream's intervals.
MAX_DT_SAMPLES = 3
MAX_DT_INTERVALS = 1.5
# The observer's -3 dB bandwidth: the paper's 0.5 Hz (at 100 Hz), but at most 1/20 of the slowest
# needed stream's rate (a 10 Hz position topic carries the velocity's change up to a few Hz at best).
BANDWIDTH_HZ = 0.5
BANDWIDTH_PER_RATE = 1.0 / 20.0
# A prior drag law from PX4's multicopter drag model defaults (PX4 parameter reference; the values
# are in the field logs' parameters too): ballistic coefficient EKF2_BCOEF_X/Y = m / (Cd A) = 100
# kg/m^2 (PX4 v1.14 and later) and momentum (rotor) drag EKF2_MCOEF = 0.15 1/s. They are tuned for
# the size PX4's defaults address, a quad of about 2 kg (X500 class; an assumption). Drag area scales
# with length^2, so with mass^(2/3) at equal density; rotor momentum drag with the mass (the air mass
# flow the rotors move grows with thrust). Calibrate with `dobwind fit`: this is a start, not a model.
REFERENCE_MASS_KG = 2.0
REFERENCE_BALLISTIC_KG_M2 = 100.0
REFERENCE_MOMENTUM_PER_S = 0.15
AIR_DENSITY_KG_M3 = 1.225  # ISA sea level
# Vertical: the disc area seen from above is larger than the frontal area (assumed twice), and the
# rotors' axial momentum drag is taken as the horizontal one.
VERTICAL_AREA_RATIO = 2.0
# rpm airframes: max_rpm is the highest airborne rpm with this headroom; the curve is k (rpm/max)^2
# through the airborne median rpm carrying the weight (the median airborne rpm is near hover).
MAX_RPM_HEADROOM = 1.25
FILTER_SPEEDS_MPS = (0.0, 3.0, 10.0)
FILTER_CUTOFF_SHARES = (0.4, 0.7, 1.0)   # of the observer bandwidth: heavier smoothing in calm air
ACCELERATION_BIAS_TIME_S = 20.0          # as the shipped m300: an autopilot's acceleration bias


# The one input init cannot check: a log holds no absolute force, only forces relative to the thrust,
# and the thrust is calibrated to m g at hover (either source), so every force scales with --mass.
MASS_UNCHECKED = ("not checked against the log: a log holds no absolute force (the thrust is set to m g at "
                  "hover), so every force the estimator sees scales with this mass")
MASS_IF_WRONG = ("a wrong mass scales the force-air law by the same factor: `dobwind fit` calibrates the law on "
                 "these forces, so the wind comes out the same, but the law's newtons are off by the mass's "
                 "error and do not carry over to the true mass or a changed payload")


@dataclass(frozen=True)
class InitChoices:
    """What init chose and why (printed, and in --json)."""
    thrust_source: str
    thrust_reason: str
    rotors: int
    rate_hz: float
    rate_reason: str
    max_dt_s: float
    bandwidth_hz: float
    acceleration: str
    # why the acceleration input: what the log has, or (dobwind/inspect/accelcheck.py) why not its own
    acceleration_reason: str = ""
    acceleration_disagreement_mps2: float | None = None


def common_rate(rate_hz: float) -> float:
    """The largest common rate at or below ``rate_hz`` (with jitter), never below the lowest."""
    fitting = [c for c in COMMON_RATES_HZ if c <= rate_hz * (1 + RATE_JITTER)]
    return max(fitting) if fitting else COMMON_RATES_HZ[0]


def _rate(s: LogSummary, collective: bool) -> tuple[float, str, list[float]]:
    """The observer rate from the attitude (and collective setpoint) rate, and the intervals (s) of the
    streams replay needs (velocity, attitude, acceleration, thrust setpoint; ESC rpm has its own gap)."""
    needed = ["velocity", "attitude"] + (["thrust"] if collective else [])
    needed += ["acceleration"] if s.role("acceleration").source else []
    rates = {r: s.stream(s.role(r).stream).rate_hz if s.stream(s.role(r).stream) else None for r in needed}
    driving = {r: v for r, v in rates.items() if r in ("attitude", "thrust") and v}
    if not driving:
        raise InputError(s.path, "attitude", "no rate: the log has fewer than two attitude messages")
    role, rate = min(driving.items(), key=lambda kv: kv[1])
    chosen = common_rate(rate)
    return chosen, f"{role} at {rate:.3g} Hz", [1.0 / v for v in rates.values() if v]


def _thrust(s: LogSummary, mass: float) -> tuple[dict[str, Any], str]:
    v = s.vehicle
    if v.rpm_nonzero_airborne and v.rotors and v.airborne_rpm_median and v.airborne_rpm_max:
        max_rpm = float(math.ceil(v.airborne_rpm_max * MAX_RPM_HEADROOM))
        k = mass * STANDARD_GRAVITY / v.rotors / (v.airborne_rpm_median / max_rpm) ** 2
        return ({"source": "rpm", "scale": 1.0, "rotors": v.rotors, "max_rpm": max_rpm, "coefficients": [0.0, 0.0, k]},
                f"rpm: ESC telemetry reads rpm > 0 on every rotor while airborne ({v.rpm_note})")
    if s.role("thrust").source is None or s.role("hover_thrust").source is None:
        what = "no collective thrust setpoint" if s.role("thrust").source is None else "no hover thrust to scale it"
        raise InputError(s.path, "thrust", f"no thrust source: no usable ESC rpm ({v.rpm_note or 'none'}) and {what}")
    said = s.role("thrust").note  # an older layout's source: what it is (dobwind/io/px4layout.py)
    return ({"source": "collective", "scale": 1.0},
            f"collective from {s.role('thrust').source} / {s.role('hover_thrust').source}"
            + (f" ({said})" if said else "") + ": " + (v.rpm_note if v.rpm_note else "no ESC rpm"))


def _drag(mass: float) -> dict[str, Any]:
    area = REFERENCE_MASS_KG / REFERENCE_BALLISTIC_KG_M2 * (mass / REFERENCE_MASS_KG) ** (2.0 / 3.0)
    q0 = 0.5 * AIR_DENSITY_KG_M3 * area
    l0 = REFERENCE_MOMENTUM_PER_S * mass
    # The vertical terms are a guess from the same scaling: the step does not publish what they read
    # (vertical_law "zero-wind": zero vertical wind, sigma_up -1) until `fit` identifies a vertical law; replay's
    # plausibility check still reads the vertical force through them (dobwind/replay/plausibility.py).
    return {"model": "drag", "vertical_law": VERTICAL_FALLBACK,
            "drag": {"frame": DragFrame.HEADING, "l0": l0, "q0": q0, "lz": l0, "qz": VERTICAL_AREA_RATIO * q0}}


def _acceleration(s: LogSummary) -> str:
    if s.role("acceleration").source:
        return "ned"
    return "specific_force" if s.role("specific_force").source else "velocity"


def _name(name: str | None, output: str) -> str:
    if name is not None:
        return name  # parse_airframe checks it, naming --name below
    # One underscore for each run of other characters, none at the ends (model/airframe.py NAME_PATTERN):
    # "quad--esc_.toml" is quad_esc, not quad__esc, which no step can be built for.
    stem = re.sub(r"[^a-z0-9]+", "_", Path(output).stem.lower()).strip("_") or "airframe"
    stem = stem if stem[0].isalpha() else f"a_{stem}"
    return stem[:NAME_MAX_CHARS].rstrip("_")


def _document(s: LogSummary, mass: float, name: str, gain: float,
              check: AccelCheck | None = None) -> tuple[dict[str, Any], InitChoices]:
    """The starter's document; ``check``: the logged acceleration's check (None before it is made): a
    broken one sends the observer to the velocity's derivative."""
    thrust, thrust_reason = _thrust(s, mass)
    collective = thrust["source"] == "collective"
    rate, rate_reason, intervals = _rate(s, collective)
    sample_time = 1.0 / rate
    # Up to the next 10 ms (rounded first: 3 x 0.1 is 0.30000000000000004 in binary).
    max_dt = math.ceil(round(max(MAX_DT_SAMPLES * sample_time, MAX_DT_INTERVALS * max(intervals)) * 100, 6)) / 100
    bandwidth = min(BANDWIDTH_HZ, BANDWIDTH_PER_RATE / max(intervals))
    acceleration = "velocity" if check is not None and check.broken else _acceleration(s)
    rotors = s.vehicle.rotors or 0
    document: dict[str, Any] = {
        "name": name, "mass": mass, "gravity": STANDARD_GRAVITY, "thrust": thrust,
        "observer": {"sample_time": sample_time, "gains": [gain] * 3, "discretization": "paper",
                     "acceleration": acceleration, "force_offset": [0.0, 0.0, 0.0],
                     "acceleration_bias_time": 0.0 if acceleration == "velocity" else ACCELERATION_BIAS_TIME_S},
        "force_air": _drag(mass),
        "filter": {"speeds": list(FILTER_SPEEDS_MPS), "cutoffs": [round(share * bandwidth, 4) for share in FILTER_CUTOFF_SHARES]},
        "limits": {"max_dt": min(max_dt, RANGES["limits.max_dt"].high), "max_tilt_deg": 60.0},
        "calibration": {"status": PRIOR},
    }
    choices = InitChoices(thrust["source"], thrust_reason, int(thrust.get("rotors", rotors)), rate,
                          f"{rate:g} Hz, the common rate at or below {rate_reason}", document["limits"]["max_dt"],
                          bandwidth, acceleration, _acceleration_reason(acceleration, check),
                          None if check is None else round(check.disagreement_mps2, 4))
    return document, choices


def _acceleration_reason(acceleration: str, check: AccelCheck | None) -> str:
    if check is not None and check.broken:
        return (f"the velocity's derivative instead of the log's own: {check.text()}, so the logged one carries "
                "errors the velocity does not (aliased vibration: a fast signal logged at a few hertz)")
    meaning = ACCELERATION_MEANING[acceleration]
    return meaning if check is None else f"{meaning}; {check.text()}"


def build_airframe(log: str, mass: float, output: str, name: str | None = None) -> tuple[str, InitChoices, LogSummary]:
    """The starter airframe's TOML text, the choices made, and the log's summary."""
    from dobwind.analysis.design import design_gain, with_gains

    if not RANGES["mass"].contains(mass):
        raise InputError("--mass", None, f"{mass!r} kg is not a multirotor's mass ({RANGES['mass'].describe()})")
    summary = inspect_log(log)
    refuse_unsuited(summary)
    chosen = _name(name, output)
    # First with the gain of the continuous observer (bandwidth = gain / (2 pi m)), then designed exactly
    # on the discrete step that will run.
    document, choices = _document(summary, mass, chosen, 2 * math.pi * BANDWIDTH_HZ * mass)
    try:
        draft = parse_airframe(dumps(document), output)
    except InputError as exc:
        if name is not None and exc.where == "name":
            raise InputError("--name", None, exc.message) from None
        raise
    check = check_log(log, draft, choices.bandwidth_hz)
    if check is not None:
        document, choices = _document(summary, mass, chosen, 2 * math.pi * BANDWIDTH_HZ * mass, check)
        draft = parse_airframe(dumps(document), output)
    elif log_signals(draft).measured_acceleration:
        # a short flight: the logged acceleration is kept, but the user must not read it as checked
        choices = replace(choices, acceleration_reason=f"{choices.acceleration_reason}; {UNCHECKED}")
    gain = design_gain(draft, choices.bandwidth_hz)
    final = with_gains(draft, (gain, gain, gain))
    header = _header(log, summary, choices, mass)
    text = header + dumps(airframe_document(final))
    parse_airframe(text, output)  # what is written must load
    return text, choices, summary


def refuse_unsuited(s: LogSummary) -> None:
    """A log no starter can come from: not a multirotor's, without the velocity or the attitude replay
    needs, or one that never flew (a pre-arm log). Each gave a starter before (or only "no thrust
    source"), which replay then refused or with which it estimated nothing or nonsense."""
    if s.vehicle.not_multirotor:
        raise InputError(s.path, "vehicle", f"{s.vehicle.not_multirotor}; {MULTIROTORS_ONLY}: no starter airframe")
    for role in (s.role(name) for name in ESSENTIAL_ROLES):
        if role.source is None:  # replay refuses such a log: a starter for it would never run
            raise InputError(s.path, role.role, f"{role.note}: replay needs it, so no starter airframe")
    if s.airborne_s is not None and s.airborne_s <= 0.0:
        raise InputError(s.path, "airborne", f"never airborne in its {s.duration_s:.1f} s ({s.airborne_source}): the "
                         "starter's thrust and rates are read from a flight; give the log of a flight")


def _header(log: str, s: LogSummary, c: InitChoices, mass: float) -> str:
    lines = [f"# Starter airframe written by `dobwind init` from {os.path.basename(log)} ({s.format}"
             + (f", {s.vehicle.airframe}" if s.vehicle.airframe else "") + ").",
             "# UNCALIBRATED: the force-air law is a prior scaled from typical multirotors (PX4's drag defaults);",
             "# every estimate carries the UNCALIBRATED status bit until `dobwind fit` calibrates this file.",
             f"# mass: {mass:g} kg from --mass, {MASS_UNCHECKED};",
             f"# {MASS_IF_WRONG}.",
             f"# thrust: {c.thrust_reason}",
             f"# rotors: {c.rotors or 'not used'} ({s.vehicle.rotor_source})",
             f"# sample_time: {c.rate_reason}; max_dt {c.max_dt_s:g} s covers the slowest needed stream",
             f"# gains: designed for a {c.bandwidth_hz:.3g} Hz observer bandwidth (dobwind analyze --bandwidth)",
             f"# acceleration: {c.acceleration} ({c.acceleration_reason})"]
    lines += [f"# layout: {n}" for n in s.notes if n.startswith(LAYOUT_NOTE)]  # an older ArduPilot log's names
    return "\n".join(lines) + "\n"


def run_init(log: str, mass: float, output: str, name: str | None, as_json: bool) -> int:
    from dobwind.io.atomic import write_text_atomically
    from dobwind.io.outputs import AIRFRAME, OutputFiles, Target, check_targets

    target = Target("-o", output, refused=AIRFRAME)
    check_targets([target], [log])
    text, choices, summary = build_airframe(log, mass, output, name)
    with OutputFiles([target]) as out:
        write_text_atomically(out.stage(output), lambda handle: handle.write(text))
    if as_json:
        from dobwind.io.jsonout import print_json

        print_json({"airframe": output, "calibration": PRIOR, "choices": asdict(choices),
                    "log": summary.path, "format": summary.format, "missing": summary.missing(),
                    "mass": {"kg": mass, "source": "--mass", "checked_against_log": False,
                             "why": MASS_UNCHECKED, "if_wrong": MASS_IF_WRONG}})
    else:
        print(_summary_text(output, choices, mass))
    return 0


UNCHECKED = ("not checked against the velocity's derivative: too little airborne flight in unbroken runs of "
             "3 periods of the band (dobwind/io/accelcheck.py), or a log replay cannot read")

# What each observer.acceleration input is, for the summary: the bare keyword means little to a new user.
ACCELERATION_MEANING = {"ned": "the log's own NED acceleration", "specific_force": "the accelerometer's specific "
                        "force, turned by the attitude", "velocity": "the velocity's derivative: the log has no acceleration"}


def _summary_text(output: str, c: InitChoices, mass: float) -> str:
    return "\n".join([f"wrote {output} (uncalibrated prior: estimates carry UNCALIBRATED until `dobwind fit`)",
                      f"  mass         {mass:g} kg from --mass, {MASS_UNCHECKED}",
                      f"               {MASS_IF_WRONG}",
                      f"  thrust       {c.thrust_reason}",
                      f"  rotors       {c.rotors or 'unknown (not used: collective thrust)'}",
                      f"  sample_time  {1 / c.rate_hz:g} s ({c.rate_reason})",
                      f"  max_dt       {c.max_dt_s:g} s",
                      f"  bandwidth    {c.bandwidth_hz:.3g} Hz (observer gains designed for it)",
                      f"  acceleration {c.acceleration} ({c.acceleration_reason})"])
