"""The statistics of a height bin that say how far its mean can be trusted: the time the flights spent in
it, the effective number of independent samples, and the standard error of the bin mean.

Rows are not independent: each is the output of the estimator's causal filters (the disturbance observer,
then a first-order low-pass of about 0.3-0.8 s time constant, the NetCDF attribute `dobwind_time_response`),
and the air's own turbulence is correlated for longer still. So N rows are worth fewer independent samples.

The effective number is taken from the rows' OWN lag-1 autocorrelation r (about the bin's straight line
in height, see residual_scatter), with the AR(1) form
N_eff = N (1 - r) / (1 + r) (the variance of the mean of an AR(1) series of many samples is sigma^2 / N_eff).
Why the rows and not the filter's time constant: the filter sets only the least correlation a row can have;
turbulence (integral time scales of seconds near the surface) and a slow pass through sheared air correlate
the rows for longer, and only the rows show it. The filter's cutoff also moves with the wind speed, so its
time constant is no one number. An estimator whose output is smoother than AR(1) (a filter after a filter)
shows a lag-1 r above the AR(1) value of its integral time scale, which makes N_eff smaller: the error
stays on the conservative side.

The random error of the mean is then the scatter about that line over sqrt(N_eff). The model's per-row
sigma is no part of it: it is a bias-like term of the calibration, the same for neighbouring rows, and does
not average down; the profile reports it apart.

Every quantity is built from additive per-bin sums (profile.SUMS), so flights still combine exactly. Pairs of
rows enter the lag sums only when both rows are in the same bin and follow each other on the log's clock, so
separate passes through a bin, or separate flights, are never correlated with one another.
"""
from __future__ import annotations

import numpy as np

# Two rows are neighbours when their times differ by at most this many sampling intervals (a dropped row
# breaks the pair, replay's uniform clock jitters by less).
PAIR_GAP_STEPS = 1.5
# The sums kept per variable x (h: the row's height less its bin's centre, so the sums stay well
# conditioned at any height): the bin's moments, then over pairs of neighbouring rows i, i+1: their count,
# sum x_i x_{i+1}, x_i, x_{i+1}, h_i, h_{i+1}, x_i h_{i+1}, h_i x_{i+1}, h_i h_{i+1}.
SERIES_SUMS = ("n", "h", "hh", "x", "xx", "xh",
               "pairs", "lag_xx", "lag_x1", "lag_x2", "lag_h1", "lag_h2", "lag_xh", "lag_hx", "lag_hh")


def sampling_step(time_s: np.ndarray | None) -> float:
    """The rows' sampling interval (the median step of the clock; NaN when the rows carry no time)."""
    if time_s is None or len(time_s) < 2:
        return float("nan")
    return float(np.median(np.diff(time_s)))


def neighbours(bins: np.ndarray, time_s: np.ndarray | None, step_s: float | None = None) -> np.ndarray:
    """Row i's flag: rows i and i+1 are a pair (same bin, consecutive on the clock of sampling interval
    step_s, by default the rows' own); the last row is never."""
    pair = np.zeros(len(bins), bool)
    if len(bins) < 2:
        return pair
    same = bins[1:] == bins[:-1]
    if time_s is not None:
        same &= np.diff(time_s) <= PAIR_GAP_STEPS * (sampling_step(time_s) if step_s is None else step_s)
    pair[:-1] = same
    return pair


def series_columns(x: np.ndarray, h: np.ndarray, pair: np.ndarray) -> np.ndarray:
    """Per-row contributions to SERIES_SUMS for variable x (NaN: the row has no x) at centred heights h;
    row i carries its pair with row i+1."""
    has = np.isfinite(x)
    xv, hv = np.where(has, x, 0.0), np.where(has, h, 0.0)
    nx, nh = np.r_[xv[1:], 0.0], np.r_[hv[1:], 0.0]
    on = pair & has & np.r_[has[1:], False]
    x1, h1 = np.where(on, xv, 0.0), np.where(on, hv, 0.0)
    x2, h2 = np.where(on, nx, 0.0), np.where(on, nh, 0.0)
    return np.column_stack([has, hv, hv * hv, xv, xv * xv, xv * hv,
                            on, x1 * x2, x1, x2, h1, h2, x1 * h2, h1 * x2, h1 * h2]).astype(float)


def residual_scatter(sums: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(standard deviation, lag-1 autocorrelation) of the rows about the bin's own straight line in height,
    per bin (columns of sums as SERIES_SUMS). The line takes out the shear across the bin: a climb through
    sheared air makes the rows drift smoothly, which is the profile, not noise, and would read as both a
    wide scatter and a strong correlation. The intercept at the bin's centre is no different from the mean
    when the rows fill the bin evenly. NaN below three rows (two with no height spread) or without a pair."""
    c = {name: sums[:, k] for k, name in enumerate(SERIES_SUMS)}
    n = c["n"]
    with np.errstate(invalid="ignore", divide="ignore"):
        h_bar, x_bar = c["h"] / n, c["x"] / n
        var_h, var_x = c["hh"] / n - h_bar ** 2, c["xx"] / n - x_bar ** 2
        cov = c["xh"] / n - x_bar * h_bar
        sloped = var_h > 1e-9
        b = np.where(sloped, cov / var_h, 0.0)
        a = x_bar - b * h_bar
        ss = np.maximum(n * (var_x - b * cov), 0.0)  # the sum of squared residuals
        dof = n - np.where(sloped, 2.0, 1.0)
        std = np.where(dof > 0, np.sqrt(ss / dof), np.nan)
        lag = (c["lag_xx"] - a * (c["lag_x1"] + c["lag_x2"]) - b * (c["lag_xh"] + c["lag_hx"])
               + a * a * c["pairs"] + a * b * (c["lag_h1"] + c["lag_h2"]) + b * b * c["lag_hh"])
        r = np.where(ss > 1e-12 * np.maximum(n * x_bar ** 2, n), (lag / c["pairs"]) / (ss / n), 0.0)
    return std, np.where(c["pairs"] > 0, r, np.nan)


def effective_count(n: np.ndarray, r: np.ndarray) -> np.ndarray:
    """N_eff = N (1 - r) / (1 + r), r clipped to [0, 1): anticorrelation earns no extra samples (it would
    come from the shortness of the series more often than from the air), and N_eff never exceeds N nor
    falls below 1 for a bin with rows. NaN where r is unknown."""
    rc = np.clip(r, 0.0, 1.0 - 1e-12)
    out = np.where(n > 0, np.clip(n * (1.0 - rc) / (1.0 + rc), 1.0, np.maximum(n, 1.0)), 0.0)
    return np.where(np.isfinite(r) | (n == 0), out, np.nan)


def standard_error(std: np.ndarray, n_eff: np.ndarray) -> np.ndarray:
    """The random part of the error of the bin mean: the rows' scatter over sqrt(N_eff) (NaN without a
    scatter). Near N_eff = 1 the scatter itself is poorly known (the rows are close to one sample): the
    profile prints N_eff beside it so a reader can tell."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n_eff >= 1.0, std / np.sqrt(n_eff), np.nan)
