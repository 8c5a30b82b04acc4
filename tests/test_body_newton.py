"""The body-frame step's tracked inversion converges at the order its steps promise.

From a previous airflow a small offset d away from the solution, the step takes one Newton step
(error of order d^2) and one chord step with that Jacobian (error of order d times the Newton step's,
d^3). Halving d must then divide the error by about 8. A step that is only nearly Newton (its
correction scaled by 1 + c, or a wrong Jacobian) leaves an error of order c d, which halving d only
halves: the round-trip tests of tests/test_body_drag.py, within a tolerance, do not see a 1 % error in
the correction; the order does. Double precision: the smallest error here, 4e-10 to 7e-10 m/s, is far above
its rounding.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from dobwind.model.forceair import DragLaw, body_drag_airflow_tracking, body_law_at

LAWS = {
    "quadratic, every in-plane term": DragLaw(0.2, 0.08, 0.03, 0.01, 0.004, -0.02, -0.005, 0.3, 0.1, 0.02, 0.01,
                                              lr=0.15, frame="body"),
    "per-axis body drag": DragLaw(0.05, 0.1, l2c=-0.006, q2c=-0.0125, l2s=0.006, q2s=0.0125, lz=0.12, qz=0.2,
                                  frame="body"),
}
SOLUTION = np.array([6.0, -3.0, 1.5])  # body-frame airflow, m/s
DIRECTION = np.array([0.6, 0.48, -0.64])  # unit vector of the previous airflow's offset


def _tracked_error(law: DragLaw, offset: float) -> float:
    """|tracked airflow - solution| (m/s) for the force the law gives at SOLUTION, from a previous
    airflow ``offset`` m/s away from it (level attitude, rotor term 1)."""
    a, rotor = ca.SX.sym("a", 3), ca.SX(1.0)
    force = ca.Function("force", [a], [body_law_at(law, a, rotor)])(SOLUTION)
    previous = ca.SX.sym("previous", 3)
    step = ca.Function("tracked", [previous], [body_drag_airflow_tracking(
        law, ca.SX(force), ca.SX.eye(3), rotor, previous, ca.SX(1))[1]])
    return float(np.linalg.norm(np.asarray(step(SOLUTION + offset * DIRECTION)).ravel() - SOLUTION))


@pytest.mark.parametrize("name", LAWS)
def test_newton_then_chord_converges_at_third_order(name):
    law = LAWS[name]
    assert law.newton_steps(2) == 2  # one Newton step and one chord step
    errors = [_tracked_error(law, d) for d in (0.02, 0.01, 0.005)]
    assert 1e-12 < errors[-1] < 1e-5  # converging, and far from double rounding
    for coarse, fine in zip(errors, errors[1:]):
        assert 6.0 < coarse / fine < 10.0, errors
