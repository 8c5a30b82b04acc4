"""C printer for CasADi SX instruction streams, one precision per printer.

In single precision every literal carries ``f`` and every math call is the ``f`` variant, so nothing
is promoted to double (checked with -Wdouble-promotion and, on Cortex-M4F, with nm).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import casadi as ca
import numpy as np
from dobwind.model.kinds import Precision

_UNARY_CALLS = {
    ca.OP_EXP: "exp", ca.OP_LOG: "log", ca.OP_SQRT: "sqrt", ca.OP_SIN: "sin", ca.OP_COS: "cos",
    ca.OP_TAN: "tan", ca.OP_ASIN: "asin", ca.OP_ACOS: "acos", ca.OP_ATAN: "atan", ca.OP_FLOOR: "floor",
    ca.OP_CEIL: "ceil", ca.OP_FABS: "fabs", ca.OP_ERF: "erf", ca.OP_SINH: "sinh", ca.OP_COSH: "cosh",
    ca.OP_TANH: "tanh", ca.OP_ASINH: "asinh", ca.OP_ACOSH: "acosh", ca.OP_ATANH: "atanh",
    ca.OP_EXPM1: "expm1", ca.OP_LOG1P: "log1p",
}
_BINARY_CALLS = {
    ca.OP_POW: "pow", ca.OP_FMOD: "fmod", ca.OP_ATAN2: "atan2", ca.OP_COPYSIGN: "copysign", ca.OP_HYPOT: "hypot",
}
_INFIX = {ca.OP_ADD: "+", ca.OP_SUB: "-", ca.OP_MUL: "*", ca.OP_DIV: "/"}
_COMPARE = {ca.OP_LT: "<", ca.OP_LE: "<=", ca.OP_EQ: "==", ca.OP_NE: "!="}
# The expensive operations, counted separately in the op summaries.
# fmin/fmax are printed inline (see CPrinter.operation), so they are not calls.
CALL_OPS = frozenset(_UNARY_CALLS) | frozenset(_BINARY_CALLS) | {ca.OP_CONSTPOW}
# IEEE 754 binary32 limits: the largest finite value and the smallest positive (subnormal) one.
FLT_MAX = 3.4028234663852886e38
FLT_TRUE_MIN = 1.401298464324817e-45


class LiteralError(ValueError):
    """A model constant that has no faithful C literal in the chosen precision."""


def check_literal(value: float, precision: Precision) -> None:
    """Refuse constants the C compiler would turn into inf or 0 (or that are not numbers at all)."""
    if math.isnan(value) or math.isinf(value):
        raise LiteralError(f"non-finite constant {value!r} in the model")
    if precision == Precision.SINGLE and abs(value) > FLT_MAX:
        raise LiteralError(f"constant {value:.9g} is beyond single precision (|x| <= {FLT_MAX:.9g})")
    if precision == Precision.SINGLE and 0.0 < abs(value) < FLT_TRUE_MIN:
        raise LiteralError(f"constant {value:.9g} would round to 0 in single precision (|x| >= {FLT_TRUE_MIN:.9g})")


def directed_float(value: float, up: bool) -> float:
    """The float32 nearest ``value`` on one side: the smallest float >= value (``up``) or the largest
    float <= value."""
    nearest = np.float32(value)
    if up and float(nearest) < value:
        nearest = np.nextafter(nearest, np.float32(np.inf))
    elif not up and float(nearest) > value:
        nearest = np.nextafter(nearest, np.float32(-np.inf))
    return float(nearest)


@dataclass(frozen=True)
class CPrinter:
    precision: Precision
    # In single precision sin/cos, expm1 and atan2 go to small static kernels in the generated file
    # (named <kernel_prefix>sincos, ...expm1, ...atan2) instead of libm's, which handle every argument
    # and cost about 2 KB of flash and hundreds of cycles on a Cortex-M; see codegen/kernels.py. Double
    # precision keeps libm so that it stays bit-identical to the CasADi reference.
    kernel_prefix: str | None = None
    # The rejection tests (validation and the result check): a comparison with a constant is printed as a
    # test of the value's bit pattern (codegen/sections.py _RangeTest, codegen/bitranges.py) with the
    # constant on the safe side (see _compared). Off elsewhere: a constant that also appears in an
    # fmin/fmax (the settling time's cap) must stay the same float in both places.
    directed_limits: bool = False

    @property
    def inline_kernels(self) -> bool:
        return self.precision == Precision.SINGLE and self.kernel_prefix is not None

    @property
    def real(self) -> str:
        return "float" if self.precision == Precision.SINGLE else "double"

    def literal(self, value: float) -> str:
        check_literal(value, self.precision)
        if self.precision == Precision.SINGLE:
            text = f"{value:.9g}"
            suffix = "f"
        else:
            text = repr(float(value))
            suffix = ""
        if "e" not in text and "." not in text and "inf" not in text:
            text += ".0"
        text += suffix
        # Every negative literal, -0.0 included (value < 0 is False for it), goes in parentheses so that
        # a negation printed before it can never make "--0.0f".
        return f"({text})" if math.copysign(1.0, value) < 0 else text

    def _compared(self, args: list[str], bools: list[bool], i: int, op: int,
                  constant_arg: Callable[[int], float | None]) -> str:
        """A comparison operand. A single-precision limit is printed as the float on the safe side of
        the double value, so that a float input decides exactly as the reference does (for
        ``x <= 0.10001`` the largest float <= 0.10001, not the nearest, which lies above it)."""
        value = constant_arg(i)
        if value is None or not self.directed_limits or self.precision != Precision.SINGLE or op not in (ca.OP_LT, ca.OP_LE):
            return f"(({self.real}){args[i]})" if bools[i] else args[i]
        # Constant on the left of <= or on the right of <: round up; otherwise round down.
        up = (i == 0) == (op == ca.OP_LE)
        return self.literal(directed_float(value, up))

    def call(self, name: str, *args: str) -> str:
        suffix = "f" if self.precision == Precision.SINGLE else ""
        return f"{name}{suffix}({', '.join(args)})"

    def zero(self) -> str:
        return self.literal(0.0)

    def one(self) -> str:
        return self.literal(1.0)

    def boolean(self, condition: str) -> str:
        return f"(({self.real})({condition}))"

    def operation(self, op: int, args: list[str], bools: list[bool],
                  constant_arg: Callable[[int], float | None]) -> tuple[str, bool]:
        """C expression for one SX operation and whether it is a truth value (printed as int).

        Truth values from comparisons stay ``int`` in C: converting them to floating point and back at
        every logical step would cost instructions for nothing. ``constant_arg(i)`` is argument i's
        value when it is a constant.
        """
        def num(i: int) -> str:  # an argument in arithmetic context
            return f"(({self.real}){args[i]})" if bools[i] else args[i]

        if op == ca.OP_ASSIGN:
            return args[0], bools[0]
        if op == ca.OP_IF_ELSE_ZERO and not bools[1]:
            return f"({self._truth(args, bools, 0)} ? {args[1]} : {self.zero()})", False
        arithmetic = self._arithmetic(op, num, constant_arg)
        if arithmetic is not None:
            return arithmetic, False
        logical = self._logical(op, args, bools, constant_arg)
        if logical is not None:
            return logical, True
        raise NotImplementedError(f"CasADi operation {op} has no C printing")

    def _truth(self, args: list[str], bools: list[bool], i: int) -> str:
        """Argument i in logical context, as an int 0 or 1."""
        return args[i] if bools[i] else f"({args[i]} != {self.zero()})"

    def _arithmetic(self, op: int, num: Callable[[int], str],
                    constant_arg: Callable[[int], float | None]) -> str | None:
        """A floating-point valued operation (None: not one)."""
        if op in _INFIX:
            return f"{num(0)} {_INFIX[op]} {num(1)}"
        if op == ca.OP_EXPM1 and self.inline_kernels:
            return f"{self.kernel_prefix}expm1({num(0)})"
        if op == ca.OP_ATAN2 and self.inline_kernels:
            return f"{self.kernel_prefix}atan2({num(0)}, {num(1)})"
        if op in _UNARY_CALLS:
            return self.call(_UNARY_CALLS[op], num(0))
        if op in (ca.OP_FMIN, ca.OP_FMAX):
            # Inline: no NaN reaches here (inputs are validated first, results checked after), and a
            # ternary is one instruction where fmin/fmax are library calls on many targets.
            a, b = num(0), num(1)
            return f"({a} < {b} ? {a} : {b})" if op == ca.OP_FMIN else f"({a} > {b} ? {a} : {b})"
        if op in _BINARY_CALLS:
            return self.call(_BINARY_CALLS[op], num(0), num(1))
        if op == ca.OP_NEG:
            return f"-{num(0)}"
        if op == ca.OP_SQ:
            return f"{num(0)} * {num(0)}"
        if op == ca.OP_TWICE:
            return f"{self.literal(2.0)} * {num(0)}"
        if op == ca.OP_INV:
            return f"{self.one()} / {num(0)}"
        if op == ca.OP_CONSTPOW:
            exponent = constant_arg(1)
            if exponent is not None and exponent.is_integer() and 1 <= exponent <= 4:
                return " * ".join([num(0)] * int(exponent))
            if exponent == 0.5:
                return self.call("sqrt", num(0))
            return self.call("pow", num(0), num(1))
        if op == ca.OP_SIGN:
            a = num(0)
            return f"({a} > {self.zero()} ? {self.one()} : ({a} < {self.zero()} ? {self.literal(-1.0)} : {a}))"
        return None

    def _logical(self, op: int, args: list[str], bools: list[bool],
                 constant_arg: Callable[[int], float | None]) -> str | None:
        """A truth-valued operation, printed as an int 0 or 1 (None: not one)."""
        def truth(i: int) -> str:
            return self._truth(args, bools, i)

        if op in _COMPARE:
            return (f"{self._compared(args, bools, 0, op, constant_arg)} {_COMPARE[op]} "
                    f"{self._compared(args, bools, 1, op, constant_arg)}")
        if op == ca.OP_NOT:
            return f"!{args[0]}" if bools[0] else f"{args[0]} == {self.zero()}"
        # Both sides are already computed and free of side effects, so bitwise & and | on 0/1 give
        # the same truth value as && and || without a branch each.
        if op == ca.OP_AND:
            return f"{truth(0)} & {truth(1)}"
        if op == ca.OP_OR:
            return f"{truth(0)} | {truth(1)}"
        if op == ca.OP_IF_ELSE_ZERO and bools[1]:
            return f"{truth(0)} & {args[1]}"
        return None
