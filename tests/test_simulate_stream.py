"""`simulate` a block of rows at a time: the log is the same whatever the block size."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.simulate.simulate import SCENARIOS, simulate, simulate_blocks, write_log
from dobwind.simulate.vehicle import load_vehicle
from tests.helpers import M300, ROOT, airframe_dict, collective


def _joined(blocks) -> dict[str, np.ndarray]:
    blocks = list(blocks)
    return {k: np.concatenate([b[k] for b in blocks]) for k in blocks[0]}


def _same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> bool:
    return list(a) == list(b) and all(np.array_equal(a[k], b[k]) for k in a)


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_blocks_join_to_the_single_pass_log(scenario):
    """simulate() of these short logs is one block; 97-row blocks must give it bit for bit (every random
    channel continues where the previous block stopped, the turbulence filter keeps its state)."""
    af = load_airframe(M300)
    whole = simulate(af, scenario, 5, hold_s=1.0, rate_hz=60.0)
    assert len(whole["t"]) > 3 * 97
    assert _same(_joined(simulate_blocks(af, scenario, 5, 1.0, 60.0, block_rows=97)), whole)


def test_blocks_join_for_a_collective_airframe_and_a_vehicle_file():
    coll = parse_airframe(dumps(collective(airframe_dict())), "<collective>")
    whole = simulate(coll, "outdoor", 2, hold_s=2.0, rate_hz=50.0)
    assert _same(_joined(simulate_blocks(coll, "outdoor", 2, 2.0, 50.0, block_rows=501)), whole)
    folder = ROOT / "benchmarks" / "vehicles"
    af, vehicle = load_airframe(folder / "px4quad.airframe.toml"), load_vehicle(folder / "px4quad.vehicle.toml")
    whole = simulate(af, "sweep", 3, hold_s=0.5, rate_hz=40.0, vehicle=vehicle)
    assert _same(_joined(simulate_blocks(af, "sweep", 3, 0.5, 40.0, vehicle, block_rows=733)), whole)


def test_written_log_does_not_depend_on_the_block_size(tmp_path):
    af = load_airframe(M300)
    write_log(tmp_path / "one.csv", af, "tunnel", 4, hold_s=2.0, rate_hz=100.0)
    rows = write_log(tmp_path / "many.csv", af, "tunnel", 4, hold_s=2.0, rate_hz=100.0, block_rows=389)
    assert rows == 1600
    assert (tmp_path / "one.csv").read_bytes() == (tmp_path / "many.csv").read_bytes()
