"""A hold-level CV whose held-out predictions diverged says so instead of a figure (dobwind/calibrate/cvdiverge.py).

The 37 s PX4 drag-fusion field log gave two CV blocks, the second a hover in a steady wind: the law fitted
on it alone had no drag to invert, every prediction of the first block diverged, and the self-check printed
"hold-level CV 480.693 m/s". Here the same shape is made: a moving block and a block at one airflow, both
from a known drag law; and, as the control, the same law on blocks that all vary, whose CV must not be
called diverged."""
from __future__ import annotations

import dataclasses
import math
import os
from pathlib import Path

import numpy as np
import pytest

from dobwind.calibrate import cvdiverge, dragfit, holdcv, selfcheck
from dobwind.calibrate.thresholds import Thresholds
from dobwind.cli.app import main
from dobwind.model.airframe import load_airframe
from tests.helpers import ROOT

TRUE = {"l0": 0.3, "q0": 0.08, "lz": 0.4, "qz": 0.1}
ACTIVE = dragfit.HORIZONTAL_SETS[0] + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS
BLOCK = 200   # samples per block (dragfit's blocks are the `group` labels)


def _samples(air: np.ndarray, group: np.ndarray, offset: np.ndarray | None = None) -> dragfit.DragSamples:
    n = len(air)
    rng = np.random.default_rng(5)
    columns = dragfit.basis(air)
    columns[:, :, dragfit.PARAMETERS.index("kappa")] = np.column_stack([np.zeros(n), np.zeros(n), -np.full(n, 30.0)])
    force = np.einsum("nap,p->na", columns, np.array([TRUE.get(p, 0.0) for p in dragfit.PARAMETERS]))
    force += 0.05 * rng.standard_normal(force.shape) + (0.0 if offset is None else offset)
    yaw = np.zeros(n)
    return dragfit.DragSamples(force, columns, np.cos(yaw), np.sin(yaw), air, group, np.zeros(n, dtype=int))


def _moving(n: int, low: float, high: float) -> np.ndarray:
    phase = np.linspace(0.0, 8 * math.pi, n)
    speed = np.linspace(low, high, n)
    return np.column_stack([speed * np.cos(phase / 3), speed * np.sin(phase / 3), 0.8 * np.sin(phase)])


@pytest.fixture(scope="module")
def short_flight() -> dragfit.DragSamples:
    """Block 0 moves (1-7 m/s, every direction); block 1 holds one airflow (1.7 m/s from one side) and
    carries a steady force against the drag's (a tilt bias): alone, it says the drag is negative, so the
    law fitted on it keeps none (drag coefficients are kept >= 0) and its inversion has nothing to invert."""
    hover = np.tile([1.2, 1.2, 0.0], (BLOCK, 1))
    air = np.vstack([_moving(BLOCK, 1.0, 7.0), hover])
    offset = np.zeros((2 * BLOCK, 3))
    offset[BLOCK:, :2] = -1.5
    return _samples(air, np.repeat([0, 1], BLOCK), offset)


def test_the_fold_fitted_on_the_hover_block_alone_is_named_with_what_it_lacked(short_flight):
    hold = holdcv.hold_cv(short_flight, dragfit.drag_fit_predict(ACTIVE))
    assert hold is not None and hold.folds == 2
    assert len(hold.diverged) == 1
    fold = hold.diverged[0]
    assert fold.held_out_blocks == (0,) and fold.fitted_blocks == (1,)
    assert fold.fitted == BLOCK and fold.held_out == BLOCK and fold.diverged > BLOCK // 2
    low, high = fold.fitted_speed_mps
    assert abs(low - math.hypot(1.2, 1.2)) < 0.1 and abs(high - math.hypot(1.2, 1.2)) < 0.1
    text = hold.diverged_text()
    assert "diverged in 1 of 2 cross-validation folds" in text
    assert "without block 0 (on 200 samples of block 1)" in text
    assert "too little airflow-speed variety" in text
    # the figure itself is the clip's mixture: tens of m/s at least, as the field log's 480
    assert hold.rms_mps > 0.05 * dragfit.ERROR_CLIP_MPS


def test_blocks_that_all_vary_give_a_cv_that_is_not_called_diverged():
    air = np.vstack([_moving(BLOCK, 1.0 + k, 3.0 + k) for k in range(5)])
    samples = _samples(air, np.repeat(np.arange(5), BLOCK))
    hold = holdcv.hold_cv(samples, dragfit.drag_fit_predict(ACTIVE))
    assert hold is not None and hold.diverged == () and hold.diverged_text() is None
    assert hold.rms_mps < 0.5


