"""The Python reference: the CasADi step run over a whole log, arrays in and arrays out.

No per-sample Python loop: the step is rolled with ``mapaccum`` over fixed-size chunks (one compiled
graph, reused). The last chunk is padded with rows that the step rejects (dt = -1); they come after the
last real row, whose state is the one carried on, so their gap bookkeeping never reaches a result.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from dobwind.model.step import StepModel

CHUNK = 4096


@dataclass(frozen=True)
class Trajectory:
    states: np.ndarray   # (N, state size): state after each row
    outputs: np.ndarray  # (N, output size)
    status: np.ndarray   # (N,) int


def rolled_step(model: StepModel, rows: int = CHUNK) -> ca.Function:
    """The step accumulated over ``rows`` samples: (state0, inputs[ni x rows]) -> per-row results."""
    return model.step.mapaccum("rolled", rows, [0], [0])


def run(model: StepModel, inputs: np.ndarray, state0: np.ndarray | None = None,
        rolled: ca.Function | None = None) -> Trajectory:
    inputs = np.atleast_2d(np.asarray(inputs, dtype=float))
    n = inputs.shape[0]
    if inputs.shape[1] != model.inputs.size:
        raise ValueError(f"inputs have {inputs.shape[1]} columns, the step takes {model.inputs.size}")
    rolled = rolled if rolled is not None else rolled_step(model)
    chunk = rolled.size2_in(1)
    state = np.zeros(model.state.size) if state0 is None else np.asarray(state0, dtype=float)
    states = np.empty((n, model.state.size))
    outputs = np.empty((n, model.outputs.size))
    status = np.empty(n, dtype=np.int64)
    dt_col = model.inputs.offset("dt")
    for start in range(0, n, chunk):
        block = inputs[start:start + chunk]
        rows = block.shape[0]
        if rows < chunk:
            pad = np.zeros((chunk - rows, model.inputs.size))
            pad[:, dt_col] = -1.0  # rejected; only rows before the padding are kept
            block = np.vstack([block, pad])
        xs, ys, st = rolled(state, block.T)
        xs, ys, st = np.asarray(xs), np.asarray(ys), np.asarray(st)
        states[start:start + rows] = xs[:, :rows].T
        outputs[start:start + rows] = ys[:, :rows].T
        status[start:start + rows] = st.reshape(-1)[:rows].astype(np.int64)
        state = xs[:, rows - 1]
    return Trajectory(states, outputs, status)
