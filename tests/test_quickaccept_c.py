"""The quick acceptance test in the compiled C, under the autopilots' flag sets (harness/flagsets.py).

tests/test_quickaccept.py checks the implication on the CasADi stage; here the generated step itself is
built with PX4's set (-funsafe-math-optimizations) and ArduPilot's (-fsingle-precision-constant, -Os), with
gcc and clang, and run with the SSE flush-to-zero and denormals-are-zero modes off and on. The build is the
generated C with its exact tests run on every sample as well: a sample the quick test accepts but the exact
tests of the same program reject returns -1. The inputs are bit patterns at every limit (both NaNs, the
infinities, both zeros, subnormals, the neighbours of each bound) and vectors whose |v|^2, |a|^2, |q|^2 or
tilt lie within a few ulps of their bounds, where a sum rounded one way in one test and another way in the
other would show."""
from __future__ import annotations

import math
import platform
import subprocess

import numpy as np
import pytest

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import run
from dobwind.harness.flagsets import FLAG_SETS, available_toolchains
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.attitude import euler_to_quaternion
from dobwind.model.airframe_toml import dumps
from dobwind.model.plausibility import MAX_ACCELERATION_MPS2, MAX_GROUND_SPEED_MPS
from dobwind.model.status import REJECTED_MASK
from dobwind.model.step import StepModel, build_step
from tests.helpers import M300, all_modes
from tests.test_quickaccept import _adversarial
from tools.mutant_table import c_mutants
from tools.mutants import apply_c_mutant

pytestmark = pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="sets the SSE MXCSR modes")

QUICK_REFUSED = "if (!quick_accept) {"
EXACT_REJECTS = "if (status != 0) {"

# Rows of raw input structs on stdin, the status of each on stdout; argv[1]: 1 for FTZ and DAZ during the step.
DRIVER = r"""
#include <stdio.h>
#include <xmmintrin.h>
#include "{name}_wind.h"
int main(int argc, char **argv)
{{
    const unsigned int modes = argc > 1 && argv[1][0] == '1' ? 0x8040u : 0u;
    const unsigned int saved = _mm_getcsr();
    {prefix}state_t start, state;
    {prefix}input_t in;
    {prefix}output_t out;
    {prefix}init(&start);
    while (fread(&in, sizeof in, 1, stdin) == 1) {{
        int status;
        state = start;
        _mm_setcsr(saved | modes);
        status = {prefix}step(&state, &in, &out);
        _mm_setcsr(saved);
        fwrite(&status, sizeof status, 1, stdout);
    }}
    return 0;
}}
"""


def _checking(source: str) -> str:
    """The step with its exact tests run on every sample, returning -1 where they reject what the quick
    test accepted."""
    assert source.count(QUICK_REFUSED) == 1 and source.count(EXACT_REJECTS) == 1
    source = source.replace(QUICK_REFUSED, "{")
    return source.replace(EXACT_REJECTS, "if (quick_accept && status != 0) {\n                return -1;\n"
                                         "            }\n            " + EXACT_REJECTS)


def _ulps(values: np.ndarray, dtype, rng: np.random.Generator) -> np.ndarray:
    """``values`` in ``dtype``, each moved by 0-3 patterns either way."""
    out = values.astype(dtype)
    for i in range(out.size):
        for _ in range(rng.integers(0, 4)):
            out.flat[i] = np.nextafter(out.flat[i], dtype(np.inf) if rng.random() < 0.5 else dtype(-np.inf))
    return out


def _boundary_rows(model: StepModel, base: np.ndarray, dtype, count: int = 400) -> np.ndarray:
    """Vectors at the norm bounds and quaternions at the norm and tilt bounds, a few ulps either side.
    Not model/boundaries.py's cases: those stand off a computed limit's flip in single precision (where
    the C's sum and the reference's differ), and here the rows must sit on it."""
    rng = np.random.default_rng(11)
    fields = {f.name: model.inputs.slice(f.name) for f in model.inputs.fields}
    norms = {"vel_ned": (MAX_GROUND_SPEED_MPS,), "acc_ned": (MAX_ACCELERATION_MPS2,),
             "specific_force": (MAX_ACCELERATION_MPS2,), "q": (0.9, 1.1)}
    rows = []
    for name, bounds in norms.items():
        if name not in fields:
            continue
        for k in range(count):
            row = base[k % len(base)].copy()
            direction = rng.normal(size=fields[name].stop - fields[name].start)
            row[fields[name]] = _ulps(direction / np.linalg.norm(direction) * bounds[k % len(bounds)], dtype, rng)
            rows.append(row)
    tilt = math.radians(model.airframe.limits.max_tilt_deg)
    for k in range(count):
        row = base[k % len(base)].copy()
        # cos(tilt) = cos(roll) cos(pitch): the tilt within about 1e-6 rad of the limit, the roll at random
        roll = rng.uniform(0, tilt)
        pitch = math.acos(math.cos(tilt + rng.normal() * 1e-6) / math.cos(roll))
        q = euler_to_quaternion(np.array(roll), np.array(pitch), np.array(rng.uniform(0, 2 * math.pi)))
        row[fields["q"]] = _ulps(q * rng.uniform(0.9, 1.1), dtype, rng)
        rows.append(row)
    return np.array(rows)


