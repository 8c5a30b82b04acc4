"""Worst differences between two trajectories (C versus reference), per output and state field.

Every element is judged as |c - ref| <= atol + rtol |ref|, with one exception: the body-frame drag
step's tracked airflow ``air_prev`` (only the start of the next inversion) also passes, row by row, when
the force the law gives at the C's airflow is within the force tolerance of the force the reference
inverted (see ``RowStarts`` and docs/verification.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind.codegen.tolerance import MIN_SPEED_FOR_DIRECTION, Tolerance
from dobwind.model.airstate import tracked_airflow_force
from dobwind.model.reference import Trajectory
from dobwind.model.status import REJECTED_MASK
from dobwind.model.step import StepModel

TRACKED_AIRFLOW = "air_prev"


@dataclass(frozen=True)
class FieldError:
    name: str
    max_abs: float
    worst_ratio: float  # max of |diff| / (atol + rtol |ref|): <= 1 passes
    worst_row: int
    # The element that sets worst_ratio: its |diff| and its reference's magnitude. max_abs alone misled
    # (issue #33): the limit cases reach 1e27, where a passing single-precision diff is 1e22.
    # For air_prev on a row judged through the law (_tracked_airflow_ratio), both are forces in N.
    worst_diff: float = 0.0
    worst_ref: float = 0.0


@dataclass(frozen=True)
class RowStarts:
    """What each compared row started from: its input, and the state before it on each side (the same
    given state for single-step cases; the previous row's state for a flight)."""
    inputs: np.ndarray
    ref_before: np.ndarray
    got_before: np.ndarray

    @staticmethod
    def cases(states: np.ndarray, inputs: np.ndarray) -> "RowStarts":
        return RowStarts(inputs, states, states)

    @staticmethod
    def flight(model: StepModel, inputs: np.ndarray, got: Trajectory, ref: Trajectory,
               initial: np.ndarray | None = None) -> "RowStarts":
        """A flight both sides ran from ``initial`` (the model's initial state if None)."""
        first = (model.initial_state() if initial is None else np.asarray(initial, dtype=float))[None, :]
        rows = len(inputs)
        return RowStarts(inputs, np.vstack([first, ref.states])[:rows], np.vstack([first, got.states])[:rows])


@dataclass(frozen=True)
class Comparison:
    rows: int
    status_mismatches: int
    outputs: tuple[FieldError, ...]
    states: tuple[FieldError, ...]

    @property
    def worst_ratio(self) -> float:
        # Not max() alone: max() keeps or drops a NaN depending on where it sits in the list.
        ratios = [e.worst_ratio for e in self.outputs + self.states]
        if any(math.isnan(r) for r in ratios):
            return math.inf
        return max(ratios + [0.0])

    def passed(self) -> bool:
        return self.status_mismatches == 0 and self.worst_ratio <= 1.0


def _angle_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + 180.0) % 360.0 - 180.0)


