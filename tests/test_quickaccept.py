"""The quick acceptance test (model/step.py, _quick_accept): the C runs it first and computes the exact
status bits only for a sample it refuses, so it must never accept a sample the exact tests reject.

Checked on the CasADi validate stage itself (the C prints it; the generated self-test and verify check
the C against the reference at every limit), for every acceleration mode and thrust source, on a clean
flight and on each input element set in turn to NaN, the infinities, the input limit and its neighbours,
zeros of both signs, subnormals and out-of-range values. Then the printer's part: a sum of squares is one
bit-pattern interval, -0 leaves only a sufficient test, and a sufficient test must be monotone."""
from __future__ import annotations

import re

import casadi as ca
import numpy as np
import pytest

from dobwind.codegen.generate import generate_code
from dobwind.codegen.printer import CPrinter
from dobwind.codegen.sections import _integer_section
from dobwind.model import step as step_module
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.exercise import flight_inputs
from dobwind.model.step import Stage, StepModel, build_step
from tests.helpers import M300, airframe_dict, all_modes, collective

# Every value a glitching log or a unit error puts in one element, and the neighbours of every limit the
# validation tests (the input limit 1e6, the ground speed, the 10 g acceleration, 1.5 max_rpm, zero).
SPECIALS = (np.nan, -np.nan, np.inf, -np.inf, 1e6, np.nextafter(1e6, 2e6), -np.nextafter(1e6, 2e6), -1e6, 0.0, -0.0,
            1e-40, -1e-40, 1e30, -1e30, -1.0, 150.0, 150.001, 98.0, 98.1, 18000.0, 18000.01, 3e4, 2e3)


def _modes() -> list:
    docs = {doc["name"]: doc for doc in all_modes()}
    keep = ("mode_paper_ned_rpm", "mode_euler_specific_force_rpm", "mode_zoh_velocity_collective",
            "mode_tustin_ned_collective")
    return [M300] + [docs[name] for name in docs if name.startswith(keep)]


def _model(mode) -> StepModel:
    return build_step(load_airframe(mode) if not isinstance(mode, dict) else parse_airframe(dumps(mode), "<test>"))


def _adversarial(model: StepModel) -> np.ndarray:
    clean = flight_inputs(model, 300, seed=3, bad_every=0)
    rows = [clean]
    for column in range(clean.shape[1]):
        bad = np.repeat(clean[column * 7 % len(clean)][None, :], len(SPECIALS), axis=0)
        bad[:, column] = SPECIALS
        rows.append(bad)
    return np.vstack(rows)


def _validate(model: StepModel, inputs: np.ndarray) -> dict[str, np.ndarray]:
    stage = model.validate
    mapped = stage.function.map(inputs.shape[0])
    args = [inputs[:, model.inputs.slice(name.split(".", 1)[1])].T for name in stage.inputs]
    return {name: np.asarray(value).ravel() for name, value in zip(stage.outputs, mapped(*args))}


def _wrongly_accepted(model: StepModel, inputs: np.ndarray) -> int:
    out = _validate(model, inputs)
    return int(np.sum((out["quick_accept"] > 0) & (out["status"] != 0)))


@pytest.mark.parametrize("mode", _modes(), ids=lambda m: getattr(m, "stem", None) or m["name"])
def test_the_quick_test_never_accepts_what_the_exact_tests_reject(mode):
    model = _model(mode)
    inputs = _adversarial(model)
    out = _validate(model, inputs)
    assert _wrongly_accepted(model, inputs) == 0
    assert np.all(out["quick_accept"][:300] > 0)  # and it accepts a whole clean flight: the path it saves
    assert np.sum(out["status"][300:] != 0) > inputs.shape[1] * 5  # the adversarial rows do reach the limits


@pytest.mark.parametrize("doc", [airframe_dict(**{"name": "fast_rotors", "thrust.max_rpm": 9e5}),
                                 collective(airframe_dict(**{"name": "heavy", "mass": 9000.0}))], ids=lambda d: d["name"])
def test_a_bound_beyond_the_input_limit_leaves_its_input_to_the_finiteness_test(doc):
    """1.5 max_rpm = 1.35e6 rpm, or 20 weights of a 9 t airframe (1.8e6 N), lie beyond |x| <= 1e6: 0 <= x <=
    bound then does not imply NONFINITE's test, so the quick test must keep it for that input (``held``)."""
    model = _model(doc)
    assert _wrongly_accepted(model, _adversarial(model)) == 0


def test_a_quick_test_without_yaws_finiteness_is_caught(monkeypatch):
    """The check can fail: yaw_ref is the one input no bound holds; without its own test, a NaN heading
    passes the quick test."""
    exact = step_module.finite_inputs
    monkeypatch.setattr(step_module, "finite_inputs", lambda x: ca.SX(1) if x.numel() == 1 else exact(x))
    model = build_step(load_airframe(M300))
    assert _wrongly_accepted(model, _adversarial(model)) > 0


