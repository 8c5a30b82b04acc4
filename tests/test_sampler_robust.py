"""The drag samples' robustness (review of issues #12/#13): the rate a sample stands for is the one the
rows were actually kept at, a log that gives no sample gives empty arrays, and invalid rows at a log's
start neither become samples nor reach the regressors' filters."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.calibrate import dragfit, fit, holdcv
from dobwind.cli.app import main
from dobwind.model.airframe import load_airframe
from tests.helpers import M300

CUTOFF_HZ = 0.5
HOLD_S = 8.0    # segment length of the synthetic logs (scored from holdcv.HOLD_SETTLE_S on)


@pytest.fixture(scope="module")
def af():
    return fit.calibration_airframe(load_airframe(M300))


def _rows(af, rate_hz: float, seconds: float, seed: int = 0) -> dict[str, np.ndarray]:
    """LogSampler.add's arguments for a synthetic log: airflow wandering through a few m/s, hover thrust,
    a slowly turning heading, every row usable, segments of HOLD_S."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * rate_hz))) / rate_hz
    n = len(t)
    airflow = np.column_stack([4 + 3 * np.sin(0.05 * t), 2 * np.cos(0.07 * t), 0.5 * np.sin(0.3 * t)])
    yaw = 0.02 * t
    q = np.column_stack([np.cos(yaw / 2), np.zeros(n), np.zeros(n), np.sin(yaw / 2)])
    thrust = np.tile([0.0, 0.0, -af.mass_kg * af.gravity_mps2], (n, 1)) * (1 + 0.01 * rng.normal(size=(n, 1)))
    return {"t": t, "force_ned": rng.normal(size=(n, 3)), "airflow_ned": airflow, "thrust_ned": thrust, "yaw": yaw,
            "usable": np.ones(n, dtype=bool), "q": q, "segment": (t // HOLD_S).astype(int)}


def _sampled(af, rows: dict[str, np.ndarray], frame: str = "heading", block: int | None = None,
             rate_hz: float = dragfit.DECIMATED_RATE_HZ) -> dict[str, np.ndarray]:
    """The log's samples, fed whole or ``block`` rows at a time."""
    sampler = dragfit.LogSampler(af, CUTOFF_HZ, dragfit.median_step(rows["t"], af), frame, rate_hz=rate_hz)
    size = block or max(1, len(rows["t"]))
    for lo in range(0, max(1, len(rows["t"])), size):   # a log of no row is fed once, empty
        sampler.add(**{k: v[lo:lo + size] for k, v in rows.items()})
    return sampler.result()


# 1. The samples' rate is the rate the rows were kept at --------------------------------------------------

@pytest.mark.parametrize("log_hz, true_hz", [(12.5, 12.5), (15.0, 7.5), (30.0, 10.0), (50.0, 10.0)])
def test_each_sample_carries_the_interval_its_rows_were_actually_kept_at(af, log_hz, true_hz):
    """10 Hz asked for, whole rows kept: 12.5 Hz keeps every row, 15 Hz every second row (7.5 Hz). The
    interval is read off the kept samples' own times, not off the sampler."""
    part = _sampled(af, _rows(af, log_hz, 60.0))
    assert np.median(np.diff(part["time"])) == pytest.approx(1.0 / true_hz)
    np.testing.assert_allclose(part["interval_s"], 1.0 / true_hz, rtol=1e-12)
    samples = dragfit.merge([part])
    np.testing.assert_allclose(samples.rates_hz(), true_hz, rtol=1e-12)
    picked = samples.select(np.arange(len(samples)) % 3 == 0)
    np.testing.assert_allclose(picked.rates_hz(), true_hz, rtol=1e-12)
    assert len(picked.rates_hz()) == len(picked)


def test_logs_of_different_rates_keep_their_own_rates_through_merge_and_select(af):
    parts = [_sampled(af, _rows(af, 15.0, 60.0)), _sampled(af, _rows(af, 12.5, 60.0, seed=1))]
    samples = dragfit.merge(parts)
    for log, rate in ((0, 7.5), (1, 12.5)):
        np.testing.assert_allclose(samples.rates_hz()[samples.log_index == log], rate, rtol=1e-12)
    picked = samples.select(samples.log_index == 1)
    np.testing.assert_allclose(picked.rates_hz(), 12.5, rtol=1e-12)
    assert len(picked.rates_hz()) == len(picked) == len(parts[1]["time"])


def _exact(train: dragfit.DragSamples, test: dragfit.DragSamples) -> np.ndarray:
    return test.airflow


@pytest.mark.parametrize("log_hz", [12.5, 15.0])
def test_held_out_holds_are_scored_for_their_true_length(af, log_hz):
    """Per segment, scored from HOLD_SETTLE_S on: each window is HOLD_S - HOLD_SETTLE_S long, whatever
    the rate the samples were kept at (to within one sample)."""
    part = _sampled(af, _rows(af, log_hz, 400.0))
    cv = holdcv.hold_cv(dragfit.merge([part]), _exact)
    interval = float(np.median(np.diff(part["time"])))
    assert abs(cv.window_s - (HOLD_S - holdcv.HOLD_SETTLE_S)) <= interval + 1e-9, (cv.window_s, interval)


@pytest.mark.parametrize("log_hz, true_hz", [(12.5, 12.5), (15.0, 7.5), (50.0, 10.0)])
def test_fixed_windows_hold_window_s_times_the_true_rate_samples(af, log_hz, true_hz):
    """Without segments, the windows counted in samples hold window_s x the samples' true rate."""
    part = {k: v for k, v in _sampled(af, _rows(af, log_hz, 400.0)).items() if k not in ("hold", "hold_age_s")}
    samples = dragfit.merge([part])
    per_window = holdcv.samples_per_window(samples, holdcv.HOLD_WINDOW_S)
    assert np.all(per_window == round(holdcv.HOLD_WINDOW_S * true_hz))
    windows, scored = holdcv._scored_windows(samples, per_window)
    _, count = np.unique(windows, return_counts=True)
    # Blocks of BLOCK_S = 20 s hold two whole windows each (the last block may be cut short).
    assert scored.all() and np.median(count) == round(holdcv.HOLD_WINDOW_S * true_hz)
    assert holdcv.hold_cv(samples, _exact).window_s == pytest.approx(holdcv.HOLD_WINDOW_S)


# 2. A log that gives no sample ----------------------------------------------------------------------------

def _assert_empty_like(empty: dict[str, np.ndarray], full: dict[str, np.ndarray]) -> None:
    """``empty`` has ``full``'s keys, with no row and the same trailing shape and dtype."""
    assert set(empty) == set(full)
    for key in full:
        assert empty[key].shape == (0,) + full[key].shape[1:], key
        assert empty[key].dtype == full[key].dtype, key


@pytest.mark.parametrize("frame", ["heading", "body"])
def test_a_log_without_rows_or_valid_rows_gives_empty_samples(af, frame):
    rows = _rows(af, 50.0, 30.0)
    full = _sampled(af, rows, frame)
    assert len(full["time"]) > 100
    no_segment = {k: v for k, v in full.items() if k not in ("hold", "hold_age_s")}
    _assert_empty_like(dragfit.LogSampler(af, CUTOFF_HZ, 0.02, frame).result(), no_segment)   # never fed
    _assert_empty_like(_sampled(af, {k: v[:0] for k, v in rows.items()}, frame), full)     # fed no row
    invalid = dict(rows, airflow_ned=np.full_like(rows["airflow_ned"], np.nan))
    for block in (None, 7):
        _assert_empty_like(_sampled(af, invalid, frame, block), full)
    unusable = dict(rows, usable=np.zeros(len(rows["t"]), dtype=bool))
    _assert_empty_like(_sampled(af, unusable, frame), full)
    merged = dragfit.merge([_sampled(af, invalid, frame), full], frame)
    assert len(merged) == len(full["time"]) and np.all(merged.log_index == 1) and merged.hold is not None
    assert len(dragfit.merge([_sampled(af, invalid, frame)], frame)) == 0


# 3. Invalid rows at a log's start -------------------------------------------------------------------------

@pytest.mark.parametrize("frame", ["heading", "body"])
@pytest.mark.parametrize("column", ["airflow_ned", "thrust_ned"])
def test_invalid_leading_rows_are_as_if_absent_whole_and_streamed(af, frame, column):
    """The first 50 rows' airflow (true wind) or thrust (rpm) NaN: the log's samples are those of the log
    without those rows (their filters start at the first valid row, in steady state), bit for bit, fed
    whole or in blocks that end inside the invalid run; every filtered column is finite."""
    rows = _rows(af, 50.0, 200.0)
    bad = 50
    assert bad % dragfit.sample_step(0.02) == 0   # the decimation keeps the same rows in both logs
    broken = {k: v.copy() for k, v in rows.items()}
    broken[column][:bad] = np.nan
    absent = _sampled(af, {k: v[bad:] for k, v in rows.items()}, frame)
    for block in (None, 23, 7):
        got = _sampled(af, broken, frame, block)
        assert np.isfinite(got["columns"]).all() and np.isfinite(got["airflow"]).all(), block
        assert got["time"].min() >= rows["t"][bad]   # no invalid row became a sample
        for key in absent:
            if key != "hold_age_s":
                np.testing.assert_array_equal(got[key], absent[key], err_msg=f"{block} {key}")
        # The segment began at the log's first row, invalid or not: ages count from there.
        np.testing.assert_allclose(got["hold_age_s"], absent["hold_age_s"] + (got["hold"] == 0) * rows["t"][bad])


def test_the_decimation_counts_the_invalid_leading_rows(af):
    """53 invalid rows (not a multiple of the step): the samples are still the log's rows 0, step,
    2 step, ... (as those of a log whose first rows were valid), fed whole or in blocks."""
    rows = _rows(af, 50.0, 100.0)
    rows["airflow_ned"][:53] = np.nan
    step = dragfit.sample_step(0.02)
    whole = _sampled(af, rows)
    assert len(whole["time"]) == len(rows["t"]) // step - 53 // step - 1
    assert np.all(np.round(whole["time"] * 50.0).astype(int) % step == 0)
    for block in (23, 7):
        np.testing.assert_array_equal(_sampled(af, rows, block=block)["columns"], whole["columns"])


def _blank_first_rows(path, out, columns: list[str], rows: int | None) -> None:
    """A copy of the CSV log with ``columns`` empty on its first ``rows`` rows (None: every row)."""
    lines = open(path).read().splitlines(keepends=True)
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header].strip().split(",")
    for row in range(len(lines) - header - 1 if rows is None else rows):
        cells = lines[header + 1 + row].rstrip("\n").split(",")
        for name in columns:
            cells[names.index(name)] = ""
        lines[header + 1 + row] = ",".join(cells) + "\n"
    out.write_text("".join(lines))


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    folder = tmp_path_factory.mktemp("leading")
    path = folder / "sweep.csv"
    vertical = folder / "vertical.csv"
    assert main(["simulate", "sweep", "--hold", "4", "--rate", "50", "--seed", "5", "-o", str(path)]) == 0
    assert main(["simulate", "vertical", "--rate", "50", "--seed", "6", "-o", str(vertical)]) == 0
    return folder, path, vertical


@pytest.mark.parametrize("columns", [["wind_n"], ["rpm_1"]])
def test_fit_of_a_log_whose_first_rows_are_invalid(sweep, columns, capsys, shared_fits):
    """End to end: the NaN rows used to reach the filters, every sample's regressors were NaN and the fit
    died in the least squares (a traceback). Now the fit is written and close to the clean log's: only
    the first second differs (the regressors' filters start at row 50; with NaN rpm the step also
    rejects those rows and settles after them). ``--hover-noise 0`` as in the test below: the low-pass
    rounds after the fit are not what this is about, and the clean fit is then that test's two-log fit
    (shared_fits computes it once)."""
    folder, path, vertical = sweep
    clean_out, broken_out = folder / f"clean_{columns[0]}.toml", folder / f"broken_{columns[0]}.toml"
    broken = folder / f"broken_{columns[0]}.csv"
    _blank_first_rows(path, broken, columns, 50)
    for log, out in ((path, clean_out), (broken, broken_out)):
        assert main(["fit", str(M300), str(log), str(vertical), "--model", "drag-heading", "--force", "--hover-noise",
                     "0", "-o", str(out)]) in (0, 1)   # 1: the self-check failed, written anyway (--force)
    assert "Traceback" not in capsys.readouterr().err
    clean, got = load_airframe(clean_out), load_airframe(broken_out)
    for key in ("l0", "q0", "lz", "qz"):
        assert getattr(got.drag, key) == pytest.approx(getattr(clean.drag, key), rel=0.02), key


def test_fit_with_a_log_without_a_valid_row(sweep, capsys, shared_fits):
    """A third log whose true wind is missing on every row: it used to give NaN samples (its rows were
    all 'before the first valid one', kept as they were) and the fit died in the least squares. Now it
    contributes no sample, the fit says so, and the drag law is the one the other two logs give.
    ``--hover-noise 0`` holds the low-pass and the acceleration route as written: those are chosen from
    the self-check's replay of every log, and the blank log's sensors are real data there (its replay
    legitimately moves the noise figure), while this test is about the samples."""
    folder, path, vertical = sweep
    blank = folder / "no_wind.csv"
    _blank_first_rows(vertical, blank, ["wind_n"], None)
    two, three = folder / "two.toml", folder / "three.toml"
    for logs, out in (([path, vertical], two), ([path, vertical, blank], three)):
        assert main(["fit", str(M300), *map(str, logs), "--model", "drag-heading", "--force", "--hover-noise", "0",
                     "-o", str(out)]) in (0, 1)
    err = capsys.readouterr().err
    assert "Traceback" not in err and f"{blank}: contributed no usable sample" in err
    assert load_airframe(three).drag == load_airframe(two).drag


def test_the_streamed_fit_of_a_log_with_invalid_first_rows_is_the_whole_log_fit(tmp_path):
    """fit read a block at a time (blocks of about 60 rows) against the whole-log fit, the first 150 rows'
    wind and thrust missing: the invalid run spans blocks, the airframes and reports are equal."""
    from dobwind.calibrate.fitfamily import fit_airframe
    from dobwind.model.airframe_toml import dump_airframe
    from tests.test_fit_stream import AIRFRAME, BLOCK_BYTES, _simulate

    sweep, vertical = _simulate(tmp_path, "sweep", 5), _simulate(tmp_path, "vertical", 6)
    broken = tmp_path / "broken.csv"
    _blank_first_rows(sweep, broken, ["wind_n", "thrust"], 150)
    af = load_airframe(AIRFRAME)
    whole, whole_report, _ = fit_airframe(af, [str(broken), vertical], model="drag", block_bytes=None)
    streamed, report, _ = fit_airframe(af, [str(broken), vertical], model="drag", block_bytes=BLOCK_BYTES)
    assert dump_airframe(streamed) == dump_airframe(whole)
    assert report == whole_report and whole_report.samples > 1000
