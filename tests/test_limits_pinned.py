"""The step's limits and the log reader's heading, pinned by numbers written here (the README's and
the paper's conventions), never by the constants the code defines: a test that imported MIN_DT_S
would move with it. The mutation suite (tools/mutants.py) relies on these to catch model mutants."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dobwind.codegen.printer import directed_float
from dobwind.model.attitude import yaw_from_quaternion
from dobwind.model.airframe import load_airframe
from dobwind.model.boundaries import neutral_row
from dobwind.model.step import build_step
from tests.helpers import M300

REJECTED = 0x83F  # NONFINITE .. NUMERIC and IMPLAUSIBLE (docs/c-api.md, the status)


@pytest.fixture(scope="module")
def model():
    return build_step(load_airframe(M300))  # max_dt 0.1 s, max_tilt 60 deg


def _status(model, **changes) -> int:
    state, row = neutral_row(model)
    row = row.copy()
    for name, value in changes.items():
        row[model.inputs.slice(name)] = value
    return int(model.step(state, row)[2])


def _hand_rotation(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Body FRD -> NED for ZYX angles: Rz(yaw) Ry(pitch) Rx(roll), written out."""
    cr, sr, cp, sp, cy, sy = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch), math.cos(yaw), math.sin(yaw)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


@pytest.mark.parametrize("yaw_deg", [-170.0, -40.0, 0.0, 40.0, 135.0])
def test_heading_from_a_tilted_quaternion_is_the_hand_rotations_yaw(yaw_deg):
    # At 30 deg roll and 25 deg pitch the heading of the body x axis projected on the ground is still the
    # ZYX yaw; a wrong sign in the x*y product is off by about 10 deg here.
    rot = _hand_rotation(math.radians(30), math.radians(25), math.radians(yaw_deg))
    x, y, z, w = Rotation.from_matrix(rot).as_quat()
    got = yaw_from_quaternion(np.array([[w, x, y, z]]))[0]
    assert math.degrees(got) == pytest.approx(yaw_deg, abs=1e-9)
    # The same heading straight from the matrix: the body x axis's ground track.
    assert math.degrees(math.atan2(rot[1, 0], rot[0, 0])) == pytest.approx(yaw_deg, abs=1e-9)


def test_dt_lower_limit_is_1e_5_s(model):
    assert _status(model, dt=1e-5) & REJECTED == 0
    assert _status(model, dt=math.nextafter(1e-5, 0)) == 2  # BAD_DT only
    assert _status(model, dt=5e-5) & REJECTED == 0  # a 20 kHz log is a log, not duplicated stamps
    assert _status(model, dt=0.0) == 2


def test_dt_upper_limit_is_max_dt_plus_1e_4(model):
    assert _status(model, dt=0.1 * 1.0001) & REJECTED == 0
    assert _status(model, dt=math.nextafter(0.1 * 1.0001, 1)) == 2
    assert _status(model, dt=0.1 * 1.0002) == 2


def test_quaternion_norm_limits_are_0_9_and_1_1(model):
    for norm, bit in ((0.895, 4), (0.905, 0), (1.095, 0), (1.105, 4)):
        assert _status(model, q=[norm, 0.0, 0.0, 0.0]) & REJECTED == bit, norm


def test_tilt_limit_is_max_tilt_deg(model):
    for tilt_deg, bit in ((59.9, 0), (60.1, 8)):
        half = math.radians(tilt_deg) / 2
        assert _status(model, q=[math.cos(half), 0.0, math.sin(half), 0.0]) & REJECTED == bit, tilt_deg


def test_input_magnitude_limit_is_1e6(model):
    # 1e6 m/s is far beyond IMPLAUSIBLE's 150 m/s, but not NONFINITE; one step further it is both.
    assert _status(model, vel_ned=[1e6, 0.0, 0.0]) & REJECTED == 2048
    assert _status(model, vel_ned=[math.nextafter(1e6, 2e6), 0.0, 0.0]) == 1 | 2048
    assert _status(model, yaw_ref=-1e6) & REJECTED == 0
    assert _status(model, yaw_ref=-1.0000001e6) == 1


@pytest.mark.parametrize("value", [1e-5, 0.1, 0.10001, 0.81, 1.21, 1e30, 1e6, 3.0])
def test_directed_float_is_the_nearest_float_on_each_side(value):
    up, down = directed_float(value, True), directed_float(value, False)
    assert down <= value <= up
    assert float(np.nextafter(np.float32(up), np.float32(-np.inf))) < value  # nothing closer above
    assert float(np.nextafter(np.float32(down), np.float32(np.inf))) > value  # nothing closer below
    assert (up == down) == (float(np.float32(value)) == value)


@pytest.mark.parametrize("precision", ["single", "double"])
def test_the_boundary_rows_statuses_in_one_call_are_each_rows_own(model, precision):
    """boundaries._statuses asks the step about many rows in one (mapped) call: each status must be what the
    step says of that row alone, including the rows on both sides of every flip (an independent loop here)."""
    from dobwind.model.boundaries import _statuses, boundary_cases
    from dobwind.model.kinds import Precision

    cases = boundary_cases(model, Precision(precision))
    rows = list(zip(cases.states, cases.inputs))
    alone = [int(model.step(state, row)[2]) for state, row in rows]
    assert list(_statuses(model, rows, Precision(precision))) == alone
    assert len(set(alone)) > 5  # accepted rows and several kinds of rejection