def test_a_looser_bound_in_the_quick_test_is_caught(monkeypatch):
    from dobwind.model import plausibility

    bounds = plausibility.input_bounds
    monkeypatch.setattr(step_module, "input_bounds", lambda *a: tuple(
        plausibility.InputBound(b.field, b.limit * 1.1, b.norm) for b in bounds(*a)))
    model = build_step(load_airframe(M300))
    assert _wrongly_accepted(model, _adversarial(model)) > 0


def _quick_lines(precision: str) -> str:
    source = generate_code(load_airframe(M300), precision).files["m300_wind.c"]
    return source[source.index("int quick_accept;"):source.index("if (!quick_accept) {")]


@pytest.mark.parametrize("precision", ["single", "double"])
def test_the_quick_test_is_one_comparison_per_bound_and_no_loop(precision):
    """Sums of squares are never negative (codegen/sections.py, nonnegative): |v|^2 <= 150^2 is one unsigned
    comparison; a rotor's 0 <= rpm <= 1.5 max_rpm is one too, -0 left to the exact tests."""
    quick = _quick_lines(precision)
    lit = "f" if precision == "single" else ""
    assert quick.count(f"<= m300_wind_bits(22500.0{lit})") == 1
    for rotor in range(4):
        assert quick.count(f"m300_wind_bits(in->rotor_rpm[{rotor}]) <= m300_wind_bits(18000.0{lit})") == 1
    assert "||" not in quick and "for (" not in quick and "0x80000000" not in quick.lower()
    assert quick.count("fabs") == 1  # yaw_ref's own finiteness test


@pytest.mark.parametrize("precision", ["single", "double"])
def test_the_exact_tests_read_the_quick_tests_values(precision):
    """|q|^2, the tilt's terms, |v|^2 and |a|^2 are computed once, in the quick test, and the exact tests
    compare those very values: two copies of a sum may be reassociated differently under PX4's
    -funsafe-math-optimizations (clang's m300 double step, fed |q|^2 within an ulp of 1.21, accepted rows in
    its quick test that the same C's exact tests, compiled without it, rejected), and then the quick test
    would no longer imply the exact ones."""
    source = generate_code(load_airframe(M300), precision).files["m300_wind.c"]
    quick, exact = source[source.index("int quick_accept;"):].split("if (!quick_accept) {", 1)
    exact = exact[:exact.index("---- attitude:")]
    real = "float" if precision == "single" else "double"
    defined = re.compile(rf"const {real} [at]\d+ = (.+);")
    computed = set(defined.findall(quick))
    assert "in->q[0] * in->q[0]" in computed  # the quaternion's squares are the quick test's
    assert not computed & set(defined.findall(exact))
    assert re.search(r"m300_wind_bits\(a\d+\), m300_wind_bits\(0\.81", exact)  # |q|^2 read, not recomputed


def _stage(expression) -> tuple[Stage, dict[str, int]]:
    x, y = ca.SX.sym("in_x"), ca.SX.sym("in_y")
    function = ca.Function("validate", [x, y], [expression(x, y)], ["in_x", "in_y"], ["quick_accept"])
    return Stage("validate", "test", function, ("in.x", "in.y"), ("quick_accept",)), {"in.x": 1, "in.y": 1, "quick_accept": 1}


NEVER_NEGATIVE = {"x*x + y*y": lambda x, y: x * x + y * y, "|x|": lambda x, y: ca.fabs(x),
                  "sqrt(x*x + y*y)": lambda x, y: ca.sqrt(x * x + y * y), "x*x*y*y": lambda x, y: (x * x) * (y * y)}
MAYBE_NEGATIVE = {"x*x - y*y": lambda x, y: x * x - y * y, "x*y": lambda x, y: x * y,
                  "x*x - 1": lambda x, y: x * x - 1, "x*x * -2": lambda x, y: (x * x) * -2.0,
                  "|x| * y": lambda x, y: ca.fabs(x) * y}


@pytest.mark.parametrize("name", [*NEVER_NEGATIVE, *MAYBE_NEGATIVE])
def test_only_a_value_never_negative_loses_the_negative_half_of_its_test(name):
    """e <= 5 holds every negative e: only for an e that is never negative (nonnegative in
    codegen/sections.py) may the printed test be the one comparison of the bits with bits(5)."""
    expression = {**NEVER_NEGATIVE, **MAYBE_NEGATIVE}[name]
    stage, sizes = _stage(lambda x, y: expression(x, y) <= 5)
    printer = CPrinter("single", kernel_prefix="p_", directed_limits=True)
    test = _integer_section(stage, "quick_accept", sizes, printer, "a", False).lines[-2]
    assert ("0x80000000u" not in test) == (name in NEVER_NEGATIVE), test


