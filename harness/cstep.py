"""The generated C step, compiled and loaded with ctypes: whole logs in one call."""
from __future__ import annotations

import ctypes
import hashlib
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import casadi
import jinja2
import numpy as np

from dobwind.harness.build import STRICT_FLAGS, build_shared_library, system_compiler, write_shim
from dobwind.harness.libcache import cache_dir, publish
from dobwind.model.reference import Trajectory
from dobwind.model.step import StepModel
from dobwind.model.kinds import Precision

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


def compile_step(model: StepModel, precision: Precision, work_dir: Path | None = None,
                 extra_flags: tuple[str, ...] = ()) -> CStep:
    """Generate, compile (strict flags) and load the C step for this model.

    With ``work_dir`` the sources and library are built there. Without it the library comes from the
    cache (``library_cache``), built on a miss: a replay then spends no time in the compiler."""
    if work_dir is not None:
        return _build_and_load(model, precision, Path(work_dir), extra_flags)
    return cached_step(model, precision, extra_flags)


def _build_and_load(model: StepModel, precision: Precision, work: Path, extra_flags: tuple[str, ...]) -> CStep:
    from dobwind.codegen.generate import generate_code, write_files

    code = generate_code(model.airframe, precision, model)
    write_files(code.files, work)
    return CStep(model, build_shared_library(model, precision, work, work, extra_flags))


def _source_key(folder: Path, extra_flags: tuple[str, ...]) -> str:
    """The hash of everything that decides the library's bytes: the generated sources and the shim, the
    compiler and its flags."""
    digest = hashlib.sha256()
    for path in sorted(folder.iterdir()):
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    digest.update("\0".join((system_compiler(), *STRICT_FLAGS, *extra_flags)).encode())
    return digest.hexdigest()[:32]


def _generator_files() -> list[Path]:
    """The files generation and the shim read: the model, the printer and templates, the harness."""
    from dobwind import codegen, model

    roots = [Path(model.__file__).parent, Path(codegen.__file__).parent, Path(__file__).parent]
    return sorted(p for root in roots for p in root.rglob("*") if p.is_file() and "__pycache__" not in p.parts)


def _recipe_key(model: StepModel, precision: Precision, extra_flags: tuple[str, ...]) -> str:
    """The hash of what the generated sources are made from, known without generating them: the
    airframe (plain values: its repr is exact), the precision, the generator's own files, the versions
    it computes the self-test vectors with, the compiler and flags. It assumes the model is
    build_step(model.airframe), as every caller's is; the step's own code is among the files hashed."""
    digest = hashlib.sha256(repr((model.airframe, precision)).encode())
    for path in _generator_files():
        digest.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    versions = (sys.version, np.__version__, casadi.__version__, jinja2.__version__)
    digest.update("\0".join((*versions, system_compiler(), *STRICT_FLAGS, *extra_flags)).encode())
    return digest.hexdigest()[:32]


def cached_step(model: StepModel, precision: Precision, extra_flags: tuple[str, ...] = ()) -> CStep:
    """The compiled step from the cache, built and added on a miss.

    Two names lead to a library: the recipe key (``_recipe_key``), found without generating the source
    (generation took 0.4 s of a replay), and the key of the generated source itself, which a changed
    generator that prints the same C still hits. The library is compiled in a private folder and renamed
    into place, so concurrent runs never see a partial file (two that miss together both build, and the
    second rename replaces an identical file). An unusable cache folder only costs the compilation: the
    private copy is loaded instead."""
    stem = f"lib{model.airframe.name}_{precision}"
    recipe = cache_dir() / f"{stem}_r{_recipe_key(model, precision, extra_flags)}.so"
    if recipe.is_file():
        return CStep(model, recipe)
    from dobwind.codegen.generate import generate_code, write_files  # on a miss only: 30-60 ms of imports

    with tempfile.TemporaryDirectory(prefix="dobwind-") as tmp:
        work = Path(tmp)
        code = generate_code(model.airframe, precision, model)
        write_files(code.files, work)
        write_shim(model, precision, work)
        cached = cache_dir() / f"{stem}_{_source_key(work, extra_flags)}.so"
        if not cached.is_file():
            built = build_shared_library(model, precision, work, work, extra_flags)
            if not publish(built, cached):
                return CStep(model, built)  # loaded before the folder goes: the loader keeps its mapping
        publish(cached, recipe)
        return CStep(model, cached)
