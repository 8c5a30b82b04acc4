"""`dobwind simulate`: synthetic flight logs with known wind, vectorized NumPy.

The vehicle's true aerodynamics are deliberately not the estimator's model: anisotropic drag with a
linear (rotor) and a quadratic (body) part that depends on the airflow's direction relative to the
heading and turns the force slightly off the airflow; a true thrust curve a few percent below the
airframe's nominal one that weakens with axial inflow, with unequal rotors; mean wind plus turbulence;
noise and bias on every sensor channel; timestamp jitter.

Motion is by inverse dynamics: a smooth ground trajectory and heading are chosen, the aerodynamic
force follows from the true model, and attitude and thrust are whatever balances
m p'' = -u_f z_b + m g e3 + f_aero exactly (an ideal position controller). So every log is consistent
physics, and an hour of 50 Hz flight takes seconds.

The log is made a block of rows at a time (``simulate_blocks``; ``write_log`` streams it, so its memory
does not grow with the log): each random channel draws from its own generator, started where one pass
over the whole log would draw that channel's first value, so a seed gives the same log, byte for byte,
whatever the block size, and the same as before the blocks (issue #13).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Iterator

import numpy as np
from scipy.spatial.transform import Rotation

from dobwind.core.errors import InputError
from dobwind.model.airframe import Airframe
from dobwind.model.numeric import rpm_for_rotor_thrust
from dobwind.simulate.vehicle import Sensors, VehicleSpec, body_force, thrust_factor
from dobwind.model.signals import log_signals

SCENARIOS = ("sweep", "vertical", "tunnel", "still-air", "outdoor", "box", "one-heading")


@dataclass(frozen=True)
class TrueVehicle:
    """The simulated vehicle's real physics and sensors (independent of the estimator's model)."""
    mass_kg: float
    gravity_mps2: float
    drag_lin: float            # N per m/s, horizontal (rotor drag)
    drag_quad: float           # N per (m/s)^2, horizontal (body drag)
    drag_lin_z: float
    drag_quad_z: float
    anisotropy_cos1: float = 0.06   # drag x (1 + a1 cos(theta) + a2 cos(2 theta)), theta: airflow vs heading
    anisotropy_cos2: float = 0.15
    deflection_deg: float = 1.0     # force turned off the airflow by this x sin(2 theta)
    thrust_scale: float = 0.97      # true thrust / nominal curve
    inflow_loss_per_mps: float = 0.04
    rotor_imbalance: float = 0.02
    # Sensor errors as an autopilot's estimator outputs them (vibration-polluted, after its filters):
    # NED acceleration from the EKF is bias-corrected; the raw accelerometer keeps a body-frame bias.
    vel_noise: float = 0.03          # m/s
    acc_noise: float = 0.05          # m/s^2, NED and body alike
    acc_bias_ned: tuple[float, float, float] = (0.005, -0.004, 0.006)
    sf_bias_body: tuple[float, float, float] = (0.03, -0.02, 0.05)
    attitude_noise_deg: float = 0.1
    rpm_noise: float = 15.0
    thrust_noise: float = 0.01       # fraction (collective)
    thrust_bias: float = 0.02        # fraction (collective)
    jitter: float = 0.1              # of the sample period (1 sigma)


def true_vehicle(af: Airframe) -> TrueVehicle:
    """A plausible vehicle of the airframe's size: drag areas scale with mass^(2/3)."""
    size = af.mass_kg ** (2.0 / 3.0)
    return TrueVehicle(af.mass_kg, af.gravity_mps2, drag_lin=0.0425 * size, drag_quad=0.02 * size,
                       drag_lin_z=0.06 * size, drag_quad_z=0.035 * size)


@dataclass(frozen=True)
class Segment:
    duration_s: float
    velocity_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw_deg: float = 0.0
    wind_ned: tuple[float, float, float] = (0.0, 0.0, 0.0)
    ramp_s: float = 2.0   # transition from the previous segment's values


@dataclass(frozen=True)
class Scenario:
    name: str
    segments: tuple[Segment, ...]
    turbulence_h: float = 0.0      # m/s, 1 sigma (plus a fraction of the mean speed)
    turbulence_frac: float = 0.0
    turbulence_v: float = 0.0
    turbulence_time_s: float = 2.0
    rate_hz: float = 50.0


