"""benchmarks/lawreach.py: the best law of a term set on a vehicle's true level force, inverted by the step."""
from __future__ import annotations

import re

import numpy as np
import pytest

from benchmarks import lawreach

ISOTROPIC = """mass = 2.0
[drag.x]
linear = 0.1
quadratic = 0.05
[drag.y]
linear = 0.1
quadratic = 0.05
"""


def _figures(line: str) -> tuple[float, float, float]:
    found = re.search(r"direction mean +([\d.]+) max +([\d.]+) deg; speed RMS ([\d.a-z]+) m/s", line)
    assert found, line
    return float(found[1]), float(found[2]), float(found[3])


def _force(text: str, tmp_path) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    from dobwind.simulate.vehicle import body_force, load_vehicle

    path = tmp_path / "v.vehicle.toml"
    path.write_text(text)
    airflow, theta, speed = lawreach.grid()
    force = body_force(load_vehicle(path), np.column_stack([airflow, 0 * speed]), np.ones(len(speed)))[:, :2]
    return airflow, theta, speed, force


def test_an_isotropic_body_is_met_exactly_by_the_isotropic_law(tmp_path):
    airflow, theta, speed, force = _force(ISOTROPIC, tmp_path)
    law, residual = lawreach.fitted_law(("l0", "q0"), airflow, force)
    assert law.l0 == pytest.approx(0.1) and law.q0 == pytest.approx(0.05) and residual < 1e-9
    mean, worst, rms = _figures(lawreach.reach_line(("l0", "q0"), airflow, theta, speed, force))
    assert worst < 0.01 and rms < 1e-3


def test_a_direction_only_the_harmonics_hold_is_missed_by_the_isotropic_law(tmp_path):
    """Side drag 3x the frontal (per axis, on the total airflow): the isotropic law reads directions tens of
    degrees off; the 2-theta law holds it exactly (per-axis drag on the total airflow is l2s = -l2c, q2s = -q2c)."""
    text = ISOTROPIC.replace("[drag.y]\nlinear = 0.1\nquadratic = 0.05", "[drag.y]\nlinear = 0.3\nquadratic = 0.15")
    airflow, theta, speed, force = _force(text, tmp_path)
    _, iso_worst, _ = _figures(lawreach.reach_line(("l0", "q0"), airflow, theta, speed, force))
    _, harm_worst, _ = _figures(lawreach.reach_line(lawreach.SETS[1], airflow, theta, speed, force))
    assert iso_worst > 20.0 and harm_worst < 0.01, (iso_worst, harm_worst)
