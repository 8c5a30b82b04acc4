"""The generated C under the autopilots' own compile flags (harness/flagsets.py, issue #32): zero
warnings with every toolchain at hand, the self-test passing when built with the flags, and the math
kernels and rejection tests keeping their accuracy where -funsafe-math-optimizations reassociates and
flushes subnormals to zero."""
from __future__ import annotations

import math
import subprocess

import numpy as np
import pytest

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import run
from dobwind.harness.flagsets import FLAG_SETS, available_toolchains, build_selftest, compile_c
from dobwind.model.airframe import load_airframe
from tests.helpers import M300

# ArduPilot's -fsingle-precision-constant makes every unsuffixed literal a float: its builds are single
# precision (the double-precision C is for hosts, and PX4's set keeps double literals double).
CASES = [("px4", "single"), ("px4", "double"), ("ardupilot", "single")]


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    af = load_airframe(M300)
    folders = {}
    for precision in ("single", "double"):
        folder = tmp_path_factory.mktemp(f"gen-{precision}")
        write_files(generate_code(af, precision).files, folder)
        folders[precision] = folder
    return folders


@pytest.mark.parametrize("flags, precision", CASES)
def test_zero_warnings_with_each_toolchain_in_c_and_cxx(generated, tmp_path, flags, precision):
    folder = generated[precision]
    sources = [folder / "m300_wind.c", folder / "m300_wind_selftest.c"]
    labels = []
    for toolchain in available_toolchains():
        for cxx in (False, True):
            compile_c(toolchain, FLAG_SETS[flags], sources, tmp_path, cxx)  # -Werror: raises on a warning
        labels.append(toolchain.label)
    assert "gcc" in labels


@pytest.mark.parametrize("flags, precision", CASES)
def test_the_self_test_passes_when_built_with_the_flags(generated, tmp_path, flags, precision):
    for toolchain in [t for t in available_toolchains() if t.hosted]:
        exe = build_selftest(toolchain, FLAG_SETS[flags], generated[precision], "m300", tmp_path)
        done = subprocess.run([str(exe)], capture_output=True, text=True)
        assert done.returncode == 0 and "PASS" in done.stdout, (toolchain.label, done.stdout[-2000:])


_PROBE = r"""
#include <stdio.h>
#include <stdlib.h>
#include "m300_wind.c"
int main(void)
{
    char line[128];
    while (fgets(line, sizeof line, stdin)) {
        const float x = strtof(line, NULL);
        const m300_wind_sincos_t sc = m300_wind_sincos(x);
        printf("%.9g %.9g %.9g\n", (double)sc.s, (double)sc.c, (double)m300_wind_expm1(x));
    }
    return 0;
}
"""


def test_kernels_keep_their_accuracy_under_px4_flags(generated, tmp_path):
    """The rounding of x 2/pi and x/ln2 to an integer must survive reassociation: with the old
    (y + 1.5*2^23) - 1.5*2^23, -funsafe-math-optimizations folded it and sin/cos erred by 1e-4."""
    (tmp_path / "probe.c").write_text(_PROBE)
    flags = [f for f in FLAG_SETS["px4"].c if f not in ("-Werror", "-Wfatal-errors")]
    exe = tmp_path / "probe"
    run(["gcc", *flags, f"-I{generated['single']}", str(tmp_path / "probe.c"), "-o", str(exe), "-lm"])
    rng = np.random.default_rng(3)
    x = np.r_[rng.uniform(-4 * math.pi, 4 * math.pi, 3000), rng.uniform(-1e4, 1e4, 500),
              rng.uniform(-87, 88, 500)].astype(np.float32).astype(float)
    done = subprocess.run([str(exe)], input="\n".join(repr(float(v)) for v in x) + "\n", capture_output=True,
                          text=True, check=True)
    got = np.loadtxt(done.stdout.splitlines(), ndmin=2)
    small = np.abs(x) <= 4 * math.pi + 1e-6
    assert np.max(np.abs(got[small, 0] - np.sin(x[small]))) < 3e-7
    assert np.max(np.abs(got[small, 1] - np.cos(x[small]))) < 3e-7
    # Beyond, the error grows with the argument's own ulp (float x carries |x| * 6e-8 of rounding).
    assert np.max(np.abs(got[:, 0] - np.sin(x)) / np.maximum(1.0, np.abs(x) * 6e-8)) < 2e-6
    expm1_range = np.abs(x) <= 87
    exact = np.expm1(x[expm1_range])
    # 4e-7: two float ulps (measured 2.3e-7; 7.8e-8 without the flags): reassociation may regroup
    # 2^k (expm1(r) + 1) - 1, which costs at most an ulp, not the reduction's k * 4e-8
    assert np.max(np.abs(got[expm1_range, 2] - exact) / np.maximum(np.abs(exact), 1e-30)) < 4e-7


def _limit_status(tmp_path, precision: str, bits: int) -> int:
    """The status of one step with rotor 1's rpm given by its IEEE 754 bits, built with PX4's flags
    (FTZ/DAZ on x86: even converting a double to a subnormal float would flush it, hence the bits)."""
    probe = r"""
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "m300_wind.h"
int main(int argc, char **argv)
{
    m300_wind_state_t state;
    m300_wind_input_t in;
    m300_wind_output_t out;
    const BITS bits = (BITS)strtoull(argv[1], NULL, 16);
    (void)argc;
    memset(&in, 0, sizeof in);
    m300_wind_init(&state);
    in.dt = (REAL)0.01;
    in.q[0] = (REAL)1;
    memcpy(&in.rotor_rpm[0], &bits, sizeof bits);
    printf("%d\n", m300_wind_step(&state, &in, &out));
    return 0;
}
"""
    real, ctype = ("float", "unsigned int") if precision == "single" else ("double", "unsigned long long")
    folder = tmp_path / precision
    folder.mkdir(exist_ok=True)
    write_files(generate_code(load_airframe(M300), precision).files, folder)
    (folder / "probe.c").write_text(probe.replace("REAL", real).replace("BITS", ctype))
    exe = folder / "probe"
    run(["gcc", *FLAG_SETS["px4"].c, f"-I{folder}", str(folder / "probe.c"), str(folder / "m300_wind.c"),
         "-o", str(exe), "-lm"])
    return int(subprocess.run([str(exe), f"{bits:x}"], capture_output=True, text=True, check=True).stdout)


@pytest.mark.parametrize("precision, sign", [("single", 1 << 31), ("double", 1 << 63)])
def test_a_negative_subnormal_rpm_is_rejected_under_flush_to_zero(tmp_path, precision, sign):
    """-funsafe-math-optimizations links crtfastmath (FTZ/DAZ): a float comparison sees the smallest
    negative subnormal as 0 and `0 <= rpm` would pass it; -0 passes as IEEE says, +subnormal too."""
    assert _limit_status(tmp_path, precision, sign | 1) & 0x10  # BAD_THRUST
    assert not _limit_status(tmp_path, precision, sign) & 0x10  # -0
    assert not _limit_status(tmp_path, precision, 1) & 0x10
