"""`init`'s starter publishes no vertical wind (its vertical drag terms are a guess scaled from the mass,
not a calibration: #31's rule for a vertical law nobody identified), and replay's plausibility check still
reads its vertical force through them, so a starter that misreads the vertical force is still named."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dobwind.model.airframe import CALIBRATED, PRIOR, VERTICAL_FALLBACK, load_airframe
from dobwind.model.forceair import DragLaw
from dobwind.model.kinds import DragFrame
from dobwind.replay.plausibility import FlightSeries, check_flight, vertical_reading
from tests.helpers import M300

LZ, QZ = 0.3, 0.02     # N/(m/s), N/(m/s)^2
AIR_DOWN = 5.0         # m/s of air moving down past the vehicle: 1.5 + 0.5 = 2.0 N down on it


def _starter(**changes):
    starter = {"drag": DragLaw(l0=0.3, q0=0.01, lz=LZ, qz=QZ, frame=DragFrame.HEADING),
               "vertical_law": VERTICAL_FALLBACK, "calibration": PRIOR}
    return dataclasses.replace(load_airframe(M300), **{**starter, **changes})


def _flight(force_d: float, seconds: float = 30.0, dt: float = 0.1) -> FlightSeries:
    n = int(seconds / dt)
    z = np.zeros(n)
    force = np.column_stack([np.full(n, 1.0), z, np.full(n, force_d)])
    return FlightSeries(np.arange(n) * dt, np.column_stack([z, z, z]), force,
                        np.column_stack([np.full(n, 3.0), z, z]), np.zeros(n, dtype=np.int64))


def test_the_starter_reads_its_vertical_force_through_its_own_law():
    """Closed form: f_d = lz a + qz |a| a with a = 5 m/s gives 2.0 N; the wind read is a downdraft of 5."""
    af = _starter()
    force_d = LZ * AIR_DOWN + QZ * AIR_DOWN * AIR_DOWN
    up = vertical_reading(af, _flight(force_d))
    assert up == pytest.approx(np.full(len(up), -AIR_DOWN), abs=1e-9)
    found = check_flight(af, _flight(force_d))
    assert [f.check for f in found] == ["vertical_wind"]
    assert found[0].value == pytest.approx(AIR_DOWN, abs=1e-6) and "publishes no vertical wind" in found[0].message
    assert check_flight(af, _flight(LZ * 1.0 + QZ)) == []   # 1 m/s: within the 4 m/s limit


@pytest.mark.parametrize("change", [{"calibration": CALIBRATED}, {"vertical_law": "fitted"},
                                    {"drag": DragLaw(l0=0.3, q0=0.01, q2c=0.002, lz=LZ, qz=QZ)}])
def test_anything_but_the_starter_reads_the_published_wind(change):
    """A calibrated airframe, a fitted vertical law, or a law with direction terms (whose reading would need
    the heading): the check reads the published vertical wind, here zero."""
    af = _starter(**change)
    assert np.all(vertical_reading(af, _flight(2.0)) == 0.0)
    assert check_flight(af, _flight(2.0)) == []


def test_init_writes_a_starter_without_a_published_vertical_wind(tmp_path):
    """The starter from a log (the project's own ULog) says vertical_law = "zero-wind", and its replay
    publishes a vertical wind of exactly 0 with sigma -1 on every estimated row."""
    from tests.test_inspect import _px4_log
    from dobwind.cli.app import main

    log = _px4_log(tmp_path / "flight.ulg")
    assert main(["init", str(log), "--mass", "2", "-o", str(tmp_path / "a.toml")]) == 0
    af = load_airframe(tmp_path / "a.toml")
    assert af.vertical_law == VERTICAL_FALLBACK and af.uncalibrated and af.drag.lz > 0
    assert main(["replay", str(tmp_path / "a.toml"), str(log), "-o", str(tmp_path / "e.csv")]) == 0
    lines = [line for line in (tmp_path / "e.csv").read_text().splitlines() if not line.startswith("#")]
    data = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
    est = {name: data[:, i] for i, name in enumerate(lines[0].split(","))}
    rows = np.isfinite(est["wind_n"])
    assert rows.any() and np.all(est["wind_d"][rows] == 0.0) and np.all(est["wind_sigma_up"][rows] == -1.0)


def test_a_row_without_a_force_reads_no_vertical_wind():
    """A NaN force (a row the step did not estimate) read as zero force gave the ground velocity's -vel_d
    as if it were the wind; it reads NaN, which the check's isfinite leaves out."""
    flight = _flight(LZ * AIR_DOWN + QZ * AIR_DOWN * AIR_DOWN)
    flight.force[:5] = np.nan
    flight.vel[:, 2] = -1.0   # climbing at 1 m/s: the still-air reading would be +1 m/s up
    up = vertical_reading(_starter(), flight)
    assert np.all(np.isnan(up[:5])) and up[5:] == pytest.approx(np.full(len(up) - 5, 1.0 - AIR_DOWN), abs=1e-9)
