"""Vehicle files for `dobwind simulate --vehicle`: the loader's refusals and the physics' closed forms."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dobwind.cli.app import main
from dobwind.model.airframe import load_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.simulate.simulate import simulate
from dobwind.simulate.vehicle import AxisDrag, VehicleSpec, body_force, parse_vehicle
from tests.helpers import M300, ROOT

QUIET = {"vel_noise": 0.0, "acc_noise": 0.0, "acc_bias_ned": [0.0, 0.0, 0.0], "sf_bias_body": [0.0, 0.0, 0.0],
         "attitude_noise_deg": 0.0, "rpm_noise": 0.0, "thrust_noise": 0.0, "thrust_bias": 0.0, "jitter": 0.0}


def _vehicle(kx: float, ky: float, kz: float) -> VehicleSpec:
    """Pure linear drag per body axis, perfect sensors, a perfect thrust curve."""
    doc = {"mass": 8.0, "drag": {"x": {"linear": kx}, "y": {"linear": ky}, "z": {"linear": kz}}, "sensors": QUIET}
    return parse_vehicle(dumps(doc), "<test>")


def _force_from_log(cols: dict[str, np.ndarray], mass: float, g: float) -> np.ndarray:
    """The aerodynamic force the logged thrust, attitude and acceleration imply (Newton, NED):
    F = u_f z_b - m g e3 + m a (the collective thrust pushes along -z body; z_b here is +z body)."""
    q = np.column_stack([cols["q_x"], cols["q_y"], cols["q_z"], cols["q_w"]])
    z_b = Rotation.from_quat(q).apply([0.0, 0.0, 1.0])
    acc = np.column_stack([cols["acc_n"], cols["acc_e"], cols["acc_d"]])
    return cols["thrust"][:, None] * z_b - mass * g * np.array([0.0, 0.0, 1.0]) + mass * acc


@pytest.fixture(scope="module")
def collective_m300():
    import dataclasses

    af = load_airframe(M300)
    return dataclasses.replace(af, thrust=dataclasses.replace(af.thrust, source="collective"))


def test_isotropic_linear_drag_gives_force_k_times_airflow(collective_m300):
    """Pure linear drag, the same on every axis: F = k (wind - velocity) at every instant, in any
    attitude, through the simulator's whole inverse dynamics."""
    k = 0.7
    cols = simulate(collective_m300, "outdoor", seed=3, hold_s=6.0, vehicle=_vehicle(k, k, k))
    force = _force_from_log(cols, 8.0, 9.80665)
    air = np.column_stack([cols[f"wind_{a}"] - cols[f"vel_{a}"] for a in "ned"])
    assert np.abs(air).max() > 3.0  # real wind and motion, not a trivial hover
    np.testing.assert_allclose(force, k * air, atol=1e-6 * 8.0 * 9.81)


@pytest.mark.parametrize("yaw_deg,expected_axis", [(90, "y"), (0, "x")])
def test_body_axis_coefficient_acts_on_that_body_axis(collective_m300, yaw_deg, expected_axis):
    """The sweep's wind blows from north. At yaw 0 it meets the nose (body x); after a 90 deg yaw it
    meets the side (body y). The drag per m/s is then that axis's coefficient (z shares it, so the
    tilt does not mix in another one)."""
    kx, ky = 0.2, 0.8
    k = kx if expected_axis == "x" else ky
    vehicle = _vehicle(kx, ky, k)
    cols = simulate(collective_m300, "sweep", seed=1, hold_s=6.0, vehicle=vehicle)
    seg = 8 * 36 + yaw_deg // 10  # the 8 m/s holds, yaw in 10 deg steps
    hold = (cols["segment"] == seg) & (cols["t"] > cols["t"][cols["segment"] == seg][0] + 3.0)
    force = _force_from_log({c: v[hold] for c, v in cols.items()}, 8.0, 9.80665).mean(axis=0)
    air = np.array([np.mean(cols[f"wind_{a}"][hold] - cols[f"vel_{a}"][hold]) for a in "ne"])
    assert air[0] == pytest.approx(-8.0, abs=0.2)
    assert math.hypot(force[0], force[1]) / math.hypot(*air) == pytest.approx(k, rel=0.02)


