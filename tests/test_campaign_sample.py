"""A seeded sample of issue #37's campaign (tools/campaign_sample.py, tools/bitflip_sample.py), every case in
its own process: special files as every input, logs in absurd units, failed runs over existing outputs,
edge-of-range airframes through generate's self-test and check, bit flips in CSV and DataFlash logs. None
may give a traceback, a hang, a multi-line error, a noisy success, a stray temporary, a damaged output or
a trusted row of absurd wind; check and generate must agree."""
from __future__ import annotations

import random
import sys
from pathlib import Path

import pytest

from tests import atmos_logs
from tools import bitflip_sample as B
from tools import campaign_sample as C

pytestmark = pytest.mark.fuzz


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    work = tmp_path_factory.mktemp("campaign")
    C.good_log(work)
    return work


def _assert_clean(outcomes: list[C.Outcome]) -> None:
    bad = [(o.case, o.exit_code, o.problems) for o in outcomes if o.problems]
    assert not bad


def test_the_classifier_sees_each_kind_of_bad_outcome(tmp_path):
    """The campaign can fail: a traceback, a multi-line error, noise, a temporary left, a damaged file and
    an absurd trusted row are each classed as such."""
    guarded = tmp_path / "kept.txt"
    guarded.write_text("before")
    estimate = tmp_path / "est.csv"
    estimate.write_text("t,wind_n,wind_e,wind_d,status\n0,60,0,0,0\n1,nan,0,0,0\n2,90,0,0,128\n")
    script = ("import sys, pathlib; print('Traceback (most recent call last):', file=sys.stderr); "
              f"print('x\\ny', file=sys.stderr); pathlib.Path({str(guarded)!r}).write_text('after'); "
              f"pathlib.Path({str(tmp_path / '.dobwind-tmp-x')!r}).write_text(''); sys.exit(2)")
    outcome = C.run_case(C.Case("bad", (sys.executable, "-c", script), guarded=str(guarded)), tmp_path)
    assert set(outcome.problems) == {"traceback", "multi-line error", "stray temporary", "damaged output"}
    assert C.absurd_trusted_rows(estimate) == 2  # 60 m/s and NaN at status 0; 90 m/s is flagged
    clean = tmp_path / "clean"  # a folder without the temporary left above
    clean.mkdir()
    noisy = C.run_case(C.Case("noisy", (sys.executable, "-c", "import sys; print('w\\n' * 50, file=sys.stderr)")), clean)
    assert noisy.problems == ("noisy success",)


def test_special_files_never_block_nor_trace(folder):
    _assert_clean(C.run_all(C.special_file_cases(folder), folder))


def test_failed_runs_leave_existing_outputs_as_they_were(folder):
    _assert_clean(C.run_all(C.failed_write_cases(folder), folder))


def test_logs_in_absurd_units_give_no_trusted_absurd_wind(folder):
    _assert_clean(C.run_all(C.absurd_unit_cases(folder), folder))


def test_edge_of_range_airframes_check_as_generate_does(folder):
    outcomes = C.run_all(C.edge_airframe_cases(folder, random.Random(37), 6), folder)
    _assert_clean(outcomes)
    assert not C.disagreements(outcomes)


def test_bit_flipped_logs_replay_cleanly(folder):
    _, cols = atmos_logs.flight(hold_s=1.0)
    dataflash = atmos_logs.write_log(folder / "flight.bin", cols)
    cases = B.bitflip_cases(str(C.M300), [folder / "good.csv", dataflash], folder, per_log=4, seed=37)
    _assert_clean(C.run_all(cases, folder))
