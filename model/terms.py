"""The force-air term grammar (docs/formats.md, airframe) parsed into CasADi expressions.

A term is ``"1"`` or factors joined by ``*``; a factor is a variable or ``variable^p`` with p any real
number. Variables: ``m``, ``n`` (heading-frame x and y force, N), ``fh`` = hypot(m, n), ``fz``
(heading-frame z force, down, N) and ``abs(v)`` of any of them.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import casadi as ca

VARIABLES = ("m", "n", "fh", "fz")
NONNEGATIVE = frozenset({"fh"})
# A negative power of a force that can be zero would divide by zero; the base is floored here (N).
NEGATIVE_POWER_FLOOR = 1e-3

# Matched with fullmatch: "$" would also match before a trailing newline ("m\n").
_FACTOR = re.compile(
    r"(?:(?P<abs>abs\((?P<avar>[a-z]+)\))|(?P<var>[a-z]+))(?:\^(?P<pow>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?))?"
)


class TermError(ValueError):
    """A term that does not parse; the message says why."""


@dataclass(frozen=True)
class Factor:
    variable: str
    absolute: bool
    power: float

    @property
    def nonnegative(self) -> bool:
        return self.absolute or self.variable in NONNEGATIVE


@dataclass(frozen=True)
class Term:
    text: str
    factors: tuple[Factor, ...]  # empty for the constant term "1"

    @property
    def variables(self) -> frozenset[str]:
        return frozenset(f.variable for f in self.factors)


def parse_term(text: str) -> Term:
    source = text.replace(" ", "")
    if source == "1":
        return Term(text, ())
    if not source:
        raise TermError("empty term")
    factors = []
    for part in source.split("*"):
        match = _FACTOR.fullmatch(part)
        if match is None:
            raise TermError(f"cannot parse factor '{part}' (expected v, v^p or abs(v)^p)")
        variable = match.group("avar") or match.group("var")
        if variable not in VARIABLES:
            raise TermError(f"unknown variable '{variable}' (expected one of {', '.join(VARIABLES)})")
        power = float(match.group("pow")) if match.group("pow") is not None else 1.0
        if not math.isfinite(power):
            raise TermError(f"power of '{part}' is not finite")
        factor = Factor(variable, match.group("abs") is not None, power)
        if not power.is_integer() and not factor.nonnegative:
            raise TermError(
                f"fractional power of signed '{variable}' would be NaN for negative values; "
                f"write abs({variable})^{match.group('pow')}"
            )
        factors.append(factor)
    return Term(text, tuple(factors))


def base_powers(term: Term) -> dict[str, float]:
    """The summed power of each variable in a term (``abs(v)`` and ``v`` alike: same magnitude)."""
    powers = dict.fromkeys(VARIABLES, 0.0)
    for factor in term.factors:
        powers[factor.variable] += factor.power
    return powers


def range_problem(term: Term, max_power: float, max_degree: float) -> str | None:
    """Why a term cannot be a force-air term, or None. Beyond the size of its powers, a term must
    stay bounded as the forces go to zero (hover): m^-2 would give c * 1e6 m/s at the 1e-3 N floor,
    an airflow set by the floor and not by the physics. Since |m|, |n| <= fh, the horizontal
    variables together (their summed power) must not be negative either: m^2*fh^-1.5 is bounded."""
    for factor in term.factors:
        if factor.power == 0.0 or abs(factor.power) > max_power:
            return f"power {factor.power:g} of '{factor.variable}' must be nonzero with |p| <= {max_power:g}"
    if sum(abs(f.power) for f in term.factors) > max_degree:
        return f"the powers' magnitudes add up to more than {max_degree:g}"
    powers = base_powers(term)
    for variable in ("m", "n", "fz"):
        if powers[variable] < 0.0:
            return (f"grows without bound as {variable} goes to 0 (summed power {powers[variable]:g}); "
                    f"only the {NEGATIVE_POWER_FLOOR:g} N floor would limit it")
    horizontal = powers["m"] + powers["n"] + powers["fh"]
    if horizontal < 0.0:
        return (f"grows without bound as the horizontal force goes to 0 (summed power of m, n, fh "
                f"{horizontal:g}); only the {NEGATIVE_POWER_FLOOR:g} N floor would limit it")
    return None


def single_precision_problem(term: Term) -> str | None:
    """Why a term cannot be evaluated in single precision to the verify tolerance, or None.

    A variable whose summed power lies in (0, 1) has an unbounded slope at 0; alone (fh^0.5) its
    error stays below eps^p, but times another variable (abs(m)^0.5*n^3) the float force's absolute
    error of about 1e-6 N is amplified without bound as that variable crosses 0 in flight."""
    powers = base_powers(term)
    groups = {"m": powers["m"], "n": powers["n"], "fz": powers["fz"],
              "the horizontal force": powers["m"] + powers["n"] + powers["fh"]}
    for name, power in groups.items():
        others = [v for v in VARIABLES if powers[v] != 0.0 and
                  (v not in ("m", "n", "fh") if name == "the horizontal force" else v != name)]
        if 0.0 < power < 1.0 and others:
            return (f"its slope in {name} (summed power {power:g}) is unbounded at 0 while it is multiplied "
                    f"by {', '.join(others)}: a float cannot follow the double reference there "
                    "(use --precision double)")
    return None


def _factor_expr(factor: Factor, value: ca.SX) -> ca.SX:
    base = ca.fabs(value) if factor.absolute else value
    p = factor.power
    if p == 1.0:
        return base
    if p == 2.0:
        return base * base
    if p < 0.0:
        floored = ca.fmax(ca.fabs(base), NEGATIVE_POWER_FLOOR)
        base = floored if factor.nonnegative else ca.if_else(base >= 0, floored, -floored)
    if p.is_integer():
        return ca.constpow(base, p)
    if p == 0.5:
        return ca.sqrt(base)
    return ca.constpow(base, p)


def term_expr(term: Term, variables: dict[str, ca.SX]) -> ca.SX:
    expr: ca.SX = ca.SX(1.0)
    for factor in term.factors:
        expr = expr * _factor_expr(factor, variables[factor.variable])
    return expr


def polynomial_expr(terms: tuple[Term, ...], coefficients: tuple[float, ...], variables: dict[str, ca.SX]) -> ca.SX:
    """sum_k c_k term_k(variables); zero coefficients are dropped so generated code stays small."""
    total: ca.SX = ca.SX(0.0)
    for term, coefficient in zip(terms, coefficients):
        if coefficient != 0.0:
            total = total + coefficient * term_expr(term, variables)
    return total
