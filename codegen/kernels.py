"""Single-precision math kernels printed into the generated C instead of libm's.

libm's atan2f, expm1f and sinf/cosf handle every float argument, special values and errno; on a
Cortex-M4F they cost about 2 KB of flash and a few hundred cycles a step. The step only ever calls them
on arguments it has validated, so small polynomial kernels do. Double precision keeps libm: there the
C must equal the CasADi reference bit for bit.

The coefficients below are frozen (the generated C must not depend on the machine that prints it).
``python -m dobwind.codegen.kernels`` re-derives them: a near-minimax fit by Lawson's iteratively
reweighted least squares on a dense grid, in double, rounded to float. tests/test_kernels.py checks the
printed C against libm over each kernel's whole range and states the bounds.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# atan(a) = a + a^3 * P(a^2) on a in [0, 1] (absolute error, radians).
ATAN_COEFFICIENTS = (-0.333316594, 0.199627027, -0.139765739, 0.0979420915, -0.0577731989, 0.0230398383,
                     -0.00435531652)
# expm1(r) = r + r^2 (1/2 + r Q(r)) on |r| <= ln2/2 (relative error).
EXPM1_COEFFICIENTS = (0.166665494, 0.0416668542, 0.00836603343, 0.00138982164)
# sin/cos: the existing minimax pair on [-pi/4, pi/4]: sin r = r + r z S(z), cos r = 1 - z/2 + z^2 C(z).
SIN_COEFFICIENTS = (-1.66666546e-1, 8.33216087e-3, -1.95152959e-4)
COS_COEFFICIENTS = (4.16666456e-2, -1.38873163e-3, 2.44331571e-5)
# pi/2 in three parts for Cody-Waite reduction: the first two have 12 significant bits, so their
# products with a 10-bit part of k are exact (see the template), the third is the rest to float.
HALF_PI_PARTS = (1.57080078125, -4.45358455e-06, -8.70551631e-10)
# ln 2 in two parts: the first has 12 bits, exact in products with |k| <= 127.
LN2_PARTS = (0.693115234, 3.19461833e-05)


def kernel_literals(printer) -> dict[str, list[str]]:
    """The constants above as C literals of the printer's precision, for the source template."""
    groups = {"atan": ATAN_COEFFICIENTS, "expm1": EXPM1_COEFFICIENTS, "sin": SIN_COEFFICIENTS,
              "cos": COS_COEFFICIENTS, "half_pi": HALF_PI_PARTS, "ln2": LN2_PARTS}
    return {name: [printer.literal(v) for v in values] for name, values in groups.items()}


@dataclass(frozen=True)
class Fit:
    coefficients: tuple[float, ...]
    max_error: float  # of the double-precision polynomial on the grid


def _lawson(target: np.ndarray, basis: np.ndarray, weight: np.ndarray, iterations: int = 300) -> np.ndarray:
    """Weighted least squares whose weights grow where the error is largest: converges to minimax."""
    w = np.full(len(target), 1.0 / len(target))
    coefficients = np.zeros(basis.shape[1])
    for _ in range(iterations):
        root = np.sqrt(w)[:, None] / weight[:, None]
        coefficients, *_ = np.linalg.lstsq(basis * root, target * root[:, 0], rcond=None)
        error = np.abs(basis @ coefficients - target) / weight
        w = w * error
        w /= w.sum()
    return coefficients


def fit_atan(terms: int = len(ATAN_COEFFICIENTS)) -> Fit:
    a = np.linspace(1e-4, 1.0, 20001)
    basis = np.stack([a ** (2 * k + 3) for k in range(terms)], axis=1)
    c = _lawson(np.arctan(a) - a, basis, np.ones_like(a))
    return Fit(tuple(float(np.float32(v)) for v in c), float(np.max(np.abs(basis @ c - (np.arctan(a) - a)))))


def fit_expm1(terms: int = len(EXPM1_COEFFICIENTS)) -> Fit:
    half = np.log(2.0) / 2
    r = np.linspace(-half, half, 20001)
    r = r[r != 0.0]
    basis = np.stack([r ** (k + 3) for k in range(terms)], axis=1)
    target = np.expm1(r) - r - r * r / 2
    c = _lawson(target, basis, np.abs(np.expm1(r)))
    return Fit(tuple(float(np.float32(v)) for v in c),
               float(np.max(np.abs(basis @ c - target) / np.abs(np.expm1(r)))))


def main() -> int:
    for label, fit in (("atan", fit_atan()), ("expm1", fit_expm1())):
        print(f"{label}: max error {fit.max_error:.3g}; coefficients {', '.join(f'{c:.9g}' for c in fit.coefficients)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
