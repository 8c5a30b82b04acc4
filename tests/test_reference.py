"""The Python reference over whole logs equals the step applied sample by sample."""
from __future__ import annotations

import numpy as np

from dobwind.model import reference
from dobwind.model.status import REJECTED_MASK
from dobwind.model.step import build_step
from tests.helpers import make_airframe


def _inputs(model, n, rng):
    af = model.airframe
    values = {
        "dt": np.full(n, af.observer.sample_time_s) * rng.uniform(0.8, 1.2, n),
        "vel_ned": np.cumsum(rng.normal(0, 0.05, (n, 3)), axis=0),
        "acc_ned": rng.normal(0, 0.5, (n, 3)),
        "q": np.tile([0.999, 0.02, -0.03, 0.01], (n, 1)),
        "rotor_rpm": rng.uniform(3000, 5000, (n, af.thrust.rotors)),
        "yaw_ref": np.full(n, 0.3),
    }
    values["dt"][n // 3] = np.nan  # one rejected row in the middle
    return model.inputs.pack(values, rows=n)


def test_rolled_reference_equals_sample_by_sample_steps():
    model = build_step(make_airframe())
    rng = np.random.default_rng(7)
    n = 300
    u = _inputs(model, n, rng)
    traj = reference.run(model, u, rolled=reference.rolled_step(model, 64))  # several chunks, a padded tail
    x = model.initial_state()
    for k in range(n):
        x, y, st = model.step(x, u[k])
        np.testing.assert_array_equal(np.asarray(x).ravel(), traj.states[k])
        np.testing.assert_array_equal(np.asarray(y).ravel(), traj.outputs[k])
        assert int(st) == traj.status[k]
    accepted = (traj.status & REJECTED_MASK) == 0
    assert not accepted[n // 3] and np.all(np.delete(accepted, n // 3))


def test_state_carries_across_calls():
    model = build_step(make_airframe())
    u = _inputs(model, 200, np.random.default_rng(8))
    whole = reference.run(model, u)
    first = reference.run(model, u[:77])
    second = reference.run(model, u[77:], state0=first.states[-1])
    np.testing.assert_array_equal(np.vstack([first.outputs, second.outputs]), whole.outputs)


def test_in_place_evaluation_equals_calling_the_function_dense_or_sparse():
    """The rolled step is evaluated in numpy buffers when its inputs and outputs are dense; a function
    with a structural zero is called the ordinary way. Both give what calling the Function gives."""
    import casadi as ca

    x, u = ca.SX.sym("x", 2), ca.SX.sym("u", 3, 5)
    dense = ca.Function("dense", [x, u], [ca.repmat(x, 1, 5) + u[:2, :], ca.sin(u), u[2, :] * 2])
    sparse = ca.Function("sparse", [x, u], [ca.vertcat(u[0, :] + x[0], ca.SX(1, 5)), ca.sin(u), u[2, :] * 2])
    assert not sparse.sparsity_out(0).is_dense()
    rng = np.random.default_rng(4)
    state, block = rng.normal(size=2), rng.normal(size=(4, 3))  # 4 rows: the fifth is padding
    for f in (dense, sparse):
        got = reference._BoundChunk(f, 3)(state, block, dt_col=1)
        padded = np.vstack([block, [0.0, -1.0, 0.0]])
        want = [np.asarray(r).T for r in f(state, padded.T)]
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
        assert np.array_equal(got[2], want[2][:, 0]), f.name()


def test_run_columns_keeps_exactly_those_columns_of_the_run():
    model = build_step(make_airframe())
    u = _inputs(model, 300, np.random.default_rng(8))
    rolled = reference.rolled_step(model, 64)
    whole = reference.run(model, u, rolled=rolled)
    states, outputs = model.state.slice("v_filt"), model.outputs.slice("force_ned")
    part = reference.run_columns(model, u, states, outputs, rolled=rolled)
    assert part.states.shape == (300, 3) and part.outputs.shape == (300, 3)
    np.testing.assert_array_equal(part.states, whole.states[:, states])
    np.testing.assert_array_equal(part.outputs, whole.outputs[:, outputs])
    np.testing.assert_array_equal(part.status, whole.status)
    assert reference.run_columns(model, u, slice(0, 0), outputs, rolled=rolled).states.shape == (300, 0)
