"""Benchmark: the generated step against CasADi's own generate() of the same Function.

Same compiler, flags, data and driver loop for both. Instructions per step come from valgrind
callgrind (exact, unlike wall time on a shared machine): the difference of two runs of different
lengths divided by the extra steps, so start-up costs cancel. ns/step is the median of 15 rounds of 10^6
steps, the two implementations run in turn within each round (interleaved). The Cortex-M4F cycles are an
instruction-level estimate of the real firmware (benchmarks/m4cycles.py), not a measurement.
Flash is a minimal Cortex-M4F firmware (-Os, gc-sections) calling the step, single precision.

    python -m benchmarks.bench [AIRFRAME ...] [--json]
"""
from __future__ import annotations

import argparse
import json
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness import cortex
from benchmarks import m4cycles
from dobwind.harness.build import run, system_compiler
from dobwind.model.airframe import load_airframe
from dobwind.model import reference
from dobwind.model.exercise import flight_inputs
from dobwind.model.step import StepModel, build_step

ROWS = 1000
# One airframe of each family: the paper's polynomial and the drag-body law fit chooses on most vehicles.
DEFAULT_AIRFRAMES = ("airframes/m300.toml", "benchmarks/bench/m300body.toml")
# -fno-math-errno (the flag the README recommends): sqrt then compiles to the instruction (sqrtss, vsqrt.f32)
# instead of a call kept for errno; the step's square roots never see a negative argument.
FLAGS = ("-std=c99", "-O2", "-fno-math-errno")

_OURS = """\
#include <stdio.h>
#include <stdlib.h>
#include "{name}_wind.h"
extern const double bench_inputs[{rows}][{ni}];
int main(int argc, char **argv)
{{
    long k, steps = argc > 1 ? atol(argv[1]) : 1000;
    double acc = 0;
    {prefix}state_t state;
    {prefix}input_t in;
    {prefix}output_t out;
    {prefix}init(&state);
    for (k = 0; k < steps; ++k) {{
        const double *u = bench_inputs[k % {rows}];
{fill}
        acc += (double){prefix}step(&state, &in, &out) + (double)out.wind_speed_h;
    }}
    printf("%.6g\\n", acc);
    return 0;
}}
"""

_CASADI = """\
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#define casadi_real {real}
#define casadi_int long long int
int {fname}(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem);
extern const double bench_inputs[{rows}][{ni}];
int main(int argc, char **argv)
{{
    long k, steps = argc > 1 ? atol(argv[1]) : 1000;
    int i;
    double acc = 0;
    casadi_real x[{ns}], u[{ni}], xn[{ns}], y[{no}], status;
    casadi_real w[{nw}];
    casadi_int iw[{niw}];
    const casadi_real *arg[2];
    casadi_real *res[3];
    memset(x, 0, sizeof x);
    arg[0] = x; arg[1] = u; res[0] = xn; res[1] = y; res[2] = &status;
    for (k = 0; k < steps; ++k) {{
        const double *row = bench_inputs[k % {rows}];
        for (i = 0; i < {ni}; ++i) u[i] = (casadi_real)row[i];
        {fname}(arg, res, iw, w, 0);
        memcpy(x, xn, sizeof x);
        acc += (double)status + (double)y[6];
    }}
    printf("%.6g\\n", acc);
    return 0;
}}
"""


@dataclass(frozen=True)
class Row:
    precision: str
    implementation: str
    instructions_per_step: float
    ns_per_step: float
    m4f_flash_bytes: int | None
    m4f_double_symbols: int | None
    m4f_cycles_estimate: float | None = None  # mean over the bench rows; see benchmarks/m4cycles.py
    m4f_object_bytes: int | None = None       # the step's object code (-Os, without libm)
    airframe: str = ""
    family: str = ""


def _data_file(model: StepModel, work: Path) -> Path:
    rows = flight_inputs(model, ROWS, seed=11)
    body = ",\n".join("{" + ", ".join(repr(float(v)) if np.isfinite(v) else ("(0.0/0.0)" if np.isnan(v) else ("1e999" if v > 0 else "-1e999")) for v in r) + "}" for r in rows)
    path = work / "bench_data.c"
    path.write_text(f"const double bench_inputs[{ROWS}][{model.inputs.size}] = {{\n{body}\n}};\n")
    return path


