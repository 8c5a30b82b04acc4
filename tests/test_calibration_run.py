"""One calibration run shared by the drag-law samples and the polynomial family's first cleaning pass
(fit.calibration_run): both read exactly what their own pass would have computed, and a run made for
another airframe or other logs is never reused."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.calibrate.fit import calibration_airframe, calibration_points, calibration_run, read_calibration_logs
from dobwind.calibrate.fitfamily import drag_samples
from dobwind.io.logs import step_inputs
from dobwind.model import reference
from dobwind.model.airframe import load_airframe
from dobwind.model.step import build_step
from tests.helpers import M300


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    path = tmp_path_factory.mktemp("run") / "sweep.csv"
    assert main(["simulate", "sweep", "--seed", "7", "--rate", "25", "--hold", "8", "-o", str(path)]) == 0
    af = load_airframe(M300)
    return af, read_calibration_logs(af, [str(path)])


def _assert_same(a, b):
    """Every field of two dataclasses (arrays or None) identical, bit for bit."""
    for f in dataclasses.fields(a):
        x, y = getattr(a, f.name), getattr(b, f.name)
        if isinstance(x, np.ndarray):
            np.testing.assert_array_equal(x, y, err_msg=f.name)
        else:
            assert x == y, f.name


def test_the_run_is_the_reference_step_of_the_calibration_airframe(sweep):
    af, logs = sweep
    run = calibration_run(af, logs)
    model = build_step(calibration_airframe(af))
    traj = reference.run(model, step_inputs(model, logs[0]))
    np.testing.assert_array_equal(run.force_ned[0], traj.outputs[:, model.outputs.slice("force_ned")])
    np.testing.assert_array_equal(run.v_filt[0], traj.states[:, model.state.slice("v_filt")])
    np.testing.assert_array_equal(run.status[0], traj.status)


def test_shared_and_own_runs_give_the_same_calibration_data(sweep):
    af, logs = sweep
    run = calibration_run(af, logs)
    shared, own = calibration_points(af, logs, run=run), calibration_points(af, logs)
    assert shared[1] == own[1]
    _assert_same(shared[0], own[0])
    shared_samples, shared_counts = drag_samples(af, logs, ("heading", "body"), run)
    own_samples, own_counts = drag_samples(af, logs, ("heading", "body"))
    assert shared_counts == own_counts and sum(own_counts) > 100
    for frame in ("heading", "body"):
        _assert_same(shared_samples[frame], own_samples[frame])


def test_a_run_for_another_airframe_or_other_logs_is_not_reused(sweep):
    af, logs = sweep
    run = calibration_run(af, logs)
    rescaled = dataclasses.replace(af, thrust=dataclasses.replace(af.thrust, scale=af.thrust.scale * 0.97))
    assert run.serves(af, logs)
    assert not run.serves(rescaled, logs)
    assert not run.serves(af, [dataclasses.replace(logs[0])])  # equal content, another log object
    points, _ = calibration_points(rescaled, logs, run=run)
    _assert_same(points, calibration_points(rescaled, logs)[0])
    # The thrust scale moves the vertical force: reusing af's run would have been visible.
    assert not np.array_equal(points.fz, calibration_points(af, logs, run=run)[0].fz)
