"""The share of a correlated noise's variance that a segment's own scatter keeps (selfcheck.within_share):
the self-check measures the noise at low airflow about each segment's mean, and a slow low-pass moves
much of the noise into that mean, where a wind reading still sees it."""
from __future__ import annotations

import math

import numpy as np
import pytest

from dobwind.calibrate.selfcheck import within_share


def test_white_noise_and_long_segments_keep_it_all():
    assert within_share(10.0, 0.0) == 1.0
    assert within_share(1e6, 1.0) == pytest.approx(1.0, abs=1e-5)


def test_long_segments_lose_two_correlation_times_of_their_length():
    # T >> tau: 1 - 2 tau / T + 2 (tau / T)^2, the classic loss of a sample variance of correlated data.
    assert within_share(100.0, 1.0) == pytest.approx(1 - 0.02 + 0.0002, rel=1e-6)


def test_short_segments_keep_about_a_third_of_their_length_over_tau():
    # T << tau: the process is nearly a straight line over the segment: share ~ T / (3 tau).
    assert within_share(0.01, 1.0) == pytest.approx(0.05)   # the floor
    assert within_share(0.3, 1.0) == pytest.approx(0.3 / 3 * (1 - 0.3 / 4), rel=0.02)


def test_the_share_matches_a_simulated_low_pass_noise():
    """Independent check: white noise through a first-order low-pass (AR(1)), cut into segments; the mean
    scatter about each segment's mean over the process variance."""
    rng = np.random.default_rng(7)
    dt, tau = 0.01, 1.0
    phi = math.exp(-dt / tau)
    n = 400_000
    drive = rng.standard_normal(n) * math.sqrt(1 - phi * phi)
    x = np.empty(n)
    x[0] = rng.standard_normal()
    for i in range(1, n):   # a plain loop: the recursion is the definition being checked
        x[i] = phi * x[i - 1] + drive[i]
    for seconds in (2.0, 5.0, 20.0):
        size = int(seconds / dt)
        segments = x[: n // size * size].reshape(-1, size)
        kept = float(np.mean(segments.var(axis=1, ddof=1)))
        assert kept == pytest.approx(within_share(seconds, tau), rel=0.06), seconds
