"""ESC rpm of every ArduPilot layout read in rpm (dobwind/io/escrpm.py): the number each firmware stored in
the RPM field, written by the test as that firmware wrote it, must come out as the rotor's rpm. The
layouts are ArduPilot's own (LogStructure.h and the ESC writers, cited in escrpm.py); pymavlink's
DFReader divides formats c and e by 100 and ignores the FMTU multiplier."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.inspect.anylog import inspect_log
from dobwind.io.escrpm import rpm_factor
from dobwind.replay.replay import replay_autopilot
from tests import test_dataflash as df
from tests.dataflash_writer import Raw, with_multipliers, write_dataflash
from tests.test_logvariants import _pre41

ESC_NAMES = [f"ESC{k}" for k in range(1, 5)]
# ArduPilot's multiplier ids as its logs declare them in MULT (LogStructure.h log_Multipliers).
MULTS = {"0": 1.0, "B": 0.01}


@pytest.mark.parametrize("fmt, mult_id, mults, factor", [
    ("c", None, {}, 1000.0),             # int16 holding rpm / 10, no FMTU: DFReader's rpm / 1000 times 1000
    ("c", "-", {}, 1000.0),              # an FMTU "no multiplier" says nothing: the same
    ("e", "B", MULTS, 1.0),              # int32 holding rpm * 100, multiplier 0.01: DFReader's value is rpm
    ("e", None, {}, 1.0),                # the same without FMTU
    ("f", "0", MULTS, 1.0),              # the current layout (the 4.6.2 log): a float in rpm
    ("e", "0", MULTS, 100.0),            # the FMTU says the int32 is rpm itself: DFReader's /100 undone
    ("f", "B", MULTS, 0.01),             # a float in hundredths of rpm, as an FMTU could declare it
    ("e", "B", {}, 1.0),                 # an id without its MULT: the format's rule
])
def test_the_factor_follows_the_fmtu_multiplier_else_the_format(fmt, mult_id, mults, factor):
    assert rpm_factor(fmt, mult_id, mults)[0] == pytest.approx(factor, rel=1e-12)


def _esc_layout(tmp_path, name: str, fmt: str, stored, mult_ids: str | None = None):
    """The pre-4.1 flight (ESC1..ESC4) with RPM in format ``fmt`` holding ``stored(rpm)``; FMTU and MULT
    when ``mult_ids`` is given (one id per column: TimeUS, RPM, Volt, Curr, Temp)."""
    af, cols = df._flight(rate=20.0)
    msgs, rows = _pre41(df.MESSAGES, df._rows(af, cols))
    msgs = {**msgs, **{n: (fmt + "CCc", ["TimeUS", "RPM", "Volt", "Curr", "Temp"]) for n in ESC_NAMES}}
    rows = [(n, {"TimeUS": v["TimeUS"], "RPM": stored(v["RPM"]), "Volt": 16.0}) if n in ESC_NAMES else (n, v)
            for n, v in rows]
    if mult_ids is not None:
        msgs, rows = with_multipliers(msgs, rows, {n: mult_ids for n in ESC_NAMES}, MULTS)
    return af, write_dataflash(tmp_path / name, msgs, rows)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The same flight with RPM as a float in rpm (as the current layout logs it): the rotor speeds to read."""
    af, cols = df._flight(rate=20.0)
    path = write_dataflash(tmp_path_factory.mktemp("ref") / "ref.bin", *_pre41(df.MESSAGES, df._rows(af, cols)))
    return af, path, replay_autopilot(af, str(path), rate_hz=20.0)[1]


def _rpm(flight) -> np.ndarray:
    return np.column_stack([flight.log.columns[f"rpm_{k}"] for k in range(1, 5)])


def test_an_int16_rpm_of_tens_without_fmtu_is_read_in_rpm(tmp_path, reference):
    """ESC1..ESC8 "Qcccc" (DataFlash/LogStructure.h before the int32 RPM; the ArduPlane 3.8.2 log here
    declares it): the int16 holds the rpm / 10 (LogFile.cpp Log_Write_ESC). DFReader returns rpm / 1000;
    read, it is the rpm to the 10 rpm step, and a note says why it was scaled."""
    af, ref_path, ref = reference
    _, path = _esc_layout(tmp_path, "c.bin", "Qc", lambda rpm: Raw(round(rpm / 10.0)))
    flight = replay_autopilot(af, str(path), rate_hz=20.0)[1]
    assert np.max(np.abs(_rpm(flight) - _rpm(ref))) <= 5.0
    assert any(n.startswith("ESC rpm: ESC1, ESC2, ESC3, ESC4 RPM read x 1000 (format c") for n in flight.notes), flight.notes
    # inspect reads the same rows (its median feeds init's max_rpm)
    s = inspect_log(str(path))
    assert s.vehicle.airborne_rpm_median == pytest.approx(inspect_log(str(ref_path)).vehicle.airborne_rpm_median, abs=5.0)


def test_an_int32_rpm_times_100_with_its_fmtu_is_read_in_rpm_unscaled(tmp_path, reference):
    """ESC1..ESC8 "QeCCcH" with FMTU multiplier B (AP_BLHeli and AP_Logger::Write_ESC store rpm * 100):
    DFReader's value is already rpm, so nothing is scaled and no note is added."""
    af, ref_path, ref = reference
    _, path = _esc_layout(tmp_path, "e.bin", "Qe", float, mult_ids="FBBBB")
    flight = replay_autopilot(af, str(path), rate_hz=20.0)[1]
    assert np.max(np.abs(_rpm(flight) - _rpm(ref))) <= 0.006
    assert not any(n.startswith("ESC rpm:") for n in flight.notes)


def test_the_fmtu_multiplier_wins_over_the_format(tmp_path, reference):
    """An int32 RPM whose FMTU multiplier is 0 (times 1: the integer is the rpm): read as the integer,
    not as DFReader's hundredth of it."""
    af, ref_path, ref = reference
    _, path = _esc_layout(tmp_path, "e0.bin", "Qe", lambda rpm: Raw(round(rpm)), mult_ids="F0BBB")
    flight = replay_autopilot(af, str(path), rate_hz=20.0)[1]
    assert np.max(np.abs(_rpm(flight) - _rpm(ref))) <= 0.5
    assert any("x 100 (format e times its FMTU multiplier 1)" in n for n in flight.notes), flight.notes