def _finiteness_mismatch(got: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """True where one side is a number and the other is not, or the two are different non-finite
    values (NaN against an infinity, or infinities of opposite sign): never within any tolerance."""
    same_nonfinite = (np.isnan(got) & np.isnan(ref)) | (np.isinf(got) & (got == ref))
    return ~(np.isfinite(got) & np.isfinite(ref)) & ~same_nonfinite


def _field_ratio(name: str, g: np.ndarray, r: np.ndarray, tol: Tolerance, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(|diff|, |diff| / tolerance) element by element; NaN never compares as close."""
    with np.errstate(invalid="ignore"):  # inf - inf and NaN arithmetic are handled by the masks below
        if name == "wind_from_deg":
            diff = _angle_diff(g, r)
            ratio = diff / tol.angle_deg
        else:
            diff = np.abs(g - r)
            ratio = diff / (tol.atol + tol.rtol * np.abs(r))
    bad = _finiteness_mismatch(g, r)
    both_finite = np.isfinite(g) & np.isfinite(r)
    diff = np.where(bad, np.inf, np.where(both_finite & mask, diff, 0.0))
    ratio = np.where(bad, np.inf, np.where(both_finite & mask, ratio, 0.0))
    return diff, ratio


def _tracked_airflow_ratio(model: StepModel, got: Trajectory, ref: Trajectory, tol: Tolerance, starts: RowStarts,
                           diff: np.ndarray, ratio: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``air_prev``'s element ratios, judged row by row through what that airflow means. On an accepted
    row the state passes as every state does (within the state tolerance, in m/s), or when the law's
    force at the C's airflow, evaluated in double, is within the force tolerance of the force the
    reference inverted on that row; the smaller of the two ratios counts. Not the law at the
    reference's own airflow: that is a tracking iterate, which may miss its target (before the start
    rule of forceair.body_drag_airflow_tracking, by 2e-3 N on the field fit: docs/verification.md). On a rejected
    row the step keeps the airflow it had: its change from the row before is compared instead, so a
    difference judged where it arose is not judged again in m/s. Returns (|diff|, its reference value,
    ratio) per element: on a row judged through the force, the force's difference and the force (N)."""
    law = tracked_airflow_force(model)
    sl = model.state.slice(TRACKED_AIRFLOW)
    if law is None or len(ref.status) == 0 or got.states.shape != ref.states.shape:
        return diff, np.abs(ref.states[:, sl]), ratio
    law_got, target = (np.asarray(v).T for v in law.map(len(ref.status))(
        starts.ref_before.T, starts.inputs.T, got.states[:, sl].T))
    with np.errstate(invalid="ignore", over="ignore"):
        force_ratio = np.abs(law_got - target) / (tol.atol + tol.rtol * np.abs(target))
        row_force = np.where(np.isnan(force_ratio), np.inf, force_ratio).max(axis=1)
        change = np.abs((got.states[:, sl] - starts.got_before[:, sl]) - (ref.states[:, sl] - starts.ref_before[:, sl]))
        kept = change / (tol.atol + tol.rtol * np.abs(ref.states[:, sl]))
    accepted = (np.asarray(ref.status, dtype=np.int64) & REJECTED_MASK) == 0
    finite = np.isfinite(got.states[:, sl]).all(axis=1) & np.isfinite(ref.states[:, sl]).all(axis=1)
    use_force = accepted & finite & (row_force < ratio.max(axis=1))
    use_kept = ~accepted & finite & np.isfinite(kept).all(axis=1)
    judged = np.where(use_force[:, None], force_ratio, ratio)
    force = use_force[:, None]
    return (np.where(force, np.abs(law_got - target), diff), np.where(force, np.abs(target), np.abs(ref.states[:, sl])),
            np.where(use_kept[:, None], np.minimum(kept, ratio), judged))


def _field_errors(layout, got: np.ndarray, ref: np.ndarray, tol: Tolerance, valid: np.ndarray,
                  speed: np.ndarray | None, judge=None) -> tuple[FieldError, ...]:
    """``judge``: the tracked airflow's own judgement (``_tracked_airflow_ratio``), for the states."""
    errors = []
    for f in layout.fields:
        sl = layout.slice(f.name)
        g, r = got[:, sl], ref[:, sl]
        name = f.name.removeprefix("last.")
        mask = valid[:, None]
        if name == "wind_from_deg" and speed is not None:
            # Direction is only defined with some wind; NaN speed compares False, so it is masked too
            # (its finiteness is still checked).
            with np.errstate(invalid="ignore"):
                mask = mask & (speed[:, None] >= MIN_SPEED_FOR_DIRECTION)
        diff, ratio = _field_ratio(name, g, r, tol, mask)
        if judge is not None and name == TRACKED_AIRFLOW:
            diff, r, ratio = judge(diff, ratio)
        flat = ratio.max(axis=1) if ratio.size else np.zeros(0)
        row = int(np.argmax(flat)) if flat.size else -1
        col = int(np.argmax(ratio[row])) if flat.size else 0
        at = (float(diff[row, col]), float(abs(r[row, col]))) if flat.size else (0.0, 0.0)
        errors.append(FieldError(f.name, float(diff.max()) if diff.size else 0.0,
                                 float(flat.max()) if flat.size else 0.0, row, *at))
    return tuple(errors)


def compare(model: StepModel, got: Trajectory, ref: Trajectory, tol: Tolerance,
            starts: RowStarts | None = None) -> Comparison:
    """``starts``: what each row started from; with it the tracked airflow is judged through the law
    (``_tracked_airflow_ratio``), without it element by element like every other state."""
    valid = np.ones(len(ref.status), dtype=bool)
    speed_col = model.outputs.slice("wind_speed_h")
    speed = ref.outputs[:, speed_col].ravel()
    state_speed = ref.states[:, model.state.slice("last.wind_speed_h")].ravel()
    judge = None
    if starts is not None and TRACKED_AIRFLOW in model.state:
        judge = lambda diff, ratio: _tracked_airflow_ratio(model, got, ref, tol, starts, diff, ratio)  # noqa: E731
    return Comparison(
        rows=len(ref.status),
        status_mismatches=_status_mismatches(got.status, ref.status),
        outputs=_field_errors(model.outputs, got.outputs, ref.outputs, tol, valid, speed),
        states=_field_errors(model.state, got.states, ref.states, tol, valid, state_speed, judge),
    )


def _status_mismatches(got: np.ndarray, ref: np.ndarray) -> int:
    """Rows whose status words differ (exact integers); a length difference counts every row."""
    if got.shape != ref.shape:
        return max(len(got), len(ref))
    return int(np.sum(np.asarray(got, dtype=np.int64) != np.asarray(ref, dtype=np.int64)))
