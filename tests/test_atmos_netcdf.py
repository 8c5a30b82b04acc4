"""`replay -o OUT.nc` (issue #35): a CF-1.8 trajectory on the log's own clock (UTC from GPS time), with the
position track on the estimate rows, pinned against closed forms and against the CSV output of the same
replay; a CF checker runs on it where one is installed, and the names/units are checked against the
CF standard-name table entries the file uses (carried here) in any case."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.io.logs import ESTIMATE_COLUMNS
from dobwind.model.status import STATUS_BITS, STATUS_LANDED, STATUS_NO_DATA
from tests import atmos_logs
from tests.helpers import M300

pytest.importorskip("pymavlink")
xr = pytest.importorskip("xarray")
pytest.importorskip("netCDF4")

# From the CF standard name table (version 84 and later): name -> canonical units. Written here by hand
# from the table, not from dobwind's own list, so a wrong name or unit in dobwind fails.
CF_TABLE = {"eastward_wind": "m s-1", "northward_wind": "m s-1", "upward_air_velocity": "m s-1",
            "wind_speed": "m s-1", "wind_from_direction": "degree", "latitude": "degrees_north",
            "longitude": "degrees_east", "altitude": "m", "height": "m", "time": None}
CF_MODIFIERS = ("standard_error", "number_of_observations")


@pytest.fixture(scope="module")
def replayed(tmp_path_factory):
    """One synthetic flight replayed to NetCDF and to CSV."""
    folder = tmp_path_factory.mktemp("nc")
    _, cols = atmos_logs.flight()
    log = atmos_logs.write_log(folder / "f.bin", cols)
    assert main(["replay", str(M300), str(log), "-o", str(folder / "f.nc")]) == 0
    assert main(["replay", str(M300), str(log), "-o", str(folder / "f.csv")]) == 0
    return folder, cols


def _csv(path):
    return np.genfromtxt(path, delimiter=",", names=True, comments="#")


def test_netcdf_holds_the_csv_estimate_under_cf_names(replayed):
    folder, _ = replayed
    csv = _csv(folder / "f.csv")
    with xr.open_dataset(folder / "f.nc") as ds:
        for var, column in (("eastward_wind", "wind_e"), ("northward_wind", "wind_n"),
                            ("upward_air_velocity", "wind_speed_up"), ("wind_speed", "wind_speed_h"),
                            ("wind_from_direction", "wind_from_deg")):
            # float32 in the file, %.6g in the CSV
            np.testing.assert_allclose(ds[var].values, csv[column], rtol=1e-5, atol=1e-5)
            assert ds[var].attrs["standard_name"] == var
        np.testing.assert_array_equal(ds["status"].values, csv["status"].astype(int))
        np.testing.assert_allclose(ds["log_time"].values, csv["t"], atol=2e-6)  # both on the log's own clock


def test_time_is_utc_from_gps_week_and_position_follows_the_track(replayed):
    folder, cols = replayed
    with xr.open_dataset(folder / "f.nc") as ds:
        t_sim = ds["log_time"].values - atmos_logs.BOOT_US * 1e-6  # the simulation's clock
        expected = np.datetime64(atmos_logs.UTC0.replace(tzinfo=None)) + (t_sim * 1e9).astype("timedelta64[ns]")
        lag = np.abs((ds["time"].values - expected) / np.timedelta64(1, "ms"))
        assert lag.max() < 2.0
        lat, lon, alt, height = atmos_logs.track(t_sim)
        inside = t_sim <= cols["t"][::5][-1]  # the track's last sample; later rows are beyond it
        np.testing.assert_allclose(ds["lat"].values[inside], lat[inside], atol=1e-9)
        np.testing.assert_allclose(ds["lon"].values[inside], lon[inside], atol=1e-9)
        np.testing.assert_allclose(ds["height"].values[inside], height[inside], atol=1e-3)
        np.testing.assert_allclose(ds["alt"].values[inside], alt[inside], atol=1e-3)
        assert ds.attrs["featureType"] == "trajectory"
        assert "POS" in ds.attrs["position_note"]


def test_names_units_and_flags_follow_cf(replayed):
    folder, _ = replayed
    with xr.open_dataset(folder / "f.nc", decode_times=False) as ds:
        assert ds.attrs["Conventions"] == "CF-1.8"
        assert ds.attrs["dobwind_airframe"] == "m300" and ds.attrs["dobwind_version"]
        assert "calibrat" in ds.attrs["dobwind_calibration"]
        assert ds["time"].attrs["units"] == "seconds since 1970-01-01 00:00:00"
        named = 0
        for name, var in ds.variables.items():
            std = var.attrs.get("standard_name")
            if std is None:
                continue
            base, *modifier = std.split()
            assert base in CF_TABLE, f"{name}: {std} not in the table"
            assert all(m in CF_MODIFIERS for m in modifier), f"{name}: modifier {modifier}"
            if CF_TABLE[base] is not None and not modifier:
                assert var.attrs["units"] == CF_TABLE[base], name
            named += 1
        assert named >= 11
        for var in ("eastward_wind", "northward_wind", "wind_speed"):
            assert "wind_speed_standard_error" in ds[var].attrs["ancillary_variables"].split()
        flags = ds["status"].attrs
        masks, meanings = list(flags["flag_masks"]), flags["flag_meanings"].split()
        assert len(masks) == len(meanings)
        for bit in STATUS_BITS:
            assert meanings[masks.index(bit.value)] == bit.name.lower()
        assert meanings[masks.index(STATUS_NO_DATA)] == "no_data"
        assert meanings[masks.index(STATUS_LANDED)] == "landed"


def cf_check(path) -> None:
    """compliance-checker's CF 1.8 suite (the `cfcheck` extra), warnings included: everything must pass."""
    pytest.importorskip("compliance_checker.runner")
    from compliance_checker.runner import CheckSuite, ComplianceChecker

    CheckSuite.load_all_available_checkers()
    report = path.parent / (path.name + ".cf.txt")
    # criteria "lenient" would pass files with warnings; "strict" fails on any of them
    passed, errors = ComplianceChecker.run_checker(str(path), ["cf:1.8"], 0, "strict", output_filename=str(report),
                                                   output_format="text")
    assert not errors and passed, report.read_text()[:3000]