def _fill_lines(model: StepModel, real: str) -> str:
    return "\n".join(f"        in.{name} = ({real})u[{col}];" for col, name in enumerate(model.inputs.element_names()))


def _casadi_source(model: StepModel, precision: str, work: Path) -> tuple[Path, str]:
    fname = f"casadi_{model.airframe.name}_step"
    symbols = model.step.sx_in()
    f = ca.Function(fname, symbols, model.step.call(symbols), {"cse": True})  # the same step, renamed
    opts = {"casadi_real": "float" if precision == "single" else "double", "casadi_int": "long long int"}
    gen = ca.CodeGenerator(f"{fname}.c", opts)
    gen.add(f)
    text = gen.dump()
    path = work / f"{fname}_{precision}.c"
    path.write_text(text)
    return path, fname


def _instructions(exe: Path, steps: int) -> int:
    done = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={exe}.cg.out", str(exe), str(steps)],
                          capture_output=True, text=True, check=True)
    match = re.search(r"Collected : (\d+)", done.stderr)
    if not match:
        raise RuntimeError(f"no callgrind total in: {done.stderr[-500:]}")
    return int(match.group(1))


def _instructions_per_step(exe: Path) -> float:
    short, long = 2000, 12000
    return (_instructions(exe, long) - _instructions(exe, short)) / (long - short)


TIMING_ROUNDS = 15
TIMING_STEPS = 1_000_000


def _interleaved_ns(exes: list[Path]) -> list[float]:
    """Median wall time per step of each program, run in turn round after round, so that a load change
    on the shared machine hits every program alike rather than whichever ran during it."""
    times: list[list[float]] = [[] for _ in exes]
    for _ in range(TIMING_ROUNDS):
        for i, exe in enumerate(exes):
            start = time.perf_counter()
            subprocess.run([str(exe), str(TIMING_STEPS)], capture_output=True, check=True)
            times[i].append(time.perf_counter() - start)
    return [statistics.median(t) / TIMING_STEPS * 1e9 for t in times]


def bench(af_path: str) -> list[Row]:
    model = build_step(load_airframe(af_path))
    name = model.airframe.name
    results = []
    with tempfile.TemporaryDirectory(prefix="dobwind-bench-") as tmp:
        work = Path(tmp)
        data = _data_file(model, work)
        for precision in ("double", "single"):
            real = "float" if precision == "single" else "double"
            pdir = work / precision
            pdir.mkdir()
            write_files(generate_code(model.airframe, precision, model).files, pdir)
            ours_main = pdir / "ours_main.c"
            ours_main.write_text(_OURS.format(name=name, prefix=f"{name}_wind_", rows=ROWS, ni=model.inputs.size,
                                              fill=_fill_lines(model, real)))
            ours = pdir / "ours"
            run([system_compiler(), *FLAGS, f"-I{pdir}", str(ours_main), str(pdir / f"{name}_wind.c"), str(data),
                 "-o", str(ours), "-lm"])
            cas_src, fname = _casadi_source(model, precision, pdir)
            cas_main = pdir / "casadi_main.c"
            cas_main.write_text(_CASADI.format(real=real, fname=fname, rows=ROWS, ni=model.inputs.size,
                                               ns=model.state.size, no=model.outputs.size,
                                               nw=max(model.step.sz_w(), 1), niw=max(model.step.sz_iw(), 1)))
            cas = pdir / "casadi"
            run([system_compiler(), *FLAGS, f"-Dcasadi_real={real}", "-Dcasadi_int=long long int", str(cas_main),
                 str(cas_src), str(data), "-o", str(cas), "-lm"])
            flash: dict[str, tuple[int | None, int | None]] = {"dobwind": (None, None), "casadi generate()": (None, None)}
            cycles = None
            code_bytes: dict[str, int | None] = {"dobwind": None, "casadi generate()": None}
            if precision == "single" and cortex.available():
                mdir = pdir / "m4f"
                mdir.mkdir()
                build = cortex.check_generated(pdir, name, model.inputs.fields, mdir)
                flash["dobwind"] = (build.firmware_flash_bytes, len(build.double_symbols))
                code_bytes["dobwind"] = build.object_text_bytes
                cycles = _m4f_cycles(model, mdir / "with_step.elf")
                cmain_text = _casadi_firmware_main(fname, model)
                elf = cortex.build_firmware([cas_src], cmain_text, mdir, "casadi_fw",
                                            ("-Dcasadi_real=float", "-Dcasadi_int=long long int"))
                obj = mdir / "casadi_obj.o"
                run([cortex.ARM_GCC, *cortex.CPU_FLAGS, *cortex.FIRMWARE_FLAGS, "-Dcasadi_real=float", "-Dcasadi_int=long long int",
                     "-c", str(cas_src), "-o", str(obj)])
                flash["casadi generate()"] = (cortex.flash_size_bytes(elf), len(cortex.double_precision_symbols(obj)))
            pair = (("dobwind", ours), ("casadi generate()", cas))
            if precision == "single" and handwritten_source(name) is not None:
                results += _handwritten_rows(model, pdir, data, ours_main)
            for (label, exe), ns in zip(pair, _interleaved_ns([ours, cas])):
                instructions = _instructions_per_step(exe)
                results.append(Row(precision, label, instructions, ns, *flash[label],
                                   cycles if label == "dobwind" and precision == "single" else None,
                                   code_bytes[label], name, family(model.airframe)))
    return results


