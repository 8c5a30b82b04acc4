"""The regrouped body-frame law of the step's Newton steps (model/dragform.py) against the law as the fit
writes it (forceair.body_drag_force, a sum over coefficients) and against a finite-difference Jacobian:
an independent transcription each, so that a term lost or misplaced in the regrouping fails here."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from dobwind.model.dragform import body_law_and_jacobian
from dobwind.model.forceair import DRAG_SPEED_EPS_MPS, DragLaw, body_drag_force

LAWS = {
    "quadratic": DragLaw(0.21, 0.12, l2c=-0.05, q2c=0.018, q1c=0.007, l2s=-0.02, q2s=0.002, lz=3.3, qz=0.36,
                         i1=0.05, i2=0.01, lr=0.19, frame="body"),
    "exponent": DragLaw(0.3, 0.2, l2c=0.04, q2c=-0.03, q1c=0.01, l2s=0.01, q2s=0.02, lz=2.0, qz=0.5, i1=0.02,
                        i2=0.003, lr=0.1, frame="body", exponent=1.7),
    "fourfold": DragLaw(0.1, 0.15, q2c=0.02, q4c=0.03, q4s=-0.01, lz=1.0, qz=0.2, lr=0.05, frame="body"),
    "sparse": DragLaw(0.2, 0.1, lz=1.5, frame="body"),
    "peraxis": DragLaw(0.1, 0.02, q2c=0.03, qax=-0.02, qay=0.12, lz=1.0, qz=0.2, lr=0.05, frame="body"),
    "peraxis-exponent": DragLaw(0.1, 0.02, qax=0.01, qay=0.1, lz=1.0, qz=0.2, frame="body", exponent=1.7),
    "peraxis-y": DragLaw(0.1, 0.0, qay=0.1, lz=1.0, frame="body"),
    # the front/back pair: cos theta couples the axes (a full in-plane block, not a diagonal one)
    "frontback": DragLaw(0.1, 0.02, q1c=0.01, qax=0.025, qay=0.15, qax1c=-0.005, qay1c=-0.03, lz=1.0, qz=0.2,
                         lr=0.05, frame="body"),
    "frontback-exponent": DragLaw(0.1, 0.02, qax1c=0.01, qay1c=-0.02, lz=1.0, qz=0.2, frame="body", exponent=1.7),
}


def _compiled(law: DragLaw) -> ca.Function:
    a, rotor = ca.SX.sym("a", 3), ca.SX.sym("rotor")
    value, jacobian = body_law_and_jacobian(law, a, rotor, DRAG_SPEED_EPS_MPS)
    return ca.Function("law", [a, rotor], [value, jacobian])


def _airflows(n: int = 40) -> np.ndarray:
    rng = np.random.default_rng(5)
    return np.vstack([rng.normal(0, 6, (n, 3)), [[0.0, 0.0, 0.0], [1e-4, 0.0, 2.0], [0.0, -7.0, 0.0]]])


@pytest.mark.parametrize("name", sorted(LAWS))
def test_value_is_the_law_as_fitted(name):
    law, f = LAWS[name], _compiled(LAWS[name])
    for a in _airflows():
        value = np.asarray(f(a, 0.9)[0]).ravel()
        want = np.array(body_drag_force(law, a[0], a[1], a[2], 0.9, DRAG_SPEED_EPS_MPS), float)
        np.testing.assert_allclose(value, want, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", sorted(LAWS))
def test_jacobian_is_the_laws_derivative(name):
    law, f = LAWS[name], _compiled(LAWS[name])
    h = 1e-7  # below the per-axis pair's smoothing of |a_x| near a_x = 0 (dragform.PER_AXIS_EPS_MPS) too
    for a in _airflows():
        jacobian = np.asarray(f(a, 1.1)[1])
        numeric = np.zeros((3, 3))
        for j in range(3):
            step = np.zeros(3)
            step[j] = h
            up = np.array(body_drag_force(law, *(a + step), 1.1, DRAG_SPEED_EPS_MPS), float)
            down = np.array(body_drag_force(law, *(a - step), 1.1, DRAG_SPEED_EPS_MPS), float)
            numeric[:, j] = (up - down) / (2 * h)
        np.testing.assert_allclose(jacobian, numeric, rtol=1e-6, atol=1e-6)
