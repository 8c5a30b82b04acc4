"""The CasADi step against the independent transcription, and the physics it must get right."""
from __future__ import annotations

import math
import zlib

import casadi as ca
import numpy as np
import pytest

from dobwind.model.discretization import first_order
from dobwind.model.dynamics import coriolis_matrix, rotational_inertia_matrix, wrench_residual
from dobwind.model.status import REJECTED_MASK
from dobwind.model.step import StepModel, build_step
from dobwind.model.airframe import parse_airframe
from dobwind.model.airframe_toml import dumps
from tests import transcription
from tests.flight import accel_inputs, attitude_for, balance, force_for_airflow, thrust_inputs
from tests.helpers import all_modes, make_airframe

MODES = all_modes()


def _model(doc) -> StepModel:
    return build_step(parse_airframe(dumps(doc), "<test>"))


def _random_input(model: StepModel, rng: np.random.Generator) -> dict[str, np.ndarray]:
    af = model.airframe
    tilt = rng.uniform(0, math.radians(af.limits.max_tilt_deg) * 0.95)
    axis = rng.normal(size=2)
    axis /= np.linalg.norm(axis)
    yaw = rng.uniform(-math.pi, math.pi)
    z_b = np.array([math.sin(tilt) * axis[0], math.sin(tilt) * axis[1], math.cos(tilt)])
    q = attitude_for(z_b, yaw) * rng.uniform(0.95, 1.05)  # not exactly unit: the step normalises
    values = {"dt": rng.uniform(0.2, 1.0) * af.limits.max_dt_s, "vel_ned": rng.normal(0, 5, 3), "q": q,
              "yaw_ref": yaw + rng.normal(0, 0.2), "acc_ned": rng.normal(0, 3, 3),
              "specific_force": rng.normal(0, 3, 3) + [0, 0, -9.8], "thrust": rng.uniform(5, 60),
              "rotor_rpm": rng.uniform(0, 9000, af.thrust.rotors or 1)}
    return {f.name: np.asarray(values[f.name], float) for f in model.inputs.fields}


def _random_state(model: StepModel, rng: np.random.Generator) -> dict[str, np.ndarray]:
    state = {f.name: rng.normal(0, 3, f.size) for f in model.state.fields}
    state["initialized"] = np.array([float(rng.random() < 0.8)])
    state["last.wind_speed_h"] = np.array([rng.uniform(0, 15)])
    # A gap (0), inside the settling time, or settled (the cap): every branch of the bookkeeping.
    settle = model.settling_time_s
    state["run_s"] = np.array([rng.choice([0.0, rng.uniform(0, settle), settle])]) * state["initialized"]
    if "check_follows" in state:  # a flag and a mean square
        state["check_follows"] = np.array([float(rng.random() < 0.8)])
        state["acc_noise"] = np.abs(state["acc_noise"])
    return state


def _squeeze(d):
    return {k: (v.item() if np.size(v) == 1 else np.asarray(v, float)) for k, v in d.items()}


@pytest.mark.parametrize("doc", MODES, ids=[d["name"] for d in MODES])
def test_step_matches_independent_transcription(doc):
    model = _model(doc)
    rng = np.random.default_rng(zlib.crc32(doc["name"].encode()))  # stable across processes, unlike hash()
    for trial in range(60):
        state = _random_state(model, rng)
        inp = _random_input(model, rng)
        if trial % 10 == 9:  # a rejected sample now and then
            inp["dt"] = np.array(-0.01)
        x = model.state.pack(state)
        u = model.inputs.pack(inp)
        x_next, y, status = (np.asarray(v).ravel() for v in model.step(x, u))
        ref_state, ref_out, ref_status = transcription.step(model.airframe, _squeeze(state), _squeeze(inp))
        assert int(status[0]) == ref_status
        np.testing.assert_allclose(x_next, model.state.pack(ref_state), rtol=1e-9, atol=1e-9)
        got = model.outputs.unpack(y)
        for name, value in ref_out.items():
            if name == "wind_from_deg":
                diff = (float(got[name][0]) - value + 180.0) % 360.0 - 180.0
                assert abs(diff) < 1e-7
            else:
                np.testing.assert_allclose(got[name], np.atleast_1d(value), rtol=1e-9, atol=1e-9, err_msg=name)