HANDWRITTEN_DIR = Path(__file__).parent / "handwritten"
# The hand-written limits of benchmarks/handwritten/<name>_step.c: (label, extra compiler flags).
# The third does the generated step's work (the acceleration check, since issue #37, too): the like-for-like one.
HANDWRITTEN_VARIANTS = (("hand-written limit", ()), ("hand-written, same validation", ("-DHANDWRITTEN_VALIDATION",)),
                        ("hand-written, same validation and acceleration check",
                         ("-DHANDWRITTEN_VALIDATION", "-DHANDWRITTEN_ACC_CHECK")))


def handwritten_source(name: str) -> Path | None:
    path = HANDWRITTEN_DIR / f"{name}_step.c"
    return path if path.exists() else None


def _handwritten_rows(model: StepModel, pdir: Path, data: Path, driver: Path) -> list[Row]:
    """The airframe's hand-written step (single precision) through the same driver, data and firmware:
    x86 instructions, firmware flash, and the M4F estimate, whose emulated outputs must match the
    reference (on a flight without bad samples for the limit without validation, which does not
    reject them)."""
    name, source, rows = model.airframe.name, handwritten_source(model.airframe.name), []
    for variant, (label, flags) in enumerate(HANDWRITTEN_VARIANTS):
        exe = pdir / f"hw{variant}"
        run([system_compiler(), *FLAGS, *flags, f"-I{pdir}", str(driver), str(source), str(data), "-o", str(exe), "-lm"])
        flash = cycles = None
        if cortex.available():
            mdir = pdir / f"m4f_{exe.name}"
            mdir.mkdir()
            elf = cortex.build_firmware([source], cortex.firmware_main(name, model.inputs.fields, "float", True), mdir,
                                        "with_step", (*flags, f"-I{pdir}"))
            flash = cortex.flash_size_bytes(elf)
            clean = flight_inputs(model, ROWS, seed=11, bad_every=0) if not flags else None
            cycles = _m4f_cycles(model, elf, clean)
        rows.append(Row("single", label, _instructions_per_step(exe), _interleaved_ns([exe])[0], flash, None, cycles,
                        None, name, family(model.airframe)))
    return rows


def family(af) -> str:
    """The force-air family, as fit names it."""
    if af.drag is None:
        return "polynomial"
    return "drag-body" if af.drag.frame == "body" else "drag-heading"


