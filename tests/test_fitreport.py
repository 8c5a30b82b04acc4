"""The fit's text report: each family's own form, and the hold-level CV's split with its longer-hold figure."""
from __future__ import annotations

import dataclasses
import math

import pytest

from dobwind.calibrate.fit import FitReport
from dobwind.calibrate.fitreport import text_report
from dobwind.calibrate.reportparts import HoldCvBySpeed


def _drag_report(model: str) -> FitReport:
    return FitReport(points=1000, thrust_scale=0.97, model=model, samples=1000,
                     drag={"lx": 0.1, "qx": 0.02}, force_offset_n=(0.0, 0.0, 0.0),
                     horizontal_rmse_mps=0.1, vertical_rmse_mps=0.05, hold_cv_speed_mps=0.05,
                     hold_cv_by_speed=HoldCvBySpeed((1.0, 5.0), (0.06, 0.04), (0.03, 0.02), (0.06, 0.06), 3.0))


@pytest.mark.parametrize("model", ["drag", "drag-body"])
def test_either_drag_family_reports_its_law_not_polynomial_terms(model):
    text = text_report(_drag_report(model))
    assert "drag law: lx 0.1, qx 0.02" in text
    assert "horizontal speed =" not in text and "calibration points" not in text


def test_hold_line_gives_the_longer_hold_figure_from_bias_and_noise():
    text = text_report(_drag_report("drag-body"))
    assert "hold-level CV 0.050 m/s (held-out holds scored 3.0 s)" in text
    # sqrt(bias^2 + noise^2 / 15 s) at each band
    expected = [math.sqrt(0.03 ** 2 + 0.06 ** 2 / 15), math.sqrt(0.02 ** 2 + 0.06 ** 2 / 15)]
    assert f"expected on holds scored 15 s: 1.0 m/s: {expected[0]:.3f}, 5.0 m/s: {expected[1]:.3f}" in text


def test_the_drag_law_line_is_followed_by_its_units():
    """Every coefficient a drag law can print has its unit on the next line (issue #36: no number
    without a unit), in the units docs/formats.md gives them."""
    from dobwind.calibrate.fitreport import DRAG_UNITS

    lines = text_report(_drag_report("drag")).splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("drag law: "))
    assert lines[at + 1] == f"  units: {DRAG_UNITS}"
    # Every parameter the drag fit can report (its own list, so a new one without a unit fails here), each
    # as a whole word of the units line (a prefix such as "q4" of "q4c" does not count).
    from dobwind.calibrate.dragfit import BODY_PARAMETERS, PARAMETERS

    words = set(DRAG_UNITS.replace(",", " ").replace(";", " ").split())
    assert {*PARAMETERS, *BODY_PARAMETERS} <= words, {*PARAMETERS, *BODY_PARAMETERS} - words
    assert "l0, l2c, l2s, lr, lz, i1 in N/(m/s)" in DRAG_UNITS and "qz, i2 in N/(m/s)^2" in DRAG_UNITS


@pytest.mark.parametrize("model", ["drag", "polynomial"])
def test_the_vertical_cv_is_printed_next_to_the_zero_score_and_their_ratio(model):
    """The margin the vertical rule judges (fitfamily.vertical_warning): CV 0.30 against zero's 0.40 is 0.75."""
    report = dataclasses.replace(_drag_report("drag"), vertical_cv_rmse_mps=0.3, vertical_zero_rmse_mps=0.4)
    if model == "polynomial":
        report = dataclasses.replace(report, model=model, drag={}, vertical_terms=["vz"], vertical_coefficients=[1.0])
    text = text_report(report)
    assert "grouped 5-fold CV 0.300 m/s; zero vertical airflow scores 0.400 m/s" in text
    assert "the CV 0.75 of it" in text


def test_without_samples_no_zero_score_is_printed():
    assert "zero vertical airflow" not in text_report(_drag_report("drag"))
