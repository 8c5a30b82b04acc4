"""Short silences of a topic are bridged in replay (dobwind/io/bridge.py): the observer runs on through the
interpolated inputs, the rows stay NO_DATA and repeat the estimate from before, and settling does not
restart; longer silences reset as before. The bound is checked against independent transcriptions of its
derivation (closed forms, a numerical integration), the replay on synthetic ULogs written here, and, when
../shared/data is beside the checkout (or DOBWIND_SHARED_DATA names it), on the field logs."""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from dobwind.io import bridge
from dobwind.io.bridge import (BRIDGE_CAP_S, airframe_bound_s, bridge_bound_s, bridged_rows, after_error,
                               estimator_lags_s, hold_bridged, tolerated_error)
from dobwind.io.resample import DEFAULT_GAP_POLICY
from dobwind.model.status import STATUS_BITS, STATUS_NO_DATA, accepted
from dobwind.replay.replay import replay_ulog
from tests.helpers import M300
from tests.test_fieldreplay import _flight, _rows  # the same 40 s m300 flight and ULog rows
from tests.ulog_writer import Topic, write_ulog

SETTLING = next(bit.value for bit in STATUS_BITS if bit.name == "SETTLING")
BAD_DT = next(bit.value for bit in STATUS_BITS if bit.name == "BAD_DT")
CEILING = DEFAULT_GAP_POLICY.ceiling_s
ESC_REPORT = {"esc_report": [("int32_t", "esc_rpm"), ("float", "esc_voltage")]}
T0_US = 5_000_000  # the ULog's clock at the first sample: 5 s since boot


# --- the bound: independent transcriptions of its derivation ------------------------------------------------

def _first_order_after_error(g: float, tau: float) -> float:
    """One lag (the other negligible): the end error (1 - e^(-u/tau)) - (u/g)(1 - e^(-g/tau)) over the time u
    from the step to the silence's end is largest where its derivative vanishes, in closed form."""
    slope = (1 - math.exp(-g / tau)) / g
    u = min(max(-tau * math.log(tau * slope), 0.0), g)
    return (1 - math.exp(-u / tau)) - u * slope


@pytest.mark.parametrize("g,tau", [(0.3, 0.3), (0.8, 0.3), (0.5, 0.1), (1.0, 2.0)])
def test_the_after_error_of_one_lag_is_the_closed_form(g, tau):
    assert after_error(g, (tau, 1e-7)) == pytest.approx(_first_order_after_error(g, tau), abs=2e-4)


@pytest.mark.parametrize("at", [0.7, 0.9, 1.4])  # the silence's end, and after it, where the low-pass catches up
def test_the_cascade_matches_a_numerical_integration_of_the_two_lags(at):
    """The derivation's inputs through two lags, integrated with small Euler steps: the truth a unit step
    at s0, the interpolation (g - s0) / g from 0 to g and 1 after; their difference at ``at``."""
    lags, g, s0, h = (0.16, 0.32), 0.7, 0.25, 1e-5
    x = np.zeros(2)  # (truth, interpolation) through the observer, then through the low-pass
    y = np.zeros(2)
    for k in range(int(round(at / h))):
        t = k * h
        u = np.array([1.0 if t >= s0 else 0.0, (g - s0) / g if t < g else 1.0])
        x, y = x + h * (u - x) / lags[0], y + h * (x - y) / lags[1]
    from dobwind.io.bridge import _GRID, _errors

    column = int(np.argmin(np.abs(np.linspace(0, g, _GRID) - s0)))
    assert float(_errors(g, lags, np.array([at]))[0, column]) == pytest.approx(abs(y[0] - y[1]), abs=2e-3)


def test_after_a_silence_the_cascades_error_can_grow_before_it_decays():
    """Why the bound looks past the silence's end: with two lags the largest error comes after it."""
    from dobwind.io.bridge import _errors

    lags, g = (0.16, 0.32), 0.8
    at_end = float(_errors(g, lags, np.array([g])).max())
    assert after_error(g, lags) > 1.1 * at_end