def _run(model: StepModel, rows: list[dict], state: np.ndarray | None = None):
    x = model.initial_state() if state is None else state
    outs = []
    for row in rows:
        x, y, st = model.step(x, model.inputs.pack(row))
        assert int(st) & REJECTED_MASK == 0, f"sample rejected: status {int(st)}"
        outs.append(model.outputs.unpack(np.asarray(y).ravel()))
    return np.asarray(x).ravel(), outs


def _steady_row(model, force_ned, velocity, yaw, dt=None):
    af = model.airframe
    q, u_f = balance(af, np.asarray(force_ned, float), yaw)
    row = {"dt": dt or af.observer.sample_time_s, "vel_ned": np.asarray(velocity, float), "q": q, "yaw_ref": yaw}
    row.update(thrust_inputs(af, u_f))
    row.update(accel_inputs(af, q, np.zeros(3)))
    return row


@pytest.mark.parametrize("doc", MODES[::2], ids=[d["name"] for d in MODES[::2]])
def test_hover_in_still_air_observes_zero_force(doc):
    """Slip 1: the bracket is m p'' - m g0 e3 + u_f z_b; the paper's '- g' would show m g0 of force."""
    model = _model(doc)
    row = _steady_row(model, np.zeros(3), np.zeros(3), 0.7)
    x, outs = _run(model, [row] * 300)
    np.testing.assert_allclose(outs[-1]["force_ned"], 0.0, atol=1e-6)
    np.testing.assert_allclose(model.state.unpack(x)["f_obs"], 0.0, atol=1e-6)


@pytest.mark.parametrize("disc", ["paper", "euler", "zoh", "tustin"])
def test_constant_force_converges_at_the_discrete_pole(disc):
    """Slip 2 too: each axis converges with its own gain of the 3x3 force block."""
    af = make_airframe(**{"observer.discretization": disc, "observer.gains": [10.0, 25.0, 40.0]})
    model = build_step(af)
    force = np.array([3.0, -2.0, 1.5])
    row = _steady_row(model, force, np.zeros(3), 0.0)
    start = model.state.unpack(model.initial_state())
    start["initialized"] = np.array([1.0])  # an observer already running at zero force
    start["run_s"] = np.array([model.settling_time_s])  # ... whose previous sample was accepted
    if "fe_prev" in start:
        start["fe_prev"] = np.zeros(3)
    x = model.state.pack(start)
    dt = af.observer.sample_time_s
    for k in range(1, 40):
        x, _, _ = model.step(x, model.inputs.pack(row))
        f_obs = model.state.unpack(np.asarray(x).ravel())["f_obs"]
        for axis, gain in enumerate(af.observer.gains):
            w = gain / af.mass_kg
            if disc == "tustin":
                c = (w * dt / 2)
                pole, b1 = (1 - c) / (1 + c), c / (1 + c)
                # first step sees x(k-1) = 0, later steps the constant force
                expected = force[axis] * (1 - pole ** k) - force[axis] * b1 * pole ** (k - 1)
            else:
                a = {"paper": dt * w / 2, "euler": dt * w, "zoh": 1 - math.exp(-dt * w)}[disc]
                expected = force[axis] * (1 - (1 - a) ** k)
            assert f_obs[axis] == pytest.approx(expected, rel=1e-10, abs=1e-12)


def test_paper_pole_is_half_the_euler_rate():
    c = first_order("paper", 50.0 / 8.0, 0.01)
    assert c.pole == pytest.approx(1 - 0.01 * 50 / 16)


@pytest.mark.parametrize("doc", MODES[::3], ids=[d["name"] for d in MODES[::3]])
@pytest.mark.parametrize("yaw", [0.0, 2.1])
def test_moving_through_still_air_estimates_zero_wind(doc, yaw):
    """Slip 3: with v_wind = v_rel + v_ground, steady flight in still air reads zero wind."""
    model = _model(doc)
    velocity = np.array([4.0, -3.0, 0.0])
    force = force_for_airflow(model.airframe, -velocity, yaw)  # drag along air minus vehicle velocity
    _, outs = _run(model, [_steady_row(model, force, velocity, yaw)] * 1500)
    np.testing.assert_allclose(outs[-1]["wind_ned"], 0.0, atol=1e-6)


