"""The ArduPilot SITL stand-in (benchmarks/vehicles/arducopter.vehicle.toml) against ArduPilot's own formulas,
worked by hand here from the default_model's constants (libraries/SITL/SIM_Frame.h and SIM_Frame.cpp)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks.sitlmodel import DefaultModel, ardupilot_force, compare, derive
from dobwind.model.airframe import load_airframe
from dobwind.simulate.vehicle import body_force, load_vehicle

ROOT = Path(__file__).resolve().parent.parent
VEHICLES = ROOT / "benchmarks" / "vehicles"
G = 9.80665


def _rho_593m_25c() -> float:
    """ArduPilot's density at refAlt 593 m and refTempC 25 C, by hand: geopotential height, the troposphere's
    temperature ratio, pressure ratio theta^(34.163195 / 6.5), ideal gas at 298.15 K with R = 287.26."""
    h = 0.593 * 6369.0 / (0.593 + 6369.0)
    theta = (288.15 - 6.5 * h) / 288.15
    return 101325.0 * theta ** (34.163195 / 6.5) / (287.26 * 298.15)


def _hand_coefficients() -> tuple[float, float]:
    """(quadratic N/(m/s)^2 per axis, momentum drag N/(m/s) at hover) from Frame::init by hand."""
    rho = _rho_593m_25c()
    drag = 3.0 * G * math.tan(math.radians(45.0))                       # 29.42 N
    thrust = 3.0 * G / math.cos(math.radians(45.0))                     # 41.6 N
    momentum = math.cos(math.radians(45.0)) * 0.2 * 15.08 * math.cos(math.radians(45.0)) * math.sqrt(thrust * rho * 0.385)
    area_cd = (drag - momentum) / (0.5 * rho * 15.08 ** 2)
    return 0.5 * rho * area_cd, 0.2 * math.sqrt(3.0 * G * rho * 0.385)


def test_hand_derivation_gives_the_vehicle_files_numbers():
    rho = _rho_593m_25c()
    assert rho == pytest.approx(1.1022, abs=5e-5)
    quadratic, momentum = _hand_coefficients()
    assert quadratic == pytest.approx(0.1015, abs=5e-5) and momentum == pytest.approx(0.7067, abs=5e-5)
    d = derive(DefaultModel())
    assert d.quadratic == pytest.approx(quadratic, rel=1e-9) and d.momentum_at_hover == pytest.approx(momentum, rel=1e-9)
    # hover power 29.3 A x 12.09 V = thrust x outflow / 2: outflow 24.08 m/s; A_eff = m g / (0.5 rho outflow^2)
    outflow = 2 * 29.3 * 12.09 / (3.0 * G)
    assert d.effective_disc_area == pytest.approx(3.0 * G / (0.5 * rho * outflow ** 2), rel=1e-9)


def test_the_file_gives_ardupilots_drag_at_one_airflow():
    """10 m/s along body x at hover thrust: areaCd 0.5 rho v^2 + mdrag v sqrt(m g rho A), all on x."""
    spec = load_vehicle(VEHICLES / "arducopter.vehicle.toml")
    quadratic, momentum = _hand_coefficients()
    expected = quadratic * 100.0 + momentum * 10.0                      # 10.15 + 7.07 = 17.22 N
    force = body_force(spec, np.array([[10.0, 0.0, 0.0]]), np.array([1.0]))[0]
    assert force[0] == pytest.approx(expected, rel=1e-3) and abs(force[1]) < 1e-9 and abs(force[2]) < 1e-9
    assert ardupilot_force(DefaultModel(), np.array([[10.0, 0.0, 0.0]]), np.array([3.0 * G]))[0, 0] == pytest.approx(expected, rel=1e-9)


def test_per_axis_law_on_a_diagonal_and_the_thrust_scaling():
    """Airflow 6 m/s at 45 deg in the body x-y plane: each axis drags on its own component (4.24 m/s), so the
    quadratic part is 1/sqrt(2) of the along-axis one; at twice the hover thrust the momentum part grows
    by sqrt(2)."""
    spec = load_vehicle(VEHICLES / "arducopter.vehicle.toml")
    quadratic, momentum = _hand_coefficients()
    c = 6.0 / math.sqrt(2.0)
    air = np.array([[c, c, 0.0]])
    expected = quadratic * c * c + momentum * math.sqrt(2.0) * c
    force = body_force(spec, air, np.array([2.0]))[0]
    assert force[0] == pytest.approx(expected, rel=1e-3) and force[1] == pytest.approx(expected, rel=1e-3)
    assert ardupilot_force(DefaultModel(), air, np.array([6.0 * G]))[0, 0] == pytest.approx(expected, rel=1e-9)


def test_the_remaining_difference_is_the_z_momentum_drags_thrust_scaling():
    """Level, the laws agree (the file's z momentum drag is fixed at its hover value, the thrust being the
    weight); at 20 deg nose-down with the airflow from the front, body z sees airflow and the file's z term
    is sqrt(cos 20) short of ArduPilot's: under 1 % of the force over 0-15 m/s."""
    spec, model = load_vehicle(VEHICLES / "arducopter.vehicle.toml"), DefaultModel()
    assert compare(spec, model, 0.0, 30.0)["max_share"] < 1e-3
    tilted = compare(spec, model, 20.0, 0.0)
    assert 0.003 < tilted["max_share"] < 0.01


def test_the_airframe_is_the_one_init_makes_from_the_field_log():
    af, spec = load_airframe(VEHICLES / "arducopter.airframe.toml"), load_vehicle(VEHICLES / "arducopter.vehicle.toml")
    assert af.mass_kg == spec.mass_kg == 3.0 and af.thrust.source == "collective"
    assert af.observer.sample_time_s == pytest.approx(1 / spec.rate_hz) == pytest.approx(0.1)
    assert af.observer.acceleration == "ned"


def test_the_density_compensated_variant_differs_in_the_thrust_scale_alone():
    """benchmarks/vehicles/densitycomp: ArduCopter's density ratio at the field log's 25 m crossing, by hand
    from its BARO (94233 Pa, ground 25.53 C) with AP_Baro's formula; every other value the stand-in's."""
    import dataclasses

    base = load_vehicle(VEHICLES / "arducopter.vehicle.toml")
    variant = load_vehicle(VEHICLES / "densitycomp" / "arducopter.vehicle.toml")
    ratio = 94233.0 / (287.26 * (25.53 + 273.15 - 0.0065 * 25.0)) / 1.225
    assert variant.thrust_scale == pytest.approx(1.0 / ratio, abs=5e-4)
    assert dataclasses.replace(variant, thrust_scale=base.thrust_scale) == base


def test_arducopters_density_ratio_is_held_until_the_altitude_moves_25_m():
    """AP_Baro's rule by hand: 1 until 25 m from zero, then recomputed only 25 m from the last computation
    (the DataFlash reader's reconstruction, dobwind/io/densitystep.py)."""
    from dobwind.io.densitystep import applied_ratio as density_ratio

    alt = np.array([0.0, 10.0, 24.9, 25.0, 40.0, 49.9, 50.1, 10.0])
    press = np.linspace(94500.0, 94000.0, len(alt))
    ground = np.full(len(alt), 25.5)
    hand = lambda k: press[k] / (287.26 * (25.5 + 273.15 - 0.0065 * alt[k])) / 1.225
    expected = [1.0, 1.0, 1.0, hand(3), hand(3), hand(3), hand(6), hand(7)]
    assert density_ratio(alt, press, ground) == pytest.approx(expected, rel=1e-12)
    assert 0.85 < hand(3) < 0.92   # about 600 m up on a 25 C day: the field log's 0.897
