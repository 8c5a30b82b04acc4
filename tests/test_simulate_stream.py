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


def test_a_set_wind_changes_the_wind_alone():
    """`simulate --wind`: the seed still draws the manoeuvres, timing and noise, so the flight at a set wind is
    the seed's own flight with every wind sample moved by the difference of the means (closed form: the
    turbulence is the same draw about either mean, a fraction of the mean speed apart)."""
    from dobwind.simulate.simulate import scenario

    af = load_airframe(M300)
    drawn = scenario("box", 1.0, np.random.default_rng(7))
    own = drawn.segments[0].wind_ned
    set_ned = (0.0, -6.0, -0.5)   # 6 m/s from the east, 0.5 m/s updraft
    base = simulate(af, "box", 7, hold_s=1.0, rate_hz=40.0)
    moved = simulate(af, "box", 7, hold_s=1.0, rate_hz=40.0, wind_ned=set_ned)
    for col in ("t", "yaw_ref", "segment"):
        assert np.array_equal(base[col], moved[col])
    wind = np.column_stack([moved[f"wind_{a}"] for a in "ned"])
    assert np.allclose(wind.mean(axis=0), set_ned, atol=0.3)
    assert not np.allclose(np.column_stack([base[f"wind_{a}"] for a in "ned"]).mean(axis=0), set_ned, atol=0.3)
    assert all(s.wind_ned == set_ned for s in scenario("box", 1.0, np.random.default_rng(7), set_ned).segments)
    assert own != set_ned


@pytest.mark.parametrize("scenario", sorted(set(SCENARIOS) - {"box", "one-heading", "outdoor"}))
def test_a_set_wind_is_refused_where_the_scenario_sweeps_its_own(tmp_path, scenario, capsys):
    from dobwind.cli.app import main

    out = tmp_path / "log.csv"
    assert main(["simulate", scenario, "--wind", "3@90", "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--wind" in err[0] and scenario in err[0]
    assert not out.exists()


def test_the_cli_wind_is_the_bearing_it_blows_from(tmp_path, capsys):
    """10@180 blows from the south, towards the north: +10 m/s north (NED), and the log says so."""
    from dobwind.cli.app import main
    from dobwind.io.logs import read_log

    out = tmp_path / "log.csv"
    assert main(["simulate", "outdoor", "--hold", "1", "--seed", "3", "--wind", "10@180,1", "-o", str(out)]) == 0
    assert "--wind 10@180,1" in out.read_text().splitlines()[0]
    mean = read_log(out).true_wind.mean(axis=0)
    assert abs(mean[0] - 10.0) < 1.0 and abs(mean[1]) < 1.0   # north, east
    assert abs(mean[2] + 1.0) < 0.3                            # down: 1 m/s up


@pytest.mark.parametrize("text", ["unknown", "3@"])
def test_a_bad_simulate_wind_does_not_offer_fits_unknown(tmp_path, capsys, text):
    """`simulate --wind unknown` said "'unknown' is not SPEED@FROM[,UP] ..., nor 'unknown'": fit's wording,
    which offers a choice simulate does not take (a simulator blows a known wind)."""
    from dobwind.cli.app import main

    out = tmp_path / "log.csv"
    assert main(["simulate", "box", "--wind", text, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"--wind: {text!r} is not SPEED@FROM[,UP]" in err[0] and "nor 'unknown'" not in err[0], err
    assert not out.exists()


@pytest.mark.parametrize("a", [0.0, 0.3, 0.999, 0.9999999, -0.5])
def test_the_turbulence_filter_is_scipys_lfilter_bit_for_bit(a):
    """simulate's Gauss-Markov recursion (written out to spare scipy.signal's 1.2 s import) against
    scipy.signal.lfilter itself, from a carried state, on normal draws and on the values where a rewrite of
    the recursion would show: huge, tiny, signed zeros, infinities and NaN."""
    from scipy.signal import lfilter

    from dobwind.simulate.simulate import gauss_markov

    rng = np.random.default_rng(4)
    white = rng.standard_normal((2000, 3)) * 3.0
    white[100:110] = [[1e300, -1e-300, -0.0], [0.0, -0.0, 5e-324], [np.inf, 1.0, -np.inf], [np.nan, 2.0, 0.0],
                      [1.0, np.nan, 1.0], [-1e308, 1e308, 1e-320], [0.0, 0.0, 0.0], [-0.0, -0.0, -0.0],
                      [1.0, -1.0, 0.5], [2.0, 3.0, -4.0]]
    state = np.array([[0.25, -1.5, 0.0]])
    want, want_state = lfilter([1.0], [1.0, -a], white, axis=0, zi=state)
    got, got_state = gauss_markov(white, a, state)
    assert got.tobytes() == want.tobytes() and got_state.tobytes() == want_state.tobytes()
    assert got_state.shape == want_state.shape == (1, 3)
