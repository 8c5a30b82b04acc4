"""A CasADi SX Function's algorithm evaluated on NumPy arrays: one NumPy operation per instruction, over
every row at once.

CasADi's own ``map`` runs the instruction list once per row in its virtual machine; for the tens of
thousands of samples the fit inverts dozens of times, that cost more than building the expression.
Here each instruction runs once over all rows. Only operations that IEEE 754 rounds exactly in both
(arithmetic, sqrt, abs, min/max, comparisons) are supported, so the results are CasADi's bit for bit;
any other instruction raises instead of risking a different libm.
"""
from __future__ import annotations

from typing import Callable

import casadi as ca
import numpy as np

_Value = np.ndarray | float


def _if_else_zero(c: _Value, x: _Value) -> _Value:
    return np.where(c != 0, x, 0.0)  # C's ``c ? x : 0``: NaN counts as true


_UNARY: dict[int, Callable[[_Value], _Value]] = {
    ca.OP_ASSIGN: lambda x: x, ca.OP_NEG: np.negative, ca.OP_SQRT: np.sqrt, ca.OP_SQ: lambda x: x * x,
    ca.OP_TWICE: lambda x: x + x, ca.OP_FABS: np.abs, ca.OP_SIGN: np.sign, ca.OP_INV: lambda x: 1.0 / x,
    ca.OP_NOT: lambda x: np.logical_not(x).astype(float),
    ca.OP_EXP: np.exp, ca.OP_LOG: np.log,
}
_BINARY: dict[int, Callable[[_Value, _Value], _Value]] = {
    ca.OP_ADD: np.add, ca.OP_SUB: np.subtract, ca.OP_MUL: np.multiply, ca.OP_DIV: np.divide,
    ca.OP_FMIN: np.fmin, ca.OP_FMAX: np.fmax, ca.OP_COPYSIGN: np.copysign, ca.OP_IF_ELSE_ZERO: _if_else_zero,
    ca.OP_LT: lambda x, y: np.less(x, y).astype(float), ca.OP_LE: lambda x, y: np.less_equal(x, y).astype(float),
    ca.OP_EQ: lambda x, y: np.equal(x, y).astype(float), ca.OP_NE: lambda x, y: np.not_equal(x, y).astype(float),
    ca.OP_AND: lambda x, y: np.logical_and(x, y).astype(float),
    ca.OP_OR: lambda x, y: np.logical_or(x, y).astype(float),
    ca.OP_POW: np.power, ca.OP_CONSTPOW: np.power,
}


class VectorFunction:
    """``function``'s instructions, read once, evaluated over many rows per call."""

    def __init__(self, function: ca.Function) -> None:
        dense = all(function.sparsity_in(i).is_dense() for i in range(function.n_in())) and all(
            function.sparsity_out(i).is_dense() for i in range(function.n_out()))
        if not dense:
            raise ValueError(f"{function.name()}: sparse arguments are not supported")
        self.name, self.work_size = function.name(), function.sz_w()
        self.output_sizes = [function.nnz_out(i) for i in range(function.n_out())]
        self.code: list[tuple[int, list[int], list[int], float]] = []
        for k in range(function.n_instructions()):
            op = function.instruction_id(k)
            if op not in _UNARY and op not in _BINARY and op not in (ca.OP_CONST, ca.OP_INPUT, ca.OP_OUTPUT):
                raise ValueError(f"{self.name}: instruction {k} (CasADi operation {op}) is not supported")
            constant = function.instruction_constant(k) if op == ca.OP_CONST else 0.0
            self.code.append((op, list(function.instruction_input(k)), list(function.instruction_output(k)), constant))

    def __call__(self, inputs: list[np.ndarray], rows: int) -> list[np.ndarray]:
        """Input i is (nnz_i, rows), or (nnz_i,) for a value shared by every row; output i is
        (nnz_i, rows), nonzeros in CasADi's column-major order."""
        work: list[_Value] = [0.0] * self.work_size
        outputs = [np.empty((size, rows)) for size in self.output_sizes]
        with np.errstate(all="ignore"):  # CasADi's VM does not trap either: inf and NaN flow through
            for op, args, res, constant in self.code:
                if op == ca.OP_INPUT:
                    work[res[0]] = inputs[args[0]][args[1]]
                elif op == ca.OP_CONST:
                    work[res[0]] = constant
                elif op == ca.OP_OUTPUT:
                    outputs[res[0]][res[1]] = work[args[0]]
                elif op in _UNARY:
                    work[res[0]] = _UNARY[op](work[args[0]])
                else:
                    work[res[0]] = _BINARY[op](work[args[0]], work[args[1]])
        return outputs
