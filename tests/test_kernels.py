"""The single-precision expm1 and atan2 kernels of the generated C against libm (in double), over each
kernel's whole range, and the M4F cycle table against the Cortex-M4 TRM."""
from __future__ import annotations

import math
import re
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from dobwind.codegen.generate import generate_code
from dobwind.codegen.kernels import fit_atan, fit_expm1
from dobwind.harness.build import run
from benchmarks.m4cycles import Instruction, cost
from dobwind.model.airframe import load_airframe
from tests.helpers import M300

_PROBE = r"""
#include <stdio.h>
#include <stdlib.h>
#include "m300_wind.c"
int main(int argc, char **argv)
{
    char line[256];
    (void)argc; (void)argv;
    while (fgets(line, sizeof line, stdin)) {
        char *end;
        float a = strtof(line, &end);
        float b = strtof(end, NULL);
        printf("%.9g %.9g\n", (double)m300_wind_expm1(a), (double)m300_wind_atan2(a, b));
    }
    return 0;
}
"""


@pytest.fixture(scope="module")
def probe(tmp_path_factory):
    work = tmp_path_factory.mktemp("kernels")
    # `make mutants` points this at a mutated copy of the generated C (tools/mutants.py).
    given = os.environ.get("DOBWIND_KERNEL_C_DIR")
    files = ({p.name: p.read_text() for p in Path(given).glob("m300_wind*")} if given
             else generate_code(load_airframe(M300), "single").files)
    for name, text in files.items():
        (work / name).write_text(text)
    (work / "probe.c").write_text(_PROBE)
    exe = work / "probe"
    run(["cc", "-std=c99", "-O2", f"-I{work}", str(work / "probe.c"), "-o", str(exe), "-lm"])

    def evaluate(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a, b = a.astype(np.float32), b.astype(np.float32)
        text = "\n".join(f"{x!r} {y!r}" for x, y in zip(a.astype(float).tolist(), b.astype(float).tolist())) + "\n"
        done = subprocess.run([str(exe)], input=text, capture_output=True, text=True, check=True)
        out = np.loadtxt(done.stdout.splitlines(), ndmin=2)
        return out[:, 0], out[:, 1]

    return evaluate


def test_expm1_kernel_matches_libm_over_its_whole_range(probe):
    rng = np.random.default_rng(1)
    # The polynomial's interval, its edges, the reduced range out to the clamp, and the step's own
    # arguments (-dt/20, -2 pi fc dt): tiny negatives.
    x = np.r_[np.linspace(-0.35, 0.35, 2001), rng.uniform(-87, 88, 2000), -np.logspace(-9, 0, 400),
              [0.0, -0.346573591, 0.346573591, -0.3465736, 0.3465736, -87.0, 88.0, -30.0, 1.0]]
    got, _ = probe(x, np.ones_like(x))
    exact = np.expm1(x.astype(np.float32).astype(float))
    relative = np.abs(got - exact) / np.maximum(np.abs(exact), 1e-30)
    assert np.max(relative) < 2e-7  # measured 7.8e-8: about one float ulp
    assert probe(np.array([-200.0, float("nan")]), np.ones(2))[0][0] == pytest.approx(-1.0)


def test_atan2_kernel_matches_libm_in_every_octant(probe):
    rng = np.random.default_rng(2)
    angle = rng.uniform(-math.pi, math.pi, 4000)
    radius = 10 ** rng.uniform(-6, 6, 4000)
    y, x = radius * np.sin(angle), radius * np.cos(angle)
    axes = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, -1.0], [-1.0, 0.0], [1.0, 1.0], [-1.0, -1.0], [1e-30, -1.0]])
    y, x = np.r_[y, axes[:, 0]], np.r_[x, axes[:, 1]]
    _, got = probe(y, x)
    exact = np.arctan2(y.astype(np.float32).astype(float), x.astype(np.float32).astype(float))
    error = np.abs(np.angle(np.exp(1j * (got - exact))))  # across the +-pi seam
    assert np.max(error) < 4e-7  # radians (2.3e-5 deg); measured 3.0e-7, float pi rounding included
    assert probe(np.array([0.0]), np.array([0.0]))[1][0] == 0.0  # not 0/0


def test_the_frozen_coefficients_are_a_near_minimax_fit():
    """Re-deriving gives the frozen polynomials' accuracy (not their digits, which depend on the BLAS)."""
    assert fit_atan().max_error < 1e-7
    assert fit_expm1().max_error < 3e-8


@pytest.mark.parametrize("mnemonic, operands, previous, cycles", [
    ("vdiv.f32", "s0, s1, s2", None, 14),        # TRM table 7-1: VDIV 14
    ("vsqrt.f32", "s0, s0", None, 14),           # VSQRT 14
    ("vmla.f32", "s0, s1, s2", None, 3),         # VMLA 3
    ("vadd.f32", "s0, s1, s2", None, 1),
    ("push", "{r4, r5, r6, r7, lr}", None, 6),   # 1 + N
    ("vpush", "{s16-s21}", None, 7),             # 1 + N
    ("ldr", "r3, [r0, #4]", None, 2),            # LDR 2
    ("ldr", "r3, [r0, #8]", ("str", "r2, [r1]"), 1),  # pipelined after a load or store
    ("sdiv", "r0, r1, r2", None, 7),             # 2-12, charged 7
])
def test_m4f_cycle_table_follows_the_trm(mnemonic, operands, previous, cycles):
    prev = Instruction(4, *previous) if previous else None
    assert cost(Instruction(4, mnemonic, operands), prev) == cycles


def test_single_precision_step_uses_the_kernels_and_shares_divisions():
    """The printer's single-precision rewrites; double keeps libm and every division (bit-identical)."""
    af = load_airframe(M300)
    single = generate_code(af, "single").files["m300_wind.c"]
    double = generate_code(af, "double").files["m300_wind.c"]
    step = single[single.index("int m300_wind_step("):]
    assert step.count("m300_wind_sincos(") == 1  # one reduction for sin and cos of yaw_ref
    assert "expm1f(" not in single and "atan2f(" not in single and "sinf(" not in single
    assert step.count("/ in->dt") == 1 and "1.0f / in->dt" in step  # one reciprocal, then products
    # 1/|q|^2, 1/dt, the airflow scale over sqrt, and the acceleration check's weight dt / (0.1 + dt)
    assert step.count(" / ") == 4
    dstep = double[double.index("int m300_wind_step("):]
    assert dstep.count("/ in->dt") == 3 and "expm1(" in dstep and "atan2(" in dstep


def test_status_bits_are_assembled_as_ints_in_one_pass():
    """Validation computes the status once (issue #32: no second, NaN-exact copy of the tests for the
    rejection path): every bit ORed as an int (no float == under -Wfloat-equal, no int/float conversions),
    every limit test on the bit patterns, and the rejection branch tests that int."""
    for precision in ("single", "double"):
        source = generate_code(load_airframe(M300), precision).files["m300_wind.c"]
        validate = source[source.index("---- validate:"):source.index("---- attitude:")]
        body, reject = validate.split("if (status != 0) {", 1)
        for bit in (1, 2, 4, 8, 16, 2048):  # NONFINITE ... BAD_THRUST, IMPLAUSIBLE
            assert f"? {bit} : 0)" in body, bit
        assert "m300_wind_key" not in source and "return status;" in reject
        assert not re.search(r"\b(in->dt|in->rotor_rpm\[\d\]) (<|<=|>|>=) ", body)  # no float comparison of an input