def test_the_bound_is_where_the_after_error_reaches_the_tolerated_one():
    lags = (0.16, 1 / (2 * math.pi * 0.5))
    bound = bridge_bound_s(lags, CEILING)
    accepted_error = tolerated_error(CEILING, lags)
    assert CEILING < bound < BRIDGE_CAP_S
    assert after_error(bound, lags) <= accepted_error + 1e-9 < after_error(bound + 0.01, lags)
    # A tolerated silence's own last row is among the rows it trusts: its end error is never above.
    assert after_error(CEILING, lags) <= accepted_error


def test_limiting_cases_of_the_bound():
    # A very fast estimator passes every input error: nothing beyond the ceiling is as safe as a trusted
    # row inside a tolerated silence... except the end, which the zero-mean error makes smaller.
    assert CEILING <= bridge_bound_s((1e-3, 1e-3), CEILING) < 0.6
    # Never beyond the cap, however slow the estimator (where the argument of one step per silence ends).
    assert bridge_bound_s((0.3, 0.8), CEILING) == BRIDGE_CAP_S
    assert bridge_bound_s((0.3, 0.8), CEILING, cap_s=0.7) == 0.7


def test_the_airframes_lags_are_its_fastest_axis_and_cutoff():
    from dobwind.model.airframe import load_airframe

    af = load_airframe(M300)
    obs, lp = estimator_lags_s(af.observer.gains, af.mass_kg, af.filter.cutoffs_hz)
    assert obs == pytest.approx(af.mass_kg / max(af.observer.gains))
    assert lp == pytest.approx(1 / (2 * math.pi * max(af.filter.cutoffs_hz)))
    assert airframe_bound_s(af) == bridge_bound_s((obs, lp), CEILING)
    # Unequal axes and a schedule: the fastest of each (the least attenuation, so the shortest bound).
    assert estimator_lags_s((10.0, 40.0, 20.0), 4.0, (0.2, 0.8, 0.5)) == pytest.approx((0.1, 1 / (2 * math.pi * 0.8)))
    assert bridge_bound_s((0.1, 0.2), CEILING) < bridge_bound_s((0.4, 0.2), CEILING)


# --- which rows are bridged -----------------------------------------------------------------------------------

def test_bridged_rows_are_inside_short_silences_of_every_stream_with_a_gap():
    clock = np.round(np.arange(0.0, 10.0, 0.01), 6)
    fast = np.round(np.arange(0.0, 10.001, 0.01), 6)
    slow = np.r_[np.arange(0.0, 3.0, 0.1), np.arange(3.6, 6.0, 0.1), np.arange(7.5, 9.5, 0.1)]  # 0.6 s, 1.6 s
    streams = {"slow": (slow, 0.4), "fast": (fast, 0.1)}
    rows = bridged_rows(streams, clock, {"slow": 1.0, "fast": 1.0})
    short = (clock > 2.9 + 1e-9) & (clock < 3.6 - 1e-9)
    assert np.array_equal(rows, short & (clock > slow[29]))  # the silence 2.9 .. 3.6 s, nothing else
    # The 1.6 s silence and the rows after the slow stream's last sample are not bridged.
    assert not rows[(clock > 5.95) & (clock < 7.5)].any() and not rows[clock > 9.45].any()
    # A short silence of one stream inside a long one of another: not bridged (nothing to interpolate).
    other = np.r_[np.arange(0.0, 2.5, 0.01), np.arange(4.0, 10.001, 0.01)]
    assert not bridged_rows({**streams, "other": (other, 0.1)}, clock, {"slow": 1.0, "fast": 1.0, "other": 1.0})[short].any()
    # Each stream's own bound: the same 0.6 s silence is not bridged under a bound of 0.5 s.
    assert not bridged_rows(streams, clock, {"slow": 0.5, "fast": 1.0}).any()


