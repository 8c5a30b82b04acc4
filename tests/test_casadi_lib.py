"""The reference run as CasADi's own generated C (harness/casadi_lib.py) is the CasADi VM bit for bit, so
the python backend may use it; without a compiler the VM is used."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.replay import backends
from dobwind.harness import casadi_lib
from dobwind.model import reference
from dobwind.model.airframe import load_airframe
from dobwind.model.exercise import flight_inputs, random_cases
from dobwind.model.step import build_step
from tests.helpers import ROOT

AIRFRAMES = sorted((ROOT / "airframes").glob("*.toml"))


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("DOBWIND_CACHE", str(tmp_path / "cache"))


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit for bit, NaN where NaN (signed zeros compare equal, as the C harness compares)."""
    return a.shape == b.shape and bool(np.array_equal(a, b, equal_nan=True))


@pytest.mark.parametrize("path", AIRFRAMES, ids=lambda p: p.stem)
def test_compiled_reference_is_the_vm_over_a_whole_flight(path):
    """A jittery flight with a rejected row in every 97 (NaN, inf, bad dt), in 4096-row chunks with the
    state carried and the last chunk padded: outputs, states and status identical."""
    model = build_step(load_airframe(path))
    rolled = reference.rolled_step(model)
    compiled = casadi_lib.compiled_function(rolled)
    assert compiled is not None and compiled is not rolled
    inputs = flight_inputs(model, 3 * reference.CHUNK + 777, seed=7)
    vm, c = reference.run(model, inputs, None, rolled), reference.run(model, inputs, None, compiled)
    assert _same(vm.outputs, c.outputs) and _same(vm.states, c.states) and _same(vm.status, c.status)
    assert (vm.status != 0).any() and np.isfinite(vm.outputs).any()  # both kinds of row were run


@pytest.mark.parametrize("path", AIRFRAMES, ids=lambda p: p.stem)
def test_compiled_reference_is_the_vm_on_random_edge_cases(path):
    """Random (state, input) pairs with the validation's boundaries and non-finite values, one step each."""
    model = build_step(load_airframe(path))
    states, inputs = random_cases(model, 3000, seed=3)
    mapped = model.step.map(len(inputs), "serial")
    compiled = casadi_lib.compiled_function(mapped)
    assert compiled is not None
    for got, want in zip(compiled(states.T, inputs.T), mapped(states.T, inputs.T)):
        assert _same(np.asarray(got), np.asarray(want))


def test_the_library_is_cached_on_its_source_and_none_without_a_compiler(monkeypatch):
    model = build_step(load_airframe(AIRFRAMES[0]))
    rolled = reference.rolled_step(model)
    assert casadi_lib.compiled_function(rolled) is not None
    # A hit neither compiles nor needs a compiler.
    monkeypatch.setattr(casadi_lib.shutil, "which", lambda name: None)
    monkeypatch.setattr(casadi_lib, "run", lambda *a, **k: pytest.fail("compiled on a cache hit"))
    assert casadi_lib.compiled_function(rolled).class_name() == "External"
    # Another Function is a miss: without a compiler there is no library, and the backend keeps the VM.
    assert casadi_lib.compiled_function(model.step.map(7, "serial")) is None
    monkeypatch.setattr(casadi_lib, "compiled_function", lambda f: None)
    assert backends.rolled_reference(model).name() == rolled.name() == "rolled"
    assert backends.rolled_reference(model).class_name() != "External"


def test_the_python_backend_uses_it_and_gives_the_vms_numbers():
    model = build_step(load_airframe(AIRFRAMES[0]))
    runner = backends.Runner(model, "python")
    assert runner._rolled.class_name() == "External"
    inputs = flight_inputs(model, 5000, seed=11)
    got = [runner.run(inputs[:1234]), runner.run(inputs[1234:])]
    want = reference.run(model, inputs)
    assert _same(np.concatenate([g.outputs for g in got]), want.outputs)
    assert _same(np.concatenate([g.status for g in got]), want.status)


def test_a_library_that_cannot_be_built_falls_back_and_a_damaged_one_is_rebuilt(tmp_path, monkeypatch):
    """No room to write the source (a full disk): None, not a traceback (the backend then runs the VM:
    same numbers). A cached file that is not a library is built again, not left to slow every run."""
    model = build_step(load_airframe(AIRFRAMES[0]))
    rolled = reference.rolled_step(model)

    def full(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(casadi_lib.Path, "write_text", full)
    assert casadi_lib.compiled_function(rolled) is None
    monkeypatch.undo()
    monkeypatch.setenv("DOBWIND_CACHE", str(tmp_path / "cache2"))
    command = [casadi_lib.system_compiler(), *casadi_lib.FLAGS]
    target = casadi_lib.library_path(rolled, casadi_lib.generated_source(rolled), command)
    target.parent.mkdir(parents=True)
    target.write_text("not a library")
    rebuilt = casadi_lib.compiled_function(rolled)
    assert rebuilt is not None and rebuilt.class_name() == "External"
    assert target.read_bytes() != b"not a library"


def test_the_cache_key_names_the_compiler_not_only_its_command(monkeypatch):
    """A different compiler behind the same name (an upgrade, update-alternatives) is another key."""
    casadi_lib.compiler_identity.cache_clear()
    command = [casadi_lib.system_compiler(), *casadi_lib.FLAGS]
    assert casadi_lib.compiler_identity(command[0]) != ""
    key = casadi_lib._key("source", command)
    monkeypatch.setattr(casadi_lib, "compiler_identity", lambda name: "another compiler")
    assert casadi_lib._key("source", command) != key
    assert "-std=c99" in casadi_lib.FLAGS and "-ffp-contract=off" in casadi_lib.FLAGS


@pytest.mark.parametrize("rows", [1, 120, 4095])
def test_a_log_shorter_than_a_chunk_runs_as_the_padded_chunk_did(rows):
    """reference.run rolls a log shorter than CHUNK with a rolled step of its own length (generate's 120-row
    self-test among them): the same bits as the 4096-row one with its padding rows rejected."""
    model = build_step(load_airframe(AIRFRAMES[0]))
    inputs = flight_inputs(model, rows, seed=rows, bad_every=23)
    own = reference.run(model, inputs, np.full(model.state.size, 0.01) if rows == 120 else None)
    padded = reference.run(model, inputs, np.full(model.state.size, 0.01) if rows == 120 else None,
                           reference.rolled_step(model))
    assert reference.rolled_step(model).size2_in(1) == reference.CHUNK > rows
    for field in ("states", "outputs", "status"):
        assert getattr(own, field).tobytes() == getattr(padded, field).tobytes(), field