def _wind_from(speed: float, from_deg: float, up: float = 0.0) -> tuple[float, float, float]:
    towards = math.radians(from_deg + 180.0)
    return (speed * math.cos(towards), speed * math.sin(towards), -up)


# The scenarios flown in one steady (mean) wind, which `simulate --wind` may set; the others sweep the wind
# through a designed sequence of speeds and have no single wind to replace.
STEADY_WIND_SCENARIOS = ("box", "one-heading", "outdoor")


def scenario(name: str, hold_s: float | None = None, rng: np.random.Generator | None = None,
             wind_ned: tuple[float, float, float] | None = None) -> Scenario:
    """The scenario's segments; ``wind_ned`` (m/s, NED, steady-wind scenarios only) replaces the mean wind the
    seed would draw. The draw is still made, so the same seed flies the same manoeuvres, timing and noise in
    any wind: a flight and its copy at twice the wind differ in the wind alone."""
    scen = _scenario(name, hold_s, rng or np.random.default_rng(0))
    if wind_ned is None:
        return scen
    if name not in STEADY_WIND_SCENARIOS:
        raise InputError("--wind", None, f"{name!r} sweeps its own winds; --wind applies to "
                         f"{', '.join(STEADY_WIND_SCENARIOS)}")
    w = tuple(float(x) for x in wind_ned)
    return dataclasses.replace(scen, segments=tuple(dataclasses.replace(s, wind_ned=w) for s in scen.segments))


def _scenario(name: str, hold_s: float | None, rng: np.random.Generator) -> Scenario:
    if name == "sweep":  # the paper's calibration: yaw 10 deg per hold through a full turn, 0..8 m/s
        hold = hold_s or 20.0
        segs = [Segment(hold, yaw_deg=yaw, wind_ned=_wind_from(speed, 0.0), ramp_s=1.5 if yaw else 3.0)
                for speed in range(0, 9) for yaw in range(0, 360, 10)]
        return Scenario(name, tuple(segs), turbulence_h=0.03, turbulence_frac=0.02, turbulence_time_s=1.0)
    if name == "vertical":  # climbs and descents in still air
        hold = hold_s or 15.0
        segs = [Segment(hold)]
        for speed in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0):
            for sign in (-1, 1):
                yaw = float(rng.uniform(0, 360))
                segs += [Segment(hold, velocity_ned=(0, 0, sign * speed), yaw_deg=yaw), Segment(hold / 2, yaw_deg=yaw)]
        return Scenario(name, tuple(segs))
    if name == "tunnel":  # fixed 60 deg relative wind angle, 3..10 m/s
        hold = hold_s or 20.0
        segs = [Segment(hold, yaw_deg=-60.0, wind_ned=_wind_from(speed, 0.0), ramp_s=3.0) for speed in range(3, 11)]
        return Scenario(name, tuple(segs), turbulence_h=0.03, turbulence_frac=0.02, turbulence_time_s=1.0)
    if name == "still-air":  # hover, fore-aft, left-right, up-down at about 2 m/s
        hold = hold_s or 12.0
        segs = [Segment(hold)]
        for yaw in (0.0, 90.0, 225.0):
            c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
            for v in ((2 * c, 2 * s, 0), (-2 * c, -2 * s, 0), (-2 * s, 2 * c, 0), (2 * s, -2 * c, 0), (0, 0, -2), (0, 0, 2)):
                segs += [Segment(hold, velocity_ned=v, yaw_deg=yaw), Segment(hold / 2, yaw_deg=yaw)]
        return Scenario(name, tuple(segs))
    if name == "outdoor":  # wind with turbulence and an updraft, manoeuvres with yaw changes
        hold = hold_s or 15.0
        from_deg = float(rng.uniform(0, 360))
        speed = float(rng.uniform(3.0, 7.0))
        wind = _wind_from(speed, from_deg, up=0.3)
        segs = []
        for _ in range(16):
            heading = float(rng.uniform(0, 2 * math.pi))
            v = float(rng.choice([0.0, 1.5, 3.0]))
            vz = float(rng.choice([0.0, 0.0, -1.0, 1.0]))
            segs.append(Segment(hold, velocity_ned=(v * math.cos(heading), v * math.sin(heading), vz),
                                yaw_deg=float(rng.uniform(0, 360)), wind_ned=wind, ramp_s=3.0))
        return Scenario(name, tuple(segs), turbulence_h=0.6, turbulence_frac=0.05, turbulence_v=0.25,
                        turbulence_time_s=3.0)
    if name in ("box", "one-heading"):
        return _field_flight(name, hold_s, rng)
    raise InputError("simulate", "SCENARIO", f"unknown scenario {name!r} (one of {', '.join(SCENARIOS)})")


