"""benchmarks/fieldcross.py's scoring against closed forms (its runs are a benchmark, not a test)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.fieldcross import TESTS, score
from dobwind.model.status import STATUS_LANDED


def _write(path, header: list[str], rows: np.ndarray) -> str:
    lines = ["# a comment line first, as dobwind writes it", ",".join(header)]
    lines += [",".join(f"{v:.9g}" for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
    return str(path)


def test_score_is_the_mean_speed_and_the_mean_vectors_bearing(tmp_path):
    """Truth 4 m/s from the north (wind_n = -4); estimate 4.4 m/s from 10 deg on the accepted rows, and
    a landed row far off that must not count."""
    n = 50
    truth = np.column_stack([np.arange(n) * 0.1, np.full(n, -4.0), np.zeros(n), np.zeros(n)])
    log = _write(tmp_path / "log.csv", ["t", "wind_n", "wind_e", "wind_d"], truth)
    towards = math.radians(190.0)
    est = np.column_stack([truth[:, 0], np.full(n, 4.4 * math.cos(towards)), np.full(n, 4.4 * math.sin(towards)),
                           np.full(n, -0.2), np.zeros(n)])
    est[0, 1:3] = (50.0, 50.0)
    est[0, 4] = STATUS_LANDED
    out = score(log, _write(tmp_path / "est.csv", ["t", "wind_n", "wind_e", "wind_d", "status"], est))
    assert out["accepted_rows"] == n - 1
    assert out["speed_error_mps"] == pytest.approx(0.4, abs=1e-6)
    assert out["direction_error_deg"] == pytest.approx(10.0, abs=1e-4)
    assert out["mean_vertical_up_mps"] == pytest.approx(0.2, abs=1e-6)   # wind_d -0.2: an updraft
    assert out["trusted_share"] == pytest.approx((n - 1) / n)


def test_the_goals_are_the_issues():
    """#36: 0.5 m/s at the calibration's wind speed, 1.0 m/s at twice it."""
    assert {t.speed_factor: t.goal_mps() for t in TESTS} == {1.0: 0.5, 2.0: 1.0}


def test_a_vehicles_flights_do_not_depend_on_which_others_run():
    from benchmarks.fieldcross import calibration_from_deg

    assert calibration_from_deg("m300", 1) == calibration_from_deg("m300", 1)
    assert len({calibration_from_deg(v, 1) for v in ("m300", "px4quad", "racer5", "heavy")}) > 1
    assert calibration_from_deg("m300", 1) != calibration_from_deg("m300", 2)
    assert all(0 <= calibration_from_deg(v, s) <= 360 for v in ("a", "b") for s in range(5))