@pytest.mark.parametrize("from_deg", [45.0, 200.0, 300.0])
def test_hovering_in_steady_wind_estimates_that_wind(from_deg):
    """Slips 3 and 4: the wind vector, where it blows from, and the up-positive vertical wind."""
    model = build_step(make_airframe())
    speed, updraft = 6.0, 0.8
    towards = math.radians(from_deg + 180.0)
    wind = np.array([speed * math.cos(towards), speed * math.sin(towards), -updraft])
    yaw = 0.4
    force = force_for_airflow(model.airframe, wind, yaw)
    _, outs = _run(model, [_steady_row(model, force, np.zeros(3), yaw)] * 1500)
    out = outs[-1]
    np.testing.assert_allclose(out["wind_ned"], wind, atol=1e-6)
    assert float(out["wind_from_deg"][0]) == pytest.approx(from_deg, abs=1e-5)
    assert float(out["wind_speed_up"][0]) == pytest.approx(updraft, abs=1e-6)
    assert float(out["wind_speed_h"][0]) == pytest.approx(speed, abs=1e-6)


def test_air_moves_with_the_force_not_against_it():
    """Slip 4: the force angle is where the air goes. A force towards north means air moving north,
    so a hovering vehicle reports wind blowing from the south (180 deg)."""
    model = build_step(make_airframe(**{"observer.force_offset": [0.0, 0.0, 0.0]}))
    _, outs = _run(model, [_steady_row(model, np.array([4.0, 0, 0]), np.zeros(3), 0.0)] * 1500)
    assert float(outs[-1]["wind_ned"][0][0] if np.ndim(outs[-1]["wind_ned"][0]) else outs[-1]["wind_ned"][0]) > 0
    assert float(outs[-1]["wind_from_deg"][0]) == pytest.approx(180.0, abs=1e-6)


def test_delay_matching_hides_manoeuvres_in_still_air():
    """A velocity step in still air (with exactly the drag it causes) must not show up as wind once the
    filters have settled, and the transient must stay far smaller than when the raw ground velocity
    is added to the delayed airflow."""
    af = make_airframe(**{"force_air.horizontal.terms": ["fh", "fh^2"], "force_air.horizontal.coefficients": [0.8, 0.05],
                          "force_air.vertical.terms": ["fz"], "force_air.vertical.coefficients": [0.6],
                          "observer.force_offset": [0.0, 0.0, 0.0]})
    model = build_step(af)
    x = model.initial_state()
    matched, raw = [], []
    for k in range(1200):
        v = np.zeros(3) if k < 300 else np.array([5.0, 0.0, 0.0])
        row = _steady_row(model, force_for_airflow(af, -v, 0.0), v, 0.0)
        x, y, _ = model.step(x, model.inputs.pack(row))
        state = model.state.unpack(np.asarray(x).ravel())
        wind = model.outputs.unpack(np.asarray(y).ravel())["wind_ned"]
        matched.append(np.linalg.norm(wind))
        raw.append(np.linalg.norm(wind - state["v_filt"] + v))
    assert matched[-1] < 1e-4
    assert max(matched) < 0.25 * max(raw)


@pytest.mark.parametrize("mode", ["ned", "specific_force"])
def test_acceleration_bias_is_learned_at_its_time_constant(mode):
    """Hovering in still air with a constant acceleration-input bias b: the bias estimate follows the
    closed form b (1 - exp(-dt/tau)^k) and the force reads zero once it has converged. Without the
    estimate the same flight reads the force m b, which is what the estimate is for."""
    tau, dt = 2.0, 0.02
    bias_ned = np.array([0.05, -0.04, 0.03])
    readings = {}
    for bias_time in (tau, 0.0):
        af = make_airframe(**{"observer.acceleration": mode, "observer.acceleration_bias_time": bias_time,
                              "observer.force_offset": [0.0, 0.0, 0.0]})
        model = build_step(af)
        row = _steady_row(model, np.zeros(3), np.zeros(3), 0.7, dt=dt)
        row.update(accel_inputs(af, row["q"], bias_ned))  # the measured acceleration is the bias alone
        x = model.initial_state()
        for k in range(1, 1501):
            x, y, status = model.step(x, model.inputs.pack(row))
            assert int(status) & REJECTED_MASK == 0
            if bias_time:
                learned = model.state.unpack(np.asarray(x).ravel())["acc_bias"]
                # The first sample only initializes; each later one moves the estimate by 1 - exp(-dt/tau).
                np.testing.assert_allclose(learned, bias_ned * (1 - math.exp(-dt / tau) ** (k - 1)), rtol=1e-9, atol=1e-12)
        readings[bias_time] = model.outputs.unpack(np.asarray(y).ravel())["force_ned"]
    np.testing.assert_allclose(readings[tau], 0.0, atol=1e-5)
    np.testing.assert_allclose(readings[0.0], 2.5 * bias_ned, rtol=1e-6)  # m b, m = 2.5 kg