def _field_flight(name: str, hold_s: float | None, rng: np.random.Generator) -> Scenario:
    """A field calibration flight in one steady wind (3-7 m/s from a random direction, light turbulence):
    'box': legs out and back along 4 tracks (8 directions) at 2 and 4 m/s, nose first, with hovers between them (what
    `fit --wind unknown` needs: varied headings and speeds), climbing or descending at 1 m/s between legs (the
    vertical law's calibration); 'one-heading': the same speeds fore and aft
    along one track, the nose never turning (what it must refuse)."""
    hold = hold_s or 8.0
    wind = _wind_from(float(rng.uniform(3.0, 7.0)), float(rng.uniform(0, 360)))
    tracks = np.arange(0.0, 180.0, 45.0) if name == "box" else np.array([float(rng.uniform(0, 360))] * 4)
    segs = [Segment(hold, yaw_deg=float(tracks[0]), wind_ned=wind, ramp_s=3.0)]
    for k, track in enumerate(tracks):
        for speed in (2.0, 4.0):
            for sign in (1.0, -1.0):
                c, s = math.cos(math.radians(track)), math.sin(math.radians(track))
                yaw = float(track) if name == "one-heading" or sign > 0 else float(track) + 180.0
                segs += [Segment(hold, velocity_ned=(sign * speed * c, sign * speed * s, 0.0), yaw_deg=yaw,
                                 wind_ned=wind, ramp_s=2.0),
                         Segment(hold / 2, velocity_ned=(0.0, 0.0, sign), yaw_deg=yaw, wind_ned=wind, ramp_s=2.0)]
    return Scenario(name, tuple(segs), turbulence_h=0.1, turbulence_frac=0.03, turbulence_time_s=1.0)


def _profile(t: np.ndarray, starts: np.ndarray, ramps: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-constant targets joined by raised-cosine ramps: (value, time derivative)."""
    k = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(starts) - 1)
    prev = values[np.maximum(k - 1, 0)]
    cur = values[k]
    s = np.clip((t - starts[k]) / ramps[k], 0.0, 1.0)[:, None]
    in_ramp = ((s > 0) & (s < 1)).astype(float)
    blend = 0.5 * (1 - np.cos(np.pi * s))
    value = prev + (cur - prev) * blend
    rate = (cur - prev) * (0.5 * np.pi * np.sin(np.pi * s) / ramps[k][:, None]) * in_ramp
    return value, rate


def aerodynamic_force(vehicle: TrueVehicle, air_rel_ned: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """The true aerodynamic force (NED) for the air's velocity relative to the vehicle."""
    c, s = np.cos(yaw), np.sin(yaw)
    x = c * air_rel_ned[:, 0] + s * air_rel_ned[:, 1]
    y = -s * air_rel_ned[:, 0] + c * air_rel_ned[:, 1]
    speed = np.hypot(x, y)
    theta = np.arctan2(y, x)
    gain = 1 + vehicle.anisotropy_cos1 * np.cos(theta) + vehicle.anisotropy_cos2 * np.cos(2 * theta)
    magnitude = (vehicle.drag_lin * speed + vehicle.drag_quad * speed * speed) * gain
    direction = theta + math.radians(vehicle.deflection_deg) * np.sin(2 * theta)
    fx, fy = magnitude * np.cos(direction), magnitude * np.sin(direction)
    vz = air_rel_ned[:, 2]
    fz = vehicle.drag_lin_z * vz + vehicle.drag_quad_z * np.abs(vz) * vz
    return np.column_stack([c * fx - s * fy, s * fx + c * fy, fz])


def _refuse_too_many_rows(name: str, total_s: float, rate_hz: float, rows: int) -> None:
    """Checked before any array is allocated: `simulate` (not `write_log`, which streams) holds the
    whole log, and `fit` on such a log needs about 2 KB per row."""
    from dobwind.core.options import SIMULATE_MAX_ROWS

    if rows > SIMULATE_MAX_ROWS:
        raise InputError(name, "--rate/--hold", f"{total_s:g} s at {rate_hz:g} Hz is {rows:,} rows, more than "
                         f"the {SIMULATE_MAX_ROWS:,} allowed (lower --rate or --hold)")


@dataclass(frozen=True)
class _Dynamics:
    """What the ideal position controller did: collective thrust, attitude, and the rotors' state."""
    u_f: np.ndarray            # N, true collective thrust
    rot: Rotation              # body FRD -> NED
    factor: np.ndarray         # true thrust / the nominal curve's, per sample
    logged_thrust: np.ndarray  # N, what a collective-thrust log reports before its noise and bias
    rotor_imbalance: float


def _attitude(need: np.ndarray, yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray, Rotation]:
    """Thrust magnitude, body z axis (NED) and the attitude that deliver `need` (= u_f z_b) at this yaw."""
    u_f = np.linalg.norm(need, axis=1)
    z_b = need / u_f[:, None]
    heading = np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros(len(yaw))])
    y_b = np.cross(z_b, heading)
    y_b /= np.linalg.norm(y_b, axis=1)[:, None]
    x_b = np.cross(y_b, z_b)
    return u_f, z_b, Rotation.from_matrix(np.stack([x_b, y_b, z_b], axis=2))