def _m4f_cycles(model: StepModel, elf: Path, inputs: np.ndarray | None = None) -> float | None:
    """The instruction-level M4F estimate of the firmware's step over the bench rows (or ``inputs``; None
    without Unicorn). The emulated outputs must match the Python reference, or the estimate ran something else."""
    if not m4cycles.available():
        return None
    rows = (flight_inputs(model, ROWS, seed=11) if inputs is None else inputs).astype(np.float32)
    result = m4cycles.estimate(elf, f"{model.airframe.name}_wind_", rows, model.state.size, model.outputs.size)
    want = reference.run(model, rows.astype(np.float64)).outputs
    if not np.allclose(result.outputs, want, rtol=1e-3, atol=1e-2, equal_nan=True):
        raise RuntimeError("the emulated Cortex-M4F step does not reproduce the reference outputs")
    return result.mean_cycles


def _casadi_firmware_main(fname: str, model: StepModel) -> str:
    ni, ns, no = model.inputs.size, model.state.size, model.outputs.size
    return f"""\
int {fname}(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem);
volatile casadi_real sink;
volatile casadi_real source = (casadi_real)1;
int main(void)
{{
    casadi_real x[{ns}], u[{ni}], xn[{ns}], y[{no}], status, w[{max(model.step.sz_w(), 1)}];
    casadi_int iw[{max(model.step.sz_iw(), 1)}];
    const casadi_real *arg[2];
    casadi_real *res[3];
    int i;
    arg[0] = x; arg[1] = u; res[0] = xn; res[1] = y; res[2] = &status;
    for (i = 0; i < {ns}; ++i) x[i] = 0;
    for (;;) {{
        for (i = 0; i < {ni}; ++i) u[i] = source;
        {fname}(arg, res, iw, w, 0);
        for (i = 0; i < {ns}; ++i) x[i] = xn[i];
        sink = y[6];
    }}
}}
"""


def table(rows: list[Row]) -> str:
    out = [f"{rows[0].airframe} ({rows[0].family})\n" if rows and rows[0].airframe else "",
           "| precision | implementation | x86-64 instructions/step | ns/step | Cortex-M4F flash (bytes) | "
           "M4F step object (bytes) | double-precision symbols | M4F cycles/step (estimate) |",
           "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        flash = "-" if r.m4f_flash_bytes is None else str(r.m4f_flash_bytes)
        code = "-" if r.m4f_object_bytes is None else str(r.m4f_object_bytes)
        dbl = "-" if r.m4f_double_symbols is None else str(r.m4f_double_symbols)
        cyc = "-" if r.m4f_cycles_estimate is None else f"{r.m4f_cycles_estimate:.0f}"
        out.append(f"| {r.precision} | {r.implementation} | {r.instructions_per_step:.0f} | {r.ns_per_step:.1f} | {flash} | "
                   f"{code} | {dbl} | {cyc} |")
    by = {(r.precision, r.implementation): r for r in rows}
    for p in ("double", "single"):
        ours, theirs = by.get((p, "dobwind")), by.get((p, "casadi generate()"))
        if ours and theirs:
            ratio = f"{p}: instructions ratio {ours.instructions_per_step / theirs.instructions_per_step:.2f}"
            if ours.m4f_flash_bytes and theirs.m4f_flash_bytes:
                ratio += f", flash ratio {ours.m4f_flash_bytes / theirs.m4f_flash_bytes:.2f}"
            out.append(f"\n{ratio}")
    ours = by.get(("single", "dobwind"))
    for label, _ in HANDWRITTEN_VARIANTS:
        limit = by.get(("single", label))
        if ours and limit:
            ratio = f"single: {ours.instructions_per_step / limit.instructions_per_step:.2f}x the {label} in instructions"
            if ours.m4f_flash_bytes and limit.m4f_flash_bytes:
                ratio += f", {ours.m4f_flash_bytes / limit.m4f_flash_bytes:.2f}x in firmware flash"
            out.append(f"\n{ratio}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench")
    parser.add_argument("airframe", nargs="*", default=list(DEFAULT_AIRFRAMES),
                        help="airframe files (default: one of each family: m300's polynomial and a drag-body fit)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    if not shutil.which("valgrind"):
        sys.stderr.write("bench: valgrind is needed (apt-get install valgrind)\n")
        return 2
    tables = [bench(path) for path in args.airframe]
    if args.json:
        print(json.dumps([asdict(r) for rows in tables for r in rows], indent=2))
    else:
        print("\n\n".join(table(rows) for rows in tables))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