def test_overlapping_silences_of_two_streams_are_one_silence_against_the_bound():
    """Each silence within its bound, but the position's and the attitude's overlap in a chain: the inputs
    are interpolated without a break from the chain's first sample to its last, which is one silence of
    that length (the bound's derivation), so the chain is bridged only when that is within the bound."""
    clock = np.round(np.arange(0.0, 10.0, 0.01), 6)
    grid = np.round(np.arange(0.0, 10.001, 0.01), 6)

    def silent(over):
        return grid[~np.any([(grid > a) & (grid < b) for a, b in over], axis=0)]

    pos = [(2.0, 2.6), (2.8, 3.4), (3.6, 4.2)]    # 0.6 s each
    att = [(2.4, 3.0), (3.2, 3.8)]                # 0.6 s each, overlapping the position's
    streams = {"pos": (silent(pos), 0.1), "att": (silent(att), 0.1)}
    chain = (clock > 2.0 + 1e-9) & (clock < 4.2 - 1e-9)
    assert not bridged_rows(streams, clock, {"pos": 0.8, "att": 0.8})[chain].any()  # 2.2 s joined
    assert bridged_rows(streams, clock, {"pos": 2.2, "att": 0.8})[chain].all()  # the longest bound holds it
    # Two that overlap but join to 0.8 s stay bridged, and a separate short one is untouched by the chain.
    pair = {"pos": (silent([(6.0, 6.6)]), 0.1), "att": (silent([(6.2, 6.8)]), 0.1)}
    joined = bridged_rows(pair, clock, {"pos": 0.8, "att": 0.8})
    assert np.array_equal(joined, (clock > 6.0 + 1e-9) & (clock < 6.8 - 1e-9))
    both = {name: (np.intersect1d(streams[name][0], pair[name][0]), 0.1) for name in streams}
    assert np.array_equal(bridged_rows(both, clock, {"pos": 0.8, "att": 0.8}), joined)


def test_holding_repeats_the_last_row_before_each_bridged_run():
    values = np.arange(10.0)[:, None] * np.array([[1.0, -1.0]])
    mask = np.zeros(10, dtype=bool)
    mask[[3, 4, 5, 8]] = True
    held = hold_bridged(values, mask)
    np.testing.assert_array_equal(held[:, 0], [0, 1, 2, 2, 2, 2, 6, 7, 7, 9])
    assert hold_bridged(values, np.zeros(10, dtype=bool)) is values


# --- replay on synthetic ULogs -----------------------------------------------------------------------------

def _dropout_ulog(path, cols, silences=(), jitter=0.0, seed=0, attitude_silences=()):
    """PX4's default rates (local position at 10 Hz, ESCs at 4 Hz, attitude at the full 100 Hz) with the
    local position silent over each (start, end) of ``silences`` and the attitude over each of
    ``attitude_silences``; ``jitter`` moves every timestamp by up to that fraction of its topic's period
    (uniform)."""
    rng = np.random.default_rng(seed)
    n, t = len(cols["t"]), cols["t"]
    every = lambda k: (np.arange(n) % k) == 0  # noqa: E731
    lp_keep, att_keep = every(10), np.ones(n, dtype=bool)
    for start, end in silences:
        lp_keep &= ~((t > start) & (t < end))
    for start, end in attitude_silences:
        att_keep &= ~((t > start) & (t < end))

    def jittered(rows, period):
        for r in rows:
            r["timestamp"] += int(round(rng.uniform(-jitter, jitter) * period * 1e6))
        return sorted(rows, key=lambda r: r["timestamp"])

    lp = ["vx", "vy", "vz", "ax", "ay", "az"]
    esc = _rows(cols, [f"rpm_{i}" for i in range(1, 5)], [f"esc[{i}].esc_rpm" for i in range(4)], every(25))
    topics = [
        Topic("vehicle_local_position", [("uint64_t", "timestamp")] + [("float", f) for f in lp],
              jittered(_rows(cols, ["vel_n", "vel_e", "vel_d", "acc_n", "acc_e", "acc_d"], lp, lp_keep), 0.1)),
        Topic("vehicle_attitude", [("uint64_t", "timestamp"), ("float[4]", "q")],
              jittered(_rows(cols, ["q_w", "q_x", "q_y", "q_z"], [f"q[{i}]" for i in range(4)], att_keep), 0.01)),
        Topic("vehicle_attitude_setpoint", [("uint64_t", "timestamp"), ("float", "yaw_body")],
              jittered(_rows(cols, ["yaw_ref"], ["yaw_body"], every(10)), 0.1)),
        Topic("esc_status", [("uint64_t", "timestamp"), ("uint8_t", "esc_count"), ("esc_report[8]", "esc")],
              jittered([dict(r, esc_count=4) for r in esc], 0.25)),
    ]
    return write_ulog(path, topics, None, ESC_REPORT)


