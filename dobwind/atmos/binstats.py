"""The statistics of a height bin that say how far its mean can be trusted: the time the flights spent in
it, the effective number of independent samples, and the standard error of the bin mean.

Rows are not independent: each is the output of the estimator's causal filters (the disturbance observer,
then a first-order low-pass of about 0.3-0.8 s time constant, the NetCDF attribute `dobwind_time_response`),
and the air's own turbulence is correlated for longer still. So N rows are worth fewer independent samples.

The effective number is taken from the rows' OWN lag-1 autocorrelation r, with the AR(1) form
N_eff = N (1 - r) / (1 + r) (the variance of the mean of an AR(1) series of many samples is sigma^2 / N_eff).
Why the rows and not the filter's time constant: the filter sets only the least correlation a row can have;
turbulence (integral time scales of seconds near the surface) and a slow pass through sheared air correlate
the rows for longer, and only the rows show it. The filter's cutoff also moves with the wind speed, so its
time constant is no one number. An estimator whose output is smoother than AR(1) (a filter after a filter)
shows a lag-1 r above the AR(1) value of its integral time scale, which makes N_eff smaller: the error
stays on the conservative side.

Every quantity is built from additive per-bin sums (profile.SUMS), so flights still combine exactly. Pairs of
rows enter the lag sums only when both rows are in the same bin and follow each other on the log's clock, so
separate passes through a bin, or separate flights, are never correlated with one another.
"""
from __future__ import annotations

import numpy as np

# Two rows are neighbours when their times differ by at most this many sampling intervals (a dropped row
# breaks the pair, replay's uniform clock jitters by less).
PAIR_GAP_STEPS = 1.5
# The lag sums, per variable, in this order (the bin's pair count, sum x_i x_{i+1}, sum x_i, sum x_{i+1}).
LAG_SUMS = ("pairs", "lag", "lag_first", "lag_second")


def sampling_step(time_s: np.ndarray | None) -> float:
    """The rows' sampling interval (the median step of the clock; NaN when the rows carry no time)."""
    if time_s is None or len(time_s) < 2:
        return float("nan")
    return float(np.median(np.diff(time_s)))


def neighbours(bins: np.ndarray, time_s: np.ndarray | None) -> np.ndarray:
    """Row i's flag: rows i and i+1 are a pair (same bin, consecutive on the clock); the last row is never."""
    pair = np.zeros(len(bins), bool)
    if len(bins) < 2:
        return pair
    same = bins[1:] == bins[:-1]
    if time_s is not None:
        same &= np.diff(time_s) <= PAIR_GAP_STEPS * sampling_step(time_s)
    pair[:-1] = same
    return pair


def lag_columns(x: np.ndarray, pair: np.ndarray) -> np.ndarray:
    """Per-row contributions to LAG_SUMS for variable x (row i carries its pair with row i+1)."""
    nxt = np.r_[x[1:], 0.0] if len(x) else x
    on = pair & np.isfinite(x) & np.isfinite(nxt)
    first, second = np.where(on, x, 0.0), np.where(on, nxt, 0.0)
    return np.column_stack([on.astype(float), first * second, first, second])


def lag1_correlation(lags: np.ndarray, s1: np.ndarray, s2: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The lag-1 autocorrelation about the bin mean, from the sums (columns of lags as LAG_SUMS; s1, s2: the
    bin's sum and sum of squares over n rows). NaN without a pair; 0 for a constant series."""
    pairs, lag, first, second = lags.T
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = s1 / n
        var = s2 / n - mean * mean
        cov = (lag - mean * (first + second)) / pairs + mean * mean
        r = np.where(var > 1e-12 * np.maximum(mean * mean, 1.0), cov / var, 0.0)
    return np.where(pairs > 0, r, np.nan)


def effective_count(n: np.ndarray, r: np.ndarray) -> np.ndarray:
    """N_eff = N (1 - r) / (1 + r), r clipped to [0, 1): anticorrelation earns no extra samples (it would
    come from the shortness of the series more often than from the air), and N_eff never exceeds N nor
    falls below 1 for a bin with rows. NaN where r is unknown."""
    rc = np.clip(r, 0.0, 1.0 - 1e-12)
    out = np.where(n > 0, np.clip(n * (1.0 - rc) / (1.0 + rc), 1.0, np.maximum(n, 1.0)), 0.0)
    return np.where(np.isfinite(r) | (n == 0), out, np.nan)


def standard_error(std: np.ndarray, n_eff: np.ndarray) -> np.ndarray:
    """The random part of the error of the bin mean: the rows' scatter over sqrt(N_eff) (NaN without a
    spread or below two effective samples, where the scatter says nothing about the mean)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n_eff >= 2.0, std / np.sqrt(n_eff), np.nan)
