"""The C step run in a child process, fed and read in its own type (float or double), for libraries built
with flags that imply fast-math.

gcc links crtfastmath.o into a shared library built with -funsafe-math-optimizations, -ffast-math or
-Ofast; loading it sets flush-to-zero and denormals-are-zero for the whole process. Loaded into the
process that computes the reference, it would change the reference (numpy's arithmetic flushes too) and
every later computation. In the child it only changes the child; and the child passes the arrays to the
shim's *_native entry points (plain copies, harness/templates/shim.c.j2), because a conversion
(double to float) under flush-to-zero would flush the subnormal limit rows before the C sees them. The
parent converts to and from the C's type itself, before and after, with IEEE subnormals."""
from __future__ import annotations

import ctypes
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from dobwind.model.errors import CheckFailed
from dobwind.model.kinds import Precision
from dobwind.model.reference import Trajectory

FAST_MATH_FLAGS = ("-ffast-math", "-funsafe-math-optimizations", "-Ofast")


def implies_fast_math(flags: tuple[str, ...]) -> bool:
    """Whether gcc links crtfastmath (flush-to-zero at load) for a shared library built with these."""
    return any(flag in FAST_MATH_FLAGS for flag in flags)


def _dtype(precision: Precision) -> type:
    return np.float32 if precision == Precision.SINGLE else np.float64


def run_isolated(library: Path, precision: Precision, sizes: tuple[int, int], states: np.ndarray,
                 inputs: np.ndarray, flight_inputs: np.ndarray) -> tuple[Trajectory, Trajectory]:
    """(the independent cases from ``states`` and ``inputs``, the run over ``flight_inputs`` from the
    initial state), as CStep.cases and CStep.run give them; ``sizes`` = (state, output) lengths."""
    real = _dtype(precision)
    with tempfile.TemporaryDirectory(prefix="dobwind-isolated-") as tmp:
        folder = Path(tmp)
        np.savez(folder / "in.npz", states=states.astype(real), inputs=inputs.astype(real),
                 flight_inputs=flight_inputs.astype(real), sizes=np.array(sizes), single=precision == Precision.SINGLE)
        done = subprocess.run([sys.executable, "-m", "dobwind.harness.isolated", str(library), str(folder)],
                              capture_output=True, text=True, errors="replace")
        if done.returncode != 0:
            raise CheckFailed(f"the C step in a child process failed:\n{done.stderr}".rstrip())
        with np.load(folder / "out.npz") as out:
            cases = Trajectory(out["cases_states"].astype(np.float64), out["cases_outputs"].astype(np.float64),
                               out["cases_status"].astype(np.int64))
            flight = Trajectory(out["flight_states"].astype(np.float64), out["flight_outputs"].astype(np.float64),
                                out["flight_status"].astype(np.int64))
    return cases, flight


def _child(library: Path, folder: Path) -> None:
    """In the child: load, run both, save everything in the C's type (no conversion here)."""
    with np.load(folder / "in.npz") as given:
        data = {key: given[key] for key in given.files}
    real = np.float32 if bool(data["single"]) else np.float64
    n_state, n_out = (int(v) for v in data["sizes"])
    pointer = np.ctypeslib.ndpointer(dtype=real, flags="C_CONTIGUOUS")
    int_p = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
    lib = ctypes.CDLL(str(library))
    lib.dobwind_shim_cases_native.argtypes = [pointer, pointer, ctypes.c_long, pointer, pointer, int_p]
    lib.dobwind_shim_run_native.argtypes = [pointer, ctypes.c_long, pointer, pointer, pointer, int_p]
    lib.dobwind_shim_init_native.argtypes = [pointer]
    result = {}
    for label, inputs in (("cases", data["inputs"]), ("flight", data["flight_inputs"])):
        n = inputs.shape[0]
        states_out = np.zeros((n, n_state), dtype=real)
        outputs, status = np.zeros((n, n_out), dtype=real), np.zeros(n, dtype=np.int32)
        if label == "cases":
            lib.dobwind_shim_cases_native(np.ascontiguousarray(data["states"]), np.ascontiguousarray(inputs), n,
                                          states_out, outputs, status)
        else:
            state = np.zeros(n_state, dtype=real)
            lib.dobwind_shim_init_native(state)
            lib.dobwind_shim_run_native(np.ascontiguousarray(inputs), n, state, states_out, outputs, status)
        result.update({f"{label}_states": states_out, f"{label}_outputs": outputs, f"{label}_status": status})
    np.savez(folder / "out.npz", **result)


if __name__ == "__main__":
    _child(Path(sys.argv[1]), Path(sys.argv[2]))
