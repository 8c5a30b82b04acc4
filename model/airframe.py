"""Airframe files (docs/formats.md, airframe): TOML in, a validated immutable ``Airframe`` out.

Every rule is checked here, so the rest of the code can trust the object. A bad file raises
``InputError`` naming the file and the dotted key.
"""
from __future__ import annotations

import difflib
import hashlib
import math
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dobwind.model.errors import InputError
from dobwind.model.forceair import (EXPONENT_RANGE, HORIZONTAL_DRAG_KEYS, ROTOR_DRAG_KEY, VERTICAL_DRAG_KEYS,
                                    DragLaw)
from dobwind.model.ranges import (MAX_TERMS, MAX_FACTOR_POWER, MAX_TERM_DEGREE, MAX_THRUST_COEFFICIENTS,
                                  MIN_SPEED_GAP_MPS, NAME_MAX_CHARS, RANGES, Range, single_precision_ok)
from dobwind.model.terms import Term, TermError, parse_term, range_problem
from dobwind.model.inputfiles import read_bounded
from dobwind.model.plausibility import hover_problem
from dobwind.model.kinds import DRAG_FRAMES, DragFrame

DISCRETIZATIONS = ("paper", "euler", "zoh", "tustin")
ACCELERATION_MODES = ("ned", "specific_force", "velocity")
THRUST_SOURCES = ("rpm", "collective")
FORCE_AIR_MODELS = ("polynomial", "drag")
STANDARD_GRAVITY = 9.80665
DEFAULT_MAX_DT_S = 0.1
DEFAULT_MAX_TILT_DEG = 60.0
MAX_ROTORS = 16

# Every key each table may hold. They are checked before any value is read, so that a misspelt key
# ("masss") is reported as unknown rather than as the correct key missing. Add new keys here.
TOP_KEYS = ("name", "mass", "gravity", "thrust", "observer", "force_air", "filter", "limits", "envelope",
            "uncertainty", "ros2_topics", "calibration")
# Roles of the ROS 2 bag reader (dobwind/io/rosbag.py) whose topic names [ros2_topics] may replace.
ROS2_TOPIC_ROLES = ("velocity", "attitude", "imu", "esc", "thrust", "hover", "land", "wind")
THRUST_KEYS = ("source", "scale", "rotors", "max_rpm", "coefficients")
OBSERVER_KEYS = ("sample_time", "gains", "discretization", "acceleration", "force_offset", "acceleration_bias_time")
FORCE_AIR_KEYS = ("model", "horizontal", "vertical", "drag")
POLYNOMIAL_KEYS = ("terms", "coefficients")
FILTER_KEYS = ("speeds", "cutoffs")
LIMITS_KEYS = ("max_dt", "max_tilt_deg")
ENVELOPE_KEYS = ("force_h_max", "force_z", "airflow_h_max")
UNCERTAINTY_KEYS = ("speeds", "sigma_h", "sigma_up", "noise_h", "noise_up")
CALIBRATION_KEYS = ("status",)
# [calibration] status: "calibrated" (the default: every file written before the key existed was
# calibrated by fit or by hand) or "prior" (a starter law scaled from typical vehicles, written by
# `dobwind init`; the step then sets the UNCALIBRATED quality bit on every accepted sample).
CALIBRATED = "calibrated"
PRIOR = "prior"
CALIBRATION_STATUSES = (CALIBRATED, PRIOR)


@dataclass(frozen=True)
class Thrust:
    source: str                       # "rpm" | "collective"
    scale: float = 1.0                # true thrust / nominal (written by `dobwind fit`)
    rotors: int = 0                   # rpm only
    max_rpm: float = 0.0              # rpm only
    coefficients: tuple[float, ...] = ()  # rpm only: N per rotor, ascending powers of rpm/max_rpm


@dataclass(frozen=True)
class Observer:
    sample_time_s: float
    gains: tuple[float, float, float]  # diagonal of K_I, x y z (kg/s)
    discretization: str
    acceleration: str
    force_offset_n: tuple[float, float, float]
    # Time constant (s) of the velocity-aided acceleration bias estimate; 0: no bias estimate.
    acceleration_bias_time_s: float = 0.0

    @property
    def estimates_acceleration_bias(self) -> bool:
        return self.acceleration_bias_time_s > 0.0


