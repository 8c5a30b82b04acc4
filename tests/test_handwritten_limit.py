"""The bench's hand-written limits (benchmarks/handwritten/m300_step.c) compute what the generated step
computes: a yardstick that skipped work would make the generated step look slow. Both variants, host
compiler, against the Python reference (the one without validation on a flight without bad samples)."""
from __future__ import annotations

import subprocess

import numpy as np
import pytest

from benchmarks.bench import HANDWRITTEN_VARIANTS, handwritten_source
from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import run, system_compiler
from dobwind.model import reference
from dobwind.model.airframe import load_airframe
from dobwind.model.exercise import flight_inputs
from dobwind.model.step import build_step
from tests.helpers import M300

ROWS = 400

_DRIVER = """\
#include <stdio.h>
#include "m300_wind.h"
static const float rows[{rows}][{ni}] = {{
{data}
}};
int main(void)
{{
    m300_wind_state_t state;
    m300_wind_input_t in;
    m300_wind_output_t out;
    int k, i;
    m300_wind_init(&state);
    for (k = 0; k < {rows}; ++k) {{
        float *u = (float *)&in;
        int status;
        for (i = 0; i < {ni}; ++i) u[i] = rows[k][i];
        status = m300_wind_step(&state, &in, &out);
        printf("%d %.9g %.9g %.9g %.9g %.9g\\n", status, out.wind_ned[0], out.wind_ned[1], out.wind_ned[2],
               out.wind_speed_h, out.wind_from_deg);
    }}
    return 0;
}}
"""


def _literal(v: float) -> str:
    if np.isnan(v):
        return "(0.0f/0.0f)"
    if np.isinf(v):
        return "(1e30f*1e30f)" if v > 0 else "(-1e30f*1e30f)"
    return f"{float(np.float32(v)):.9e}f"


def _glitched(model, inputs: np.ndarray) -> np.ndarray:
    """0.5 s of -5 m/s^2 on every acceleration axis (model/biasgate.py's glitch), after the check has learnt
    the flight's spread."""
    out = inputs.copy()
    columns = [model.inputs.element_names().index(f"acc_ned[{i}]") for i in range(3)]
    start = ROWS // 2
    out[start:start + int(0.5 / model.airframe.observer.sample_time_s), columns] -= 5.0
    return out


@pytest.mark.parametrize("label,flags", HANDWRITTEN_VARIANTS)
def test_the_hand_written_step_matches_the_reference(tmp_path, label, flags):
    model = build_step(load_airframe(M300))
    inputs = flight_inputs(model, ROWS, seed=3, bad_every=23 if flags else 0)
    if "-DHANDWRITTEN_ACC_CHECK" in flags:
        inputs = _glitched(model, inputs)
    inputs = inputs.astype(np.float32).astype(np.float64)
    write_files(generate_code(model.airframe, "single", model).files, tmp_path)
    data = ",\n".join("{" + ", ".join(_literal(v) for v in row) + "}" for row in inputs)
    driver = tmp_path / "driver.c"
    driver.write_text(_DRIVER.format(rows=ROWS, ni=model.inputs.size, data=data))
    exe = tmp_path / "hw"
    run([system_compiler(), "-std=c99", "-O2", "-fno-math-errno", *flags, f"-I{tmp_path}", str(driver),
         str(handwritten_source("m300")), "-o", str(exe), "-lm"])
    got = np.loadtxt(subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.splitlines())
    want = reference.run(model, inputs)
    names = model.outputs.element_names()
    columns = [names.index(n) for n in ("wind_ned[0]", "wind_ned[1]", "wind_ned[2]", "wind_speed_h")]
    np.testing.assert_array_equal(got[:, 0], want.status)
    np.testing.assert_allclose(got[:, 1:5], want.outputs[:, columns], rtol=1e-4, atol=2e-4)
    if flags:
        assert (got[:, 0] != 0).any()  # the bad samples were there, and rejected with the reference's bits
    if "-DHANDWRITTEN_ACC_CHECK" in flags:
        assert (want.status.astype(int) & 2048).any()  # the glitch tripped the check, as it does by hand