def _inflow(air_rel: np.ndarray, z_b: np.ndarray) -> np.ndarray:
    """Axial inflow: air moving down through the rotor discs, relative to the vehicle (m/s)."""
    return np.einsum("ij,ij->i", air_rel, z_b)


def _heading_frame_dynamics(vehicle: TrueVehicle, air_rel: np.ndarray, acc: np.ndarray, yaw: np.ndarray) -> _Dynamics:
    """The built-in vehicle: drag in the heading frame, independent of the tilt."""
    m, g = vehicle.mass_kg, vehicle.gravity_mps2
    force = aerodynamic_force(vehicle, air_rel, yaw)
    u_f, z_b, rot = _attitude(m * g * np.array([0, 0, 1.0]) + force - m * acc, yaw)
    factor = np.clip(1 - vehicle.inflow_loss_per_mps * _inflow(air_rel, z_b), 0.8, 1.2) * vehicle.thrust_scale
    return _Dynamics(u_f, rot, factor, u_f, vehicle.rotor_imbalance)


BODY_FIXED_POINT_ITERATIONS = 6  # the tilt changes the body-frame airflow, which changes the force and tilt


def _body_frame_dynamics(spec: VehicleSpec, air_rel: np.ndarray, acc: np.ndarray, yaw: np.ndarray) -> _Dynamics:
    """A vehicle file's physics: the force acts on the body-frame airflow at the REAL attitude, which
    itself balances that force; solved by fixed-point iteration from level flight."""
    m, g = spec.mass_kg, spec.gravity_mps2
    weight = m * g
    u_f, z_b, rot = _attitude(np.tile([0.0, 0.0, weight], (len(yaw), 1)) - m * acc, yaw)
    for _ in range(BODY_FIXED_POINT_ITERATIONS):
        force = rot.apply(body_force(spec, rot.inv().apply(air_rel), u_f / weight))
        u_f, z_b, rot = _attitude(weight * np.array([0, 0, 1.0]) + force - m * acc, yaw)
    factor = thrust_factor(spec, u_f / weight, _inflow(air_rel, z_b))
    # A collective-thrust log reports the autopilot's thrust from its nominal model, i.e. the
    # rotors' true thrust divided by the true/nominal factor.
    return _Dynamics(u_f, rot, factor, u_f / factor, spec.rotor_imbalance)


BLOCK_ROWS = 1 << 15  # rows simulated at a time: about 1 KB each while they are worked on

# The random channels in the order a single pass over the whole log draws them (it draws each channel
# for every row before the next): (name, columns per row; None: the rotor count).
_CHANNELS = (("jitter", 1), ("turbulence", 3), ("attitude", 3), ("velocity", 3), ("acceleration", 3),
             ("specific_force", 3), ("thrust", 1), ("rpm", None))


@dataclass(frozen=True)
class _Plan:
    """What every block of rows needs: the scenario's schedule, the vehicle and its sensors."""
    scen: Scenario
    rows: int
    period: float
    starts: np.ndarray
    ramps: np.ndarray
    sensors: TrueVehicle | Sensors
    builtin: TrueVehicle | None
    vehicle: VehicleSpec | None