def test_drag_laws_in_closed_form():
    axis = AxisDrag(linear=0.0, quadratic=0.3, exponent=1.8)
    spec = VehicleSpec(mass_kg=1.0, drag=(axis, AxisDrag(), AxisDrag()))
    air = np.array([[2.0, 0.0, 0.0], [8.0, 0.0, 0.0]])
    np.testing.assert_allclose(body_force(spec, air, np.ones(2))[:, 0], 0.3 * np.array([2.0, 8.0]) ** 1.8)
    # Reynolds-dependent Cd: 1 + g exp(-V/V0), so the ratio to plain quadratic drag is that factor.
    quad = AxisDrag(quadratic=0.3)
    plain = VehicleSpec(mass_kg=1.0, drag=(quad, quad, quad))
    varying = VehicleSpec(mass_kg=1.0, drag=(quad, quad, quad), reynolds_gain=0.6, reynolds_speed_mps=2.5)
    ratio = body_force(varying, air, np.ones(2))[:, 0] / body_force(plain, air, np.ones(2))[:, 0]
    np.testing.assert_allclose(ratio, 1 + 0.6 * np.exp(-np.array([2.0, 8.0]) / 2.5))
    # Rotor drag grows with rotor speed, i.e. the square root of the thrust; it has no z part.
    rotor = VehicleSpec(mass_kg=1.0, rotor_drag=0.2)
    f = body_force(rotor, np.array([[3.0, -1.0, 2.0]] * 2), np.array([1.0, 4.0]))
    np.testing.assert_allclose(f, [[0.6, -0.2, 0.0], [1.2, -0.4, 0.0]])
    # Front/back asymmetry: cos(theta) makes head-on drag exceed tail-on drag by 2 cos1.
    shaped = VehicleSpec(mass_kg=1.0, drag=(AxisDrag(linear=1.0),) * 3, shape_cos1=0.1)
    f = body_force(shaped, np.array([[1.0, 0, 0], [-1.0, 0, 0]]), np.ones(2))
    np.testing.assert_allclose(f[:, 0], [1.1, -0.9])


@pytest.mark.parametrize("text,key", [
    ("mass = 1.0\n[drag.x]\nquadratc = 0.1\n", "drag.x.quadratc: unknown key"),
    ("mass = 1.0\n[drag.y]\nexponent = 0.5\n", "drag.y.exponent: must be in (1, 3]"),
    ("mass = -1.0\n", "mass: must be > 0"),
    ("rate = 50.0\n", "mass: missing required key"),
    ("mass = 1.0\n[sensors]\njitter = 0.7\n", "sensors.jitter: must stay below 0.5"),
    ("mass = 1.0\n[thrust]\nscale = 'x'\n", "thrust.scale: expected a finite number"),
    ("mass = 1.0\n[shape]\ncos1 = 0.6\ncos2 = 0.5\n", "shape.cos1: |cos1| + |cos2| must stay below 1"),
    ("mass = 1.0\nextra = 2\n", "extra: unknown key"),
    ("mass = \n", "TOML syntax error"),
])
def test_bad_vehicle_file_is_one_line_exit_2(tmp_path, capsys, text, key):
    path = tmp_path / "bad.vehicle.toml"
    path.write_text(text)
    out = tmp_path / "log.csv"
    assert main(["simulate", "tunnel", "--vehicle", str(path), "--hold", "1", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and key in err, err
    assert not out.exists()


def test_every_benchmark_vehicle_file_loads_and_simulates(tmp_path):
    folder = ROOT / "benchmarks" / "vehicles"
    names = sorted(p.name.removesuffix(".vehicle.toml") for p in folder.glob("*.vehicle.toml"))
    assert len(names) >= 6
    for name in names:
        out = tmp_path / f"{name}.csv"
        args = ["simulate", "tunnel", "--airframe", str(folder / f"{name}.airframe.toml"),
                "--vehicle", str(folder / f"{name}.vehicle.toml"), "--hold", "0.5", "-o", str(out)]
        assert main(args) == 0, name
        assert out.stat().st_size > 0
