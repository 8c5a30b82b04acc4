"""The estimator's two backends behind one interface: the CasADi reference (``python``; CasADi's own C of
it when a compiler is found, see rolled_reference) and dobwind's generated C compiled on the fly (``c``,
through ``dobwind.harness.cstep``), run over consecutive chunks of a log."""
from __future__ import annotations

import numpy as np

from dobwind.model import reference
from dobwind.model.reference import Trajectory
from dobwind.model.step import StepModel
from dobwind.model.kinds import Precision


def run_backend(model: StepModel, inputs: np.ndarray, backend: str, precision: Precision = Precision.SINGLE) -> Trajectory:
    return Runner(model, backend, precision).run(inputs)


def rolled_reference(model: StepModel):
    """The reference's rolled step (reference.rolled_step), run as CasADi's own generated C when a
    compiler builds it (harness/casadi_lib.py: the same numbers, a fifth of the VM's time), else in
    CasADi's virtual machine."""
    from dobwind.harness.casadi_lib import compiled_function

    rolled = reference.rolled_step(model)
    return compiled_function(rolled) or rolled


class Runner:
    """The chosen backend over consecutive chunks of one log, the estimator state carried from each chunk
    to the next: the results are those of one pass over the whole log, bit for bit."""

    def __init__(self, model: StepModel, backend: str, precision: Precision = Precision.SINGLE) -> None:
        self._model, self._backend, self._precision = model, backend, precision
        if backend == "python":
            self._rolled = rolled_reference(model)
            self._state: np.ndarray | None = None
        else:
            from dobwind.harness.cstep import compile_step

            self._cstep = compile_step(model, precision)
            self._state = self._cstep.initial_state()

    def run(self, inputs: np.ndarray) -> Trajectory:
        if self._backend == "python":
            traj = reference.run(self._model, inputs, self._state, self._rolled)
            self._state = traj.states[-1].copy()
            return traj
        if self._precision == Precision.SINGLE:
            inputs = inputs.astype(np.float32).astype(np.float64)
        traj = self._cstep.run(inputs, self._state, keep_states=False)
        self._state = traj.states[-1].copy()
        return traj