def _channel_scales(plan: _Plan) -> dict[str, float]:
    s = plan.sensors
    return {"jitter": s.jitter * plan.period, "turbulence": 1.0, "attitude": math.radians(s.attitude_noise_deg),
            "velocity": s.vel_noise, "acceleration": s.acc_noise, "specific_force": s.acc_noise,
            "thrust": s.thrust_noise, "rpm": s.rpm_noise}


def _channel_generators(rng: np.random.Generator, plan: _Plan, af: Airframe) -> dict[str, np.random.Generator]:
    """One generator per channel, each at the point of the seeded stream where a single pass draws that
    channel's first value: the stream is run through once (in blocks, values discarded) to find them.
    Normal draws do not depend on how they are split into calls, so a block's values are the single
    pass's, and every log is the same whatever the block size."""
    scales = _channel_scales(plan)
    out: dict[str, np.random.Generator] = {}
    for name, width in _CHANNELS:
        if name == "rpm" and not log_signals(af).rotor_speeds:
            continue
        cols = af.thrust.rotors if width is None else width
        out[name] = np.random.Generator(type(rng.bit_generator)())
        out[name].bit_generator.state = rng.bit_generator.state
        for start in range(0, plan.rows, BLOCK_ROWS):
            _draw(rng, name, scales[name], min(BLOCK_ROWS, plan.rows - start), cols)
    return out


def _draw(rng: np.random.Generator, name: str, scale: float, rows: int, cols: int) -> np.ndarray:
    """A channel's draws for ``rows`` rows, shaped as the single pass draws them."""
    if name == "turbulence":
        return rng.standard_normal((rows, 3))
    return rng.normal(0, scale, rows if cols == 1 else (rows, cols))


def _plan(af: Airframe, name: str, rng: np.random.Generator, hold_s: float | None, rate_hz: float | None,
          vehicle: VehicleSpec | None, wind_ned: tuple[float, float, float] | None = None) -> _Plan:
    scen = scenario(name, hold_s, rng, wind_ned)
    builtin = true_vehicle(af) if vehicle is None else None
    sensors: TrueVehicle | Sensors = builtin if builtin is not None else vehicle.sensors  # type: ignore[union-attr]
    rate = rate_hz or (scen.rate_hz if vehicle is None else vehicle.rate_hz)
    durations = np.array([s.duration_s for s in scen.segments])
    total = float(durations.sum())
    n = int(total * rate)
    _refuse_too_many_rows(name, total, rate, n)
    # A ramp ends within its segment: cut off by the next segment's start, it would leave the velocity
    # stepping there (a hold of 2 s against a 3 s ramp), with no acceleration to match.
    ramps = np.array([max(min(s.ramp_s, s.duration_s), 1e-3) for s in scen.segments])
    return _Plan(scen, n, 1.0 / rate, np.concatenate([[0.0], np.cumsum(durations)[:-1]]), ramps, sensors,
                 builtin, vehicle)


def simulate_blocks(af: Airframe, name: str, seed: int = 0, hold_s: float | None = None,
                    rate_hz: float | None = None, vehicle: VehicleSpec | None = None,
                    block_rows: int = BLOCK_ROWS,
                    wind_ned: tuple[float, float, float] | None = None) -> Iterator[dict[str, np.ndarray]]:
    """simulate() a block of rows at a time, in bounded memory; the blocks joined are simulate()'s log
    whatever ``block_rows`` is (the turbulence filter's state is carried from block to block)."""
    rng = np.random.default_rng(seed)
    plan = _plan(af, name, rng, hold_s, rate_hz, vehicle, wind_ned)
    gens = _channel_generators(rng, plan, af)
    scales = _channel_scales(plan)
    a = math.exp(-plan.period / plan.scen.turbulence_time_s)
    state = np.zeros((1, 3))
    for start in range(0, plan.rows, block_rows):
        rows = min(block_rows, plan.rows - start)
        cols, state = _block(af, plan, gens, scales, start, rows, a, state)
        yield cols


