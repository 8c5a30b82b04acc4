"""`dobwind profile` with an airframe whose vertical law is the zero-wind fallback (issue #36, a new
user's pass): the step publishes 0 there with sigma_up -1, which the profile averaged into an "up m/s
+0.00" as if a calm had been measured. The vertical columns must be empty and the horizontal ones intact."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.atmos.profile import Samples, bin_sums, combine, table
from dobwind.cli.app import main
from tests.helpers import M300
from tests.test_atmos_profile import _read, _wind_from, two_flights  # noqa: F401 - a fixture


def test_a_nan_vertical_wind_leaves_the_vertical_statistics_only():
    heights = np.array([1.0, 2.0, 3.0, 4.0])
    measured = Samples(heights, _wind_from(4.0, 90.0, up=[1.0, 2.0, 3.0, 4.0]), np.full(4, 0.3), np.full(4, -1.0))
    wind = _wind_from(np.full(4, 6.0), 270.0)
    wind[:, 2] = np.nan
    unknown = Samples(heights, wind, np.full(4, 0.3), np.full(4, -1.0))
    alone = table(bin_sums(unknown, 10.0), 10.0)
    assert alone["count"].tolist() == [4] and alone["speed_mean_mps"][0] == pytest.approx(6.0)
    assert np.isnan(alone["up_mean_mps"][0]) and np.isnan(alone["up_std_mps"][0])
    both = table(combine([bin_sums(measured, 10.0), bin_sums(unknown, 10.0)]), 10.0)
    # Eight rows for the horizontal wind (4 m/s from 90 and 6 m/s from 270: 1 m/s from 270 on average) ...
    assert both["count"].tolist() == [8] and both["speed_mean_mps"][0] == pytest.approx(5.0)
    assert both["eastward_mean_mps"][0] == pytest.approx(1.0)
    # ... and only the four measured ones for the vertical: mean 2.5, sample std of 1..4.
    assert both["up_mean_mps"][0] == pytest.approx(2.5)
    assert both["up_std_mps"][0] == pytest.approx(np.std([1, 2, 3, 4], ddof=1))


def test_profile_of_a_zero_wind_vertical_law_prints_no_vertical_wind(two_flights, tmp_path, capsys):  # noqa: F811
    folder, logs, _ = two_flights
    text = M300.read_text()
    assert "vertical_law" not in text
    fallback = tmp_path / "m300_zero.toml"
    assert "[force_air]" not in text  # its force-air tables are [force_air.horizontal] and [force_air.vertical]
    fallback.write_text(text.replace("[force_air.horizontal]", '[force_air]\nvertical_law = "zero-wind"\n\n'
                                     "[force_air.horizontal]", 1))
    out_fitted, out_zero = tmp_path / "fitted.csv", tmp_path / "zero.csv"
    # --min-seconds 0: the synthetic flight spends less than the default 10 s in each bin
    assert main(["profile", str(M300), str(logs[0]), "-o", str(out_fitted), "--jobs", "1", "--min-seconds", "0"]) == 0
    capsys.readouterr()
    assert main(["profile", str(fallback), str(logs[0]), "-o", str(out_zero), "--jobs", "1", "--min-seconds", "0"]) == 0
    printed = capsys.readouterr().out
    fitted, zero = _read(out_fitted), _read(out_zero)
    assert np.isfinite(fitted["up_mean_mps"][fitted["count"] > 0]).all()
    assert np.isnan(zero["up_mean_mps"]).all() and zero["count"].sum() > 100
    assert 'vertical_law = "zero-wind"' in printed and "+0.00" not in printed
    assert "speed m/s" in printed.splitlines()[0]


def test_a_prior_airframe_profile_names_the_reason_and_allowed_rows_are_not_called_trusted(two_flights, tmp_path,  # noqa: F811
                                                                                            capfd):
    """`init`'s starter on a log: the refusal only said "--allow admits quality-flagged rows"; with
    `--allow uncalibrated` the rows were printed and written as "trusted rows"."""
    folder, logs, _ = two_flights
    prior = tmp_path / "prior.toml"
    prior.write_text(M300.read_text() + '\n[calibration]\nstatus = "prior"\n')
    out = tmp_path / "p.csv"
    assert main(["profile", str(prior), str(logs[0]), "-o", str(out), "--jobs", "1"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "uncalibrated prior" in err and "--allow uncalibrated" in err
    assert not out.exists()
    assert main(["profile", str(prior), str(logs[0]), "-o", str(out), "--jobs", "1", "--allow", "uncalibrated"]) == 0
    printed = capfd.readouterr().out
    comment = out.read_text().splitlines()[0]
    for text in (printed, comment):
        assert "trusted rows" not in text and "UNCALIBRATED" in text
    assert main(["profile", str(M300), str(logs[0]), "-o", str(out), "--jobs", "1"]) == 0
    assert "trusted rows" in capfd.readouterr().out and "trusted rows only" in out.read_text().splitlines()[0]


def test_a_refusal_under_allow_uncalibrated_does_not_advise_allow_uncalibrated(tmp_path, capfd):
    """A prior's log too short to settle, profiled WITH --allow uncalibrated: the refusal said "or --allow
    uncalibrated for a rough profile", which the user had given; the log's own reason (SETTLING) stays."""
    from dobwind.io.logs import write_csv
    from tests import atmos_logs

    _, cols = atmos_logs.flight(hold_s=2.0)
    first = cols["t"] < 0.5   # half a second: every row still SETTLING
    names = [k for k in cols if k != "segment"]
    prior = tmp_path / "prior.toml"
    prior.write_text(M300.read_text() + '\n[calibration]\nstatus = "prior"\n')
    short = tmp_path / "short.csv"
    write_csv(short, names, np.column_stack([cols[n][first] for n in names]), ["%.17g"] * len(names))
    out = tmp_path / "p.csv"
    assert main(["profile", str(prior), str(short), "-o", str(out), "--jobs", "1", "--allow", "uncalibrated"]) == 2
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and "short.csv" in err and "SETTLING" in err
    assert "--allow uncalibrated" not in err and not out.exists()
