"""The mutation suite's machinery, end to end on a few mutants (the whole suite is `make mutants`):
a mutant is applied where its anchor says, the checks catch it, and an anchor that does not match
stops the run instead of counting as caught."""
from __future__ import annotations

import pytest

from dobwind.codegen.generate import generate_code
from dobwind.harness.verify import ReferenceChecks
from tools.mutant_table import CMutant, ModelMutant, c_mutants, model_mutants
from tools.mutants import AnchorError, Outcome, apply_c_mutant, check_c, run_model_mutant, table
from dobwind.model.airframe import load_airframe
from dobwind.model.step import build_step
from tests.helpers import M300


@pytest.fixture(scope="module")
def model():
    return build_step(load_airframe(M300))


@pytest.fixture(scope="module")
def code(model) -> dict[str, dict[str, str]]:
    """The generated files in each precision, made once for the module (about a second each; every test
    below mutates its own copy of the text, never these)."""
    return {precision: generate_code(model.airframe, precision, model).files for precision in ("single", "double")}


@pytest.fixture(scope="module")
def references(model) -> dict[str, ReferenceChecks]:
    """The reference's answers to verify's cases in each precision, once for the module: `make mutants`
    shares one per precision across its whole table in the same way (tools/mutants.run_c_mutants)."""
    return {precision: ReferenceChecks.build(model, precision, 300, 1) for precision in ("single", "double")}


def _mutant(model, name: str) -> CMutant:
    return next(m for m in c_mutants(model.airframe) if m.name == name)


# One mutant of each kind issue #10 names for the generated C, in both precisions (`make mutants` runs
# the whole table): a constant, an operator, a NaN output, an early return before the state commit and
# dropped validation tests. Each must be caught by the generated self-test AND by verify's cases, so
# neither check can quietly lose its teeth.
C_KINDS = ["m*g x1.001", "dt upper bound <= becomes <", "NaN wind_from_deg output",
           "early return before the state commit", "finiteness loop skips the last input", "rpm check on rotor 2 dropped"]


@pytest.mark.parametrize("precision", ["single", "double"])
@pytest.mark.parametrize("name", C_KINDS)
def test_a_c_mutant_is_caught_by_verify_and_the_self_test(model, code, references, tmp_path, name, precision):
    files = code[precision]
    source = "m300_wind.c"
    mutated = apply_c_mutant(files[source], _mutant(model, name), precision, "m300_wind_")
    assert mutated != files[source]
    found = check_c(model, dict(files, **{source: mutated}), precision, 300, tmp_path, "mutant", references[precision])
    assert "self-test" in found and "verify cases" in found, found


def test_the_unmutated_c_passes_the_same_checks(model, code, references, tmp_path):
    """The other half of the tests above: the checks do not simply fail on everything."""
    for precision in ("single", "double"):
        files = code[precision]
        assert check_c(model, files, precision, 300, tmp_path, f"clean-{precision}", references[precision]) == ()


# The model mutants issue #10 names: verify cannot see them (the C and the reference change together),
# so the suite's independent transcription of the step must.
MODEL_KINDS = ["gravity sign", "observer factor 2 (paper)", "quaternion order (x, y, z, w)", "heading-frame sign"]


@pytest.mark.parametrize("name", MODEL_KINDS)
def test_the_named_model_mutants_are_caught_by_the_suite(tmp_path, name):
    mutant = next(m for m in model_mutants() if m.name == name)
    outcome = run_model_mutant(mutant, tmp_path, ("tests/test_model.py::test_step_matches_independent_transcription",))
    assert outcome.caught_by == ("test test_step_matches_independent_transcription",), outcome


def test_an_anchor_that_does_not_match_stops_the_run(code):
    text = code["single"]["m300_wind.c"]
    with pytest.raises(AnchorError, match="matched 0 times"):
        apply_c_mutant(text, CMutant("no such code", "validate", r"in->no_such_input", "x"), "single", "m300_wind_")
    with pytest.raises(AnchorError, match="region 'no_such_section'"):
        apply_c_mutant(text, CMutant("no such region", "no_such_section", "x", "y"), "single", "m300_wind_")
    with pytest.raises(AnchorError, match="matched 3 times"):  # m*g's literal appears once, the mass thrice
        apply_c_mutant(text, CMutant("ambiguous", "external_force", near=8.0, scale=2.0), "single", "m300_wind_")


def test_a_model_mutant_is_applied_and_caught_by_the_pinned_tests(tmp_path):
    mutant = ModelMutant("MIN_DT_S 1e-5 -> 1e-4", "dobwind.model.status", "MIN_DT_S = 1e-5", "MIN_DT_S = 1e-4")
    outcome = run_model_mutant(mutant, tmp_path, ("tests/test_limits_pinned.py::test_dt_lower_limit_is_1e_5_s",))
    assert outcome.caught_by == ("test test_dt_lower_limit_is_1e_5_s",)
    missing = ModelMutant("absent", "dobwind.model.status", "NO_SUCH_TEXT = 1", "NO_SUCH_TEXT = 2")
    with pytest.raises(AnchorError, match="found 0 times"):
        run_model_mutant(missing, tmp_path, ("tests/test_limits_pinned.py",))


def test_the_table_counts_survivors():
    text = table([Outcome("a", "C single: validate", ("self-test",)), Outcome("b", "model: status", ())])
    assert "SURVIVED" in text.splitlines()[3]
    assert text.splitlines()[-1] == "caught 1/2: 1 survived (a missing test)"
