"""Generated C against the Python reference: every mode, both precisions, sanitizers, Cortex-M4F."""
from __future__ import annotations

import os
import re
import numpy as np
import pytest

from dobwind.codegen.tolerance import TOLERANCE
from dobwind.harness import cortex
from dobwind.harness.build import build_shared_library
from dobwind.harness.compare import compare
from dobwind.harness.cstep import CStep, compile_step
from dobwind.harness.fuzz import fuzz
from dobwind.harness.verify import reference_cases, verify_airframe
from dobwind.model import reference
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.exercise import flight_inputs, random_cases
from dobwind.model.status import REJECTED_MASK
from dobwind.model.step import build_step
from tests.helpers import M300, airframe_dict, all_modes

MODES = all_modes()


@pytest.mark.parametrize("doc", MODES, ids=[d["name"] for d in MODES])
def test_every_mode_matches_the_reference_in_double(doc, tmp_path):
    """rednose-style: the compiled step and the reference side by side, state carried, every step."""
    model = build_step(parse_airframe(dumps(doc), "<mode>"))
    cstep = compile_step(model, "double", tmp_path)
    states, inputs = random_cases(model, 1500, seed=3)
    cases = compare(model, cstep.cases(states, inputs), reference_cases(model, states, inputs), TOLERANCE["double"])
    flight_rows = flight_inputs(model, 3000, seed=4)
    flight = compare(model, cstep.run(flight_rows), reference.run(model, flight_rows), TOLERANCE["double"])
    assert cases.passed(), cases
    assert flight.passed(), flight
    assert flight.status_mismatches == 0 and cases.status_mismatches == 0


@pytest.mark.parametrize("doc", [MODES[0], MODES[11], MODES[16], MODES[23]], ids=lambda d: d["name"])
def test_single_precision_stays_within_the_documented_bound(doc, tmp_path):
    model = build_step(parse_airframe(dumps(doc), "<mode>"))
    cstep = compile_step(model, "single", tmp_path)
    rows = flight_inputs(model, 20000, seed=5).astype(np.float32).astype(np.float64)
    result = compare(model, cstep.run(rows), reference.run(model, rows), TOLERANCE["single"])
    assert result.passed(), result


def test_verify_command_passes_on_the_reference_airframe():
    report = verify_airframe(load_airframe(M300), "both", steps=5000)
    assert report.passed, report.text()
    assert set(report.precisions[0].compilers) >= {"cc (C99)", "c++ (C++11)"}


def test_verify_can_fail_on_a_wrong_constant(tmp_path):
    """The comparison must catch a one-character error in the generated code."""
    model = build_step(load_airframe(M300))
    from dobwind.codegen.generate import generate_code, write_files
    files = generate_code(model.airframe, "double", model).files
    source = files["m300_wind.c"]
    assert "8.0 * p_ddot[0]" in source
    files["m300_wind.c"] = source.replace("8.0 * p_ddot[0]", "8.001 * p_ddot[0]")
    write_files(files, tmp_path)
    cstep = CStep(model, build_shared_library(model, "double", tmp_path, tmp_path))
    rows = flight_inputs(model, 2000, seed=6)
    result = compare(model, cstep.run(rows), reference.run(model, rows), TOLERANCE["double"])
    assert not result.passed()
    assert max(e.worst_ratio for e in result.outputs if e.name == "force_ned") > 1e3


def test_overflow_is_rejected_in_c_as_in_the_reference(tmp_path):
    # fh^8, the highest degree the loader accepts (|p| <= 4 per factor, 8 in all)
    doc = airframe_dict(**{"force_air.horizontal.terms": ["fh^4*fh^4"], "force_air.horizontal.coefficients": [1.0]})
    model = build_step(parse_airframe(dumps(doc), "<overflow>"))
    cstep = compile_step(model, "double", tmp_path)
    states, inputs = random_cases(model, 400, seed=9)
    # A huge filtered force in the state: fh^8 overflows the 1e30 bound. (An input of 9e5 m/s^2 would be
    # IMPLAUSIBLE before it could overflow anything, issue #37.)
    for name in ("f_obs", "f_filt"):
        states[::2, model.state.slice(name)] = 9e5
    got, ref = cstep.cases(states, inputs), reference_cases(model, states, inputs)
    assert np.any(ref.status == 32)
    np.testing.assert_array_equal(got.status, ref.status)
    rejected = (ref.status & REJECTED_MASK) != 0
    kept = states.copy()
    kept[:, model.state.slice("run_s")] = 0.0  # a rejection records the gap, and changes nothing else
    np.testing.assert_array_equal(got.states[rejected], kept[rejected])


