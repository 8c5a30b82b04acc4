"""codegen/bitranges.py against numpy's IEEE 754 comparisons: the pattern sets must hold exactly the
floats (NaN, both zeros, subnormals and infinities included) for which the comparison is true, and
combine (and, or, not) exactly."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.codegen import bitranges
from dobwind.model.kinds import Precision

SINGLE = bitranges.fmt(Precision.SINGLE)
DOUBLE = bitranges.fmt(Precision.DOUBLE)


def _probe(f: bitranges.Format, constants: list[float]) -> np.ndarray:
    """Every special pattern, both sides of each constant, and random patterns (NaNs of both signs too)."""
    rng = np.random.default_rng(7)
    specials = [0, f.sign, f.inf, f.inf + 1, f.sign | f.inf, (f.sign | f.inf) + 1, f.top, f.sign - 1, 1, f.sign + 1]
    near = [f.pattern(c) + d for c in constants for d in (-2, -1, 0, 1, 2)]
    near += [f.pattern(-c) + d for c in constants for d in (-1, 0, 1)]
    random = rng.integers(0, f.top, size=4000, dtype=np.uint64 if f.bits == 64 else np.uint32, endpoint=True)
    patterns = np.array([p & f.top for p in specials + near] + [int(r) for r in random], dtype=f.utype)
    return patterns


def _member(intervals, patterns) -> np.ndarray:
    return np.array([bitranges.contains(intervals, int(p)) for p in patterns])


CONSTANTS = [0.0, -0.0, 1e-5, 0.1, 22500.0, -3.5, 1e30, 1.4e-45]


@pytest.mark.parametrize("f", [SINGLE, DOUBLE], ids=["single", "double"])
@pytest.mark.parametrize("c", CONSTANTS)
@pytest.mark.parametrize("left,strict", [(False, False), (False, True), (True, False), (True, True)])
def test_a_comparison_is_the_set_of_patterns_it_holds_for(f, c, left, strict):
    c = float(f.dtype(c))
    patterns = _probe(f, CONSTANTS)
    x = patterns.view(f.dtype)
    with np.errstate(invalid="ignore"):
        want = {(False, False): x <= c, (False, True): x < c, (True, False): c <= x, (True, True): c < x}[(left, strict)]
    got = _member(bitranges.comparison(f, left, strict, c), patterns)
    assert np.array_equal(got, want)
    assert len(bitranges.comparison(f, left, strict, c)) <= 2


@pytest.mark.parametrize("f", [SINGLE, DOUBLE], ids=["single", "double"])
def test_and_or_not_combine_exactly_including_nan(f):
    patterns = _probe(f, CONSTANTS)
    x = patterns.view(f.dtype)
    lo, hi = float(f.dtype(1e-5)), float(f.dtype(0.1))
    above, below = bitranges.comparison(f, True, False, lo), bitranges.comparison(f, False, False, hi)
    both = bitranges.intersection(f, above, below)
    with np.errstate(invalid="ignore"):
        assert np.array_equal(_member(both, patterns), (lo <= x) & (x <= hi))
        assert np.array_equal(_member(bitranges.union(f, above, below), patterns), (lo <= x) | (x <= hi))
        # not: true for NaN, as !(x <= c) is in C
        assert np.array_equal(_member(bitranges.complement(f, both), patterns), ~((lo <= x) & (x <= hi)))
    assert both == ((f.pattern(lo), f.pattern(hi)),)  # one interval: one subtraction and one comparison


def test_a_complement_around_the_top_prints_as_one_wrapped_interval():
    inside = ((SINGLE.pattern(1e-5), SINGLE.pattern(0.1)),)
    outside = bitranges.complement(SINGLE, inside)
    assert len(outside) == 2 and len(bitranges.wrapped(SINGLE, outside)) == 1
    (lo, hi), = bitranges.wrapped(SINGLE, outside)
    assert lo == SINGLE.pattern(0.1) + 1 and hi == SINGLE.pattern(1e-5) - 1


def test_a_mutated_bound_is_caught():
    """The check above can fail: an off-by-one pattern (x <= c taken as x < c) disagrees on c itself."""
    c = 0.1
    wrong = bitranges.comparison(SINGLE, False, True, float(np.float32(c)))
    patterns = np.array([SINGLE.pattern(c)], dtype=np.uint32)
    assert not np.array_equal(_member(wrong, patterns), patterns.view(np.float32) <= np.float32(c))


def test_the_generated_tests_of_one_value_are_one_interval():
    """dt's two bounds are printed as one subtraction and one comparison, with the airframe's limits as
    literals (the float on the safe side of each), and no test is printed twice."""
    from dobwind.codegen.generate import generate_code
    from dobwind.model.airframe import load_airframe
    from tests.helpers import M300

    source = generate_code(load_airframe(M300), "single").files["m300_wind.c"]
    dt = "m300_wind_within(m300_wind_bits(in->dt), m300_wind_bits(1.00000007e-05f), m300_wind_bits(0.100009993f))"
    quick, exact = source[source.index("int quick_accept;"):].split("if (!quick_accept) {", 1)
    exact = exact[:exact.index("---- attitude:")]
    for part in (quick, exact):  # once in the quick test, once in the exact tests
        assert part.count(dt) == 1 and part.count("m300_wind_bits(in->dt)") == 1