SHORT = (12.02, 12.58)  # the 10 Hz position silent from 12.0 to 12.6 s: 0.6 s, beyond its 0.4 s tolerance
LONG = (20.02, 21.48)   # 20.0 to 21.5 s: 1.5 s, beyond the bound (at most 1 s)


@pytest.fixture(scope="module")
def dropouts(tmp_path_factory):
    af, cols = _flight()
    path = _dropout_ulog(tmp_path_factory.mktemp("bridge") / "dropouts.ulg", cols, (SHORT, LONG))
    return af, str(path)


def _rows_in(t, start, end):
    return (t > start) & (t < end)


def test_a_short_silence_keeps_the_settled_status_and_a_long_one_resets(dropouts):
    af, path = dropouts
    assert CEILING < 0.6 < airframe_bound_s(af) < 1.5  # the premise: one silence on each side of the bound
    model, flight, traj = replay_ulog(af, path)
    t, settle = flight.log.time_s, model.settling_time_s
    short, long_ = _rows_in(t, 12.0, 12.6), _rows_in(t, 20.0, 21.5)
    assert np.all(traj.status[short] == STATUS_NO_DATA) and np.all(traj.status[long_] == STATUS_NO_DATA)
    # Exactly the short silence's NO_DATA rows were fed (its edges: the sample instants, within a microsecond).
    around = _rows_in(t, 11.95, 12.65)
    assert np.array_equal(flight.bridged, around & (traj.status == STATUS_NO_DATA)) and flight.bridged[short].all()
    # Settled before the short silence, and trusted again from its first row after: no settling restart.
    assert np.all(traj.status[_rows_in(t, 12.6, 20.0)] == 0)
    # The long silence resets: SETTLING for one settling time after it, then trusted.
    assert np.all(traj.status[_rows_in(t, 21.5, 21.5 + settle - 0.05)] == SETTLING)
    assert np.all(traj.status[t > 21.5 + settle + 0.05] == 0)
    assert any("bridged" in note for note in flight.notes)


def test_bridged_rows_repeat_the_estimate_from_before_the_silence(dropouts):
    af, path = dropouts
    _, flight, traj = replay_ulog(af, path)
    short = flight.bridged
    before = int(np.flatnonzero(short)[0]) - 1
    assert np.all(traj.outputs[short] == traj.outputs[before])
    assert np.all(np.isfinite(traj.outputs[short]))
    # No NaN in any trusted row.
    assert np.all(np.isfinite(traj.outputs[traj.status == 0]))


def test_without_bridging_the_short_silence_restarts_the_settling(dropouts):
    """The mutation "bridging disabled": the check above fails on the same log."""
    af, path = dropouts
    model, flight, traj = replay_ulog(af, path, bridge_gaps=False)
    t = flight.log.time_s
    assert flight.bridged is None
    assert np.all(traj.status[_rows_in(t, 12.6, 12.6 + model.settling_time_s - 0.05)] == SETTLING)


def test_a_bound_ten_times_longer_would_bridge_the_long_silence(dropouts, monkeypatch):
    """The mutation "bound x10": the long silence no longer resets, which the test above forbids."""
    af, path = dropouts
    real = bridge.airframe_bound_s(af)
    monkeypatch.setattr(bridge, "airframe_bound_s", lambda _af: 10 * real)
    _, flight, traj = replay_ulog(af, path)
    t = flight.log.time_s
    assert flight.bridged[_rows_in(t, 20.0, 21.5)].all()
    assert not (traj.status[_rows_in(t, 21.5, 22.0)] & SETTLING).any()


# The position silent 0.56 s four times and the attitude 0.56 s three times, each silence within the bound
# but overlapping: one chain from 12.0 to 15.0 s.
CHAIN_POSITION = ((12.02, 12.58), (12.82, 13.38), (13.62, 14.18), (14.42, 14.98))
CHAIN_ATTITUDE = ((12.42, 12.98), (13.22, 13.78), (14.02, 14.58))


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    af, cols = _flight()
    path = _dropout_ulog(tmp_path_factory.mktemp("chain") / "chain.ulg", cols, CHAIN_POSITION,
                         attitude_silences=CHAIN_ATTITUDE)
    return af, str(path)


