"""A TRUE vehicle in its own TOML file, for `dobwind simulate --vehicle`: physics the estimator never sees.

The airframe file says what the user believes (nominal mass, nominal thrust curve, observer gains);
the vehicle file says what the simulated vehicle really does. Its aerodynamics act on the air's
velocity relative to the BODY (the real attitude, tilt included), axis by axis, so a body-y coefficient
acts on body-y airflow whatever the heading. Keys (all SI; every table and key optional except `mass`;
unknown keys are an error):

    mass = 1.4                  # kg, > 0: the real mass (the airframe's `mass` is the nominal one)
    gravity = 9.80665           # m/s^2
    rate = 250.0                # Hz: default sample rate of `simulate` with this vehicle (default 50)

    [drag.x]                    # body-frame drag along FRD x; likewise [drag.y] and [drag.z]
    linear = 0.0                # N per m/s of airflow along this axis
    quadratic = 0.0             # N per (m/s)^2: force = quadratic * |a|^(exponent-1) * a_axis,
    exponent = 2.0              #   |a| the total airspeed relative to the body; 2 is Newtonian drag
                                #   (1 < exponent <= 3; 1.8 is a transitional-Reynolds law)
    [drag]
    speed = "airflow"           # what each axis's quadratic part grows with: "airflow" (|a|, the total
                                #   airspeed: one drag along the airflow, shared out by axis) or "axis"
                                #   (|a_axis|: each axis drags on its own airflow component alone, like
                                #   flat plates or a simulator's per-face drag; force and airflow then
                                #   differ in direction even with equal coefficients)
    reynolds_gain = 0.0         # the quadratic part's Cd is (1 + gain * exp(-|a| / reynolds_speed)):
    reynolds_speed = 3.0        #   m/s; higher drag coefficient at low Reynolds number, smoothly

    [rotor_drag]                # momentum (rotor/blade-flapping) drag, as PX4's EKF2_MCOEF models it
    coefficient = 0.0           # N per m/s of in-plane (body x-y) airflow at hover thrust; scales
                                #   with rotor speed, i.e. sqrt(thrust / weight)

    [shape]                     # on the body x-y drag (not the rotor drag), theta = airflow angle in
    cos1 = 0.0                  #   the body x-y plane: gain 1 + cos1 cos(theta) + cos2 cos(2 theta)
    cos2 = 0.0                  #   (cos1: front/back asymmetry; cos2: front vs side)
    deflection_deg = 0.0        # body x-y force turned off the airflow by this times sin(2 theta)

    [thrust]                    # true thrust = nominal * scale * (1 + shape (T/W - 1)) * inflow term
    scale = 1.0                 # true / nominal thrust curve at hover
    shape = 0.0                 # per unit of thrust-to-weight above 1: the curve's shape error
    inflow_loss = 0.0           # per m/s of axial inflow (air moving down through the discs), clipped +-20 %
    imbalance = 0.0             # rotors alternately this fraction stronger and weaker (rpm logs)

    [sensors]                   # levels as an autopilot's estimator outputs them
    vel_noise = 0.03            # m/s, 1 sigma
    acc_noise = 0.05            # m/s^2, NED acceleration and accelerometer alike
    acc_bias_ned = [0.005, -0.004, 0.006]   # m/s^2
    sf_bias_body = [0.03, -0.02, 0.05]      # m/s^2, accelerometer FRD
    attitude_noise_deg = 0.1
    rpm_noise = 15.0            # rev/min
    thrust_noise = 0.01         # fraction (collective thrust)
    thrust_bias = 0.02          # fraction (collective thrust)
    jitter = 0.1                # of the sample period, 1 sigma
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dobwind.core.errors import InputError
from dobwind.model.airframe import STANDARD_GRAVITY, TableReader
from dobwind.model.inputfiles import read_bounded


@dataclass(frozen=True)
class AxisDrag:
    linear: float = 0.0       # N per m/s
    quadratic: float = 0.0    # N per (m/s)^exponent
    exponent: float = 2.0


@dataclass(frozen=True)
class Sensors:
    vel_noise: float = 0.03
    acc_noise: float = 0.05
    acc_bias_ned: tuple[float, float, float] = (0.005, -0.004, 0.006)
    sf_bias_body: tuple[float, float, float] = (0.03, -0.02, 0.05)
    attitude_noise_deg: float = 0.1
    rpm_noise: float = 15.0
    thrust_noise: float = 0.01
    thrust_bias: float = 0.02
    jitter: float = 0.1


@dataclass(frozen=True)
class VehicleSpec:
    """A vehicle file's contents (see the module text for units)."""
    mass_kg: float
    gravity_mps2: float = STANDARD_GRAVITY
    rate_hz: float = 50.0
    drag: tuple[AxisDrag, AxisDrag, AxisDrag] = (AxisDrag(), AxisDrag(), AxisDrag())
    reynolds_gain: float = 0.0
    reynolds_speed_mps: float = 3.0
    per_axis_speed: bool = False   # [drag] speed = "axis"
    rotor_drag: float = 0.0
    shape_cos1: float = 0.0
    shape_cos2: float = 0.0
    deflection_deg: float = 0.0
    thrust_scale: float = 1.0
    thrust_shape: float = 0.0
    inflow_loss_per_mps: float = 0.0
    rotor_imbalance: float = 0.0
    sensors: Sensors = field(default_factory=Sensors)


