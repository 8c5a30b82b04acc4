"""Random benchmark vehicles: valid files, reproducible by seed, spread over the ranges they claim."""
from __future__ import annotations

import math

import numpy as np

from benchmarks.accuracy import available_vehicles, parse_config
from benchmarks.accuracy_family import GAIN_PER_KG, GRAVITY_MPS2, write_random_vehicles
from dobwind.model.airframe import load_airframe
from dobwind.simulate.vehicle import load_vehicle


def test_vehicles_load_and_are_reproducible_by_seed(tmp_path):
    names = write_random_vehicles(tmp_path / "a", 5, 40)
    assert available_vehicles(tmp_path / "a") == tuple(sorted(names)) and len(names) == 40
    write_random_vehicles(tmp_path / "b", 5, 40)
    for name in names:
        for kind in ("vehicle", "airframe"):
            assert (tmp_path / "a" / f"{name}.{kind}.toml").read_bytes() == (tmp_path / "b" / f"{name}.{kind}.toml").read_bytes()
    write_random_vehicles(tmp_path / "c", 6, 1)
    assert (tmp_path / "c" / "rand6_0.vehicle.toml").read_text() != (tmp_path / "a" / "rand5_0.vehicle.toml").read_text()

    masses, sources, modes, rates, per_axis = [], set(), set(), set(), []
    for name in names:
        spec = load_vehicle(tmp_path / "a" / f"{name}.vehicle.toml")
        af = load_airframe(tmp_path / "a" / f"{name}.airframe.toml")   # the loader's own range checks
        masses.append(spec.mass_kg)
        assert 0.03 <= spec.mass_kg <= 25.0 and abs(af.mass_kg / spec.mass_kg - 1) <= 0.02
        assert af.observer.sample_time_s == 1.0 / spec.rate_hz
        assert np.allclose(af.observer.gains, GAIN_PER_KG * af.mass_kg)
        x, y, _ = spec.drag
        assert 0.8 <= y.quadratic / x.quadratic <= 1.5
        assert 0.02 * spec.mass_kg <= spec.rotor_drag <= 0.2 * spec.mass_kg
        if af.thrust.source == "rpm":   # hover near 45-65 % of max rpm: c1 x + c2 x^2 = weight per rotor
            _, c1, c2 = af.thrust.coefficients
            share = (-c1 + math.sqrt(c1 ** 2 + 4 * c2 * af.mass_kg * GRAVITY_MPS2 / af.thrust.rotors)) / (2 * c2)
            assert 0.45 - 1e-9 <= share <= 0.65 + 1e-9
        sources.add(af.thrust.source)
        modes.add(af.observer.acceleration)
        rates.add(spec.rate_hz)
        per_axis.append(spec.per_axis_speed)
    assert min(masses) < 0.3 and max(masses) > 5.0          # log-uniform over 0.03-25 kg
    assert sources == {"rpm", "collective"} and modes == {"velocity", "ned", "specific_force"}
    assert rates == {50.0, 100.0, 200.0, 250.0, 500.0}
    assert 8 <= sum(per_axis) <= 24                          # 40 % of 40 draws: per-axis drag speed


def test_the_benchmark_runs_the_drawn_vehicles_from_the_output_folder(tmp_path):
    config = parse_config(["--random", "3", "--random-seed", "9", "-o", str(tmp_path / "out")])
    assert config.vehicle_dir == tmp_path / "out" / "random_vehicles"
    assert config.vehicles == ("rand9_0", "rand9_1", "rand9_2") and not config.rates
