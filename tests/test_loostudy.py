"""The leave-one-out study's refit (benchmarks/loostudy.scaled_fit) on the synthetic tunnel runs of
test_runmeans: at the fit's own weighting it is the anchored fit, and the within-run scale moves the
law from the run means' towards the within-run shape."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks import loostudy
from dobwind.calibrate import dragfit
from tests.test_runmeans import ACTIVE, TRUE, _samples, _values


def test_at_the_fits_own_weighting_the_study_is_the_anchored_fit():
    samples = _samples(offsets={6.0: 2.0})
    theta, weights = loostudy.scaled_fit(samples, ACTIVE, 1.0)
    expected, expected_weights = dragfit.anchored_theta(samples, ACTIVE, dragfit._solve(samples, ACTIVE))
    np.testing.assert_allclose(theta, expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(weights, expected_weights, rtol=1e-12, atol=1e-12)


def test_the_within_run_scale_moves_the_law_from_the_means_to_the_within_run_shape():
    """Within-run variation 1.6 times steeper than the law the means follow: without it the means give the
    true law; weighted 64 times it pulls the quadratic term up (a sweep about a mean s sees the slope
    1.6 (l0 + 2 q0 s), which grows faster with s than the law's)."""
    samples = _samples(within_gain=1.6)
    means_only = _values(loostudy.scaled_fit(samples, ACTIVE, 0.0)[0])
    shape_heavy = _values(loostudy.scaled_fit(samples, ACTIVE, 64.0)[0])
    assert means_only["l0"] == pytest.approx(TRUE["l0"], abs=0.03)
    assert means_only["q0"] == pytest.approx(TRUE["q0"], abs=0.005)
    assert shape_heavy["q0"] > means_only["q0"] + 0.02