def _axis(reader: TableReader | None) -> AxisDrag:
    if reader is None:
        return AxisDrag()
    linear = reader.number("linear", default=0.0)
    quadratic = reader.number("quadratic", default=0.0)
    exponent = reader.number("exponent", default=2.0)
    for key, value in (("linear", linear), ("quadratic", quadratic)):
        if value < 0:
            raise reader.fail(key, f"must be >= 0 (drag opposes the motion), got {value!r}")
    if not 1.0 < exponent <= 3.0:
        raise reader.fail("exponent", f"must be in (1, 3], got {exponent!r}")
    reader.done()
    return AxisDrag(linear, quadratic, exponent)


def _sensors(reader: TableReader | None) -> Sensors:
    if reader is None:
        return Sensors()
    d = Sensors()
    values = {}
    for name in ("vel_noise", "acc_noise", "attitude_noise_deg", "rpm_noise", "thrust_noise", "thrust_bias", "jitter"):
        values[name] = reader.number(name, default=getattr(d, name))
        if name != "thrust_bias" and values[name] < 0:
            raise reader.fail(name, f"must be >= 0, got {values[name]!r}")
    if values["jitter"] >= 0.5:
        raise reader.fail("jitter", "must stay below 0.5 of the sample period (time must increase)")
    for name in ("acc_bias_ned", "sf_bias_body"):
        values[name] = reader.numbers(name, length=3, default=getattr(d, name))
    reader.done()
    return Sensors(**values)


def _non_negative(reader: TableReader, name: str, default: float = 0.0) -> float:
    value = reader.number(name, default=default)
    if value < 0:
        raise reader.fail(name, f"must be >= 0, got {value!r}")
    return value


