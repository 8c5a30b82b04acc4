"""The wind 1-sigma's correlation inflation (windsolve._inflation) and benchmarks/windsigma.py's readings of
it, against the closed forms of an AR(1) residual: the variance of a mean of n samples of an AR(1) series
of coefficient phi is (sigma^2 / n) (1 + phi) / (1 - phi) for n much longer than 1 / (1 - phi)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.windsigma import _ar1, _integral_scale, _lag1, table
from dobwind.calibrate import windsolve


def _ar1_residual(phi: float, rows: int, seed: int = 3) -> np.ndarray:
    """Two independent AR(1) force components per row, raveled as windsolve's data residual."""
    rng = np.random.default_rng(seed)
    noise = rng.normal(size=(rows, 2))
    out = np.empty_like(noise)
    out[0] = noise[0] / math.sqrt(1 - phi * phi)
    for t in range(1, rows):
        out[t] = phi * out[t - 1] + noise[t]
    return out.ravel()


def _closed_form(phi: float) -> float:
    return math.sqrt((1 + phi) / (1 - phi))


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.8])
def test_the_inflation_is_the_ar1_variance_of_a_mean(phi):
    """White residuals leave the least-squares 1-sigma alone; an AR(1) one of phi inflates it by the closed form."""
    r = _ar1_residual(phi, 40000)
    index = np.zeros(40000, int)
    assert windsolve._inflation(r, index) == pytest.approx(_closed_form(phi), rel=0.03, abs=0.02)
    assert _integral_scale(r, index) == pytest.approx(_closed_form(phi), rel=0.05, abs=0.03)
    assert _ar1(_lag1(r, index), 0.999) == pytest.approx(_closed_form(phi), rel=0.03, abs=0.02)


def test_the_inflation_is_capped_at_a_lag1_correlation_of_095():
    """The cap the measured coverage rests on (docs/field-calibration.md): a residual correlated at 0.99 is
    read as 0.95, x6.24, not x14.1."""
    r = _ar1_residual(0.99, 40000)
    assert windsolve._inflation(r, np.zeros(40000, int)) == pytest.approx(_closed_form(0.95), rel=1e-9)
    assert _ar1(_lag1(r, np.zeros(40000, int)), 0.999) == pytest.approx(_closed_form(0.99), rel=0.1)


def test_no_correlation_is_counted_across_logs():
    """Two logs whose residuals are each constant but of opposite sign: within a log lag 1 is perfectly
    correlated, across the boundary it is not, and the pair at the boundary must not enter the sum."""
    r = np.r_[np.ones(200), -np.ones(200)]
    joined = _lag1(r, np.zeros(200, int))
    split = _lag1(r, np.repeat([0, 1], 100))
    # 400 values, 99 + 99 same-sign row pairs of 2 components each; the boundary pair counts -2 when joined
    assert split == pytest.approx(396 / 400) and joined == pytest.approx(394 / 400)


def test_the_table_counts_coverage_against_the_normal_shares():
    """|z| of 0.5 and 1.5 in equal numbers: half within 1, all within 2; one fit over the limit is refused."""
    rows = [{"z": {name: [0.5, 1.5] for name in ("ls", "ar1cap", "fit")},
             "sigma": {name: [0.1, 0.6 if k == 0 else 0.1] for name in ("ls", "ar1cap", "fit")},
             "identified": True} for k in range(4)]
    text = table(rows)
    assert "| ls | 50% | 100% | 100% | 1.00 | 3/4 | 3/3 |" in text, text
