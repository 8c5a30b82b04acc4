"""`dobwind profile` (issue #35): the binning in closed form (vector-mean direction, spreads, counts,
flights combined in any order), and the command end to end on synthetic flights with a position track."""
from __future__ import annotations

import json

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.atmos.profile import Samples, allowed_mask, bin_sums, combine, table
from tests import atmos_logs
from tests.helpers import M300


def _wind_from(speed, from_deg, up=0.0):
    """NED wind rows blowing FROM from_deg (clockwise from north) at speed."""
    rad, speed, up = np.broadcast_arrays(np.radians(np.asarray(from_deg, float)), np.asarray(speed, float),
                                         np.asarray(up, float))
    return np.column_stack([-speed * np.cos(rad), -speed * np.sin(rad), -up])


def _samples(height, wind, sigma=0.4):
    n = len(height)
    return Samples(np.asarray(height, float), wind, np.full(n, sigma), np.full(n, -1.0))


def _read(path):
    """A CSV with '#' comment lines before its header."""
    import io

    text = "".join(line for line in open(path) if not line.startswith("#"))
    return np.genfromtxt(io.StringIO(text), delimiter=",", names=True)


def test_direction_is_the_vector_mean_not_the_mean_of_angles():
    wind = _wind_from(5.0, [350.0, 10.0, 350.0, 10.0])
    stats = table(bin_sums(_samples([1, 2, 3, 4], wind), 10.0), 10.0)
    assert stats["count"].tolist() == [4]
    d = stats["direction_from_deg"][0]
    assert min(d, 360 - d) < 1e-9  # north; the mean of the angles would say 180
    # Two directions 20 deg apart, half each: mean resultant length cos(10 deg); circular std from it.
    expected_spread = np.degrees(np.sqrt(-2 * np.log(np.cos(np.radians(10.0)))))
    assert stats["direction_spread_deg"][0] == pytest.approx(expected_spread, rel=1e-9)
    assert stats["speed_mean_mps"][0] == pytest.approx(5.0)
    assert stats["vector_speed_mps"][0] == pytest.approx(5.0 * np.cos(np.radians(10.0)))


def test_bins_counts_spreads_and_sigmas_in_closed_form():
    heights = np.array([0.5, 1.5, 2.5, 12.0, 13.0, 25.0])
    speeds = np.array([1.0, 2.0, 3.0, 6.0, 8.0, 4.0])
    wind = _wind_from(speeds, 270.0, up=0.5)
    stats = table(bin_sums(_samples(heights, wind), 10.0), 10.0)
    assert stats["height_bottom_m"].tolist() == [0.0, 10.0, 20.0]
    assert stats["height_m"].tolist() == [5.0, 15.0, 25.0]
    assert stats["count"].tolist() == [3, 2, 1]
    np.testing.assert_allclose(stats["speed_mean_mps"], [2.0, 7.0, 4.0])
    np.testing.assert_allclose(stats["speed_std_mps"][:2], [1.0, np.sqrt(2.0)])  # sample std (n - 1)
    assert np.isnan(stats["speed_std_mps"][2])  # one sample has no spread
    np.testing.assert_allclose(stats["direction_from_deg"], 270.0)
    np.testing.assert_allclose(stats["eastward_mean_mps"], [2.0, 7.0, 4.0])  # from the west: blowing east
    np.testing.assert_allclose(stats["up_mean_mps"], 0.5)
    np.testing.assert_allclose(stats["sigma_h_mps"], 0.4)
    assert np.all(np.isnan(stats["sigma_up_mps"]))  # -1: unknown, never a number


def test_flights_combine_exactly_in_any_order_and_gaps_stay_empty():
    rng = np.random.default_rng(4)
    h = rng.uniform(0, 40, 300)
    h[(h > 20) & (h < 30)] += 15  # nothing between 20 and 30 m
    wind = _wind_from(rng.uniform(2, 9, 300), rng.uniform(150, 210, 300), up=rng.normal(0, 0.3, 300))
    whole = table(bin_sums(_samples(h, wind), 5.0), 5.0)
    parts = [bin_sums(_samples(h[s], wind[s]), 5.0) for s in (slice(0, 100), slice(100, 300))]
    for order in (parts, parts[::-1]):
        split = table(combine(order), 5.0)
        for key in whole:
            np.testing.assert_allclose(split[key], whole[key], rtol=1e-12, equal_nan=True)
    empty = (whole["height_bottom_m"] >= 20) & (whole["height_top_m"] <= 30)
    assert empty.sum() == 2 and np.all(whole["count"][empty] == 0) and np.all(np.isnan(whole["speed_mean_mps"][empty]))