def test_a_cf_checker_passes_it(replayed):
    folder, _ = replayed
    cf_check(folder / "f.nc")


def test_without_position_it_says_so_and_writes_no_coordinates(tmp_path, capsys):
    _, cols = atmos_logs.flight()
    log = atmos_logs.write_log(tmp_path / "nopos.bin", cols, position=False, gps_time=False)
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "nopos.nc")]) == 0
    err = capsys.readouterr().err
    assert "warning" in err and "no latitude" in err and "nopos.bin" in err
    with xr.open_dataset(tmp_path / "nopos.nc", decode_times=False) as ds:
        assert "lat" not in ds.variables and "lon" not in ds.variables and "featureType" not in ds.attrs
        assert "no global position" in ds.attrs["position_note"]
        # No GPS time: no CF time coordinate, the rows are on the log's own clock (seconds since boot).
        assert "time" not in ds.variables and ds["log_time"].attrs["units"] == "s"
        np.testing.assert_allclose(ds["log_time"].values[0], atmos_logs.BOOT_US * 1e-6, atol=1e-6)
    cf_check(tmp_path / "nopos.nc")


def test_csv_log_to_netcdf_and_a_failed_write_loses_nothing(tmp_path, monkeypatch):
    from dobwind.atmos import ncstream
    from dobwind.io.logs import write_csv

    _, cols = atmos_logs.flight(hold_s=1.0)
    names = [n for n in cols if n != "segment"]
    write_csv(tmp_path / "f.csv", names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    out = tmp_path / "f.nc"
    assert main(["replay", str(M300), str(tmp_path / "f.csv"), "-o", str(out)]) == 0
    with xr.open_dataset(out, decode_times=False) as ds:
        assert ds.sizes["log_time"] == len(cols["t"]) and "lat" not in ds.variables
    before = out.read_bytes()

    def half_then_full_disk(path, *args):  # a disk that fills up halfway through the file
        path.write_bytes(b"CDF partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(ncstream, "stream_csv_netcdf", half_then_full_disk)
    assert main(["replay", str(M300), str(tmp_path / "f.csv"), "-o", str(out)]) == 2
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.csv", "f.nc"]  # no temporary left behind
    assert len(ESTIMATE_COLUMNS) == 13  # the columns the file maps; a new output needs a NetCDF name too


def _wrap(lon):
    """Longitude into [-180, 180), as autopilots report it."""
    return (lon + 180.0) % 360.0 - 180.0


def test_px4_position_home_and_utc_from_a_ulog(tmp_path):
    """The PX4 reader alone: vehicle_global_position on the rows, home_position's altitude as the take-off
    point, time_utc_usec against its timestamp (rows before the receiver knew the time carry 0)."""
    pytest.importorskip("pyulog")
    from dobwind.io.position import on_rows, read_geo
    from tests.ulog_writer import Topic, write_ulog

    stamps = np.arange(0, 20_000_000, 200_000) + 5_000_000  # 5 Hz from 5 s after boot
    t = stamps * 1e-6
    gpos = Topic("vehicle_global_position", [("uint64_t", "timestamp"), ("double", "lat"), ("double", "lon"),
                                             ("float", "alt")],
                 [{"timestamp": s, "lat": -35.0 + 1e-6 * k, "lon": _wrap(179.99999 + 1e-6 * k), "alt": 600.0 + 0.5 * k}
                  for k, s in enumerate(stamps)])
    utc0 = 1_700_000_000.0
    gps = Topic("vehicle_gps_position", [("uint64_t", "timestamp"), ("uint64_t", "time_utc_usec")],
                [{"timestamp": s, "time_utc_usec": 0 if k < 3 else round((utc0 + s * 1e-6) * 1e6)}
                 for k, s in enumerate(stamps)])
    home = Topic("home_position", [("uint64_t", "timestamp"), ("float", "alt")],
                 [{"timestamp": 4_000_000, "alt": 590.0}, {"timestamp": 6_000_000, "alt": 599.0}])
    geo = read_geo(str(write_ulog(tmp_path / "f.ulg", [gpos, gps, home])))
    assert geo.utc_offset_s == pytest.approx(utc0, abs=1e-5)
    rows = t[:-1] + 0.1  # halfway between position samples
    pos = on_rows(geo.track, rows)
    k = np.arange(len(rows)) + 0.5
    np.testing.assert_allclose(pos.lat_deg, -35.0 + 1e-6 * k, atol=1e-9)
    # Across the antimeridian the longitude is interpolated the short way and wrapped into [-180, 180).
    lon = 179.99999 + 1e-6 * k
    np.testing.assert_allclose(pos.lon_deg, _wrap(lon), atol=1e-9)
    assert (pos.lon_deg < 0).any() and (pos.lon_deg > 0).any()
    # Above the home in force: 590 m until PX4 re-homed at 6 s (the first home holds before it, too).
    home_alt = np.where(rows < 6.0, 590.0, 599.0)
    np.testing.assert_allclose(pos.height_m, 600.0 + 0.5 * k - home_alt, atol=1e-3)
    far = on_rows(geo.track, np.array([t[0] - 1.0, t[-1] + 1.0]))
    assert np.all(np.isnan(far.lat_deg))  # no position outside the track


SITL = Path(__file__).resolve().parents[2] / "shared" / "data" / "field" / "arducopter_sitl_wind10_from180.bin"


@pytest.mark.skipif(not SITL.exists(), reason="the field logs are not beside the checkout")
def test_the_sitl_log_has_utc_position_and_home(tmp_path):
    from dobwind.io.position import read_geo

    geo = read_geo(str(SITL))
    when = np.datetime64(int(geo.utc_offset_s + geo.track.t_s[0]), "s")
    assert np.datetime64("2020-01-01") < when < np.datetime64("2030-01-01")
    height = geo.track.alt_m - geo.track.home_alt_m
    assert 25.0 < height.max() < 40.0 and abs(height[0]) < 1.0  # the README: up to 33 m, from the ground


def test_px4_ulog_replay_to_netcdf_end_to_end(tmp_path):
    """A whole PX4 flight (the ULog tests' writer) with a global position track and GPS time beside it:
    the NetCDF rows carry UTC and the position at their own instants."""
    pytest.importorskip("pyulog")
    from tests.test_ulog import _flight, _ulog
    from tests.ulog_writer import Topic

    _, cols = _flight(rate=50.0)
    t0_us, utc0 = 1_000_000, 1_650_000_000.0
    stamps = t0_us + np.arange(0, int(cols["t"][-1] * 1e6), 100_000)  # 10 Hz
    gpos = Topic("vehicle_global_position", [("uint64_t", "timestamp"), ("double", "lat"), ("double", "lon"),
                                             ("float", "alt")],
                 [{"timestamp": s, "lat": 52.0 + 1e-7 * (s - t0_us) * 1e-3, "lon": 13.0, "alt": 40.0 + 1.5e-6 * (s - t0_us)}
                  for s in stamps])
    gps = Topic("vehicle_gps_position", [("uint64_t", "timestamp"), ("uint64_t", "time_utc_usec")],
                [{"timestamp": s, "time_utc_usec": round(utc0 * 1e6) + s} for s in stamps])
    log = _ulog(tmp_path / "f.ulg", cols, extra=(gpos, gps))
    assert main(["replay", str(M300), str(log), "-o", str(tmp_path / "f.nc")]) == 0
    with xr.open_dataset(tmp_path / "f.nc", decode_times=False) as ds:
        boot_s = ds["log_time"].values
        np.testing.assert_allclose(ds["time"].values, utc0 + boot_s, atol=1e-3)
        inside = boot_s <= stamps[-1] * 1e-6
        np.testing.assert_allclose(ds["lat"].values[inside], 52.0 + 1e-4 * (boot_s[inside] - 1.0), atol=1e-9)
        # No home_position and no landed rows before the first airborne one: above the first position.
        np.testing.assert_allclose(ds["height"].values[inside], 1.5 * (boot_s[inside] - 1.0) - 1.5 * (boot_s[0] - 1.0),
                                   atol=1e-4)
        assert "vehicle_global_position" in ds.attrs["position_note"]


def test_a_csv_log_streamed_in_small_chunks_gives_the_same_file_content(tmp_path):
    """The NetCDF of a CSV log is appended chunk by chunk: many chunks hold what one chunk holds."""
    import argparse

    from dobwind.io.logs import write_csv
    from dobwind.model.airframe import load_airframe
    from dobwind.atmos.ncreplay import replay_csv_netcdf
    from dobwind.io.outputs import OutputFiles, Target

    _, cols = atmos_logs.flight(hold_s=1.0)
    t = cols["t"]
    cols = {k: v for k, v in cols.items() if k != "segment"}
    cols.update(lat=np.full_like(t, 47.0), lon=np.full_like(t, 8.0), alt=500.0 + t)
    names = list(cols)
    write_csv(tmp_path / "f.csv", names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    af = load_airframe(M300)
    for name, block in (("one.nc", None), ("many.nc", 4096)):
        args = argparse.Namespace(airframe=str(M300), log=str(tmp_path / "f.csv"), backend="python",
                                  precision="single", plot=None, output=str(tmp_path / name))
        with OutputFiles([Target("-o", args.output)]) as out:
            result = replay_csv_netcdf(args, af, out, block_bytes=block)
        assert result.metrics["rows"] == len(t)
    with xr.open_dataset(tmp_path / "one.nc", decode_times=False) as one, \
            xr.open_dataset(tmp_path / "many.nc", decode_times=False) as many:
        assert many.sizes["log_time"] == len(t)
        for var in one.variables:
            np.testing.assert_array_equal(many[var].values, one[var].values, err_msg=var)
        np.testing.assert_allclose(many["height"].values, t - t[0], atol=1e-9)
        assert many.attrs == one.attrs
    cf_check(tmp_path / "many.nc")  # no GPS time in a CSV log: log_time is the rows' coordinate


def test_a_zero_wind_vertical_law_writes_no_upward_air_velocity(tmp_path):
    """The fallback's vertical wind is exactly 0 by construction: written under a CF name it would read as a
    measured calm. The file leaves it out (and its standard error) and says why; the horizontal wind stays."""
    text = M300.read_text()
    assert "[force_air.vertical]" in text
    frame = tmp_path / "flat.toml"
    frame.write_text(text.replace("[force_air.horizontal]", '[force_air]\nvertical_law = "zero-wind"\n\n[force_air.horizontal]'))
    _, cols = atmos_logs.flight(hold_s=1.0)
    log = atmos_logs.write_log(tmp_path / "f.bin", cols)
    for airframe, name in ((M300, "fitted.nc"), (frame, "flat.nc")):
        assert main(["replay", str(airframe), str(log), "-o", str(tmp_path / name)]) == 0
    with xr.open_dataset(tmp_path / "fitted.nc") as fitted, xr.open_dataset(tmp_path / "flat.nc") as flat:
        assert "upward_air_velocity" in fitted and "vertical_note" not in fitted.attrs
        assert "upward_air_velocity" not in flat and "upward_air_velocity_standard_error" not in flat
        assert "zero-wind" in flat.attrs["vertical_note"]
        np.testing.assert_allclose(flat["eastward_wind"].values, fitted["eastward_wind"].values, rtol=1e-4, atol=1e-4)
    cf_check(tmp_path / "flat.nc")


def test_every_row_coordinate_is_named_on_the_variables_not_in_a_global_attribute(replayed):
    """CF has no global "coordinates" attribute: log_time, a coordinate of the rows beside UTC time, is
    named in each variable's own list, so a reader that is not xarray finds it too."""
    import netCDF4

    folder, _ = replayed
    with netCDF4.Dataset(folder / "f.nc") as nc:
        assert "coordinates" not in nc.ncattrs()
        for name in ("eastward_wind", "wind_speed", "status"):
            assert nc[name].getncattr("coordinates").split() == ["time", "log_time", "lat", "lon", "alt", "height"]


def test_the_trajectory_name_is_a_char_array_that_reads_back_as_the_log_name(replayed):
    """CF's classic text form (a char array), which every CF checker and NetCDF-3 era reader takes; xarray
    still decodes it to the log's name."""
    import netCDF4

    folder, _ = replayed
    with netCDF4.Dataset(folder / "f.nc") as nc:
        assert nc["trajectory"].dtype == np.dtype("S1") and nc["trajectory"].getncattr("cf_role") == "trajectory_id"
    with xr.open_dataset(folder / "f.nc") as ds:
        assert str(ds["trajectory"].values) == "f.bin"


def test_a_csv_replay_figure_draws_no_vertical_wind_for_the_zero_wind_law(tmp_path, monkeypatch):
    """The CSV paths (estimate CSV and streamed NetCDF) draw the same as the autopilot path: no vertical
    line for an airframe whose vertical wind is 0 by construction."""
    import dobwind.io.plots as plots
    from dobwind.io.logs import write_csv

    drawn = []
    monkeypatch.setattr(plots, "replay_plot", lambda *a, **k: drawn.append(np.asarray(a[1])))
    frame = tmp_path / "flat.toml"
    frame.write_text(M300.read_text().replace("[force_air.horizontal]",
                                              '[force_air]\nvertical_law = "zero-wind"\n\n[force_air.horizontal]'))
    _, cols = atmos_logs.flight(hold_s=1.0)
    names = [k for k in cols if k != "segment"]
    log = tmp_path / "f.csv"
    write_csv(log, names, np.column_stack([cols[n] for n in names]), ["%.17g"] * len(names))
    for out in ("e.csv", "e.nc"):
        assert main(["replay", str(frame), str(log), "-o", str(tmp_path / out), "--plot", str(tmp_path / "w.png")]) == 0
    assert len(drawn) == 2
    for wind in drawn:
        assert np.all(np.isnan(wind[:, 2])) and np.isfinite(wind[:, :2]).any()


def test_the_file_says_each_row_is_a_filters_output_with_its_time_constants(replayed):
    """A meteorologist compares rows with a mast's block means: the file says what averaging the rows carry,
    from the airframe's own low-pass schedule (time constant 1 / (2 pi f) of each cutoff)."""
    from dobwind.model.airframe import load_airframe

    folder, _ = replayed
    af = load_airframe(M300)
    with xr.open_dataset(folder / "f.nc") as ds:
        text = ds.attrs["dobwind_time_response"]
    assert "not a block mean" in text and f"at {1.0 / af.observer.sample_time_s:g} Hz" in text
    for speed, cutoff in zip(af.filter.speeds_mps, af.filter.cutoffs_hz):
        assert f"{cutoff:g} Hz at {speed:g} m/s (time constant {1.0 / (2.0 * np.pi * cutoff):.2f} s)" in text


def test_log_time_does_not_promise_time_since_boot():
    """A SITL's clock may count from 1970 and a ROS 2 bag keeps its recorder's: log_time says it is the log's
    own stamps and not UTC, rather than "time since the autopilot booted" for every log."""
    from dobwind.io.netcdf import _coords
    from dobwind.io.position import Geo

    name = _coords(np.array([1.71e9, 1.71e9 + 0.1]), Geo(None, None, "none"))["log_time"][2]["long_name"]
    assert "own clock" in name and "not corrected to UTC" in name and "since the autopilot booted" not in name


def test_the_time_response_names_the_rows_own_rate(replayed, tmp_path):
    """replay --rate 50 writes rows at 50 Hz: the attribute said "at 100 Hz", the airframe's observer rate."""
    folder, _ = replayed
    assert main(["replay", str(M300), str(folder / "f.bin"), "--rate", "50", "-o", str(tmp_path / "r.nc")]) == 0
    with xr.open_dataset(tmp_path / "r.nc") as ds:
        text, step = ds.attrs["dobwind_time_response"], float(np.median(np.diff(ds["log_time"].values)))
    assert step == pytest.approx(0.02, abs=1e-9) and "causal filters at 50 Hz," in text