def _block(af: Airframe, plan: _Plan, gens: dict[str, np.random.Generator], scales: dict[str, float],
           start: int, rows: int, a: float, state: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Rows start .. start + rows of the log, and the turbulence filter's state after them."""
    scen, period = plan.scen, plan.period
    jitter = gens["jitter"].normal(0, scales["jitter"], rows)
    t = np.arange(start, start + rows) * period + np.clip(jitter, -0.3 * period, 0.3 * period)
    if start == 0:
        t[0] = 0.0
    starts, ramps = plan.starts, plan.ramps
    vel, acc = _profile(t, starts, ramps, np.array([s.velocity_ned for s in scen.segments], dtype=float))
    yaw_targets = np.unwrap(np.radians([s.yaw_deg for s in scen.segments]))
    yaw = _profile(t, starts, ramps, yaw_targets[:, None])[0][:, 0]
    wind_mean, _ = _profile(t, starts, ramps, np.array([s.wind_ned for s in scen.segments], dtype=float))
    mean_speed = np.hypot(wind_mean[:, 0], wind_mean[:, 1])
    sigma = np.column_stack([scen.turbulence_h + scen.turbulence_frac * mean_speed] * 2
                            + [np.full(rows, scen.turbulence_v)])
    white = gens["turbulence"].standard_normal((rows, 3)) * math.sqrt(1 - a * a)
    unit, state = gauss_markov(white, a, state)  # first-order Gauss-Markov per axis
    wind = wind_mean + unit * sigma
    if plan.builtin is not None:
        dyn, g = _heading_frame_dynamics(plan.builtin, wind - vel, acc, yaw), plan.builtin.gravity_mps2
    else:
        dyn, g = _body_frame_dynamics(plan.vehicle, wind - vel, acc, yaw), plan.vehicle.gravity_mps2  # type: ignore[arg-type,union-attr]
    cols: dict[str, np.ndarray] = {"t": t, "segment": np.searchsorted(starts, t, side="right") - 1}
    cols.update(_sensor_columns(af, plan.sensors, dyn, vel, acc, g, gens, scales))
    cols["yaw_ref"] = np.angle(np.exp(1j * yaw))
    for i, axis in enumerate("ned"):
        cols[f"wind_{axis}"] = wind[:, i]
    return cols, state


def gauss_markov(white: np.ndarray, a: float, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """scipy.signal.lfilter([1.0], [1.0, -a], white, axis=0, zi=state) (white: rows x axes, state: 1 x axes),
    the same bits: its direct form II transposed recursion written out with the same operations in the same
    order (y = x * b0 + z, z = x * b1 - y * a1 with b0 = 1, b1 = 0, a1 = -a), in Python floats (IEEE double,
    as the C). Written here because importing scipy.signal takes 1.2 s (scipy 1.17, on this machine), most
    of a short `dobwind simulate`; the loop takes about 11 ms per 32,768-row block of three axes.
    tests/test_simulate_stream.py compares it with lfilter bit for bit."""
    out = np.empty_like(white)
    z_out = []
    for axis, (column, z) in enumerate(zip(white.T.tolist(), state[0].tolist())):
        ys = []
        for x in column:
            y = x * 1.0 + z
            z = x * 0.0 - y * -a
            ys.append(y)
        out[:, axis] = ys
        z_out.append(z)
    return out, np.array([z_out])


def simulate(af: Airframe, name: str, seed: int = 0, hold_s: float | None = None,
             rate_hz: float | None = None, vehicle: VehicleSpec | None = None,
             wind_ned: tuple[float, float, float] | None = None) -> dict[str, np.ndarray]:
    """Log columns (docs/formats.md, flight log) plus `segment`, for the scenario; the true vehicle is
    `vehicle` (a vehicle file), or by default one of the airframe's size (`true_vehicle`)."""
    blocks = list(simulate_blocks(af, name, seed, hold_s, rate_hz, vehicle, wind_ned=wind_ned))
    return {k: np.concatenate([b[k] for b in blocks]) for k in blocks[0]}


def _sensor_columns(af: Airframe, sensors: TrueVehicle | Sensors, dyn: _Dynamics, vel: np.ndarray, acc: np.ndarray,
                    g: float, gens: dict[str, np.random.Generator], scales: dict[str, float]) -> dict[str, np.ndarray]:
    """What the autopilot logs: every channel with its noise and bias (each from its own generator)."""
    n = len(vel)
    rot = dyn.rot
    noisy_rot = Rotation.from_rotvec(gens["attitude"].normal(0, scales["attitude"], (n, 3))) * rot
    xyzw = noisy_rot.as_quat()
    xyzw *= np.sign(xyzw[:, 3:4] + 1e-12)  # scalar part non-negative, a common logging convention
    cols: dict[str, np.ndarray] = {}
    v_meas = vel + gens["velocity"].normal(0, scales["velocity"], (n, 3))
    a_meas = acc + np.asarray(sensors.acc_bias_ned) + gens["acceleration"].normal(0, scales["acceleration"], (n, 3))
    sf = (rot.inv().apply(acc - g * np.array([0, 0, 1.0])) + np.asarray(sensors.sf_bias_body)
          + gens["specific_force"].normal(0, scales["specific_force"], (n, 3)))
    for i, axis in enumerate("ned"):
        cols[f"vel_{axis}"] = v_meas[:, i]
        cols[f"acc_{axis}"] = a_meas[:, i]
    for i, axis in enumerate("xyz"):
        cols[f"sf_{axis}"] = sf[:, i]
    for i, part in enumerate(("q_w", "q_x", "q_y", "q_z")):
        cols[part] = xyzw[:, (3, 0, 1, 2)[i]]
    cols["thrust"] = dyn.logged_thrust * (1 + sensors.thrust_bias) * (1 + gens["thrust"].normal(0, scales["thrust"], n))
    if log_signals(af).rotor_speeds:
        rotors = af.thrust.rotors
        imbalance = 1 + dyn.rotor_imbalance * np.where(np.arange(rotors) % 2 == 0, 1.0, -1.0)
        per_rotor = (dyn.u_f / rotors)[:, None] / (dyn.factor[:, None] * imbalance[None, :])
        rpm = rpm_for_rotor_thrust(af.thrust.coefficients, af.thrust.max_rpm, per_rotor)
        rpm += gens["rpm"].normal(0, scales["rpm"], rpm.shape)
        for i in range(rotors):
            cols[f"rpm_{i + 1}"] = rpm[:, i]
    return cols


def log_comments(af: Airframe, name: str, seed: int, vehicle_source: str | None = None,
                 wind_ned: tuple[float, float, float] | None = None) -> list[str]:
    truth = ("true vehicle physics differ from the airframe's model" if vehicle_source is None
             else f"true vehicle from {vehicle_source}")
    wind = "" if wind_ned is None else f" --wind {_wind_text(wind_ned)}"
    return [f"dobwind simulate {name} --seed {seed}{wind}: airframe {af.name} (sha256 {af.content_sha256[:12]})",
            f"{truth}; wind_* is the true wind at the vehicle"]


def _wind_text(wind_ned: tuple[float, float, float]) -> str:
    """A NED wind as `--wind` spells it: SPEED@FROM[,UP]."""
    from dobwind.model.forceair import wind_from_deg

    n, e, d = wind_ned
    text = f"{math.hypot(n, e):g}@{float(wind_from_deg(n, e)) % 360.0:g}"
    return text + (f",{-d:g}" if d else "")


def write_log(path, af: Airframe, name: str, seed: int = 0, hold_s: float | None = None,
              rate_hz: float | None = None, vehicle: VehicleSpec | None = None,
              vehicle_source: str | None = None, block_rows: int = BLOCK_ROWS,
              wind_ned: tuple[float, float, float] | None = None) -> int:
    """Simulate a scenario and write it as a flight-log CSV (atomically), a block of rows at a time so
    that memory does not grow with the log; returns the row count."""
    from dobwind.io.logs import CsvWriter, write_atomically

    rows = 0

    def write(handle) -> None:
        nonlocal rows
        writer = None
        for cols in simulate_blocks(af, name, seed, hold_s, rate_hz, vehicle, block_rows, wind_ned):
            names = column_order(cols)
            if writer is None:
                writer = CsvWriter(handle, names, ["%.6f"] + ["%.7g"] * (len(names) - 2) + ["%d"],
                                   log_comments(af, name, seed, vehicle_source, wind_ned))
            writer.write(np.column_stack([cols[n] for n in names]))
            rows += len(cols["t"])

    write_atomically(path, write)
    return rows


def column_order(cols: dict[str, np.ndarray]) -> list[str]:
    first = ["t", "vel_n", "vel_e", "vel_d", "acc_n", "acc_e", "acc_d", "sf_x", "sf_y", "sf_z",
             "q_w", "q_x", "q_y", "q_z"]
    rpm = sorted((c for c in cols if c.startswith("rpm_")), key=lambda c: int(c[4:]))
    return [c for c in first if c in cols] + rpm + ["thrust", "yaw_ref", "wind_n", "wind_e", "wind_d", "segment"]