@pytest.mark.parametrize("doc,precision", [(None, "single"), (MODES[22], "double"), (MODES[9], "single")],
                         ids=["m300-single", "tustin-velocity-rpm-double", "zoh-velocity-collective-single"])
def test_adversarial_fuzz_under_sanitizers(doc, precision, tmp_path):
    af = load_airframe(M300) if doc is None else parse_airframe(dumps(doc), "<fuzz>")
    summary = fuzz(build_step(af), precision, tmp_path, iterations=60000)
    assert summary.startswith("PASS"), summary
    rejected = int(re.search(r"(\d+) rejected", summary).group(1))
    assert 1000 < rejected < 60000  # both paths exercised


def _need_cross_compiler():
    if not cortex.available():
        if os.environ.get("CI"):
            pytest.fail("arm-none-eabi-gcc missing in CI (.ci/run installs gcc-arm-none-eabi)")
        pytest.skip("arm-none-eabi-gcc not installed (`.ci/run` installs it)")


@pytest.mark.parametrize("doc", [None, MODES[7], MODES[21]], ids=["m300", "euler-specific-force-collective", "tustin-specific-force-rpm"])
def test_cortex_m4f_build_has_no_double_precision(doc, tmp_path):
    _need_cross_compiler()
    af = load_airframe(M300) if doc is None else parse_airframe(dumps(doc), "<m4>")
    model = build_step(af)
    from dobwind.codegen.generate import generate_code, write_files
    write_files(generate_code(af, "single", model).files, tmp_path)
    build = cortex.check_generated(tmp_path, af.name, model.inputs.fields, tmp_path)
    assert build.double_symbols == ()
    assert 0 < build.object_text_bytes < build.firmware_flash_bytes


def test_cortex_check_detects_double_precision(tmp_path):
    """The nm check must be able to fail: a file calling sin() on a double is caught."""
    _need_cross_compiler()
    source = tmp_path / "bad.c"
    source.write_text("#include <math.h>\nfloat f(float x) { return (float)sin((double)x) * 2.5f; }\n")
    obj = tmp_path / "bad.o"
    from dobwind.harness.build import run
    run([cortex.ARM_GCC, *cortex.CPU_FLAGS, "-Os", "-c", str(source), "-o", str(obj)])
    assert "sin" in cortex.double_precision_symbols(obj)


@pytest.mark.parametrize("doc", [MODES[0], MODES[16]], ids=lambda d: d["name"])
def test_a_sample_rejected_before_the_first_accepted_one_reports_an_unknown_sigma(doc, tmp_path):
    """Before any accepted sample there is no estimate: the repeated initial output's 1-sigma fields are
    -1 (unknown), in the C's init and in the reference alike, never 0 (a perfectly known wind)."""
    model = build_step(parse_airframe(dumps(doc), "<mode>"))
    cstep = compile_step(model, "double", tmp_path)
    rows = flight_inputs(model, 4, seed=6)
    rows[:2, model.inputs.slice("dt")] = np.nan  # NONFINITE: the first two samples are rejected
    for got in (cstep.run(rows), reference.run(model, rows)):
        assert np.all(got.status[:2] & REJECTED_MASK) and not np.any(got.status[2:] & REJECTED_MASK)
        for name in ("wind_sigma_h", "wind_sigma_up"):
            first = got.outputs[:2, model.outputs.slice(name)]
            assert np.all(first == -1.0), (name, first)
        assert np.all(got.outputs[:2, model.outputs.slice("wind_speed_h")] == 0.0)
    assert np.array_equal(cstep.initial_state(), model.initial_state())