@dataclass(frozen=True)
class ForceAirModel:
    terms: tuple[Term, ...]
    coefficients: tuple[float, ...]

    @property
    def term_texts(self) -> tuple[str, ...]:
        return tuple(t.text for t in self.terms)


@dataclass(frozen=True)
class FilterSchedule:
    speeds_mps: tuple[float, ...]
    cutoffs_hz: tuple[float, ...]


@dataclass(frozen=True)
class Limits:
    max_dt_s: float = DEFAULT_MAX_DT_S
    max_tilt_deg: float = DEFAULT_MAX_TILT_DEG


@dataclass(frozen=True)
class Envelope:
    """The calibrated range (written by `dobwind fit`): beyond it the force-air model extrapolates."""
    force_h_max_n: float                  # heading-frame horizontal force magnitude, after the offset
    force_z_n: tuple[float, float]        # heading-frame vertical force (down), after the offset
    airflow_h_max_mps: float              # the model's horizontal airflow speed


@dataclass(frozen=True)
class Uncertainty:
    """1-sigma errors of one estimate: the calibrated model's over airflow speed (piecewise linear,
    clamped outside), and the observer noise, the sample-to-sample scatter of the estimate about its
    mean in steady flight, independent of the model's error and so added in quadrature."""
    speeds_mps: tuple[float, ...]
    sigma_h_mps: tuple[float, ...]
    sigma_up_mps: tuple[float, ...]
    noise_h_mps: float = 0.0   # horizontal wind speed
    noise_up_mps: float = 0.0  # vertical wind


@dataclass(frozen=True)
class Airframe:
    name: str
    mass_kg: float
    gravity_mps2: float
    thrust: Thrust
    observer: Observer
    horizontal: ForceAirModel
    vertical: ForceAirModel
    filter: FilterSchedule
    limits: Limits
    content_sha256: str  # of the file's bytes; names the source in generated code without a path
    envelope: Envelope | None = None        # optional: absent => EXTRAPOLATED is never set
    uncertainty: Uncertainty | None = None  # optional: absent => the sigma outputs carry -1 (unknown)
    drag: DragLaw | None = None  # the ``drag`` force-air family; None: the polynomial family
    ros2_topics: tuple[tuple[str, str], ...] = ()  # optional (role, topic) replacing the bag reader's defaults
    calibration: str = CALIBRATED  # [calibration] status; PRIOR: the step sets UNCALIBRATED

    @property
    def uncalibrated(self) -> bool:
        return self.calibration != CALIBRATED
    # [force_air] vertical_law: "fitted" (the law's vertical part is inverted), or VERTICAL_FALLBACK when
    # the calibration did not identify it: the step then publishes zero vertical wind and sigma_up -1, and
    # the header says VERTICAL_ESTIMATED 0 (model/status.py, docs/c-api.md).
    vertical_law: str = "fitted"

    @property
    def force_air_model(self) -> str:
        return "polynomial" if self.drag is None else "drag"