def _rows(model: StepModel, dtype) -> np.ndarray:
    every = _adversarial(model)
    rows = np.vstack([every, _boundary_rows(model, every[:300], dtype)]).astype(dtype)
    with np.errstate(invalid="ignore"):
        negative_nan = np.array(-np.inf, dtype) * dtype(0)  # x86's default NaN, sign bit set
    assert np.signbit(negative_nan) and np.isnan(negative_nan)
    nans = np.repeat(rows[:1], rows.shape[1], axis=0)
    nans[np.arange(rows.shape[1]), np.arange(rows.shape[1])] = negative_nan
    return np.vstack([rows, nans])


def _build(model: StepModel, precision: str, source: str, toolchain, flags, work) -> str:
    name = model.airframe.name
    files = dict(generate_code(model.airframe, precision, model).files)
    files[f"{name}_wind.c"] = source
    write_files(files, work)
    (work / "driver.c").write_text(DRIVER.format(name=name, prefix=f"{name}_wind_"))
    exe = work / "driver"
    kept = [f for f in toolchain.adapt(flags.c) if not f.startswith("-Werror")]
    run([toolchain.cc, *kept, f"-I{work}", str(work / f"{name}_wind.c"), str(work / "driver.c"), "-o", str(exe), "-lm"])
    return str(exe)


def _statuses(exe: str, rows: np.ndarray, ftz: bool) -> np.ndarray:
    done = subprocess.run([exe, "1" if ftz else "0"], input=np.ascontiguousarray(rows).tobytes(), capture_output=True,
                          check=True)
    return np.frombuffer(done.stdout, dtype=np.int32)


def _modes() -> list:
    docs = {doc["name"]: doc for doc in all_modes()}
    return [M300, docs["mode_euler_specific_force_collective_bias"]]


@pytest.mark.parametrize("mode", _modes(), ids=lambda m: getattr(m, "stem", None) or m["name"])
def test_the_compiled_quick_test_never_accepts_what_its_exact_tests_reject(mode, tmp_path):
    model = build_step(load_airframe(mode) if not isinstance(mode, dict) else parse_airframe(dumps(mode), "<test>"))
    hosted = [t for t in available_toolchains() if t.hosted]
    for precision, dtype in (("single", np.float32), ("double", np.float64)):
        source = _checking(generate_code(model.airframe, precision, model).files[f"{model.airframe.name}_wind.c"])
        rows = _rows(model, dtype)
        for toolchain in hosted:
            for flags in FLAG_SETS.values():
                if precision == "double" and not flags.double_ok:
                    continue
                work = tmp_path / f"{precision}-{toolchain.cc}-{flags.name}"
                work.mkdir()
                exe = _build(model, precision, source, toolchain, flags, work)
                for ftz in (False, True):
                    status = _statuses(exe, rows, ftz)
                    where = f"{precision}, {toolchain.label}, {flags.name}, FTZ/DAZ {'on' if ftz else 'off'}"
                    assert len(status) == len(rows), where
                    assert not np.any(status == -1), (where, rows[status == -1][:3])
                    rejected = (status & REJECTED_MASK) != 0  # a fresh state's accepted sample is SETTLING
                    assert 0.2 < np.mean(rejected) < 0.9, where  # both sides of the limits reached


def test_the_check_sees_a_quick_test_that_accepts_too_much(tmp_path):
    """The check can fail: the quick test's ground-speed bound 10 % wide (tools/mutant_table.py) accepts
    the rows a few ulps above |v| = 150 m/s that its exact tests reject."""
    model = build_step(load_airframe(M300))
    mutant = next(m for m in c_mutants(model.airframe) if m.name.startswith("quick test: its ground speed bound"))
    source = generate_code(model.airframe, "single", model).files["m300_wind.c"]
    mutated = _checking(apply_c_mutant(source, mutant, "single", "m300_wind_"))
    toolchain = next(t for t in available_toolchains() if t.hosted)
    exe = _build(model, "single", mutated, toolchain, FLAG_SETS["px4"], tmp_path)
    assert np.any(_statuses(exe, _rows(model, np.float32), False) == -1)