def test_a_narrow_spread_is_not_blamed_when_the_fitted_blocks_varied():
    fold = cvdiverge.FoldDivergence((2,), (0, 1), 10, 50, 300, (1.0, 4.0), (5.0, 9.0), 1e6)
    assert "lies beyond the other blocks' (1.0-4.0 m/s)" in fold.text()
    assert "without blocks" not in fold.text() and "without block 2 (on 300 samples of blocks 0, 1)" in fold.text()


def test_the_self_check_says_why_instead_of_the_figure():
    why = "held-out predictions diverged in 1 of 2 cross-validation folds: the reason"
    diverged = selfcheck.verdict(_airframe(), [], 480.693, 7.06, Thresholds(cv_diverged=why))
    assert diverged.reasons == [f"hold-level CV not measured (limit 0.424 m/s): {why}"]
    assert diverged.cv_diverged == why and "not measured" in selfcheck.text_table(diverged)
    plain = selfcheck.verdict(_airframe(), [], 0.9, 7.06, Thresholds())
    assert plain.reasons == ["hold-level CV 0.900 m/s > 0.424 m/s"] and plain.cv_diverged is None
    assert "hold-level CV 0.900 m/s (limit 0.424)" in selfcheck.text_table(plain)


def _airframe():
    return load_airframe(str(ROOT / "airframes" / "m300.toml"))


@pytest.mark.parametrize("speed, sigma, degrees", [(1.75, 0.45, 14.4), (10.0, 0.1, 0.57), (3.0, 3.0 * math.tan(math.radians(30)), 30.0)])
def test_a_found_winds_direction_carries_the_1_sigma_its_speed_allows(speed, sigma, degrees):
    from dobwind.calibrate.windsolve import WindGroup
    group = WindGroup("f.ulg", 0.0, 37.0, (-speed, 0.0), sigma, 155)
    assert group.direction_text() == f"direction 1-sigma {degrees:.0f} deg"


def test_a_wind_no_faster_than_its_1_sigma_has_no_direction():
    from dobwind.calibrate.windsolve import WindGroup
    assert "not determined" in WindGroup("f.ulg", 0.0, 37.0, (0.3, 0.0), 0.45, 155).direction_text()


def test_the_report_says_why_instead_of_the_hold_figure_and_marks_a_clipped_per_sample_cv():
    from dobwind.calibrate.fit import FitReport
    from dobwind.calibrate.fitreport import text_report
    from dobwind.calibrate.reportparts import HoldCvBySpeed
    table = HoldCvBySpeed((2.9,), (480.693,), (476.884,), (60.0,), 8.9)
    base = FitReport(points=258, model="drag", samples=258, drag={"l0": 0.15}, horizontal_cv_rmse_mps=1071.115,
                     horizontal_rmse_mps=1.865, vertical_rmse_mps=3.264,
                     hold_cv_speed_mps=480.693, hold_cv_by_speed=table)
    plain = text_report(base)
    assert "hold-level CV 480.693 m/s (held-out holds scored 8.9 s)" in plain
    why = "held-out predictions diverged in 1 of 2 cross-validation folds: the reason"
    text = text_report(dataclasses.replace(base, hold_cv_diverged=why))
    assert f"hold-level CV not measured: {why}" in text and "hold-level CV 480.693" not in text
    assert "grouped 5-fold CV 1071.115 m/s (held-out predictions diverged" in text
    scored = {"exponent_scores": {"1.9": 588.726, "2": 588.726, "2.1": 588.726}}
    assert "rank nothing" not in text_report(dataclasses.replace(base, **scored))
    assert "these scores rank nothing" in text_report(dataclasses.replace(base, hold_cv_diverged=why, **scored))
    assert base.as_dict()["hold_cv_diverged"] is None


FIELD_LOG = (Path(os.environ.get("DOBWIND_SHARED_DATA", ROOT.parent / "shared" / "data"))
             / "field" / "px4_quad_dragfusion_esc.ulg")


@pytest.mark.skipif(not FIELD_LOG.exists(), reason="the shared field logs are not here")
def test_the_drag_fusion_field_log_names_its_diverged_fold_instead_of_480_mps(tmp_path, capsys):
    """The reviewer's two commands (docs/field-calibration.md): still refused, now with the fold and why."""
    start, out = tmp_path / "s.toml", tmp_path / "f.toml"
    assert main(["init", str(FIELD_LOG), "--mass", "1.5", "-o", str(start)]) == 0
    capsys.readouterr()
    assert main(["fit", str(start), str(FIELD_LOG), "--wind", "unknown", "-o", str(out)]) == 1
    captured = capsys.readouterr()
    refusal = captured.err.strip().splitlines()[-1]
    assert "hold-level CV not measured" in refusal and "hold-level CV 480" not in refusal
    assert "the law fitted without block 0 (on 110 samples of block 1)" in refusal
    assert "too little airflow-speed variety in the other block" in refusal
    assert "direction 1-sigma 14 deg" in captured.out and not out.exists()