def _finite_float(value: Any) -> float | None:
    """The value as a finite float, or None: booleans, text and integers too large for a float
    (TOML allows any number of digits; float() of those raises OverflowError) are not numbers here."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    try:
        number = float(value)
    except OverflowError:
        return None
    return number if math.isfinite(number) else None


class TableReader:
    """Typed access to one TOML table, recording which keys were read so leftovers are errors."""

    def __init__(self, source: str, table: dict[str, Any], prefix: str = "",
                 known: tuple[str, ...] | None = None) -> None:
        self.source = source
        self.table = table
        self.prefix = prefix
        self.used: set[str] = set()
        if known is not None:
            self.refuse_unknown(known)

    def refuse_unknown(self, known: tuple[str, ...]) -> None:
        unknown = sorted(set(self.table) - set(known))
        if unknown:
            close = difflib.get_close_matches(unknown[0], known, n=1)
            hint = f"; did you mean '{close[0]}'?" if close else f" (expected one of: {', '.join(known)})"
            raise InputError(self.source, self.key(unknown[0]), f"unknown key{hint}")

    def key(self, name: str) -> str:
        return f"{self.prefix}{name}"

    def fail(self, name: str, message: str) -> InputError:
        return InputError(self.source, self.key(name), message)

    def has(self, name: str) -> bool:
        return name in self.table

    def raw(self, name: str, required: bool = True) -> Any:
        if name not in self.table:
            if required:
                raise InputError(self.source, self.key(name), "missing required key")
            return None
        self.used.add(name)
        return self.table[name]

    def number(self, name: str, default: float | None = None, positive: bool = False) -> float:
        value = self.raw(name, required=default is None)
        if value is None:
            return float(default)  # type: ignore[arg-type]
        number = _finite_float(value)
        if number is None:
            raise self.fail(name, f"expected a finite number, got {_short(value)}")
        if positive and number <= 0:
            raise self.fail(name, f"must be > 0, got {value!r}")
        return number

    def string(self, name: str, choices: tuple[str, ...] | None = None, default: str | None = None) -> str:
        value = self.raw(name, required=default is None)
        if value is None:
            return default  # type: ignore[return-value]
        if not isinstance(value, str):
            raise self.fail(name, f"expected a string, got {value!r}")
        if choices is not None and value not in choices:
            raise self.fail(name, f"must be one of {', '.join(repr(c) for c in choices)}, got {value!r}")
        return value

    def numbers(self, name: str, length: int | None = None, default: tuple[float, ...] | None = None,
                positive: bool = False) -> tuple[float, ...]:
        value = self.raw(name, required=default is None)
        if value is None:
            return default  # type: ignore[return-value]
        if not isinstance(value, list) or not all(_finite_float(v) is not None for v in value):
            raise self.fail(name, f"expected a list of finite numbers, got {_short(value)}")
        if not value:
            raise self.fail(name, "must not be empty")
        if length is not None and len(value) != length:
            raise self.fail(name, f"expected {length} numbers, got {len(value)}")
        if positive and any(v <= 0 for v in value):
            raise self.fail(name, f"every value must be > 0, got {value!r}")
        return tuple(float(v) for v in value)

    def within(self, name: str, values: float | tuple[float, ...], range_key: str, magnitude: bool = False) -> None:
        """Every value (its magnitude with ``magnitude``) inside ``RANGES[range_key]``."""
        bounds: Range = RANGES[range_key]
        for value in (values if isinstance(values, tuple) else (values,)):
            if not bounds.contains(abs(value) if magnitude else value):
                what = "|value|" if magnitude else "value"
                raise self.fail(name, f"{what} must be {bounds.describe()}, got {value:g}")

    def table_of(self, name: str, known: tuple[str, ...] | None = None, required: bool = True) -> "TableReader | None":
        value = self.raw(name, required=required)
        if value is None:
            return None
        if not isinstance(value, dict):
            raise self.fail(name, "expected a table")
        return TableReader(self.source, value, f"{self.key(name)}.", known)

    def done(self) -> None:
        unknown = sorted(set(self.table) - self.used)
        if unknown:
            raise InputError(self.source, self.key(unknown[0]), "unknown key (check the spelling)")


def _short(value: Any) -> str:
    """A value for an error message: one line, however long the value in the file was."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _force_air(reader: TableReader) -> ForceAirModel:
    raw_terms = reader.raw("terms")
    if not isinstance(raw_terms, list) or not raw_terms or not all(isinstance(t, str) for t in raw_terms):
        raise reader.fail("terms", "expected a non-empty list of strings")
    if len(raw_terms) > MAX_TERMS:
        raise reader.fail("terms", f"has {len(raw_terms)} terms; at most {MAX_TERMS}")
    terms = []
    for text in raw_terms:
        try:
            term = parse_term(text)
        except TermError as exc:
            raise reader.fail("terms", f"term {_short(text)}: {exc}") from None
        problem = range_problem(term, MAX_FACTOR_POWER, MAX_TERM_DEGREE)
        if problem is not None:
            raise reader.fail("terms", f"term {_short(text)}: {problem}")
        terms.append(term)
    coefficients = reader.numbers("coefficients")
    reader.within("coefficients", coefficients, "force_air.coefficients", magnitude=True)
    if len(coefficients) != len(terms):
        raise reader.fail("coefficients", f"has {len(coefficients)} values for {len(terms)} terms")
    reader.done()
    return ForceAirModel(tuple(terms), coefficients)


DRAG_TABLE_KEYS = HORIZONTAL_DRAG_KEYS + (ROTOR_DRAG_KEY,) + VERTICAL_DRAG_KEYS + ("frame", "exponent")


