"""Optional checks on the real data in ../shared/data (never copied into the project). They skip
where the data is absent; CI has it beside the clone, so there they run."""
from __future__ import annotations

import pytest

from dobwind import realdata


@pytest.fixture(scope="module")
def results():
    if len(realdata.runs(realdata.DEFAULT_DATA)) < 5:
        pytest.skip("the Neural-Fly runs are not beside this checkout")
    return realdata.check()


def test_neural_fly_wind_direction(results):
    for name, r in results["split"].items():
        if r["nominal_mps"] > 0:
            assert abs((r["mean_from_deg"] + 180) % 360 - 180) < 15.0, name


def test_neural_fly_held_out_speed(results):
    held_out = results["split"]["70wind"]
    assert not held_out["trained_on"]
    assert held_out["mean_speed_mps"] == pytest.approx(held_out["nominal_mps"], rel=0.25)