def test_a_chain_of_overlapping_short_silences_longer_than_the_bound_resets(chain):
    af, path = chain
    assert 0.6 < airframe_bound_s(af) < 3.0  # the premise: each silence within the bound, the chain beyond
    model, flight, traj = replay_ulog(af, path)
    t, settle = flight.log.time_s, model.settling_time_s
    assert np.all(traj.status[_rows_in(t, 12.0, 15.0)] & STATUS_NO_DATA)
    assert flight.bridged is None or not flight.bridged[_rows_in(t, 11.9, 15.1)].any()
    assert np.all(traj.status[_rows_in(t, 15.0, 15.0 + settle - 0.05)] == SETTLING)
    assert np.all(traj.status[_rows_in(t, 15.0 + settle + 0.05, 20.0)] == 0)


def test_without_joining_overlapping_silences_the_chain_would_be_bridged(chain, monkeypatch):
    """The mutation "chains not held to the bound": the 3 s chain is bridged and the row after it trusted
    at once, which the test above forbids."""
    af, path = chain
    monkeypatch.setattr(bridge, "_within_bounds", lambda rows, *_: np.ones(len(rows), dtype=bool))
    _, flight, traj = replay_ulog(af, path)
    t = flight.log.time_s
    assert flight.bridged[_rows_in(t, 12.05, 14.95)].all()
    assert not (traj.status[_rows_in(t, 15.0, 15.5)] & SETTLING).any()


def test_the_estimate_after_a_bridged_silence_joins_the_uninterrupted_one(tmp_path):
    """In wind, against the same flight without the silence: right after it, the bridged estimate is within
    the 0.15 m/s that 10 Hz interpolation costs anyway (tests/test_fieldreplay.py, the RMS against the full
    rate), and the difference then decays with the estimator: after two settling times it is under a tenth
    of its peak (not 2 %: the acceleration bias, m300's 20 s ``acceleration_bias_time``, keeps a trace)."""
    af, cols = _flight("tunnel", 3.0)
    model, flight, gap = replay_ulog(af, str(_dropout_ulog(tmp_path / "gap.ulg", cols, (SHORT,))))
    _, _, whole = replay_ulog(af, str(_dropout_ulog(tmp_path / "whole.ulg", cols)))
    t, wind, settle = flight.log.time_s, model.outputs.slice("wind_ned"), model.settling_time_s
    n = min(len(gap.status), len(whole.status))
    t = t[:n]
    diff = np.linalg.norm(gap.outputs[:n, wind] - whole.outputs[:n, wind], axis=1)
    after = _rows_in(t, 12.6, 12.6 + settle)
    assert np.all(gap.status[:n][after] == 0)  # trusted at once
    peak = float(diff[after].max())
    assert 0 < peak < 0.15, peak
    assert np.all(diff[_rows_in(t, 12.6 + 2 * settle, 12.6 + 3 * settle)] < 0.1 * peak)


@pytest.mark.parametrize("seed", [1, 2])
def test_jitter_of_five_percent_never_resets_the_settling(tmp_path, seed):
    """Every topic's timestamps moved by up to +-5 % of its own period, on top of the simulator's 10 % (1
    sigma) at 100 Hz: the uniform clock keeps dt constant, no row is BAD_DT or NO_DATA, and after the first
    settling time every row is trusted (no restart)."""
    af, cols = _flight()
    model, flight, traj = replay_ulog(af, str(_dropout_ulog(tmp_path / "jitter.ulg", cols, jitter=0.05, seed=seed)))
    t = flight.log.time_s
    assert not (traj.status & (BAD_DT | STATUS_NO_DATA)).any()
    assert np.all(traj.status[t > model.settling_time_s + 0.05] == 0)


# --- the field logs (optional: they are licensed and not in the repository) ----------------------------------

SHARED = Path(os.environ.get("DOBWIND_SHARED_DATA", M300.parents[1].parent / "shared" / "data"))


