"""Cross-validation at the scale of a hold: the figure that predicts the replay error on unseen holds.

The fit's own CV (dragfit.grouped_cv) is the RMS of the horizontal airflow VECTOR error over single
decimated samples of the held-out blocks. A user (and `replay`) judges the estimate differently: the
speed of the mean wind over a hold, after the transition. Two things separate the figures:
- sample noise (force noise, turbulence seen through the nonlinear inverse) averages out over a hold;
- a vector error counts direction errors too (2 deg at 8 m/s is 0.28 m/s), a speed error does not.
So this CV keeps the same folds and the same fitted models, but scores each held-out block in windows
of about a hold: the speed of the mean predicted airflow minus the speed of the mean true airflow, both
H-filtered, heading frame. Its RMS over windows is the figure a replay's per-hold speed errors follow.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind import dragfit

HOLD_WINDOW_S = 10.0   # about a steady hold's scored part, for logs without a `segment` column
HOLD_SETTLE_S = 5.0    # with segments: scored from this long after each segment's start, as replay does
MIN_WINDOWS_PER_BAND = 20
MAX_BANDS = 5


def _window_ids(group: np.ndarray, samples_per_window: int) -> np.ndarray:
    """Consecutive runs of at most ``samples_per_window`` samples inside each block (samples are in
    time order within a block)."""
    start = np.r_[True, group[1:] != group[:-1]]
    first = np.maximum.accumulate(np.where(start, np.arange(len(group)), 0))
    position = np.arange(len(group)) - first
    block = np.cumsum(start) - 1
    return block * (10 ** 6) + position // samples_per_window


def _scored_windows(samples: dragfit.DragSamples, per_window: int) -> tuple[np.ndarray, np.ndarray]:
    """Window of every sample and which samples are scored. A log with segments is scored per segment
    (one window each, from HOLD_SETTLE_S after its start: what replay's per-segment errors measure);
    otherwise in consecutive windows of ``per_window`` samples within each block."""
    scored = samples.hold_age_s >= HOLD_SETTLE_S if samples.hold_age_s is not None else None
    if samples.hold is None or scored is None or not scored.any():  # no segments, or none long enough
        return _window_ids(samples.group, per_window), np.ones(len(samples), dtype=bool)
    return samples.log_index.astype(np.int64) * (10 ** 9) + samples.hold.astype(np.int64), scored


def window_speed_errors(predicted: np.ndarray, truth: np.ndarray, windows: np.ndarray) -> np.ndarray:
    """Per window: |mean predicted horizontal airflow| - |mean true horizontal airflow| (m/s)."""
    _, inverse, count = np.unique(windows, return_inverse=True, return_counts=True)
    mean = [np.bincount(inverse, weights=x) / count for x in (predicted[:, 0], predicted[:, 1], truth[:, 0], truth[:, 1])]
    return np.hypot(mean[0], mean[1]) - np.hypot(mean[2], mean[3])


@dataclass(frozen=True)
class HoldCV:
    """Held-out hold-mean speed errors: overall, by true speed, and beyond the calibrated range."""
    rms_mps: float                        # over every held-out window
    band_speeds_mps: tuple[float, ...]    # mean true speed of each band of windows, increasing
    band_rms_mps: tuple[float, ...]       # RMS error of the windows in that band
    extrapolation_mps: float              # top blocks held out, the model fitted on the rest

    def predicted(self, speed_mps: float, calibrated_mps: float) -> float:
        """The error to expect on a hold at this airflow speed: the band's CV inside the calibrated
        range (linear between bands, clamped), the extrapolation figure beyond it."""
        if speed_mps > calibrated_mps and math.isfinite(self.extrapolation_mps):
            return self.extrapolation_mps
        if not self.band_speeds_mps:
            return self.rms_mps
        return float(np.interp(speed_mps, self.band_speeds_mps, self.band_rms_mps))


def _folds(group: np.ndarray) -> np.ndarray:
    """dragfit.grouped_cv's fold of every sample (same blocks, same seed)."""
    unique = np.unique(group)
    fold_of = dict(zip(np.random.default_rng(0).permutation(unique), np.arange(len(unique)) % dragfit.FOLDS))
    return np.array([fold_of[g] for g in group])


def _held_out(samples: dragfit.DragSamples, fit_predict: dragfit.FitPredict, test: np.ndarray,
              per_window: int) -> tuple[np.ndarray, np.ndarray]:
    """Hold-mean speed errors and true speeds of the windows of the ``test`` samples."""
    held_out = samples.select(test)
    # A diverged prediction counts as the clip (dragfit.prediction_error), never as inf or NaN.
    predicted = held_out.airflow + dragfit.prediction_error(fit_predict(samples.select(~test), held_out), held_out.airflow)
    windows, scored = _scored_windows(held_out, per_window)
    predicted, held_out, windows = predicted[scored], held_out.select(scored), windows[scored]
    _, inverse, count = np.unique(windows, return_inverse=True, return_counts=True)
    speed = np.bincount(inverse, weights=np.hypot(held_out.airflow[:, 0], held_out.airflow[:, 1])) / count
    return window_speed_errors(predicted, held_out.airflow, windows), speed


def _bands(speed: np.ndarray, error: np.ndarray) -> tuple[tuple[float, ...], tuple[float, ...]]:
    order = np.argsort(speed, kind="stable")
    count = int(min(MAX_BANDS, max(1, speed.size // MIN_WINDOWS_PER_BAND)))
    centres, rms = [], []
    for band in np.array_split(order, count):
        centre = float(np.mean(speed[band]))
        if band.size and (not centres or centre > centres[-1]):
            centres.append(centre)
            rms.append(float(np.sqrt(np.mean(error[band] ** 2))))
    return tuple(centres), tuple(rms)


def hold_cv(samples: dragfit.DragSamples, fit_predict: dragfit.FitPredict,
            window_s: float = HOLD_WINDOW_S) -> HoldCV | None:
    """Hold-level CV on dragfit.grouped_cv's folds, and the same error on the top blocks (those
    dragfit.extrapolation_error holds out) when fitted below them. None with fewer than two blocks."""
    if len(np.unique(samples.group)) < 2:
        return None
    fold = _folds(samples.group)
    per_window = max(1, int(round(window_s * dragfit.DECIMATED_RATE_HZ)))
    parts = [_held_out(samples, fit_predict, fold == k, per_window) for k in range(min(dragfit.FOLDS, fold.max() + 1))]
    error, speed = np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])
    unique, inverse = np.unique(samples.group, return_inverse=True)
    level = np.bincount(inverse, np.hypot(samples.airflow[:, 0], samples.airflow[:, 1])) / np.bincount(inverse)
    top = level[inverse] >= dragfit.TOP_SHARE * level.max()
    extrapolation = math.nan
    if not top.all() and (~top).sum() >= 50:
        top_error, _ = _held_out(samples, fit_predict, top, per_window)
        extrapolation = float(np.sqrt(np.mean(top_error ** 2)))
    return HoldCV(float(np.sqrt(np.mean(error ** 2))), *_bands(speed, error), extrapolation)