def test_only_quality_flags_can_be_allowed():
    from dobwind.core.errors import InputError
    from dobwind.model.status import STATUS_BITS

    settling = next(b.value for b in STATUS_BITS if b.name == "SETTLING")
    assert allowed_mask(["settling"]) == settling
    with pytest.raises(InputError, match="not a quality flag"):
        allowed_mask(["tilt"])  # a rejection: its rows carry no new estimate


@pytest.fixture(scope="module")
def two_flights(tmp_path_factory):
    pytest.importorskip("pymavlink")
    folder = tmp_path_factory.mktemp("profile")
    logs, last = [], []
    for seed in (3, 4):
        _, cols = atmos_logs.flight(seed=seed)
        (folder / "logs").mkdir(exist_ok=True)
        logs.append(atmos_logs.write_log(folder / "logs" / f"f{seed}.bin", cols))
        last.append(cols["t"][(len(cols["t"]) - 1) // 5 * 5])  # the track's last sample
    return folder, logs, last


def test_profile_command_bins_each_row_at_its_height(two_flights, capsys):
    from dobwind.model.airframe import load_airframe
    from dobwind.model.status import trusted
    from dobwind.replay.replay import replay_autopilot

    folder, logs, last = two_flights
    out = folder / "p.csv"
    assert main(["profile", str(M300), *map(str, logs), "-o", str(out), "--bin", "4", "--jobs", "1"]) == 0
    got = _read(out)
    # Expected counts: every trusted row, at the height the made-up track gives its time (2 m/s climb).
    expected: dict[float, int] = {}
    for log, t_last in zip(logs, last):
        _, flight, traj = replay_autopilot(load_airframe(M300), str(log))
        t_sim = flight.t0_s + flight.log.time_s - atmos_logs.BOOT_US * 1e-6
        inside = t_sim <= t_last + 1e-6  # beyond the track's last sample a row has no height
        _, _, _, height = atmos_logs.track(t_sim[trusted(traj.status) & inside])
        for bottom in np.floor(height / 4.0) * 4.0:
            expected[bottom] = expected.get(bottom, 0) + 1
    assert got["count"].sum() == sum(expected.values()) > 500
    for bottom, count in expected.items():
        row = got["height_bottom_m"] == bottom
        assert abs(got["count"][row][0] - count) <= 2  # a row exactly on a bin edge may fall either side
    text = capsys.readouterr().out
    assert "f3.bin" in text and "f4.bin" in text


def test_profile_netcdf_and_plot(two_flights, capsys):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    folder, logs, _ = two_flights
    out, png = folder / "p.nc", folder / "p.png"
    assert main(["profile", str(M300), str(folder / "logs"), "-o", str(out), "--plot", str(png), "--jobs", "2"]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from tests.test_atmos_netcdf import cf_check

    cf_check(out)
    csv = folder / "p2.csv"
    capsys.readouterr()
    assert main(["profile", str(M300), *map(str, logs), "-o", str(csv), "--jobs", "1", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    ref = _read(csv)
    assert [b["count"] for b in report["bins"]] == ref["count"].astype(int).tolist()
    assert [entry["exit"] for entry in report["logs"]] == [0, 0]
    assert report["time_coverage_utc"][0] == ds_start_iso(out)
    with xr.open_dataset(out) as ds:
        # The flights' GPS time: both start at UTC0 (the synthetic logs share their clock), end within 16 s.
        start = np.datetime64(ds.attrs["time_coverage_start"].rstrip("Z"))
        end = np.datetime64(ds.attrs["time_coverage_end"].rstrip("Z"))
        utc0 = np.datetime64(atmos_logs.UTC0.replace(tzinfo=None))
        assert utc0 - np.timedelta64(1, "s") <= start <= utc0 + np.timedelta64(5, "s")
        assert start < end <= utc0 + np.timedelta64(17, "s")
        assert ds["height"].attrs["standard_name"] == "height" and ds["height"].attrs["positive"] == "up"
        assert ds["wind_from_direction"].attrs["standard_name"] == "wind_from_direction"
        np.testing.assert_array_equal(ds["count"].values, ref["count"])  # two workers = one process
        np.testing.assert_allclose(ds["wind_speed"].values, ref["speed_mean_mps"], rtol=1e-5, equal_nan=True)


def test_without_global_position_the_ekf_height_serves_and_without_both_it_refuses(tmp_path, capsys):
    pytest.importorskip("pymavlink")
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = atmos_logs.write_log(tmp_path / "nopos.bin", cols, position=False)
    assert main(["profile", str(M300), str(log), "-o", str(tmp_path / "p.txt")]) == 2
    assert "csv or .nc" in capsys.readouterr().err
    assert main(["profile", str(M300), str(log), "-o", str(tmp_path / "p.csv"), "--bin", "2"]) == 0
    assert "XKF1.PD" in capsys.readouterr().out
    # The EKF's up position less its value at take-off: the same 2 m/s climb as the POS track gives.
    with_pos = atmos_logs.write_log(tmp_path / "pos.bin", cols)
    assert main(["profile", str(M300), str(with_pos), "-o", str(tmp_path / "ref.csv"), "--bin", "2"]) == 0
    got, ref = _read(tmp_path / "p.csv"), _read(tmp_path / "ref.csv")
    assert got["count"].sum() >= ref["count"].sum() > 0  # the EKF rows reach past the last POS sample
    # A row at a bin edge may fall either side: the two heights are interpolated from different messages.
    np.testing.assert_allclose(got["count"][:-1], ref["count"][:-1], atol=1)
    assert got["count"][:-1].sum() == ref["count"][:-1].sum()
    bare = atmos_logs.write_log(tmp_path / "bare.bin", cols, position=False, local=False)
    assert main(["profile", str(M300), str(bare), "-o", str(tmp_path / "q.csv")]) == 2
    err = capsys.readouterr().err
    assert "no global or local position" in err and "bare.bin" in err and not (tmp_path / "q.csv").exists()


def test_csv_log_with_position_columns_to_netcdf_and_profile(tmp_path, capsys):
    """A CSV log with the optional lat, lon, alt columns: the NetCDF carries them, and the profile bins by
    the altitude above the first row (no landed rows in a CSV log: its first position is the take-off)."""
    xr = pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    from dobwind.io.logs import write_csv
    from dobwind.model.airframe import load_airframe
    from dobwind.model.status import trusted
    from dobwind.replay.replay import replay

    _, cols = atmos_logs.flight(hold_s=1.0)
    t = cols["t"]
    cols = {k: v for k, v in cols.items() if k != "segment"}
    cols.update(lat=np.full_like(t, 60.1), lon=np.full_like(t, 24.9), alt=100.0 + 3.0 * t)
    names = list(cols)
    log = tmp_path / "f.csv"
    write_csv(log, names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "f.nc")]) == 0
    with xr.open_dataset(tmp_path / "f.nc", decode_times=False) as ds:
        np.testing.assert_allclose(ds["height"].values, 3.0 * (t - t[0]), atol=1e-9)
        np.testing.assert_allclose(ds["lat"].values, 60.1)
    assert main(["profile", str(M300), str(log), "-o", str(tmp_path / "p.csv"), "--bin", "10"]) == 0
    got = _read(tmp_path / "p.csv")
    _, _, traj = replay(load_airframe(M300), str(log))
    height = (3.0 * (t - t[0]))[trusted(traj.status)]
    expected = np.bincount(np.floor(height / 10.0).astype(int))
    assert got["count"].astype(int).tolist() == expected[expected.nonzero()[0][0]:].tolist()


def test_profilecheck_law_and_verdict(two_flights, capsys):
    from benchmarks.profilecheck import law, main as check

    np.testing.assert_allclose(law(np.array([0.0, 15.0, 60.0, 90.0]), 10.0, 60.0, 0.5), [0.0, 5.0, 10.0, 10.0])
    _, logs, _ = two_flights
    args = [str(M300), str(logs[0]), "--min-height", "0", "--from-deg", "0"]
    generous = ["--max-speed-error", "100", "--max-direction-error", "180"]
    # The synthetic flight spends under the default 10 s in every bin: no bin has a mean to check.
    assert check(args + generous) == 1
    assert "under --min-seconds: no mean" in capsys.readouterr().out
    args += ["--min-seconds", "0"]
    assert check(args) == 1  # a 10 m/s square-root law is not this flight's wind
    assert check(args + generous) == 0
    assert "PASS" in capsys.readouterr().out


def test_a_failing_log_is_left_out_and_the_exit_says_so(two_flights, tmp_path, capsys):
    folder, logs, _ = two_flights
    alone, mixed = tmp_path / "alone.csv", tmp_path / "mixed.csv"
    assert main(["profile", str(M300), str(logs[0]), "-o", str(alone), "--jobs", "1"]) == 0
    capsys.readouterr()
    code = main(["profile", str(M300), str(logs[0]), str(tmp_path / "gone.bin"), "-o", str(mixed), "--jobs", "2"])
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert code == 2 and len(err) == 1 and "gone.bin" in err[0]
    assert mixed.read_bytes().split(b"\n", 1)[1] == alone.read_bytes().split(b"\n", 1)[1]  # the same bins


def ds_start_iso(path):
    xr = pytest.importorskip("xarray")
    with xr.open_dataset(path) as ds:
        return ds.attrs["time_coverage_start"]


def test_the_printed_table_says_dash_where_a_bin_has_no_number():
    """A bin of one sample has no spread, calm samples no direction, an empty bin nothing: the printed
    table says '-' there (docs/atmospheric.md), never 'nan'."""
    from dobwind.cli.profile import _text

    heights = np.array([1.0, 12.0, 13.0, 31.0])
    wind = _wind_from([3.0, 0.2, 0.3, 4.0], [90.0, 90.0, 270.0, 180.0])
    stats = table(bin_sums(_samples(heights, wind), 10.0), 10.0)
    text = _text(stats, [])
    assert "nan" not in text.lower()
    # columns: bottom, "..", top, n, time, N_eff, speed, std, SE, from, spread, up, sigma_h, why no mean
    rows = {line.split()[0]: line.split() for line in text.splitlines()[1:]}
    # one sample without a clock: no time, no neighbour (no N_eff), speed and direction, no spreads, no SE
    assert rows["0"][3:11] == ["1", "-", "-", "3.00", "-", "-", "90", "-"]
    assert rows["10"][10] == "-"                              # calm samples: no direction spread
    assert rows["20"][3:] == ["0", "0.0", "0.0"] + ["-"] * 7 + ["empty"]  # an empty bin says so


def test_a_log_that_never_flew_is_named_as_such_not_sent_to_allow(tmp_path, capsys):
    """A pre-arm log gives no row because it never flew: --allow cannot admit LANDED, so the refusal must
    say what is missing (a flight), not point at --allow."""
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = atmos_logs.write_log(tmp_path / "ground.bin", cols, airborne=False)
    assert main(["profile", str(M300), str(log), "-o", str(tmp_path / "p.csv")]) == 2
    err = capsys.readouterr().err
    assert "ground.bin: never airborne (every row LANDED)" in err and "--allow admits" not in err
    assert not (tmp_path / "p.csv").exists()


def test_why_no_row_names_the_flags_that_kept_the_rows_out():
    from dobwind.atmos.profile import why_no_row
    from dobwind.model.status import STATUS_LANDED

    settling, uncal = 1 << 6, 1 << 10
    status = np.array([STATUS_LANDED] * 3 + [settling] * 2 + [settling | uncal] * 5 + [1 << 1])
    text = why_no_row(status, np.zeros(len(status), bool))
    assert "none of its 7 accepted airborne rows is trusted (SETTLING|UNCALIBRATED 5, SETTLING 2)" in text
    assert "never airborne" in why_no_row(np.full(4, STATUS_LANDED), np.zeros(4, bool))


def test_why_no_row_under_allow_names_what_was_allowed():
    from dobwind.atmos.profile import why_no_row

    uncal, suspect = 1 << 10, 1 << 13
    status = np.full(6, uncal | suspect)
    text = why_no_row(status, np.zeros(6, bool), allow=uncal)
    assert "none of its 6 accepted airborne rows is trusted or flagged only as --allow admits (UNCALIBRATED|SUSPECT 6)" in text