def test_negative_zero_is_dropped_only_from_a_sufficient_test():
    stage, sizes = _stage(lambda x, y: ca.logic_and(ca.logic_and(0 <= x, x <= 5), y <= 1))
    printer = CPrinter("single", kernel_prefix="p_", directed_limits=True)
    sufficient = "\n".join(_integer_section(stage, "quick_accept", sizes, printer, "a", True).lines)
    exact = "\n".join(_integer_section(stage, "quick_accept", sizes, printer, "a", False).lines)
    assert "p_bits(in->x) <= p_bits(5.0f) &&" in sufficient and "0x80000000u" not in sufficient
    assert "0x80000000u" in exact  # x = -0 passes 0 <= x: the exact test keeps it


def test_a_sufficient_test_must_be_monotone():
    """A negated test would accept -0 where the exact one refuses it: refused as it is printed."""
    stage, sizes = _stage(lambda x, y: ca.logic_not(ca.logic_and(ca.logic_and(0 <= x, x <= 5), y <= 1)))
    printer = CPrinter("single", kernel_prefix="p_", directed_limits=True)
    with pytest.raises(ValueError, match="and/or"):
        _integer_section(stage, "quick_accept", sizes, printer, "a", True)


_JUNCTION_C = """#include <stdint.h>
#include <stdio.h>
#include <string.h>
typedef struct {{ float x; float y; }} in_t;
static uint32_t p_bits(float v) {{ uint32_t u; memcpy(&u, &v, sizeof u); return u; }}
static int p_within(uint32_t u, uint32_t lo, uint32_t hi) {{ return (uint32_t)(u - lo) <= (uint32_t)(hi - lo); }}
static int quick(const in_t *in)
{{
    int quick_accept;
{lines}
    return quick_accept;
}}
int main(void)
{{
    static const float values[] = {{{values}}};
    const int n = (int)(sizeof values / sizeof values[0]);
    int i, j;
    for (i = 0; i < n; ++i) {{
        for (j = 0; j < n; ++j) {{
            in_t in;
            in.x = values[i];
            in.y = values[j];
            putchar('0' + quick(&in));
        }}
    }}
    return 0;
}}
"""


def test_a_sufficient_junction_compiles_to_its_truth_table(tmp_path):
    """The quick test's and/or is printed as one short-circuit expression (codegen/sections.py, junctions):
    an or of ands, with a comparison of two values and a sum of squares among its terms, compiled strictly
    and run over every pair of special values, is the CasADi expression's truth wherever no input is -0,
    and never accepts what it refuses (-0 may only be refused: the exact tests decide it)."""
    import shutil
    import subprocess

    compiler = shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        pytest.fail("no C compiler: the suite's setup installs gcc")
    expression = lambda x, y: ca.logic_or(ca.logic_and(ca.logic_and(x <= 1, x <= y), 0 <= y),  # noqa: E731
                                          ca.logic_and(5 <= x, x * x + y * y <= 100))
    stage, sizes = _stage(expression)
    lines = _integer_section(stage, "quick_accept", sizes, CPrinter("single", kernel_prefix="p_", directed_limits=True),
                             "a", True).lines
    assert any("||" in line for line in lines) and any("&&" in line for line in lines)
    values = np.array(SPECIALS + (0.5, 1.0, 1.5, 5.0, 6.0, 9.9, 10.0, 11.0, -5.0), dtype=np.float32)
    text = _JUNCTION_C.format(lines="\n".join(f"    {line}" for line in lines),
                              values=", ".join("(0.0f / 0.0f)" if np.isnan(v) else
                                               ("(1e30f * 1e30f)" if v > 0 else "(-1e30f * 1e30f)") if np.isinf(v)
                                               else f"{float(v):.9e}f" for v in values))
    (tmp_path / "j.c").write_text(text)
    subprocess.run([compiler, "-std=c99", "-Wall", "-Wextra", "-Werror", "-O2", str(tmp_path / "j.c"),
                    "-o", str(tmp_path / "j")], check=True)
    got = np.array([c == "1" for c in subprocess.run([str(tmp_path / "j")], capture_output=True, text=True,
                                                     check=True).stdout]).reshape(len(values), len(values))
    f = stage.function
    truth = np.array([[bool(float(f(float(x), float(y)))) for y in values] for x in values])
    negative_zero = np.signbit(values) & (values == 0)
    plain = ~negative_zero[:, None] & ~negative_zero[None, :]
    assert np.array_equal(got[plain], truth[plain])
    assert not np.any(got & ~truth)
    assert got.sum() > 10 and (~got).sum() > 10  # both outcomes occur