def _drag_law(reader: TableReader) -> DragLaw:
    frame = DragFrame(reader.string("frame", DRAG_FRAMES, default=DragFrame.HEADING.value))
    values = {key: reader.number(key, default=0.0) for key in HORIZONTAL_DRAG_KEYS + VERTICAL_DRAG_KEYS}
    if frame == DragFrame.BODY:
        values[ROTOR_DRAG_KEY] = reader.number(ROTOR_DRAG_KEY, default=0.0)
    elif reader.has(ROTOR_DRAG_KEY):
        raise reader.fail(ROTOR_DRAG_KEY, 'rotor drag is a term of the body-frame law only (frame = "body")')
    for key, value in values.items():
        reader.within(key, value, "force_air.drag", magnitude=True)
    for key in ("l0", "q0", "lz", "qz") + ((ROTOR_DRAG_KEY,) if frame == DragFrame.BODY else ()):
        if values[key] < 0:
            raise reader.fail(key, f"a drag coefficient must be >= 0, got {values[key]!r}")
    if values["l0"] + values["q0"] + values.get(ROTOR_DRAG_KEY, 0.0) <= 0:
        raise reader.fail("q0", "l0, q0 (and lr) are all 0: the law cannot be inverted")
    if values["lz"] + values["qz"] <= 0 and (values["i1"] or values["i2"]):
        raise reader.fail("qz", "lz and qz are both 0 while inflow terms are set")
    exponent = reader.number("exponent", default=2.0)
    low, high = EXPONENT_RANGE
    if not low <= exponent <= high:
        raise reader.fail("exponent", f"must be in [{low:g}, {high:g}] (the growth of the quadratic terms), got {exponent!r}")
    reader.done()
    return DragLaw(**values, frame=frame, exponent=exponent)


# [force_air] vertical_law (issue #31): whether the vertical part of the law is used or the zero-wind fallback.
VERTICAL_FALLBACK = "zero-wind"
VERTICAL_LAWS = ("fitted", VERTICAL_FALLBACK)
FORCE_AIR_KEYS = FORCE_AIR_KEYS + ("vertical_law",)


def _vertical_law(fa: TableReader) -> str:
    return fa.string("vertical_law", VERTICAL_LAWS, default="fitted")


def _force_air_tables(fa: TableReader) -> tuple[ForceAirModel, ForceAirModel, DragLaw | None]:
    model = fa.string("model", FORCE_AIR_MODELS, default="polynomial")
    if model == "drag":
        for key in ("horizontal", "vertical"):
            if fa.has(key):
                raise fa.fail(key, 'only used with model = "polynomial"')
        drag = _drag_law(fa.table_of("drag", DRAG_TABLE_KEYS))  # type: ignore[arg-type]
        fa.done()
        return ForceAirModel((), ()), ForceAirModel((), ()), drag
    if fa.has("drag"):
        raise fa.fail("drag", 'only used with model = "drag"')
    horizontal = _force_air(fa.table_of("horizontal", POLYNOMIAL_KEYS))  # type: ignore[arg-type]
    vertical = _force_air(fa.table_of("vertical", POLYNOMIAL_KEYS))  # type: ignore[arg-type]
    fa.done()
    return horizontal, vertical, None


def _thrust(reader: TableReader) -> Thrust:
    source = reader.string("source", THRUST_SOURCES)
    scale = reader.number("scale", default=1.0, positive=True)
    reader.within("scale", scale, "thrust.scale")
    if source == "collective":
        for key in ("rotors", "max_rpm", "coefficients"):
            if reader.has(key):
                raise reader.fail(key, 'only used with source = "rpm"')
        reader.done()
        return Thrust("collective", scale)
    rotors = reader.raw("rotors")
    if isinstance(rotors, bool) or not isinstance(rotors, int) or not 1 <= rotors <= MAX_ROTORS:
        raise reader.fail("rotors", f"expected a whole number from 1 to {MAX_ROTORS}, got {rotors!r}")
    max_rpm = reader.number("max_rpm", positive=True)
    reader.within("max_rpm", max_rpm, "thrust.max_rpm")
    coefficients = reader.numbers("coefficients")
    if len(coefficients) > MAX_THRUST_COEFFICIENTS:
        raise reader.fail("coefficients", f"has {len(coefficients)} values; at most {MAX_THRUST_COEFFICIENTS}")
    reader.within("coefficients", coefficients, "thrust.coefficients", magnitude=True)
    # The step folds c_k * scale / max_rpm^k (and rotors * c_0 * scale) into one constant per power.
    for k, c in enumerate(coefficients):
        folded = c * scale * (rotors if k == 0 else 1.0 / max_rpm ** k)
        if not single_precision_ok(folded):
            raise reader.fail("coefficients", f"coefficient {k} ({c:g}) over max_rpm^{k} is {folded:.3g}, "
                              "outside single precision's normal range")
    reader.done()
    return Thrust("rpm", scale, rotors, max_rpm, coefficients)