def test_acceleration_bias_estimate_leaves_real_forces_alone():
    """A real, changing external force moves the acceleration and the velocity together: the bias
    estimate must stay at zero and the force output must equal the one without the estimate."""
    dt = 0.02
    outputs = {}
    for bias_time in (1.5, 0.0):
        af = make_airframe(**{"observer.acceleration_bias_time": bias_time, "observer.force_offset": [0.0, 0.0, 0.0]})
        model = build_step(af)
        level = _steady_row(model, np.zeros(3), np.zeros(3), 0.0, dt=dt)  # level, thrust holding the weight
        x, v, trace = model.initial_state(), np.zeros(3), []
        for k in range(1000):
            force = np.array([2.0 * math.sin(0.9 * k * dt), 1.0 - math.cos(0.4 * k * dt), 0.5 * math.sin(2.0 * k * dt)])
            acc = force / af.mass_kg  # level thrust cancels gravity, so m p'' = f_e
            v = v + acc * dt  # the velocity the step's backward difference turns back into acc
            row = dict(level, vel_ned=v.copy(), acc_ned=acc)
            x, y, _ = model.step(x, model.inputs.pack(row))
            trace.append(model.outputs.unpack(np.asarray(y).ravel())["force_ned"])
        if bias_time:
            assert np.max(np.abs(model.state.unpack(np.asarray(x).ravel())["acc_bias"])) < 1e-10
        outputs[bias_time] = np.array(trace)
    assert np.max(np.abs(outputs[0.0])) > 0.5  # the force did move
    np.testing.assert_allclose(outputs[1.5], outputs[0.0], atol=1e-9)


def test_rejected_sample_leaves_state_and_output_unchanged():
    model = build_step(make_airframe())
    row = _steady_row(model, np.array([1.0, 2.0, 0.0]), np.array([1.0, 0, 0]), 0.3)
    x, outs = _run(model, [row] * 20)
    bad = dict(row)
    bad["vel_ned"] = np.array([np.nan, 0.0, 0.0])
    x2, y2, status = model.step(x, model.inputs.pack(bad))
    assert int(status) & 1
    kept = x.copy()
    kept[model.state.slice("run_s")] = 0.0  # the gap bookkeeping, and nothing else, records the rejection
    assert x[model.state.slice("run_s")][0] > 0
    np.testing.assert_array_equal(np.asarray(x2).ravel(), kept)
    np.testing.assert_array_equal(model.outputs.unpack(np.asarray(y2).ravel())["wind_ned"], outs[-1]["wind_ned"])


@pytest.mark.parametrize("field,value,bit", [
    ("dt", 0.0, 2), ("dt", 1.0, 2), ("dt", np.inf, 1 | 2), ("q", [0.5, 0, 0, 0], 4), ("q", [0, 0, 0, 0], 4), ("q", [np.nan, 0, 0, 1], 1 | 4 | 8),
    ("q", [math.cos(0.6), math.sin(0.6), 0, 0], 8), ("rotor_rpm", [-1.0, 0, 0, 0], 16), ("yaw_ref", 2e6, 1),
])
def test_each_status_bit(field, value, bit):
    model = build_step(make_airframe())
    row = _steady_row(model, np.zeros(3), np.zeros(3), 0.0)
    row[field] = np.asarray(value, float)
    _, _, status = model.step(model.initial_state(), model.inputs.pack(row))
    assert int(status) == bit


