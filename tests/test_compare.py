"""The C-versus-reference comparison must refuse NaN and infinities wherever the reference has a number.

Each case starts from a trajectory compared with itself (which must pass) and breaks one thing.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from dobwind.codegen.tolerance import TOLERANCE
from dobwind.harness.compare import compare
from dobwind.model import reference
from dobwind.model.airframe import load_airframe
from dobwind.model.exercise import flight_inputs
from dobwind.model.reference import Trajectory
from dobwind.model.step import build_step
from tests.helpers import M300


@pytest.fixture(scope="module")
def case():
    model = build_step(load_airframe(M300))
    ref = reference.run(model, flight_inputs(model, 600, seed=7))
    return model, ref


def _copy(t: Trajectory) -> Trajectory:
    return Trajectory(t.states.copy(), t.outputs.copy(), t.status.copy())


def _with_output(model, ref: Trajectory, field: str, value: float, rows=slice(None)) -> Trajectory:
    got = _copy(ref)
    got.outputs[rows, model.outputs.slice(field)] = value
    return got


def test_a_trajectory_matches_itself(case):
    model, ref = case
    result = compare(model, _copy(ref), ref, TOLERANCE["double"])
    assert result.passed() and result.worst_ratio == 0.0


def test_nan_wind_direction_on_every_row_fails(case):
    """The reported hole: the angle branch let NaN through."""
    model, ref = case
    result = compare(model, _with_output(model, ref, "wind_from_deg", np.nan), ref, TOLERANCE["single"])
    assert not result.passed()
    assert result.worst_ratio == np.inf


def test_nan_direction_fails_even_where_the_wind_is_too_light_for_a_direction(case):
    model, ref = case
    light = _with_output(model, ref, "wind_speed_h", 0.1, slice(10, 11))  # below MIN_SPEED_FOR_DIRECTION
    assert compare(model, _with_output(model, light, "wind_from_deg", 123.0, slice(10, 11)), light,
                   TOLERANCE["single"]).passed()  # any direction is accepted in light wind...
    got = _with_output(model, light, "wind_from_deg", np.nan, slice(10, 11))
    assert not compare(model, got, light, TOLERANCE["single"]).passed()  # ...but not no number at all


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("field", ["wind_ned", "wind_speed_h", "force_ned"])
def test_a_non_finite_output_where_the_reference_is_finite_fails(case, field, value):
    model, ref = case
    got = _with_output(model, ref, field, value, slice(100, 101))
    assert not compare(model, got, ref, TOLERANCE["single"]).passed()


def test_a_finite_output_where_the_reference_is_nan_fails(case):
    """And the other way round: the C must not invent a number where the reference has none."""
    model, ref = case
    bad_ref = _with_output(model, ref, "wind_speed_h", np.nan, slice(5, 6))
    assert not compare(model, _copy(ref), bad_ref, TOLERANCE["single"]).passed()


def test_nan_in_a_state_fails(case):
    model, ref = case
    got = _copy(ref)
    got.states[:, 0] = np.nan
    assert not compare(model, got, ref, TOLERANCE["single"]).passed()


def test_status_is_compared_exactly(case):
    model, ref = case
    got = _copy(ref)
    got.status[3] ^= 1 << 6
    result = compare(model, got, ref, TOLERANCE["single"])
    assert result.status_mismatches == 1 and not result.passed()
    shorter = dataclasses.replace(ref, status=ref.status[:-1])
    assert compare(model, shorter, ref, TOLERANCE["single"]).status_mismatches == len(ref.status)


def test_worst_ratio_does_not_drop_nan_wherever_it_sits(case):
    model, ref = case
    result = compare(model, _copy(ref), ref, TOLERANCE["double"])
    for position in (0, -1):
        fields = list(result.outputs)
        fields[position] = dataclasses.replace(fields[position], worst_ratio=float("nan"))
        broken = dataclasses.replace(result, outputs=tuple(fields))
        assert broken.worst_ratio == np.inf and not broken.passed()
