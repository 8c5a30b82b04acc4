"""Worst differences between two trajectories (C versus reference), per output and state field."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind.codegen.tolerance import MIN_SPEED_FOR_DIRECTION, Tolerance
from dobwind.model.reference import Trajectory
from dobwind.model.step import StepModel


@dataclass(frozen=True)
class FieldError:
    name: str
    max_abs: float
    worst_ratio: float  # max of |diff| / (atol + rtol |ref|): <= 1 passes
    worst_row: int
    # The element that sets worst_ratio: its |diff| and its reference's magnitude. max_abs alone misled
    # (issue #33): the limit cases reach 1e27, where a passing single-precision diff is 1e22.
    worst_diff: float = 0.0
    worst_ref: float = 0.0


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


def _field_errors(layout, got: np.ndarray, ref: np.ndarray, tol: Tolerance, valid: np.ndarray,
                  speed: np.ndarray | None) -> tuple[FieldError, ...]:
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
        flat = ratio.max(axis=1) if ratio.size else np.zeros(0)
        row = int(np.argmax(flat)) if flat.size else -1
        col = int(np.argmax(ratio[row])) if flat.size else 0
        at = (float(diff[row, col]), float(abs(r[row, col]))) if flat.size else (0.0, 0.0)
        errors.append(FieldError(f.name, float(diff.max()) if diff.size else 0.0,
                                 float(flat.max()) if flat.size else 0.0, row, *at))
    return tuple(errors)


def compare(model: StepModel, got: Trajectory, ref: Trajectory, tol: Tolerance) -> Comparison:
    valid = np.ones(len(ref.status), dtype=bool)
    speed_col = model.outputs.slice("wind_speed_h")
    speed = ref.outputs[:, speed_col].ravel()
    state_speed = ref.states[:, model.state.slice("last.wind_speed_h")].ravel()
    return Comparison(
        rows=len(ref.status),
        status_mismatches=_status_mismatches(got.status, ref.status),
        outputs=_field_errors(model.outputs, got.outputs, ref.outputs, tol, valid, speed),
        states=_field_errors(model.state, got.states, ref.states, tol, valid, state_speed),
    )


def _status_mismatches(got: np.ndarray, ref: np.ndarray) -> int:
    """Rows whose status words differ (exact integers); a length difference counts every row."""
    if got.shape != ref.shape:
        return max(len(got), len(ref))
    return int(np.sum(np.asarray(got, dtype=np.int64) != np.asarray(ref, dtype=np.int64)))
