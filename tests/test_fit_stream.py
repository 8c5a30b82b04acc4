"""`fit` reads its logs a block at a time (issue #13): the written airframe is the whole-log fit's, byte
for byte, with blocks small enough to end inside holds, inside runs of rejected rows and inside the
cleaning's moving-mean windows; and each streamed stage gives its whole-log numbers bit for bit."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from dobwind.calibrate import calpoints, calstream, dragfit, fit
from dobwind.cli.app import main
from dobwind.calibrate.fitfamily import fit_airframe
from dobwind.io.logs import FlightLog, iter_log, read_log
from dobwind.model.airframe import load_airframe
from dobwind.model.airframe_toml import dump_airframe
from dobwind.model.step import build_step
from dobwind.calibrate.selfcheck import check_log
from tests.helpers import ROOT

AIRFRAME = ROOT / "benchmarks" / "vehicles" / "px4quad.airframe.toml"
VEHICLE = ROOT / "benchmarks" / "vehicles" / "px4quad.vehicle.toml"
RATE_HZ, HOLD_S = 12.5, 10.0   # holds long enough for the polynomial family's 2 s chunks, few rows
BLOCK_BYTES = 12_000   # about 60 rows, 5 s: shorter than a hold, longer than the 3 s smoothing window
                       # (the moving-mean test below has blocks shorter than the window)
REJECTED_ROWS = 40     # a run of rows the step rejects (no ground velocity), laid across a block's end


def _simulate(folder, scenario: str, seed: int) -> str:
    path = folder / f"{scenario}.csv"
    assert main(["simulate", scenario, "--airframe", str(AIRFRAME), "--vehicle", str(VEHICLE), "--rate", str(RATE_HZ),
                 "--hold", str(HOLD_S), "--seed", str(seed), "-o", str(path)]) == 0
    return str(path)


def _blank_velocity_across_block_ends(path: str, out) -> list[int]:
    """A copy of the log with vel_n empty on REJECTED_ROWS rows around three of the block ends that
    reading it BLOCK_BYTES at a time gives; returns the first row of each block of the copy (the
    shorter lines move the ends by a few rows)."""
    starts = [chunk.first_row for chunk in iter_log(path, block_bytes=BLOCK_BYTES)]
    lines = open(path).read().splitlines(keepends=True)
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    column = lines[header].strip().split(",").index("vel_n")
    for start in starts[len(starts) // 4::len(starts) // 4][:3]:
        for row in range(start - REJECTED_ROWS // 3, start - REJECTED_ROWS // 3 + REJECTED_ROWS):
            cells = lines[header + 1 + row].rstrip("\n").split(",")
            cells[column] = ""
            lines[header + 1 + row] = ",".join(cells) + "\n"
    out.write_text("".join(lines))
    return [chunk.first_row for chunk in iter_log(out, block_bytes=BLOCK_BYTES)]


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fitstream")
    sweep = _simulate(folder, "sweep", 5)
    starts = _blank_velocity_across_block_ends(sweep, folder / "sweep_gaps.csv")
    return {"sweep": str(folder / "sweep_gaps.csv"), "vertical": _simulate(folder, "vertical", 6), "starts": starts}


def test_the_blocks_end_inside_holds_windows_and_rejected_runs(logs):
    """The premise of the byte-for-byte test below: its blocks are shorter than what they must cut."""
    log = read_log(logs["sweep"])
    lengths = np.diff(logs["starts"])
    dt = float(np.median(np.diff(log.time_s)))
    assert len(lengths) > 100 and lengths.max() * dt < HOLD_S        # a block end inside every other hold
    settle = build_step(fit.calibration_airframe(load_airframe(AIRFRAME))).settling_time_s + 1.0
    assert lengths.max() < 2 * round(max(settle, 3.0) / dt)          # a smoothing window spans every block end
    missing = np.flatnonzero(np.isnan(log.columns["vel_n"]))
    assert len(missing) == 3 * REJECTED_ROWS and np.intersect1d(missing, logs["starts"]).size == 3


@pytest.mark.parametrize("model, dynamic", [("auto", False), ("polynomial", True)])
def test_the_streamed_fit_writes_the_whole_log_fits_airframe_byte_for_byte(logs, model, dynamic):
    af = load_airframe(AIRFRAME)
    paths = [logs["sweep"], logs["vertical"]]
    whole, whole_report, whole_points = fit_airframe(af, paths, model=model, dynamic=dynamic, block_bytes=None)
    streamed, report, points = fit_airframe(af, paths, model=model, dynamic=dynamic, block_bytes=BLOCK_BYTES)
    assert whole_report.self_check.passed and whole_report.samples > 1000
    assert dump_airframe(streamed) == dump_airframe(whole)
    assert dataclasses.asdict(report) == dataclasses.asdict(whole_report)
    assert (points is None) == (whole_points is None)
    if points is not None:
        for f in dataclasses.fields(points):
            np.testing.assert_array_equal(getattr(points, f.name), getattr(whole_points, f.name), err_msg=f.name)


def test_the_moving_mean_and_unwrap_over_blocks_are_one_passes_bit_for_bit():
    """Against numpy's whole-array np.convolve and np.unwrap, at block sizes below, at and above the
    window (odd and even windows: the centring differs)."""
    rng = np.random.default_rng(3)
    x = np.cumsum(rng.normal(size=(997, 3)), axis=0)
    yaw = np.angle(np.exp(1j * np.cumsum(rng.normal(0.0, 0.8, 997))))   # wrapped, with many jumps
    for window in (1, 2, 7, 50, 997):
        whole = np.column_stack([np.convolve(x[:, i], np.ones(window) / window, mode="same") for i in range(3)])
        for rows in (1, 6, 49, 50, 333):
            mean, unwrap = calpoints.MovingMean(window, 3), calpoints.Unwrap()
            pieces = [mean.add(x[lo:lo + rows]) for lo in range(0, len(x), rows)] + [mean.finish()]
            np.testing.assert_array_equal(np.concatenate(pieces), whole, err_msg=f"window {window}, rows {rows}")
            unwrapped = np.concatenate([unwrap(yaw[lo:lo + rows]) for lo in range(0, len(yaw), rows)])
            np.testing.assert_array_equal(unwrapped, np.unwrap(yaw))
    assert np.ptp(np.unwrap(yaw)) > 4 * math.pi   # the unwrap had jumps to remove


def test_the_log_sampler_over_blocks_is_one_pass_with_segments_and_invalid_rows(logs):
    """dragfit.LogSampler fed blocks: a run of invalid rows (filled from the last valid row), the
    decimation by absolute row and the segment runs all cross block ends."""
    af = fit.calibration_airframe(load_airframe(AIRFRAME))
    log = read_log(logs["sweep"])
    n = log.rows
    t = log.time_s / 4   # 50 Hz: every 5th row is a sample, and 23-row blocks do not divide that
    q = log.stack("q_w", "q_x", "q_y", "q_z")
    rng = np.random.default_rng(1)
    force = rng.normal(size=(n, 3))
    airflow = log.true_wind - np.nan_to_num(log.stack("vel_n", "vel_e", "vel_d"))
    airflow[500:530] = np.nan   # an invalid run across the block end at row 506
    thrust = dragfit.thrust_ned(af, None, log.columns["thrust"], q)
    yaw, usable, segment = log.columns["yaw_ref"], rng.random(n) > 0.1, log.columns["segment"]
    for frame in ("heading", "body"):
        whole = dragfit.log_samples(af, 0.5, t, force, airflow, thrust, yaw, usable, frame, q, segment)
        assert dragfit.sample_step(dragfit.median_step(t, af)) == 5
        sampler = dragfit.LogSampler(af, 0.5, dragfit.median_step(t, af), frame)
        for lo in range(0, n, 23):
            rows = slice(lo, lo + 23)
            sampler.add(t[rows], force[rows], airflow[rows], thrust[rows], yaw[rows], usable[rows], q[rows],
                        segment[rows])
        parts = sampler.result()
        assert set(parts) == set(whole) and len(whole["time"]) > n / 5 * 0.8
        for key in whole:
            np.testing.assert_array_equal(parts[key], whole[key], err_msg=f"{frame} {key}")
        assert np.isfinite(whole["columns"]).all() and np.isfinite(whole["airflow"]).all()


@pytest.mark.parametrize("labels", ["segments", "recurring", "windows"])
def test_the_self_check_over_blocks_is_one_pass(logs, labels):
    """check_log a block at a time: per segment (a segment's rows are dropped once it is scored), with
    labels that come back later (every segment kept), and in fixed windows without a segment column."""
    af = load_airframe(AIRFRAME)
    log = read_log(logs["sweep"])
    columns = dict(log.columns)
    if labels == "recurring":
        columns["segment"] = columns["segment"] % 5
    elif labels == "windows":
        columns.pop("segment")
    log = FlightLog(log.path, columns)
    whole = check_log(af, log, 1)
    for rows in (37, 1000):
        assert dataclasses.asdict(check_log(af, log, 1, block_rows=rows)) == dataclasses.asdict(whole), rows
    assert len(whole.segments) >= 5 and whole.noise_h_mps > 0


def test_the_points_reducer_over_blocks_is_the_whole_log_cleaning(logs):
    af = load_airframe(AIRFRAME)
    log = read_log(logs["sweep"])
    logs_ = fit.read_calibration_logs(af, [logs["sweep"]])
    run = fit.calibration_run(af, logs_)
    whole, settle = fit.calibration_points(af, logs_, run=run)
    rows = fit.heading_rows(logs_[0], run.force_ned[0], run.v_filt[0], run.status[0])
    shape = calstream.LogShape(log.rows, dragfit.median_step(log.time_s, af))
    for size in (11, 400):
        reducer = calstream.points_reducer(run.model, shape, False, 0)
        for lo in range(0, log.rows, size):
            reducer.add(*(x[lo:lo + size] for x in rows))
        points = fit.points_from(reducer.finish()[0])
        for f in dataclasses.fields(points):
            np.testing.assert_array_equal(getattr(points, f.name), getattr(whole, f.name), err_msg=f"{size} {f.name}")
    assert len(whole) > 50


def test_the_sample_rate_falls_so_that_a_long_calibration_keeps_at_most_max_samples():
    assert dragfit.sample_rate_hz(3600.0) == dragfit.DECIMATED_RATE_HZ == 10.0
    assert dragfit.sample_rate_hz(4 * 3600.0) == pytest.approx(2.5)
    assert dragfit.sample_rate_hz(0.0) == 10.0
    assert dragfit.sample_step(0.01, 2.5) == 40 and dragfit.sample_step(0.01) == 10


def test_a_capped_calibration_is_thinned_evenly_and_streams_byte_for_byte(logs, monkeypatch):
    """With the cap at a quarter of these logs' 10 Hz count, both paths take the same sparser samples
    (2.5 Hz: every 5th row of the 12.5 Hz logs, where 10 Hz keeps every row), and the hold-level CV
    counts its windows in seconds at that rate (samples.rates_hz())."""
    af = load_airframe(AIRFRAME)
    paths = [logs["sweep"], logs["vertical"]]
    total_s = sum(read_log(p).rows * dragfit.median_step(read_log(p).time_s, af) for p in paths)
    _, full, _ = fit_airframe(af, paths, model="drag-body", block_bytes=None)
    monkeypatch.setattr(dragfit, "MAX_SAMPLES", total_s * dragfit.DECIMATED_RATE_HZ / 4)
    whole, whole_report, _ = fit_airframe(af, paths, model="drag-body", block_bytes=None)
    streamed, report, _ = fit_airframe(af, paths, model="drag-body", block_bytes=BLOCK_BYTES)
    assert dump_airframe(streamed) == dump_airframe(whole)
    assert dataclasses.asdict(report) == dataclasses.asdict(whole_report)
    counts = [c.fit_samples for c in whole_report.self_check.logs]
    full_counts = [c.fit_samples for c in full.self_check.logs]
    assert all(abs(n - full_n / 5) <= 0.01 * full_n / 5 + 2 for n, full_n in zip(counts, full_counts)), (counts, full_counts)
    assert whole_report.samples == sum(counts)
    # The held-out holds are scored for as many seconds as at 10 Hz (fewer samples each).
    window, full_window = whole_report.hold_cv_by_speed.window_s, full.hold_cv_by_speed.window_s
    assert window == pytest.approx(full_window, rel=0.25) and full_window > 1.0
    assert not any("the hold-level CV's windows hold" in w for w in whole_report.warnings + full.warnings)
    # A sweep with a vertical log identifies the vertical law: no warning that it does not.
    assert not any("the vertical law predicts" in w for w in whole_report.warnings + full.warnings)


def test_sparse_cv_windows_are_warned_of():
    """8 h of calibration with 8 s holds: 36,000 samples over 28,800 s is 1.25 Hz, and a hold scored
    from 5 s after its start holds 3 s, 3.75 samples: under 4, a warning; an hour (10 Hz) is not."""
    from dobwind.calibrate.holdcv import sparse_windows

    rate_8h = dragfit.sample_rate_hz(8 * 3600.0)
    assert rate_8h == pytest.approx(1.25)
    warning = sparse_windows(3.0, rate_8h)
    assert warning is not None and "3.8 samples" in warning and "1.25 Hz" in warning
    assert sparse_windows(3.0, dragfit.sample_rate_hz(3600.0)) is None
    assert sparse_windows(3.2, 1.25) is None  # exactly 4
    rate = 50.0 / 9  # a 50 Hz log at step 9: 4 samples are 0.72 s, whose product with the rate is 3.9999...
    assert sparse_windows(4 / rate, rate) is None
    assert sparse_windows(None, 1.25) is None


def test_a_fit_sampled_too_sparsely_for_its_cv_says_so(logs, monkeypatch):
    af = load_airframe(AIRFRAME)
    paths = [logs["sweep"], logs["vertical"]]
    total_s = sum(read_log(p).rows * dragfit.median_step(read_log(p).time_s, af) for p in paths)
    monkeypatch.setattr(dragfit, "MAX_SAMPLES", total_s * dragfit.DECIMATED_RATE_HZ / 40)
    _, report, _ = fit_airframe(af, paths, model="drag-body", block_bytes=None)
    assert any("the hold-level CV's windows hold" in w for w in report.warnings), report.warnings
