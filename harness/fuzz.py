"""Sanitizer-instrumented adversarial fuzzing of the generated step (see templates/fuzz.c.j2)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import HARNESS_TEMPLATES, run, system_compiler
from dobwind.model.exercise import flight_inputs
from dobwind.model.plausibility import MAX_WIND_MPS
from dobwind.model.step import StepModel
from dobwind.model.kinds import Precision

SANITIZE = ("-fsanitize=address,undefined,float-cast-overflow,float-divide-by-zero", "-fno-sanitize-recover=all",
            "-fno-omit-frame-pointer", "-g", "-O1")


def build_fuzzer(model: StepModel, precision: Precision, work: Path) -> Path:
    code = generate_code(model.airframe, precision, model)
    write_files(code.files, work)
    real = "float" if precision == Precision.SINGLE else "double"
    base = flight_inputs(model, 1, seed=5, bad_every=0)[0]
    literal = (lambda v: f"{float(np.float32(v))!r}f") if precision == Precision.SINGLE else (lambda v: repr(float(v)))
    name = model.airframe.name
    text = HARNESS_TEMPLATES.get_template("fuzz.c.j2").render(
        name=name, prefix=f"{name}_wind_", real=real, n_in=model.inputs.size, elements=model.inputs.element_names(),
        base=", ".join(literal(v) for v in base), denormal="1e-40f" if precision == Precision.SINGLE else "4e-320",
        max_wind=repr(MAX_WIND_MPS), bookkeeping=_bookkeeping(model),
    )
    source = work / "fuzz.c"
    source.write_text(text)
    exe = work / "fuzz"
    run([system_compiler(), "-std=c99", "-Wall", "-Wextra", "-Werror", *SANITIZE, f"-I{work}", str(source),
         str(work / f"{name}_wind.c"), "-o", str(exe), "-lm"])
    return exe


def _bookkeeping(model: StepModel) -> list[tuple[str, int]]:
    """(state field, size) that a rejection may write: the gap bookkeeping and the acceleration check's
    state (model/biasgate.py); every other field must come out of a rejection unchanged."""
    names = dict.fromkeys([f for f, _ in model.reset_on_reject] + [f for f, _ in model.advance_on_check])
    return [(name, model.state.field(name).size) for name in names]


def fuzz(model: StepModel, precision: Precision, work: Path, iterations: int) -> str:
    """Runs the fuzzer; returns its summary line. Raises CheckFailed on a violation or a sanitizer report."""
    exe = build_fuzzer(model, precision, work)
    done = run([str(exe), str(iterations)])
    return done.stdout.strip().splitlines()[-1]
