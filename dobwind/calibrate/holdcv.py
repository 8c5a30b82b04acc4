"""Cross-validation at the scale of a hold: the figure that predicts the replay error on unseen holds.

The fit's own CV (dragfit.grouped_cv) is the RMS of the horizontal airflow VECTOR error over single
decimated samples of the held-out blocks. A user (and `replay`) judges the estimate differently: the
speed of the mean wind over a hold, after the transition. Two things separate the figures:
- sample noise (force noise, turbulence seen through the nonlinear inverse) averages out over a hold;
- a vector error counts direction errors too (2 deg at 8 m/s is 0.28 m/s), a speed error does not.
So this CV keeps the same folds and the same fitted models, but scores each held-out block in windows
of about a hold: the speed of the mean predicted airflow minus the speed of the mean true airflow, both
H-filtered, heading frame. Its RMS over windows is the figure a replay's per-hold speed errors follow.

A hold's error has a part a longer hold keeps (the model's bias at that airflow) and a part that averages
out (noise). Calibration holds are often short (8 s, scored 3 s), the holds a user replays longer, so the
two are separated: the difference between a window's two halves holds no bias, and its mean square over
4 is the noise variance of the whole window's mean. Noise variance times scored length is about constant
once the window is longer than the noise's correlation (1 s turbulence, the H filter), so the error to
expect on a hold scored for T seconds is sqrt(bias^2 + noise^2 / T). Halves still correlated make the
difference small, so the split leans toward bias: the longer-hold figure errs high, never low.

Two laws fitted on the same samples pair up window by window, so one can be said to predict the holds
better than another only when the gain is significant (significant_gain). The drag law's exponent
(dragexponent) and the choice between parameter sets whose per-sample scores tie (prefer_on_holds) rest
on that test.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dobwind.calibrate import cvdiverge, dragfit
from dobwind.calibrate.reportparts import HoldCvBySpeed

HOLD_WINDOW_S = 10.0   # about a steady hold's scored part, for logs without a `segment` column
HOLD_SETTLE_S = 5.0    # with segments: scored from this long after each segment's start, as replay does
MIN_WINDOWS_PER_BAND = 20
MAX_BANDS = 5


# Fewer samples than this in a scored window and its half differences (the noise term) mean little.
MIN_SAMPLES_PER_WINDOW = 4


def sparse_windows(window_s: float | None, rate_hz: float, minimum: int = MIN_SAMPLES_PER_WINDOW) -> str | None:
    """A warning when the hold-level CV's scored windows (``window_s`` long: HoldCvBySpeed.window_s) hold
    fewer than ``minimum`` samples at ``rate_hz``: a very long calibration is sampled sparsely
    (dragfit.MAX_SAMPLES), and the CV then cannot see the noise a hold averages."""
    window = window_s
    # The window's length is its count over the rate: the product gives the count back to rounding.
    if window is None or not round(window * rate_hz, 6) < minimum:
        return None
    return (f"the hold-level CV's windows hold {window * rate_hz:.1f} samples ({window:.1f} s at {rate_hz:.3g} Hz; "
            f"long calibrations are sampled sparsely, MAX_SAMPLES): its noise term is not measured, so it may read low")


def samples_per_window(samples: dragfit.DragSamples, window_s: float) -> np.ndarray:
    """(N,) how many samples of its log make a window of ``window_s`` (logs are sampled at their own
    rates: whole rows, not the rate asked for)."""
    return np.maximum(1, np.round(window_s * samples.rates_hz())).astype(np.int64)


def _window_ids(group: np.ndarray, samples_per_window: int | np.ndarray) -> np.ndarray:
    """Consecutive runs of at most ``samples_per_window`` samples (one figure, or each sample's) inside
    each block (samples are in time order within a block, a block inside one log)."""
    start = np.r_[True, group[1:] != group[:-1]]
    first = np.maximum.accumulate(np.where(start, np.arange(len(group)), 0))
    position = np.arange(len(group)) - first
    block = np.cumsum(start) - 1
    return block * (10 ** 6) + position // samples_per_window


def _scored_windows(samples: dragfit.DragSamples,
                    per_window: int | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
    band_bias_mps: tuple[float, ...] = ()          # per band: the RMS error a hold of any length keeps
    band_noise_mps_sqrt_s: tuple[float, ...] = ()  # per band: the noise RMS of a 1 s hold (falls as 1/sqrt(T))
    window_s: float = math.nan                     # median scored length of the held-out windows
    # Each held-out window's hold-mean speed error, and each top window's, in an order that depends only
    # on the samples (so two laws' errors on the same samples pair up: dragexponent's test).
    window_errors_mps: np.ndarray | None = field(default=None, compare=False, repr=False)
    top_errors_mps: np.ndarray | None = field(default=None, compare=False, repr=False)
    window_folds: np.ndarray | None = field(default=None, compare=False, repr=False)  # each window's CV fold
    # The folds whose held-out predictions diverged (the figure then mixes clips with errors), of ``folds``.
    diverged: tuple[cvdiverge.FoldDivergence, ...] = field(default=(), compare=False, repr=False)
    folds: int = field(default=0, compare=False, repr=False)

    def diverged_text(self) -> str | None:
        """What the self-check says instead of the figure when folds diverged (cvdiverge.summary)."""
        return cvdiverge.summary(self.diverged, self.folds, self.rms_mps)

    def band_table(self) -> HoldCvBySpeed:
        """The bands as the fit reports them (`hold_cv_by_speed`); ``from_table`` reads them back."""
        return HoldCvBySpeed(self.band_speeds_mps, self.band_rms_mps, self.band_bias_mps, self.band_noise_mps_sqrt_s,
                             self.window_s if math.isfinite(self.window_s) else None)

    @staticmethod
    def from_table(rms_mps: float, table: HoldCvBySpeed | None, extrapolation_mps: float | None = None) -> "HoldCV":
        """A fit report's figures back as a HoldCV (no table: no bands; a report read as JSON:
        HoldCvBySpeed.from_json)."""
        if table is None:
            return HoldCV(rms_mps, (), (), math.nan if extrapolation_mps is None else extrapolation_mps)
        return HoldCV(rms_mps, tuple(table.speeds_mps), tuple(table.rms_mps),
                      math.nan if extrapolation_mps is None else extrapolation_mps,
                      tuple(table.bias_mps), tuple(table.noise_mps_sqrt_s),
                      math.nan if table.window_s is None else table.window_s)

    def predicted(self, speed_mps: float, calibrated_mps: float, scored_s: float | None = None) -> float:
        """The error to expect on a hold at this airflow speed: the band's CV inside the calibrated
        range (linear between bands, clamped), the extrapolation figure beyond it. With ``scored_s``
        (the hold's scored length), the band's bias and noise give the figure for a hold that long."""
        if speed_mps > calibrated_mps and math.isfinite(self.extrapolation_mps):
            return self.extrapolation_mps
        if not self.band_speeds_mps:
            return self.rms_mps
        if scored_s is None or len(self.band_bias_mps) != len(self.band_speeds_mps):
            return float(np.interp(speed_mps, self.band_speeds_mps, self.band_rms_mps))
        bias = np.interp(speed_mps, self.band_speeds_mps, np.square(self.band_bias_mps))
        noise = np.interp(speed_mps, self.band_speeds_mps, np.square(self.band_noise_mps_sqrt_s))
        return float(np.sqrt(bias + noise / max(scored_s, 1e-3)))


def _half_differences(predicted: np.ndarray, truth: np.ndarray, inverse: np.ndarray,
                      count: np.ndarray) -> np.ndarray:
    """Per window: the speed error of its second half (in time) minus that of its first half; NaN for
    a window of fewer than 4 samples. Samples of a window are in time order (dragfit's row order)."""
    order = np.argsort(inverse, kind="stable")
    rank = np.empty_like(inverse)
    rank[order] = np.arange(len(inverse)) - np.repeat(np.cumsum(count) - count, count)
    half = inverse * 2 + (2 * rank >= count[inverse])
    halves = np.full(2 * len(count), np.nan)
    present = np.unique(half)
    halves[present] = window_speed_errors(predicted, truth, half)
    difference = halves[1::2] - halves[0::2]
    return np.where(count >= MIN_SAMPLES_PER_WINDOW, difference, np.nan)


@dataclass(frozen=True)
class _Windows:
    """The held-out windows of one fold: hold-mean speed error, true speed, half difference, length."""
    error_mps: np.ndarray
    speed_mps: np.ndarray
    half_difference_mps: np.ndarray
    length_s: np.ndarray

    @staticmethod
    def joined(parts: list["_Windows"]) -> "_Windows":
        return _Windows(*(np.concatenate([getattr(p, f) for p in parts]) for f in
                          ("error_mps", "speed_mps", "half_difference_mps", "length_s")))


def _held_out(split: dragfit.Split, fit_predict: dragfit.FitPredict, window_s: float) -> _Windows:
    """Hold-mean speed errors, true speeds, half differences and lengths of the held-out samples' windows
    (``split``: fitted on, scored on; windows of ``window_s``)."""
    return _fold(split, fit_predict, window_s)[0]


def _fold(split: dragfit.Split, fit_predict: dragfit.FitPredict,
          window_s: float) -> tuple[_Windows, cvdiverge.FoldDivergence | None]:
    """_held_out's windows, and the fold's divergence (cvdiverge: None when its predictions did not diverge)."""
    held_out = split[1]
    raw = fit_predict(*split)
    divergence = cvdiverge.fold_divergence(split, cvdiverge.unpredicted(raw, held_out.airflow))
    # A diverged prediction counts as the clip (dragfit.prediction_error), never as inf or NaN.
    predicted = held_out.airflow + dragfit.prediction_error(raw, held_out.airflow)
    windows, scored = _scored_windows(held_out, samples_per_window(held_out, window_s))
    predicted, held_out, windows = predicted[scored], held_out.select(scored), windows[scored]
    _, first, inverse, count = np.unique(windows, return_index=True, return_inverse=True, return_counts=True)
    speed = np.bincount(inverse, weights=np.hypot(held_out.airflow[:, 0], held_out.airflow[:, 1])) / count
    # A window lies in one log, so its first sample's rate is the window's.
    length_s = count / held_out.rates_hz()[first]
    return _Windows(window_speed_errors(predicted, held_out.airflow, windows), speed,
                    _half_differences(predicted, held_out.airflow, inverse, count), length_s), divergence


def _split(windows: _Windows, band: np.ndarray) -> tuple[float, float]:
    """(bias RMS, noise RMS x sqrt(s)) of a band of windows; see the module's note."""
    usable = band[np.isfinite(windows.half_difference_mps[band])]
    if not usable.size:
        return float(np.sqrt(np.mean(windows.error_mps[band] ** 2))), 0.0
    noise_var = windows.half_difference_mps[usable] ** 2 / 4.0                 # of each window's mean
    bias_var = max(0.0, float(np.mean(windows.error_mps[usable] ** 2) - np.mean(noise_var)))
    return math.sqrt(bias_var), math.sqrt(float(np.mean(noise_var * windows.length_s[usable])))


def _bands(windows: _Windows) -> tuple[tuple[float, ...], ...]:
    """Per band of windows by true speed: mean speed, RMS error, bias RMS, noise RMS x sqrt(s)."""
    speed, error = windows.speed_mps, windows.error_mps
    order = np.argsort(speed, kind="stable")
    count = int(min(MAX_BANDS, max(1, speed.size // MIN_WINDOWS_PER_BAND)))
    centres: list[float] = []
    rms: list[float] = []
    bias: list[float] = []
    noise: list[float] = []
    for band in np.array_split(order, count):
        centre = float(np.mean(speed[band]))
        if band.size and (not centres or centre > centres[-1]):
            centres.append(centre)
            rms.append(float(np.sqrt(np.mean(error[band] ** 2))))
            b, n = _split(windows, band)
            bias.append(b)
            noise.append(n)
    return tuple(centres), tuple(rms), tuple(bias), tuple(noise)


def hold_cv(samples: dragfit.DragSamples, fit_predict: dragfit.FitPredict,
            window_s: float = HOLD_WINDOW_S) -> HoldCV | None:
    """Hold-level CV on dragfit.grouped_cv's folds, and the same error on the top blocks (those
    dragfit.extrapolation_error holds out) when fitted below them. None with fewer than two blocks.
    The splits of dragfit.fold_splits and top_split: a law the grouped CV scored is not fitted again."""
    scored = [_fold(split, fit_predict, window_s) for split in dragfit.each_fold(samples)]
    if not scored:   # fewer than two blocks
        return None
    parts = [windows for windows, _ in scored]
    diverged = tuple(d for _, d in scored if d is not None)
    held = _Windows.joined(parts)
    folds = np.concatenate([np.full(len(p.error_mps), k) for k, p in enumerate(parts)])
    top = dragfit.top_split(samples)
    extrapolation, top_error = math.nan, None
    if top is not None:
        top_error = _held_out(top, fit_predict, window_s).error_mps
        extrapolation = float(np.sqrt(np.mean(top_error ** 2)))
    centres, rms, bias, noise = _bands(held)
    return HoldCV(float(np.sqrt(np.mean(held.error_mps ** 2))), centres, rms, extrapolation, bias, noise,
                  float(np.median(held.length_s)), held.error_mps, top_error, folds, diverged, len(parts))


# A hold-level gain counts when it is this share (on the held-out holds and the top holds alike) ...
HOLD_GAIN = 0.05
# ... and this many standard errors of the CV folds' mean paired differences (significant_gain).
HOLD_SIGMAS = 2.0


def hold_score(hold: HoldCV | None) -> float:
    """The hold-level counterpart of DragChoice.score: held-out hold means and the top holds."""
    return math.nan if hold is None else dragfit.combined(hold.rms_mps, hold.extrapolation_mps)


def significant_gain(base: HoldCV | None, other: HoldCV | None,
                     gain: float = HOLD_GAIN, sigmas: float = HOLD_SIGMAS) -> bool:
    """``other`` scores ``gain`` below ``base``, on the top holds too, and its held-out windows' squared
    errors fall by ``sigmas`` standard errors or more, paired window by window. The windows of one CV
    fold share one fitted law, so their differences are not independent: the standard error is that of
    the folds' mean differences (one value per fold)."""
    if base is None or other is None or base.window_errors_mps is None or other.window_errors_mps is None:
        return False
    if not hold_score(other) < (1 - gain) * hold_score(base):
        return False
    # The gain must include the top holds: the growth rate is what an exponent changes, and a lower one
    # also cancels the low bias that noise gives a concave inverse at low airflow, which improves the
    # held-out holds while the top holds get worse (a review: 0.014 -> 0.031 m/s on a quadratic law).
    # For a larger parameter set the same holds: extra terms that only fit the slow holds' noise do not
    # carry to the top holds.
    if math.isfinite(base.extrapolation_mps) and not other.extrapolation_mps < (1 - gain) * base.extrapolation_mps:
        return False
    difference = np.asarray(base.window_errors_mps) ** 2 - np.asarray(other.window_errors_mps) ** 2
    folds = base.window_folds if base.window_folds is not None else np.zeros(difference.size, int)
    if difference.shape != np.shape(other.window_errors_mps) or np.shape(folds) != difference.shape:
        return False
    means = np.array([difference[folds == k].mean() for k in np.unique(folds)])
    if means.size < 3:
        return False
    return float(means.mean()) > sigmas * float(means.std(ddof=1)) / math.sqrt(means.size)


def prefer_on_holds(samples: dragfit.DragSamples, tied: tuple[tuple[str, ...], ...]) -> int:
    """Of parameter sets whose per-sample scores tie (dragfit.choose_drag_law: within 2 %, in the order
    of preference, the smallest first), the index of the one to fit: the first, unless another predicts
    the held-out holds significantly better (significant_gain), and then the best of those. The
    per-sample score is dominated by noise and by the transients after each change of airflow, which
    any set fits alike; a term whose worth shows only in hold means (a front/back asymmetry under
    per-axis drag: 0.10 against 0.03 m/s) is otherwise cut by the parsimony rule."""
    base = hold_cv(samples, dragfit.drag_fit_predict(tied[0]))
    best, best_score = 0, math.inf
    for index, active in enumerate(tied[1:], start=1):
        other = hold_cv(samples, dragfit.drag_fit_predict(active))
        if significant_gain(base, other) and hold_score(other) < best_score:
            best, best_score = index, hold_score(other)
    return best
