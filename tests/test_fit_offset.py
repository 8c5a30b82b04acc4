"""The force offset found from airflow directions alone (fit without zero-airflow data), against a
closed form: with speed = c sqrt(fh) and the force along the airflow, a known offset added to every
force must come back out."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.calibrate.fit import Points, _offset_from_directions, _opposing_directions


def _points(offset: tuple[float, float], speeds: np.ndarray, angles_deg: np.ndarray, c: float = 2.5) -> Points:
    speed, angle = (a.ravel() for a in np.meshgrid(speeds, np.radians(angles_deg)))
    fh = (speed / c) ** 2  # the inverse of speed = c fh^0.5
    m, n = fh * np.cos(angle) + offset[0], fh * np.sin(angle) + offset[1]
    rows = len(speed)
    return Points(m, n, np.zeros(rows), speed, np.zeros(rows), angle, np.arange(rows))


@pytest.mark.parametrize("offset", [(0.3, -0.2), (-0.5, 0.0), (0.0, 0.0)])
def test_the_offset_comes_back_from_the_directions(offset):
    points = _points(offset, np.arange(2.0, 8.1, 1.0), np.arange(0.0, 360.0, 30.0))
    assert _opposing_directions(points)
    assert _offset_from_directions(points) == pytest.approx(offset, abs=2e-3)

