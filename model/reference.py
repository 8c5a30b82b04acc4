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
    states: np.ndarray   # (N, state size): state after each row (run_columns: the kept columns)
    outputs: np.ndarray  # (N, output size) (likewise)
    status: np.ndarray   # (N,) int


def rolled_step(model: StepModel, rows: int = CHUNK) -> ca.Function:
    """The step accumulated over ``rows`` samples: (state0, inputs[ni x rows]) -> per-row results."""
    return model.step.mapaccum("rolled", rows, [0], [0])


def run(model: StepModel, inputs: np.ndarray, state0: np.ndarray | None = None,
        rolled: ca.Function | None = None) -> Trajectory:
    return run_columns(model, inputs, slice(None), slice(None), state0, rolled)


def run_columns(model: StepModel, inputs: np.ndarray, state_columns: slice, output_columns: slice,
                state0: np.ndarray | None = None, rolled: ca.Function | None = None) -> Trajectory:
    """``run``, keeping only these columns of the states and outputs (the same numbers): the whole
    trajectory of an hour at 250 Hz is 280 MB, most of it unread by calibration, and freshly allocated
    memory costs page faults."""
    inputs = np.atleast_2d(np.asarray(inputs, dtype=float))
    n = inputs.shape[0]
    if inputs.shape[1] != model.inputs.size:
        raise ValueError(f"inputs have {inputs.shape[1]} columns, the step takes {model.inputs.size}")
    # A log shorter than a chunk gets a rolled step of its own length: building the 4096-row one took 25 ms
    # and evaluated 4096 steps for the 120 rows of generate's self-test. Each row is the same evaluation
    # of the step either way; the padding rows after the last real one are never read.
    rolled = rolled if rolled is not None else rolled_step(model, min(max(n, 1), CHUNK))
    chunk = rolled.size2_in(1)
    state = model.initial_state() if state0 is None else np.asarray(state0, dtype=float)
    states = np.empty((n, len(range(model.state.size)[state_columns])))
    outputs = np.empty((n, len(range(model.outputs.size)[output_columns])))
    status = np.empty(n, dtype=np.int64)
    rolled_chunk = _BoundChunk(rolled, model.inputs.size)
    dt_col = model.inputs.offset("dt")
    for start in range(0, n, chunk):
        rows = min(chunk, n - start)
        xs, ys, st = rolled_chunk(state, inputs[start:start + rows], dt_col)
        states[start:start + rows] = xs[:rows, state_columns]
        outputs[start:start + rows] = ys[:rows, output_columns]
        status[start:start + rows] = st[:rows].astype(np.int64)
        state = xs[rows - 1].copy()
    return Trajectory(states, outputs, status)


class _BoundChunk:
    """The rolled step evaluated in place on numpy arrays (CasADi's FunctionBuffer): converting each
    chunk's results from DM to numpy cost more than evaluating them (issue #13). The same Function and
    evaluation, so the same numbers as calling it. A row-major (rows, k) array holds the nonzeros of a
    dense k x rows matrix in CasADi's column-major order, so the buffers are the transposes."""

    def __init__(self, rolled: ca.Function, n_inputs: int) -> None:
        self._rolled, rows = rolled, rolled.size2_in(1)
        dense = all(rolled.sparsity_in(i).is_dense() for i in range(2)) and all(
            rolled.sparsity_out(i).is_dense() for i in range(3))
        self._state = np.zeros(rolled.size1_in(0))
        self._block = np.zeros((rows, n_inputs))
        self._out = [np.zeros((rolled.size2_out(i), rolled.size1_out(i))) for i in range(3)]
        self._evaluate = None
        if dense:  # always, for the step's functions; a sparse one is called the ordinary way
            buffer, self._evaluate = rolled.buffer()
            buffer.set_arg(0, memoryview(self._state))
            buffer.set_arg(1, memoryview(self._block))
            for i, out in enumerate(self._out):
                buffer.set_res(i, memoryview(out))
            self._buffer = buffer  # the evaluation needs it alive

    def __call__(self, state: np.ndarray, block: np.ndarray, dt_col: int) -> list[np.ndarray]:
        rows = block.shape[0]
        self._state[:] = state
        self._block[:rows] = block
        if rows < len(self._block):
            self._block[rows:] = 0.0
            self._block[rows:, dt_col] = -1.0  # rejected; only rows before the padding are kept
        if self._evaluate is None:
            results = [np.asarray(r).T for r in self._rolled(self._state, self._block.T)]
        else:
            self._evaluate()
            results = self._out
        return [r if r.shape[1] > 1 else r[:, 0] for r in results]
