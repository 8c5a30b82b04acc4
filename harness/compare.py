"""Worst differences between two trajectories (C versus reference), per output and state field."""
from __future__ import annotations

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


@dataclass(frozen=True)
class Comparison:
    rows: int
    status_mismatches: int
    outputs: tuple[FieldError, ...]
    states: tuple[FieldError, ...]

    @property
    def worst_ratio(self) -> float:
        return max([e.worst_ratio for e in self.outputs + self.states] + [0.0])

    def passed(self) -> bool:
        return self.status_mismatches == 0 and self.worst_ratio <= 1.0


def _angle_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + 180.0) % 360.0 - 180.0)


def _field_errors(layout, got: np.ndarray, ref: np.ndarray, tol: Tolerance, valid: np.ndarray,
                  speed: np.ndarray | None) -> tuple[FieldError, ...]:
    errors = []
    for f in layout.fields:
        sl = layout.slice(f.name)
        g, r = got[:, sl], ref[:, sl]
        name = f.name.removeprefix("last.")
        if name == "wind_from_deg":
            diff = _angle_diff(g, r)
            mask = valid[:, None] & (speed[:, None] >= MIN_SPEED_FOR_DIRECTION) if speed is not None else valid[:, None]
            ratio = np.where(mask, diff / tol.angle_deg, 0.0)
            diff = np.where(mask, diff, 0.0)
        else:
            diff = np.abs(g - r)
            diff = np.where(np.isnan(g) & np.isnan(r), 0.0, np.where(np.isnan(diff), np.inf, diff))
            ratio = diff / (tol.atol + tol.rtol * np.abs(r))
        flat = ratio.max(axis=1) if ratio.size else np.zeros(0)
        row = int(np.argmax(flat)) if flat.size else -1
        errors.append(FieldError(f.name, float(diff.max()) if diff.size else 0.0,
                                 float(flat.max()) if flat.size else 0.0, row))
    return tuple(errors)


def compare(model: StepModel, got: Trajectory, ref: Trajectory, tol: Tolerance) -> Comparison:
    valid = np.ones(len(ref.status), dtype=bool)
    speed_col = model.outputs.slice("wind_speed_h")
    speed = ref.outputs[:, speed_col].ravel()
    state_speed = ref.states[:, model.state.slice("last.wind_speed_h")].ravel()
    return Comparison(
        rows=len(ref.status),
        status_mismatches=int(np.sum(got.status != ref.status)),
        outputs=_field_errors(model.outputs, got.outputs, ref.outputs, tol, valid, speed),
        states=_field_errors(model.state, got.states, ref.states, tol, valid, state_speed),
    )
