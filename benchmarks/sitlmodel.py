"""ArduPilot SITL's default multicopter, from its own constants, against benchmarks/vehicles/arducopter.vehicle.toml.

ArduPilot's SITL (libraries/SITL/SIM_Frame.cpp, SIM_Motor.cpp; the default_model of SIM_Frame.h, the
frame ArduCopter's `--model quad` flies without a JSON file) sizes its drag from a reference flight and
applies it per BODY axis: body drag areaCd 0.5 rho v_i |v_i| and momentum drag mdrag_coef v_i
sqrt(|T_z| rho disc_area) on each axis i, v the vehicle's velocity through the air in the body frame and
T_z the rotors' thrust. This module recomputes those numbers (the derivation written in the vehicle file's
comments) and compares the two force laws over 0-15 m/s of airflow, level at hover thrust and tilted 20 deg
at the thrust that holds altitude there, so the stand-in's remaining differences are figures:

    .venv/bin/python -m benchmarks.sitlmodel [--vehicle benchmarks/vehicles/arducopter.vehicle.toml]
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.simulate.vehicle import VehicleSpec, body_force, load_vehicle

VEHICLE = Path(__file__).resolve().parent / "vehicles" / "arducopter.vehicle.toml"
GRAVITY = 9.80665              # ArduPilot's GRAVITY_MSS
ISA_GAS_CONSTANT = 287.26      # J/(kg K), ArduPilot's value
SEA_LEVEL_PRESSURE = 101325.0  # Pa
SEA_LEVEL_TEMPERATURE = 288.15  # K


@dataclass(frozen=True)
class DefaultModel:
    """The default_model of SIM_Frame.h: the fields that shape the forces (units in the names' comments)."""
    mass: float = 3.0            # kg
    ref_speed: float = 15.08     # m/s, refSpd: the reference flight's airspeed ...
    ref_angle_deg: float = 45.0  # ... at this tilt (refAngle)
    ref_voltage: float = 12.09   # V, refVoltage: hover power = ref_current x ref_voltage
    ref_current: float = 29.3    # A, refCurrent
    ref_alt_m: float = 593.0     # m AMSL, refAlt: where the reference density is taken
    ref_temp_c: float = 25.0     # refTempC: the temperature of every density ArduPilot computes
    hover_throttle: float = 0.39  # hoverThrOut
    disc_area: float = 0.385     # m^2, all rotors
    mdrag_coef: float = 0.2      # momentum drag coefficient (no unit)


def air_density(model: DefaultModel, alt_m: float) -> float:
    """ArduPilot's Frame::get_air_density: the standard troposphere's pressure at this altitude (geopotential,
    Earth radius 6369 km) over the gas constant times refTempC (not the standard temperature)."""
    km = alt_m / 1000.0
    h = km * 6369.0 / (km + 6369.0)
    theta = (SEA_LEVEL_TEMPERATURE - 6.5 * h) / SEA_LEVEL_TEMPERATURE
    pressure = SEA_LEVEL_PRESSURE * theta ** (34.163195 / 6.5)
    return pressure / (ISA_GAS_CONSTANT * (273.15 + model.ref_temp_c))


@dataclass(frozen=True)
class Derived:
    """What Frame::init derives from the model (SI units)."""
    rho: float                 # kg/m^3 at refAlt
    reference_drag_n: float    # m g tan(refAngle): the reference flight's horizontal force
    reference_momentum_n: float  # its momentum-drag share
    area_cd: float             # m^2: the body drag's area times Cd, the rest
    quadratic: float           # N/(m/s)^2: areaCd 0.5 rho, per body axis
    momentum_at_hover: float   # N/(m/s): mdrag_coef sqrt(m g rho disc_area), per body axis
    effective_disc_area: float  # m^2: what gives hover thrust at the hover power's outflow speed
    inflow_loss: float         # N/(m/s)^2 of climb: 0.5 rho A_eff


def derive(model: DefaultModel) -> Derived:
    rho = air_density(model, model.ref_alt_m)
    weight = model.mass * GRAVITY
    tilt = math.radians(model.ref_angle_deg)
    drag = weight * math.tan(tilt)
    ref_thrust = weight / math.cos(tilt)
    # the momentum drag acts on the body-x airflow (refSpd cos tilt); cos tilt of it is horizontal
    momentum = math.cos(tilt) * model.mdrag_coef * model.ref_speed * math.cos(tilt) * math.sqrt(ref_thrust * rho * model.disc_area)
    if momentum > drag:
        raise ValueError("momentum drag exceeds the reference drag: ArduPilot rescales mdrag_coef (not transcribed)")
    area_cd = (drag - momentum) / (0.5 * rho * model.ref_speed ** 2)
    outflow = 2.0 * model.ref_current * model.ref_voltage / weight   # hover power = thrust x outflow / 2
    a_eff = weight / (0.5 * rho * outflow ** 2)
    return Derived(rho, drag, momentum, area_cd, 0.5 * rho * area_cd,
                   model.mdrag_coef * math.sqrt(weight * rho * model.disc_area), a_eff, 0.5 * rho * a_eff)


def ardupilot_force(model: DefaultModel, air_body: np.ndarray, thrust_n: np.ndarray) -> np.ndarray:
    """Frame::calculate_forces' drag in the body frame (FRD, N) for the air's velocity relative to the body
    (rows, m/s; ArduPilot's vel_air_bf is its negative, and its drag opposes that, so the force points
    along these rows) at this rotor thrust (N)."""
    d = derive(model)
    momentum = model.mdrag_coef * np.sqrt(np.abs(thrust_n) * d.rho * model.disc_area)
    return d.quadratic * np.abs(air_body) * air_body + momentum[:, None] * air_body


def flights(tilt_deg: float, speeds: np.ndarray, heading_deg: float, weight: float) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal airflow at these speeds, relative to a vehicle pitched nose-down by tilt_deg and holding
    altitude (thrust weight / cos tilt), arriving from heading_deg off the nose: body airflow and thrust."""
    h = math.radians(heading_deg)
    air_level = np.column_stack([-speeds * math.cos(h), -speeds * math.sin(h), np.zeros_like(speeds)])
    t = math.radians(tilt_deg)
    # body axes of a nose-down pitch: x_b = (cos t, 0, sin t), z_b = (-sin t, 0, cos t) in the level frame
    pitch = np.array([[math.cos(t), 0.0, math.sin(t)], [0.0, 1.0, 0.0], [-math.sin(t), 0.0, math.cos(t)]])
    return air_level @ pitch.T, np.full(len(speeds), weight / math.cos(t))


def compare(spec: VehicleSpec, model: DefaultModel, tilt_deg: float, heading_deg: float) -> dict[str, float]:
    """Largest difference of the file's force from ArduPilot's over 0-15 m/s of airflow, in N and as a share
    of ArduPilot's force at the speed where it is largest (speeds under 1 m/s left out of the share)."""
    speeds = np.linspace(0.0, 15.0, 151)
    weight = model.mass * GRAVITY
    air, thrust = flights(tilt_deg, speeds, heading_deg, weight)
    ours = body_force(spec, air, thrust / (spec.mass_kg * spec.gravity_mps2))
    theirs = ardupilot_force(model, air, thrust)
    diff = np.linalg.norm(ours - theirs, axis=1)
    share = diff[speeds >= 1.0] / np.linalg.norm(theirs[speeds >= 1.0], axis=1)
    return {"tilt_deg": tilt_deg, "heading_deg": heading_deg, "max_diff_n": float(diff.max()),
            "max_share": float(share.max()), "force_at_15_n": float(np.linalg.norm(theirs[-1]))}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--vehicle", default=str(VEHICLE))
    args = p.parse_args(argv)
    model, spec = DefaultModel(), load_vehicle(args.vehicle)
    d = derive(model)
    print(f"rho {d.rho:.4f} kg/m^3; reference drag {d.reference_drag_n:.2f} N, momentum share {d.reference_momentum_n:.2f} N; "
          f"areaCd {d.area_cd:.4f} m^2; quadratic {d.quadratic:.4f} N/(m/s)^2; momentum at hover {d.momentum_at_hover:.4f} "
          f"N/(m/s); A_eff {d.effective_disc_area:.4f} m^2; inflow loss {d.inflow_loss:.4f} N/(m/s)^2")
    print("| tilt | airflow from | ArduPilot's force at 15 m/s | largest difference | as a share |")
    print("|---|---|---|---|---|")
    for tilt in (0.0, 20.0):
        for heading in (0.0, 45.0, 90.0):
            r = compare(spec, model, tilt, heading)
            print(f"| {tilt:g} deg | {heading:g} deg off the nose | {r['force_at_15_n']:.2f} N | {r['max_diff_n']:.3f} N "
                  f"| {100 * r['max_share']:.2f} % |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
