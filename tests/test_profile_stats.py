"""How far a profile bin's mean can be trusted (atmos/binstats.py), against closed forms: white noise of
known sigma gives a standard error sigma / sqrt(n); an AR(1) series of known correlation gives
N_eff = n (1 - phi) / (1 + phi) and a standard error that matches the exact variance of its mean over many
independent bins; the model's per-row sigma does not average down; a bin under --min-seconds prints '-'
and says why, in the table and in the files."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.atmos.profile import SUMS, Samples, bin_sums, combine, table
from dobwind.cli.app import main

STEP = 0.1  # s: a 10 Hz estimator


def _series(speed: np.ndarray, height: np.ndarray, sigma: float = 0.4, step: float = STEP) -> Samples:
    """Rows of a wind from the west (blowing east) at the given speeds, on a clock of the given step."""
    n = len(speed)
    wind = np.column_stack([np.zeros(n), speed, np.zeros(n)])
    return Samples(height, wind, np.full(n, sigma), np.full(n, -1.0), (), None, np.arange(n) * step)


def _ar1(rng: np.random.Generator, n: int, phi: float, sigma: float) -> np.ndarray:
    """A stationary AR(1) series of innovation sigma: x_k = phi x_(k-1) + e_k."""
    e = rng.normal(0.0, sigma, n)
    x = np.empty(n)
    x[0] = e[0] / np.sqrt(1.0 - phi * phi)
    for k in range(1, n):
        x[k] = phi * x[k - 1] + e[k]
    return x


def _var_of_ar1_mean(n: int, phi: float, sigma: float) -> float:
    """The exact variance of the mean of n samples of a stationary AR(1) (written out from its
    autocovariance sigma_x^2 phi^k, not from the code under test)."""
    k = np.arange(1, n)
    var_x = sigma ** 2 / (1.0 - phi ** 2)
    return var_x / n * (1.0 + 2.0 * np.sum((1.0 - k / n) * phi ** k))


def test_white_noise_gives_sigma_over_root_n_and_the_row_sigma_does_not_average_down():
    rng = np.random.default_rng(11)
    sigma = 0.3
    for n in (400, 40_000):
        height = np.linspace(0.0, 9.99, n)  # a steady climb through one 10 m bin
        stats = table(bin_sums(_series(6.0 + rng.normal(0.0, sigma, n), height), 10.0), 10.0)
        assert stats["count"].tolist() == [n]
        assert stats["seconds"][0] == pytest.approx(n * STEP)
        assert 0.9 * n <= stats["n_eff"][0] <= n  # independent rows: N_eff about n
        # the sample standard error scatters by about 1/sqrt(2n) relative, the N_eff estimate a little more
        assert stats["speed_se_mps"][0] == pytest.approx(sigma / np.sqrt(n), rel=0.1 if n < 1000 else 0.02)
        assert stats["sigma_h_mps"][0] == pytest.approx(0.4)  # the model's sigma: the same at any n


def test_the_sums_give_what_a_direct_fit_gives_even_a_kilometre_up():
    """The additive sums against numpy on the rows themselves: the straight line's residual scatter (n - 2
    degrees of freedom) and the lag-1 autocorrelation of the residuals, in a 5 m bin at 1000 m."""
    from dobwind.atmos import binstats

    rng = np.random.default_rng(9)
    n = 300
    height = 1000.0 + np.sort(rng.uniform(0.5, 4.0, n))
    x = 7.0 - 0.4 * height / 1000.0 + 0.05 * height + _ar1(rng, n, 0.7, 0.01)
    stats = table(bin_sums(_series(x, height), 5.0), 5.0)
    k = int(np.flatnonzero(stats["count"])[0])
    line = np.polyval(np.polyfit(height, x, 1), height)
    e = x - line
    r = np.mean(e[:-1] * e[1:]) / np.mean(e * e)
    assert stats["n_eff"][k] == pytest.approx(n * (1 - r) / (1 + r), rel=1e-7)
    assert stats["speed_se_mps"][k] == pytest.approx(np.sqrt(np.sum(e * e) / (n - 2) / (n * (1 - r) / (1 + r))),
                                                     rel=1e-7)
    std, r_sums = binstats.residual_scatter(np.sum(binstats.series_columns(x, height - 1002.5, binstats.neighbours(
        np.zeros(n), np.arange(n) * STEP)), axis=0)[None, :])
    assert r_sums[0] == pytest.approx(r, rel=1e-7) and std[0] == pytest.approx(np.sqrt(np.sum(e * e) / (n - 2)))


def test_an_ar1_series_gives_its_known_effective_count():
    """Through a shear across the upper half of the bin (the straight line in height comes out first)."""
    rng = np.random.default_rng(5)
    n, phi = 60_000, 0.9
    height = np.linspace(5.0, 9.99, n)
    x = 6.0 + 0.3 * height + _ar1(rng, n, phi, 0.1)
    stats = table(bin_sums(_series(x, height), 10.0), 10.0)
    # lag-1 r estimated to about sqrt((1 - phi^2) / n) = 0.002, i.e. N_eff to about 2 %
    assert stats["n_eff"][0] == pytest.approx(n * (1 - phi) / (1 + phi), rel=0.08)
    # An anticorrelated series (phi < 0) would be worth more than n samples: no credit is given for it.
    anti = table(bin_sums(_series(6.0 + _ar1(rng, 2000, -0.5, 0.1), np.linspace(0.0, 9.99, 2000)), 10.0), 10.0)
    assert anti["n_eff"][0] == 2000


def test_the_standard_error_matches_the_scatter_of_independent_bin_means():
    """Many bins, each one pass of an AR(1) series: the spread of their means is the closed form, and the
    standard error each bin reports from its own rows says the same."""
    rng = np.random.default_rng(7)
    bins, n, phi, sigma = 300, 400, 0.8, 0.1
    parts = []
    for k in range(bins):
        height = k * 10.0 + np.linspace(0.01, 9.99, n)
        parts.append(bin_sums(_series(5.0 + _ar1(rng, n, phi, sigma), height), 10.0))
    stats = table(combine(parts), 10.0)
    exact = _var_of_ar1_mean(n, phi, sigma)
    # 300 bins: a variance to about sqrt(2/300) = 8 % (1 sigma)
    assert np.var(stats["speed_mean_mps"] - 5.0) == pytest.approx(exact, rel=0.25)
    assert np.mean(stats["speed_se_mps"] ** 2) == pytest.approx(exact, rel=0.15)
    naive = np.mean(stats["speed_std_mps"] ** 2 / n)  # rows taken as independent: far too small
    assert naive < 0.3 * exact


def test_separate_passes_and_the_shear_across_a_bin_are_not_noise():
    """A linear shear across the bin is the profile, not scatter: a noiseless climb through it has no
    random error; two passes through a bin are not neighbours of one another."""
    n = 500
    height = np.linspace(0.0, 9.99, n)
    sheared = table(bin_sums(_series(4.0 + 0.2 * height, height), 10.0), 10.0)
    assert sheared["speed_std_mps"][0] > 0.5 and sheared["speed_se_mps"][0] < 1e-6
    rng = np.random.default_rng(3)
    up = _series(6.0 + _ar1(rng, n, 0.5, 0.2), height)
    down = _series(6.5 + _ar1(rng, n, 0.5, 0.2), height[::-1])
    later = Samples(down.height_m, down.wind_ned, down.sigma_h, down.sigma_up, (), None, down.time_s + 1000.0)
    joined = Samples(*(np.concatenate([a, b]) for a, b in ((up.height_m, later.height_m), (up.wind_ned, later.wind_ned),
                                                          (up.sigma_h, later.sigma_h), (up.sigma_up, later.sigma_up))),
                     (), None, np.concatenate([up.time_s, later.time_s]))
    one = table(bin_sums(joined, 10.0), 10.0)
    two = table(combine([bin_sums(up, 10.0), bin_sums(later, 10.0)]), 10.0)
    for key in ("seconds", "n_eff", "speed_se_mps"):
        assert one[key][0] == pytest.approx(two[key][0], rel=1e-9)  # the gap on the clock breaks the pair
    assert one["seconds"][0] == pytest.approx(2 * n * STEP)


def test_a_bin_under_the_minimum_gives_no_mean_and_says_why():
    from dobwind.cli.profile import _text

    n_short, n_long = 50, 150  # 5 s and 15 s at 10 Hz
    height = np.r_[np.linspace(0.0, 9.9, n_long), np.linspace(10.0, 19.9, n_short)]
    rng = np.random.default_rng(2)
    stats = table(bin_sums(_series(6.0 + rng.normal(0, 0.1, n_long + n_short), height), 10.0), 10.0, 10.0)
    assert stats["below_minimum"].tolist() == [False, True]
    assert np.isfinite(stats["speed_mean_mps"][0]) and np.isnan(stats["speed_mean_mps"][1])
    assert np.isnan(stats["sigma_h_mps"][1]) and stats["count"][1] == n_short
    rows = {line.split()[0]: line.split() for line in _text(stats, [], min_seconds=10.0).splitlines()[1:3]}
    # columns: bottom, "..", top, n, time, N_eff, speed, std, SE, from, spread, up, sigma_h, why no mean
    assert rows["0"][3:5] == [str(n_long), "15.0"] and rows["0"][6] == "6.00" and len(rows["0"]) == 13
    assert rows["10"][3:5] == [str(n_short), "5.0"] and rows["10"][6:13] == ["-"] * 7
    assert " ".join(rows["10"][13:]) == "5.0 s < --min-seconds 10"
    # --min-seconds 0: every bin with rows has a mean
    assert not table(bin_sums(_series(np.full(3, 6.0), np.array([1.0, 2.0, 3.0])), 10.0), 10.0)["below_minimum"][0]


HOP_S = 14.5


@pytest.fixture(scope="module")
def hover_then_hop(tmp_path_factory):
    """A CSV log (50 Hz, jittered clock) with a position: in the 0-10 m bin until HOP_S, then in the 10-20 m
    bin for the 1.5 s left."""
    from dobwind.io.logs import write_csv
    from tests import atmos_logs

    _, cols = atmos_logs.flight(hold_s=2.0)
    t = cols["t"]
    cols = {k: v for k, v in cols.items() if k != "segment"}
    cols.update(lat=np.full_like(t, 60.1), lon=np.full_like(t, 24.9), alt=np.where(t < HOP_S, 105.0, 115.0))
    names = list(cols)
    log = tmp_path_factory.mktemp("hop") / "hop.csv"
    write_csv(log, names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    return log, t


def test_the_command_prints_no_mean_under_the_minimum_and_writes_why(hover_then_hop, capsys):
    from dobwind.model.airframe import load_airframe
    from dobwind.model.status import trusted
    from dobwind.replay.replay import replay
    from tests.helpers import M300
    from tests.test_atmos_profile import _read

    log, t = hover_then_hop
    out = log.parent / "p.csv"
    assert main(["profile", str(M300), str(log), "-o", str(out), "--bin", "10"]) == 0
    printed = capsys.readouterr().out
    got = _read(out)
    _, _, traj = replay(load_airframe(M300), str(log))
    kept = trusted(traj.status)
    # expected time per bin: the span of its trusted rows (one unbroken run each) plus one 50 Hz step
    expected = [np.ptp(t[kept & below]) + 0.02 for below in (t < HOP_S, t >= HOP_S)]
    np.testing.assert_allclose(got["seconds"], expected, rtol=0.02)
    assert got["seconds"][0] >= 10.0 > got["seconds"][1] > 1.0
    assert got["below_minimum"].tolist() == [0, 1]
    assert np.isfinite(got["speed_mean_mps"][0]) and np.isnan(got["speed_mean_mps"][1])
    assert np.isfinite(got["speed_se_mps"][0]) and 1.0 <= got["n_eff"][0] <= got["count"][0]
    line = next(row for row in printed.splitlines() if row.startswith("10 .. 20"))
    assert f"{got['seconds'][1]:.1f} s < --min-seconds 10" in line and "nan" not in line


def test_the_netcdf_labels_the_error_of_the_mean_apart_from_the_row_sigma(hover_then_hop, capsys):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    from tests.helpers import M300
    from tests.test_atmos_netcdf import cf_check

    log, _ = hover_then_hop
    out = log.parent / "p.nc"
    assert main(["profile", str(M300), str(log), "-o", str(out), "--bin", "10", "--json"]) == 0
    capsys.readouterr()
    cf_check(out)  # no GPS time in a CSV log: no time coordinate, and still CF
    with xr.open_dataset(out) as ds:
        assert ds["wind_speed_standard_error_of_mean"].attrs["standard_name"] == "wind_speed standard_error"
        assert "standard_name" not in ds["wind_speed_standard_error"].attrs  # one row's sigma, not the mean's
        assert "not the standard error of the bin mean" in ds["wind_speed_standard_error"].attrs["long_name"]
        assert "time" not in ds.variables
        assert "over the time the flights spent there" in ds["wind_speed"].attrs["cell_methods"]
        assert ds["below_minimum"].values.tolist() == [0, 1] and ds.attrs["dobwind_min_seconds"] == 10.0
        assert np.isnan(ds["wind_speed"].values[1]) and ds["time_in_bin"].values[1] > 1.0


def test_with_gps_time_the_mean_is_over_height_and_time(tmp_path, capsys):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("netCDF4")
    pytest.importorskip("pymavlink")
    from tests import atmos_logs
    from tests.helpers import M300
    from tests.test_atmos_netcdf import cf_check

    _, cols = atmos_logs.flight(hold_s=2.0)
    log = atmos_logs.write_log(tmp_path / "f.bin", cols)
    out = tmp_path / "p.nc"
    assert main(["profile", str(M300), str(log), "-o", str(out), "--min-seconds", "0"]) == 0
    capsys.readouterr()
    cf_check(out)
    with xr.open_dataset(out, decode_times=False) as ds:
        assert ds["wind_speed"].attrs["cell_methods"].startswith("height: time: mean")
        assert ds["wind_speed_spread"].attrs["cell_methods"].startswith("height: time: standard_deviation")
        utc0 = atmos_logs.UTC0.timestamp()
        assert utc0 <= float(ds["time"].values) <= utc0 + 17.0  # the middle of the flight's UTC span


def test_a_kept_row_counts_one_step_of_the_logs_clock_not_of_the_kept_rows():
    """Every tenth row trusted for 60 s of a 10 Hz flight is 6 s of trusted rows, not 60 s (the kept rows'
    own median step is ten steps), and no two of them are neighbours; a flight that gives a bin one row
    adds one step to it rather than making its time unknown (a one-row clock has no step of its own)."""
    rng = np.random.default_rng(5)
    full = _series(6.0 + rng.normal(0, 0.1, 600), np.full(600, 3.0))
    every_tenth = slice(0, 600, 10)
    sparse = Samples(full.height_m[every_tenth], full.wind_ned[every_tenth], full.sigma_h[every_tenth],
                     full.sigma_up[every_tenth], (), None, full.time_s[every_tenth], STEP)
    stats = table(bin_sums(sparse, 10.0), 10.0, 10.0)
    assert stats["seconds"][0] == pytest.approx(60 * STEP) and stats["below_minimum"][0]
    pairs = bin_sums(sparse, 10.0)[0][list(SUMS).index("speed_pairs")]
    assert pairs == 0
    one = Samples(full.height_m[:1], full.wind_ned[:1], full.sigma_h[:1], full.sigma_up[:1], (), None,
                  full.time_s[:1] + 1000.0, STEP)
    both = table(combine([bin_sums(full, 10.0), bin_sums(one, 10.0)]), 10.0, 10.0)
    assert both["seconds"][0] == pytest.approx(601 * STEP) and np.isfinite(both["speed_mean_mps"][0])


def test_a_flight_carries_the_step_of_its_whole_clock(hover_then_hop):
    from dobwind.atmos.profile import flight_samples
    from dobwind.model.airframe import load_airframe
    from tests.helpers import M300

    log, t = hover_then_hop
    samples = flight_samples(load_airframe(M300), str(log))
    assert samples.step_s == pytest.approx(float(np.median(np.diff(t))))