def _envelope(reader: TableReader) -> Envelope:
    force_h_max = reader.number("force_h_max", positive=True)
    reader.within("force_h_max", force_h_max, "envelope.force_h_max")
    force_z = reader.numbers("force_z", length=2)
    reader.within("force_z", force_z, "envelope.force_z", magnitude=True)
    if force_z[0] >= force_z[1]:
        raise reader.fail("force_z", f"must be [low, high] with low < high, got {list(force_z)!r}")
    airflow_h_max = reader.number("airflow_h_max", positive=True)
    reader.within("airflow_h_max", airflow_h_max, "envelope.airflow_h_max")
    reader.done()
    return Envelope(force_h_max, (force_z[0], force_z[1]), airflow_h_max)


def _uncertainty(reader: TableReader) -> Uncertainty:
    speeds = reader.numbers("speeds")
    if speeds[0] < 0 or any(b <= a for a, b in zip(speeds, speeds[1:])):
        raise reader.fail("speeds", f"must be >= 0 and strictly increasing, got {_short(list(speeds))}")
    reader.within("speeds", speeds, "uncertainty.speeds")
    columns = []
    for key in ("sigma_h", "sigma_up"):
        values = reader.numbers(key)
        if len(values) != len(speeds):
            raise reader.fail(key, f"has {len(values)} values for {len(speeds)} speeds")
        if any(v < 0 for v in values):
            raise reader.fail(key, f"every value must be >= 0, got {_short(list(values))}")
        reader.within(key, values, "uncertainty.sigma")
        columns.append(values)
    noise = []
    for key in ("noise_h", "noise_up"):
        value = reader.number(key, default=0.0)
        if value < 0:
            raise reader.fail(key, f"must be >= 0, got {value!r}")
        if value > 0:
            reader.within(key, value, "uncertainty.sigma")
        noise.append(value)
    reader.done()
    return Uncertainty(speeds, columns[0], columns[1], noise[0], noise[1])


# The spec's [a-z][a-z0-9_]* (../shared/spec/INTERFACES.md) without a run of underscores or a trailing one:
# "<name>_step" is a CasADi Function name, which may not hold "__" (a name ending in "_" gives one), and
# C++ reserves every identifier holding "__" (the generated header is included from C++).
NAME_PATTERN = r"[a-z][a-z0-9]*(?:_[a-z0-9]+)*"


def _name(top: TableReader) -> str:
    name = top.string("name")
    if len(name) > NAME_MAX_CHARS:
        raise top.fail("name", f"has {len(name)} characters; at most {NAME_MAX_CHARS} (it prefixes C symbols and file names)")
    if not re.fullmatch(NAME_PATTERN, name):
        raise top.fail("name", "must match [a-z][a-z0-9_]* with no '__' and no trailing '_' (it prefixes C "
                       f"symbols: <name>_wind_step), got {_short(name)}")
    return name



def _observer(obs: TableReader) -> Observer:
    sample_time = obs.number("sample_time", positive=True)
    obs.within("sample_time", sample_time, "observer.sample_time")
    gains = obs.numbers("gains", length=3, positive=True)
    obs.within("gains", gains, "observer.gains")
    discretization = obs.string("discretization", DISCRETIZATIONS)
    acceleration = obs.string("acceleration", ACCELERATION_MODES)
    offset = obs.numbers("force_offset", length=3, default=(0.0, 0.0, 0.0))
    obs.within("force_offset", offset, "observer.force_offset", magnitude=True)
    bias_time = obs.number("acceleration_bias_time", default=0.0)
    if bias_time < 0:
        raise obs.fail("acceleration_bias_time", f"must be >= 0 s (0: no bias estimate), got {bias_time!r}")
    obs.within("acceleration_bias_time", bias_time, "observer.acceleration_bias_time")
    if bias_time > 0 and acceleration == "velocity":
        raise obs.fail("acceleration_bias_time", 'needs an acceleration input; with acceleration = "velocity" '
                       "there is no acceleration bias to estimate (set it to 0 or remove it)")
    obs.done()
    return Observer(sample_time, gains, discretization, acceleration, offset, bias_time)  # type: ignore[arg-type]


