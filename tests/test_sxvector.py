"""The SX algorithm evaluated on NumPy arrays (model/sxvector.py) against CasADi's own evaluation, and
the drag laws' NumPy inversions built once on symbolic coefficients against the expressions built on
each numeric law (what they replaced)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dobwind.model import forceair
from dobwind.model.forceair import DragLaw, body_drag_airflow_numpy, drag_airflow_numpy
from dobwind.model.sxvector import VectorFunction


def _every_supported_operation() -> ca.Function:
    x, y, p = ca.SX.sym("x", 2), ca.SX.sym("y"), ca.SX.sym("p")
    a, b = x[0], x[1]
    outputs = [a + b, a - y, a * p, a / b, -a, ca.sqrt(ca.fabs(a)), a * a, 2 * a, ca.sign(b), 1 / b,
               ca.fmin(a, y), ca.fmax(a, y), ca.copysign(a, b), ca.if_else(a < y, a, 0.0),
               a <= b, a == y, a != b, ca.logic_not(a < 0), ca.logic_and(a < 0, b < 0), ca.logic_or(a < 0, b < 0),
               ca.jacobian(ca.fmax(a * b, y) + ca.fabs(a) * ca.sqrt(b * b + 1), x).T]
    return ca.Function("ops", [x, y, p], [ca.vertcat(*outputs)])


def test_every_supported_operation_equals_casadi_bit_for_bit():
    f = _every_supported_operation()
    rng = np.random.default_rng(3)
    rows = 400
    x = rng.normal(0, 3, (2, rows))
    x[:, :20] = 0.0                        # ties and zeros: sign, comparisons, the fmax derivative
    x[0, 20:30] = np.inf
    x[1, 30:40] = np.nan                   # NaN flows through as in CasADi's VM
    y = np.round(rng.normal(0, 3, (1, rows)))
    p = np.array([1.7])                    # one value for every row
    theirs = np.asarray(f.map(rows)(x, y, p))
    ours = VectorFunction(f)([x, y, p], rows)[0]
    assert theirs.shape == ours.shape
    np.testing.assert_array_equal(ours, theirs)


def test_an_unsupported_operation_is_refused():
    x = ca.SX.sym("x")
    with pytest.raises(ValueError, match="not supported"):
        VectorFunction(ca.Function("s", [x], [ca.sin(x)]))


def _rebuilt_heading(law: DragLaw, force: np.ndarray) -> np.ndarray:
    m, n, z = ca.SX.sym("m"), ca.SX.sym("n"), ca.SX.sym("z")
    f = ca.Function("d", [m, n, z], [ca.vertcat(*forceair.drag_airflow(law, m, n, z))])
    return np.asarray(f.map(len(force))(force[:, 0], force[:, 1], force[:, 2])).T


def _rebuilt_body(law: DragLaw, force: np.ndarray, rot: np.ndarray, rotor: np.ndarray) -> np.ndarray:
    sf, sr, sq = ca.SX.sym("f", 3), ca.SX.sym("rot", 9), ca.SX.sym("rotor")
    f = ca.Function("b", [sf, sr, sq], [forceair.body_drag_airflow(law, sf, ca.reshape(sr, 3, 3), sq)])
    flat = np.transpose(rot, (0, 2, 1)).reshape(len(rot), 9)
    return np.asarray(f.map(len(force))(force.T, flat.T, rotor[None, :])).T


def _forces(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    force = rng.normal(0, 2, (n, 3))
    force[:5] = 0.0  # zero force: the inversions' floors
    rot = Rotation.from_euler("ZYX", rng.uniform(-0.7, 0.7, (n, 3))).as_matrix()
    return force, rot, np.sqrt(rng.uniform(0.7, 1.6, n))


EVERY_TERM = dict(l0=0.2, q0=0.08, l2c=0.03, q2c=0.01, q1c=0.004, l2s=-0.02, q2s=-0.005, lz=0.3, qz=0.1,
                  i1=0.02, i2=0.01)
SPARSE = dict(l0=0.3, q0=0.0, lz=0.5, qz=0.05)


def test_heading_inversion_equals_the_expression_built_on_the_law():
    force, _, _ = _forces(300, 5)
    full = DragLaw(**EVERY_TERM)
    # Every coefficient nonzero and distinct: the same expression, so the same numbers (and each
    # coefficient is read from its own key).
    np.testing.assert_array_equal(drag_airflow_numpy(full, *force.T), _rebuilt_heading(full, force))
    # Zero coefficients: their terms add an exact 0 instead of being dropped; CasADi simplifies the
    # rebuilt expression differently, so they agree to round-off.
    sparse = DragLaw(**SPARSE)
    np.testing.assert_allclose(drag_airflow_numpy(sparse, *force.T), _rebuilt_heading(sparse, force),
                               rtol=1e-12, atol=1e-14)


def test_body_inversion_equals_the_expression_built_on_the_law():
    force, rot, rotor = _forces(300, 6)
    full = DragLaw(**EVERY_TERM, lr=0.15, frame="body")
    np.testing.assert_array_equal(body_drag_airflow_numpy(full, force, rot, rotor), _rebuilt_body(full, force, rot, rotor))
    sparse = DragLaw(**SPARSE, lr=0.1, frame="body")
    np.testing.assert_allclose(body_drag_airflow_numpy(sparse, force, rot, rotor),
                               _rebuilt_body(sparse, force, rot, rotor), rtol=1e-12, atol=1e-14)