def test_rotational_dynamics_coriolis_is_consistent():
    """M' - 2C is skew-symmetric for the Christoffel-symbol Coriolis matrix (energy conservation)."""
    eta, eta_dot = ca.SX.sym("eta", 3), ca.SX.sym("eta_dot", 3)
    inertia = ca.DM(np.diag([0.3, 0.35, 0.6]))
    m = rotational_inertia_matrix(inertia, eta)
    m_dot = ca.jtimes(ca.reshape(m, 9, 1), eta, eta_dot)
    c = coriolis_matrix(inertia, eta, eta_dot)
    f = ca.Function("f", [eta, eta_dot], [ca.reshape(m_dot, 3, 3) - 2 * c])
    rng = np.random.default_rng(3)
    for _ in range(5):
        n = np.asarray(f(rng.normal(size=3) * 0.5, rng.normal(size=3)))
        np.testing.assert_allclose(n + n.T, 0.0, atol=1e-12)


def test_wrench_residual_is_zero_on_the_dynamics_and_needs_six_gains():
    """Slip 2: the wrench observer has six channels (force and torque); the residual of the compact
    form vanishes on a consistent motion with no disturbance and equals the injected wrench."""
    eta, eta_dot, qdd, u, d = (ca.SX.sym(n, k) for n, k in [("eta", 3), ("eta_dot", 3), ("qdd", 6), ("u", 4), ("d", 6)])
    inertia = ca.DM(np.diag([0.3, 0.35, 0.6]))
    residual = wrench_residual(2.0, 9.81, inertia, eta, eta_dot, qdd, u, d)
    assert residual.numel() == 6
    # Forward dynamics: solve residual(qdd) = 0 for qdd with a known disturbance, then check.
    sol = ca.Function("sol", [eta, eta_dot, u, d], [-ca.solve(ca.jacobian(residual, qdd), ca.substitute(residual, qdd, ca.SX.zeros(6)))])
    res = ca.Function("res", [eta, eta_dot, qdd, u, d], [residual])
    rng = np.random.default_rng(4)
    e, ed, uu, dd = rng.normal(size=3) * 0.3, rng.normal(size=3), np.r_[20.0, rng.normal(size=3) * 0.1], rng.normal(size=6)
    q_ddot = sol(e, ed, uu, dd)
    np.testing.assert_allclose(np.asarray(res(e, ed, q_ddot, uu, dd)), 0.0, atol=1e-10)
    # Seen without the disturbance, the residual is the disturbance itself: all six components.
    np.testing.assert_allclose(np.asarray(res(e, ed, q_ddot, uu, np.zeros(6))).ravel(), dd, atol=1e-10)


@pytest.mark.parametrize("coefficients", [(0.0, 0.0, 21.6), (0.0, 1.5, 2.5), (1e-3, 0.2, 4.0, 0.5), (2.0,), (-0.0, 3.0)])
def test_one_rotor_thrust_inverts_as_the_vectorized_bisection_does(coefficients):
    """rpm_for_rotor_thrust of one thrust takes a Python-float bisection (the limit cases ask it ~50 times per
    render): the same bits as the same thrust among others (the numpy bisection), on thrusts inside, at and
    beyond the curve's ends, zeros of both signs, NaN and infinity; and the rpm thrusts what was asked."""
    import math

    from dobwind.model.numeric import rpm_for_rotor_thrust

    rng = np.random.default_rng(7)
    top = sum(coefficients[k] * 2.0 ** k for k in range(len(coefficients)))
    for thrust in [*rng.uniform(0.0, top, 40), -1.0, 0.0, -0.0, top, 2 * top, 1e-300, math.nan, math.inf]:
        alone = rpm_for_rotor_thrust(coefficients, 9000.0, np.array([thrust]))
        among = rpm_for_rotor_thrust(coefficients, 9000.0, np.array([thrust, 0.5 * top]))[:1]
        assert alone.tobytes() == among.tobytes(), thrust
        assert np.asarray(rpm_for_rotor_thrust(coefficients, 9000.0, np.float64(thrust))).tobytes() == alone.tobytes()
        if coefficients[0] < thrust < top and len(coefficients) > 1:  # inside the curve's range
            omega = alone[0] / 9000.0
            assert sum(c * omega ** k for k, c in enumerate(coefficients)) == pytest.approx(thrust, rel=1e-9)
