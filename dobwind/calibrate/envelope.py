"""What `fit` records about its own calibration, for the step's quality outputs: the envelope of the
calibrated forces and airflow (beyond it the status bit EXTRAPOLATED is set) and the 1-sigma error of
the fitted model as a function of airflow speed plus the observer noise (the wind_sigma_* outputs).

Plain NumPy arrays in, airframe records out, so the fit procedure can change without touching this.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from dobwind.model.airframe import Envelope, Uncertainty

# Calibration points are means over seconds; single samples of the filtered force scatter around them.
# The envelope is widened by this share of the largest force magnitude so that flight inside the
# calibrated range does not flicker EXTRAPOLATED at its edge.
ENVELOPE_MARGIN = 0.05
# Fewer residuals than this give no usable standard deviation for a speed band.
MIN_POINTS_PER_BAND = 8
MAX_BANDS = 6


def calibration_envelope(force_h: np.ndarray, force_z: np.ndarray, airflow_h: np.ndarray) -> Envelope:
    """Envelope from the calibration points: heading-frame horizontal force magnitude and vertical
    force (N, after the force offset) and the model's horizontal airflow speed (m/s) at each point."""
    force_h, force_z, airflow_h = (np.asarray(a, dtype=float) for a in (force_h, force_z, airflow_h))
    if not (force_h.size and force_h.size == force_z.size == airflow_h.size):
        raise ValueError("calibration_envelope needs equally long, non-empty arrays")
    margin = ENVELOPE_MARGIN * max(float(np.max(force_h)), float(np.max(np.abs(force_z))), 1e-6)
    speed_margin = ENVELOPE_MARGIN * max(float(np.max(airflow_h)), 1e-6)
    return Envelope(float(np.max(force_h)) + margin,
                    (float(np.min(force_z)) - margin, float(np.max(force_z)) + margin),
                    float(np.max(airflow_h)) + speed_margin)


def _bands(speed: np.ndarray) -> list[np.ndarray]:
    """Indices of the points in speed bands of (nearly) equal counts, slowest first."""
    order = np.argsort(speed, kind="stable")
    count = int(min(MAX_BANDS, max(1, speed.size // MIN_POINTS_PER_BAND)))
    return [band for band in np.array_split(order, count) if band.size]


def uncertainty_table(true_speed: np.ndarray, predicted_speed: np.ndarray, true_up: np.ndarray,
                      predicted_up: np.ndarray) -> Uncertainty:
    """Piecewise-linear 1-sigma table over horizontal airflow speed from calibration residuals.

    Each band of true speed gives one breakpoint at its mean speed, with the root-mean-square of the
    horizontal-speed and vertical residuals in it (RMS, not the standard deviation about the mean: a
    bias is an error too)."""
    arrays = [np.asarray(a, dtype=float) for a in (true_speed, predicted_speed, true_up, predicted_up)]
    if not (arrays[0].size and all(a.size == arrays[0].size for a in arrays)):
        raise ValueError("uncertainty_table needs equally long, non-empty arrays")
    speed, h_residual, up_residual = arrays[0], arrays[1] - arrays[0], arrays[3] - arrays[2]
    speeds, sigma_h, sigma_up = [], [], []
    for band in _bands(speed):
        centre = float(np.mean(speed[band]))
        if speeds and centre <= speeds[-1]:
            continue  # equal speeds in two bands: one breakpoint (the loader wants increasing speeds)
        speeds.append(centre)
        sigma_h.append(float(np.sqrt(np.mean(h_residual[band] ** 2))))
        sigma_up.append(float(np.sqrt(np.mean(up_residual[band] ** 2))))
    return Uncertainty(tuple(speeds), tuple(sigma_h), tuple(sigma_up))


def observer_noise(segment_errors: list[np.ndarray]) -> tuple[float, int]:
    """The sample-to-sample scatter of an estimate and its degrees of freedom, from the per-sample
    errors of steady segments (one array each): each segment's mean error is the model's error there
    (what the residual table covers) and is removed; the pooled standard deviation of what remains is
    the observer noise. Segments of fewer than two samples carry no scatter."""
    return pooled_scatter([segment_scatter(e) for e in segment_errors])


def segment_scatter(errors: np.ndarray) -> tuple[float, int]:
    """One segment's sum of squared deviations from its mean error, and its sample count (none below
    two samples): what observer_noise pools, kept when a segment's samples are dropped."""
    e = np.asarray(errors, dtype=float)
    if e.size < 2:
        return 0.0, 0
    d = e - np.mean(e)
    return float(np.sum(d * d)), int(d.size)


def pooled_scatter(parts: list[tuple[float, int]]) -> tuple[float, int]:
    """observer_noise from the segments' segment_scatter, in their order."""
    kept = [(squares, size) for squares, size in parts if size >= 2]
    dof = sum(size - 1 for _, size in kept)
    if dof == 0:
        return 0.0, 0
    return float(math.sqrt(sum(squares for squares, _ in kept) / dof)), dof


def pooled_noise(noises: list[tuple[float, int]]) -> float:
    """Several logs' (noise, degrees of freedom) as one figure: their variances weighted by dof."""
    dof = sum(n for _, n in noises)
    return float(math.sqrt(sum(s * s * n for s, n in noises) / dof)) if dof else 0.0


def with_observer_noise(unc: Uncertainty | None, noise_h_mps: float, noise_up_mps: float) -> Uncertainty | None:
    """The residual table with the observer noise recorded beside it (the step adds it in quadrature)."""
    if unc is None:
        return None
    return dataclasses.replace(unc, noise_h_mps=float(noise_h_mps), noise_up_mps=float(noise_up_mps))
