"""The generated C step, compiled and loaded with ctypes: whole logs in one call."""
from __future__ import annotations

import ctypes
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import build_shared_library
from dobwind.model.reference import Trajectory
from dobwind.model.step import StepModel

_DOUBLE_P = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_INT_P = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")


@dataclass
class CStep:
    model: StepModel
    library_path: Path

    def __post_init__(self) -> None:
        lib = ctypes.CDLL(str(self.library_path))
        lib.dobwind_shim_run.argtypes = [_DOUBLE_P, ctypes.c_long, _DOUBLE_P, ctypes.c_void_p, _DOUBLE_P, _INT_P]
        lib.dobwind_shim_cases.argtypes = [_DOUBLE_P, _DOUBLE_P, ctypes.c_long, _DOUBLE_P, _DOUBLE_P, _INT_P]
        lib.dobwind_shim_init.argtypes = [_DOUBLE_P]
        self._lib = lib

    def initial_state(self) -> np.ndarray:
        state = np.zeros(self.model.state.size)
        self._lib.dobwind_shim_init(state)
        return state

    def run(self, inputs: np.ndarray, state0: np.ndarray | None = None, keep_states: bool = True) -> Trajectory:
        inputs = np.ascontiguousarray(inputs, dtype=np.float64)
        n = inputs.shape[0]
        state = np.ascontiguousarray(self.initial_state() if state0 is None else state0, dtype=np.float64).copy()
        states = np.zeros((n, self.model.state.size)) if keep_states else None
        outputs = np.zeros((n, self.model.outputs.size))
        status = np.zeros(n, dtype=np.int32)
        states_ptr = states.ctypes.data_as(ctypes.c_void_p) if states is not None else None
        self._lib.dobwind_shim_run(inputs, n, state, states_ptr, outputs, status)
        return Trajectory(states if states is not None else state[None, :], outputs, status.astype(np.int64))

    def cases(self, states: np.ndarray, inputs: np.ndarray) -> Trajectory:
        states = np.ascontiguousarray(states, dtype=np.float64)
        inputs = np.ascontiguousarray(inputs, dtype=np.float64)
        n = inputs.shape[0]
        out_states = np.zeros_like(states)
        outputs = np.zeros((n, self.model.outputs.size))
        status = np.zeros(n, dtype=np.int32)
        self._lib.dobwind_shim_cases(states, inputs, n, out_states, outputs, status)
        return Trajectory(out_states, outputs, status.astype(np.int64))


def compile_step(model: StepModel, precision: str, work_dir: Path | None = None,
                 extra_flags: tuple[str, ...] = ()) -> CStep:
    """Generate, compile (strict flags) and load the C step for this model.

    Without ``work_dir`` the sources and library go to a temporary folder that is removed once the
    library is loaded: the loader keeps its own mapping, so deleting the file does not unload it."""
    if work_dir is not None:
        return _build_and_load(model, precision, Path(work_dir), extra_flags)
    with tempfile.TemporaryDirectory(prefix="dobwind-") as tmp:
        return _build_and_load(model, precision, Path(tmp), extra_flags)


def _build_and_load(model: StepModel, precision: str, work: Path, extra_flags: tuple[str, ...]) -> CStep:
    code = generate_code(model.airframe, precision, model)
    write_files(code.files, work)
    return CStep(model, build_shared_library(model, precision, work, work, extra_flags))