@pytest.mark.parametrize("name", ["field/px4_x500_mission_corrupt_msg.ulg", "field/px4_quad_dragfusion_esc.ulg"])
def test_field_logs_with_short_dropouts_settle_more_with_bridging(name):
    path = SHARED / name
    if not path.exists():
        pytest.skip(f"{name} is not beside this checkout")
    from dobwind.model.airframe import load_airframe

    af = load_airframe(M300.parent / "nf_quad.toml")
    shares = []
    for bridging in (False, True):
        _, flight, traj = replay_ulog(af, str(path), bridge_gaps=bridging)
        air = ~flight.landed
        assert np.all(np.isfinite(traj.outputs[traj.status == 0]))
        shares.append(np.mean(accepted(traj.status[air]) & ((traj.status[air] & SETTLING) == 0)))
    assert flight.bridged.any() and shares[1] > shares[0] + 0.05, shares


def test_the_command_writes_bridged_rows_as_no_data_repeating_the_row_before(dropouts, tmp_path, capsys):
    import json

    from dobwind.cli.app import main

    _, path = dropouts
    out = tmp_path / "est.csv"
    assert main(["replay", str(M300), path, "--json", "-o", str(out)]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert any("bridged" in note and "settling does not restart" in note for note in summary["notes"])
    est = np.genfromtxt(out, delimiter=",", names=True)
    t = est["t"] - est["t"][0]
    short = _rows_in(t, 12.05, 12.55)
    values = [n for n in est.dtype.names if n not in ("t", "status")]
    first = int(np.flatnonzero(short)[0])
    assert np.all(est["status"][short] == STATUS_NO_DATA)
    for name in values:  # the estimate and its sigmas from before the silence, never NaN or -1 there
        assert np.all(est[name][short] == est[name][first - 1]), name
    assert np.all(est["wind_sigma_h"][short] == est["wind_sigma_h"][first - 1])
    assert np.all(est["status"][_rows_in(t, 12.65, 19.95)] == 0)  # off the edges: t is printed to the microsecond


def test_a_held_setpoint_is_bridged_only_up_to_the_ceiling(tmp_path):
    """The collective thrust is held, not interpolated: the same criterion gives the tolerance's ceiling
    (0.5 s) as its bound. A 0.3 s silence of vehicle_thrust_setpoint is bridged, a 0.7 s one is not,
    though 0.7 s is within the bound of an interpolated stream (the velocity's 0.6 s silence above)."""
    from dobwind.model.airframe import parse_airframe
    from dobwind.model.airframe_toml import dumps
    from tests.helpers import airframe_dict

    af = parse_airframe(dumps(airframe_dict(thrust={"source": "collective"}, mass=8.0, name="coll",
                                            **{"observer.force_offset": [0.0, 0.0, 0.0]})), "<c>")
    assert airframe_bound_s(af) > 0.7
    _, cols = _flight()
    t = cols["t"]
    thrust_keep = ~(_rows_in(t, 10.0, 10.3) | _rows_in(t, 20.0, 20.7))
    rows = _rows(cols, ["thrust"], ["xyz[2]"], thrust_keep)
    for row in rows:
        row["xyz[2]"] = -row["xyz[2]"] / (8.0 * 9.80665) * 0.5
    lp = ["vx", "vy", "vz", "ax", "ay", "az"]
    topics = [
        Topic("vehicle_local_position", [("uint64_t", "timestamp")] + [("float", f) for f in lp],
              _rows(cols, ["vel_n", "vel_e", "vel_d", "acc_n", "acc_e", "acc_d"], lp)),
        Topic("vehicle_attitude", [("uint64_t", "timestamp"), ("float[4]", "q")],
              _rows(cols, ["q_w", "q_x", "q_y", "q_z"], [f"q[{i}]" for i in range(4)])),
        Topic("vehicle_thrust_setpoint", [("uint64_t", "timestamp"), ("float[3]", "xyz")], rows),
    ]
    path = write_ulog(tmp_path / "held.ulg", topics, {"MPC_THR_HOVER": 0.5})
    model, flight, traj = replay_ulog(af, str(path))
    rt = flight.log.time_s
    assert flight.bridged[_rows_in(rt, 10.05, 10.25)].all()
    assert not flight.bridged[_rows_in(rt, 20.0, 20.7)].any()
    assert np.all(traj.status[_rows_in(rt, 10.35, 19.95)] == 0)
    assert np.all(traj.status[_rows_in(rt, 20.75, 20.7 + model.settling_time_s - 0.05)] == SETTLING)