def parse_vehicle(text: str, source: str) -> VehicleSpec:
    """Validate vehicle TOML text; a bad key raises InputError naming ``source`` and the dotted key."""
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(source, None, f"TOML syntax error: {exc}") from None
    top = TableReader(source, document)
    mass = top.number("mass", positive=True)
    gravity = top.number("gravity", default=STANDARD_GRAVITY, positive=True)
    rate = top.number("rate", default=50.0, positive=True)
    drag = top.table_of("drag", required=False)
    axes = (AxisDrag(), AxisDrag(), AxisDrag())
    reynolds_gain, reynolds_speed, per_axis = 0.0, 3.0, False
    if drag is not None:
        axes = tuple(_axis(drag.table_of(a, required=False)) for a in "xyz")  # type: ignore[assignment]
        reynolds_gain = _non_negative(drag, "reynolds_gain")
        reynolds_speed = drag.number("reynolds_speed", default=3.0, positive=True)
        per_axis = drag.string("speed", choices=("airflow", "axis"), default="airflow") == "axis"
        drag.done()
    rotor = top.table_of("rotor_drag", required=False)
    rotor_drag = 0.0
    if rotor is not None:
        rotor_drag = _non_negative(rotor, "coefficient")
        rotor.done()
    shape = top.table_of("shape", required=False) or TableReader(source, {}, "shape.")
    cos1, cos2 = shape.number("cos1", default=0.0), shape.number("cos2", default=0.0)
    if abs(cos1) + abs(cos2) >= 1.0:
        raise shape.fail("cos1", "|cos1| + |cos2| must stay below 1 (the drag gain must stay positive)")
    deflection = shape.number("deflection_deg", default=0.0)
    shape.done()
    thrust = top.table_of("thrust", required=False) or TableReader(source, {}, "thrust.")
    scale = thrust.number("scale", default=1.0, positive=True)
    thrust_shape = thrust.number("shape", default=0.0)
    inflow = thrust.number("inflow_loss", default=0.0)
    imbalance = _non_negative(thrust, "imbalance")
    if imbalance >= 0.5:
        raise thrust.fail("imbalance", f"must be below 0.5, got {imbalance!r}")
    thrust.done()
    sensors = _sensors(top.table_of("sensors", required=False))
    top.done()
    return VehicleSpec(mass, gravity, rate, axes, reynolds_gain, reynolds_speed, per_axis,  # type: ignore[arg-type]
                       rotor_drag, cos1, cos2, deflection, scale, thrust_shape, inflow, imbalance, sensors)


def load_vehicle(path: str | Path) -> VehicleSpec:
    path = Path(path)
    try:
        text = read_bounded(str(path)).decode("utf-8")
    except OSError as exc:
        raise InputError(str(path), None, f"cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise InputError(str(path), None, "not UTF-8 text") from None
    return parse_vehicle(text, str(path))


def body_force(spec: VehicleSpec, air_body: np.ndarray, thrust_to_weight: np.ndarray) -> np.ndarray:
    """The true aerodynamic force in the body frame (FRD, N) for the air's velocity relative to the
    body (FRD rows, m/s). The force points along the air's relative motion (drag)."""
    speed = np.linalg.norm(air_body, axis=1)
    cd = 1.0 + spec.reynolds_gain * np.exp(-speed / spec.reynolds_speed_mps)
    parts = []
    for i, axis in enumerate(spec.drag):
        # |a|^(p-1) a_i: the axis's share of a drag that grows like |a|^p along the airflow; or, per
        # axis, |a_i|^(p-1) a_i: the axis alone, as if it were a plate facing that component.
        own = np.abs(air_body[:, i]) if spec.per_axis_speed else speed
        grow = np.power(np.maximum(own, 1e-12), axis.exponent - 1.0)
        parts.append(axis.linear * air_body[:, i] + axis.quadratic * cd * grow * air_body[:, i])
    body = np.column_stack(parts)
    theta = np.arctan2(air_body[:, 1], air_body[:, 0])
    gain = 1.0 + spec.shape_cos1 * np.cos(theta) + spec.shape_cos2 * np.cos(2 * theta)
    turn = math.radians(spec.deflection_deg) * np.sin(2 * theta)
    fx, fy = body[:, 0] * gain, body[:, 1] * gain
    c, s = np.cos(turn), np.sin(turn)
    # Rotor drag: in-plane, proportional to rotor speed ~ sqrt(thrust), not shaped by the body.
    rotor = spec.rotor_drag * np.sqrt(np.maximum(thrust_to_weight, 0.0))
    return np.column_stack([c * fx - s * fy + rotor * air_body[:, 0],
                            s * fx + c * fy + rotor * air_body[:, 1], body[:, 2]])


def thrust_factor(spec: VehicleSpec, thrust_to_weight: np.ndarray, inflow_mps: np.ndarray) -> np.ndarray:
    """True thrust / the nominal curve's thrust for the same rotor speeds."""
    shape = 1.0 + spec.thrust_shape * (thrust_to_weight - 1.0)
    return spec.thrust_scale * shape * np.clip(1.0 - spec.inflow_loss_per_mps * inflow_mps, 0.8, 1.2)