def _filter(flt: TableReader, sample_time: float) -> FilterSchedule:
    speeds = flt.numbers("speeds")
    if speeds[0] < 0:
        raise flt.fail("speeds", "must be >= 0")
    if any(b <= a for a, b in zip(speeds, speeds[1:])):
        raise flt.fail("speeds", f"must be strictly increasing, got {_short(list(speeds))}")
    flt.within("speeds", speeds, "filter.speeds")
    gap = min((b - a for a, b in zip(speeds, speeds[1:])), default=MIN_SPEED_GAP_MPS)
    if gap < MIN_SPEED_GAP_MPS * (1 - 1e-9):  # 99.99 - 99.98 is 0.00999999999999 in binary
        raise flt.fail("speeds", f"breakpoints {gap:.3g} m/s apart; at least {MIN_SPEED_GAP_MPS:g} m/s")
    cutoffs = flt.numbers("cutoffs", positive=True)
    if len(cutoffs) != len(speeds):
        raise flt.fail("cutoffs", f"has {len(cutoffs)} values for {len(speeds)} speeds")
    flt.within("cutoffs", cutoffs, "filter.cutoffs")
    flt.done()
    nyquist = 0.5 / sample_time
    if max(cutoffs) >= nyquist:
        raise flt.fail("cutoffs", f"must stay below the Nyquist frequency {nyquist:g} Hz")
    return FilterSchedule(speeds, cutoffs)


def _limits(lim: TableReader | None, sample_time: float, source: str) -> Limits:
    limits = Limits()
    if lim is not None:
        max_dt = lim.number("max_dt", default=DEFAULT_MAX_DT_S, positive=True)
        lim.within("max_dt", max_dt, "limits.max_dt")
        max_tilt = lim.number("max_tilt_deg", default=DEFAULT_MAX_TILT_DEG, positive=True)
        if max_tilt >= 90.0:
            raise lim.fail("max_tilt_deg", f"must be below 90, got {max_tilt!r}")
        lim.within("max_tilt_deg", max_tilt, "limits.max_tilt_deg")
        lim.done()
        limits = Limits(max_dt, max_tilt)
    if limits.max_dt_s < sample_time:
        raise InputError(source, "limits.max_dt", f"must be at least observer.sample_time ({sample_time:g} s)")
    return limits


def _ros2_topics(ros: TableReader | None) -> tuple[tuple[str, str], ...]:
    if ros is None:
        return ()
    topics = tuple((role, ros.string(role)) for role in ROS2_TOPIC_ROLES if ros.has(role))
    for role, topic in topics:
        if not topic.startswith("/"):
            raise ros.fail(role, f"must be an absolute topic name starting with '/', got {_short(topic)}")
    ros.done()
    return topics


def _calibration(cal: TableReader | None) -> str:
    if cal is None:
        return CALIBRATED
    status = cal.string("status", CALIBRATION_STATUSES, default=CALIBRATED)
    cal.done()
    return status


def _document(text: str, source: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, None, f"TOML syntax error: {exc}") from None
    except RecursionError:  # tomllib recurses once per nesting level of arrays and inline tables
        raise InputError(source, None, "TOML nested too deeply") from None


def parse_airframe(text: str, source: str) -> Airframe:
    """Validate airframe TOML text; ``source`` names the file in error messages. Every number is
    checked against its range in ``model/ranges.py`` before anything is built from it."""
    top = TableReader(source, _document(text, source), known=TOP_KEYS)
    name = _name(top)
    mass = top.number("mass", positive=True)
    top.within("mass", mass, "mass")
    gravity = top.number("gravity", default=STANDARD_GRAVITY, positive=True)
    top.within("gravity", gravity, "gravity")
    thrust = _thrust(top.table_of("thrust", THRUST_KEYS))  # type: ignore[arg-type]
    if thrust.source == "rpm":
        problem = hover_problem(thrust.rotors, thrust.max_rpm, thrust.coefficients, thrust.scale, mass * gravity)
        if problem is not None:
            raise InputError(source, "thrust.coefficients", problem)
    observer = _observer(top.table_of("observer", OBSERVER_KEYS))  # type: ignore[arg-type]
    force_air = top.table_of("force_air", FORCE_AIR_KEYS)
    vertical_law = _vertical_law(force_air)  # type: ignore[arg-type]
    horizontal, vertical, drag = _force_air_tables(force_air)  # type: ignore[arg-type]
    schedule = _filter(top.table_of("filter", FILTER_KEYS), observer.sample_time_s)  # type: ignore[arg-type]
    limits = _limits(top.table_of("limits", LIMITS_KEYS, required=False), observer.sample_time_s, source)
    env = top.table_of("envelope", ENVELOPE_KEYS, required=False)
    unc = top.table_of("uncertainty", UNCERTAINTY_KEYS, required=False)
    ros2_topics = _ros2_topics(top.table_of("ros2_topics", ROS2_TOPIC_ROLES, required=False))
    calibration = _calibration(top.table_of("calibration", CALIBRATION_KEYS, required=False))
    top.done()
    return Airframe(
        name=name,
        mass_kg=mass,
        gravity_mps2=gravity,
        thrust=thrust,
        observer=observer,
        horizontal=horizontal,
        vertical=vertical,
        filter=schedule,
        limits=limits,
        content_sha256=hashlib.sha256(text.encode()).hexdigest(),
        envelope=_envelope(env) if env is not None else None,
        uncertainty=_uncertainty(unc) if unc is not None else None,
        drag=drag,
        ros2_topics=ros2_topics,
        calibration=calibration,
        vertical_law=vertical_law,
    )


# The package that carries the shipped airframes (the checkout's airframes/ folder, pyproject.toml).
SHIPPED_AIRFRAMES_PACKAGE = "dobwind.airframes"


def shipped_airframe_path(name: str) -> Path | None:
    """The shipped airframe called ``name`` ("m300" or "m300.toml"), or None."""
    from importlib import resources

    stem = name.removesuffix(".toml")
    if not stem or Path(stem).name != stem:
        return None
    try:
        entry = resources.files(SHIPPED_AIRFRAMES_PACKAGE) / f"{stem}.toml"
    except ModuleNotFoundError:
        return None
    path = Path(str(entry))
    return path if path.is_file() else None


def resolve_airframe_path(path: str | Path) -> Path:
    """``path`` itself when it exists or names a folder; a bare name with no such file ("m300") is the
    shipped airframe of that name, so `dobwind generate m300` works from any folder (issue #33)."""
    path = Path(path)
    if path.exists() or len(path.parts) != 1:
        return path
    return shipped_airframe_path(path.name) or path


def load_airframe(path: str | Path) -> Airframe:
    path = resolve_airframe_path(path)
    try:
        data = read_bounded(str(path))
    except OSError as exc:
        shipped = "" if len(path.parts) != 1 else " (nor is it the name of a shipped airframe)"
        raise InputError(str(path), None, f"cannot read: {exc.strerror}{shipped}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(str(path), None, "not UTF-8 text" + _log_given_as_airframe(data)) from None
    return parse_airframe(text, str(path))


# The first bytes of the binary logs a user may give where the airframe belongs (the arguments swapped:
# `dobwind replay LOG AIRFRAME`): PX4 ULog's file magic, ArduPilot DataFlash's message header, MCAP's magic.
LOG_MAGIC = ((b"ULog\x01\x12\x35", "a PX4 ULog flight log"), (b"\xa3\x95", "an ArduPilot DataFlash flight log"),
             (b"\x89MCAP", "a ROS 2 bag (MCAP)"), (b"SQLite format 3\x00", "a ROS 2 bag (SQLite)"))


def _log_given_as_airframe(data: bytes) -> str:
    """What to add to "not UTF-8 text" when the bytes are a flight log: the airframe comes first."""
    for magic, what in LOG_MAGIC:
        if data.startswith(magic):
            return f": this is {what}, not an airframe TOML (replay, fit and report take AIRFRAME then LOG)"
    return ""
