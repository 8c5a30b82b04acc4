"""Bridging a short silence of a topic in replay, instead of restarting the observer's settling.

A topic silent for longer than its tolerance (``resample.GapPolicy``) makes its rows NO_DATA. Until now
replay fed those rows as NaN: the step rejected them, and a rejection restarts the SETTLING period
(``run_s`` = 0), so one lost burst of a 10 Hz position topic cost a whole settling time (seconds) of
trusted rows. A bridged silence instead feeds the step the inputs interpolated across it, as the
resampler does inside a tolerated silence; its rows stay NO_DATA (never trusted) and are written with the
estimate of the row before the silence (``hold_bridged``); the observer is not reset, so the rows after the
silence are trusted as soon as the silence ends. The step and the C are unchanged: only what replay feeds.

How long a silence may be bridged (``bridge_bound_s``) is derived from the estimator, not tuned. Linear
interpolation across a silence keeps the velocity at both ends, hence the mean acceleration over the
silence (the impulse); it only misplaces the acceleration inside it. Model that as the worst case, a unit
step of the force at an unknown instant s0 inside the silence, seen instead as a constant (g - s0) / g
over the whole silence of length g. The estimate is the observer then the low-pass, two first-order lags
(``estimator_lags_s``). A tolerated silence (up to ``GapPolicy.ceiling_s``) is interpolated the same
way, but its rows are trusted: the worst error of any row inside or after it is what replay already
accepts in a trusted row. A silence is bridged when the worst error it leaves in the trusted rows after
it (its after error) is no larger than that. Past ``BRIDGE_CAP_S`` a silence is never bridged: the one
step per silence of the argument stops being a fair model once a whole manoeuvre (a stop and a turn, about
a second for a multirotor's position loop) fits inside it. Silences of several streams that overlap are
one silence for this (``_within_bounds``): some input is interpolated throughout, so a chain of them,
each within its bound, is bridged only when the whole chain is.

Held streams (setpoints: the collective thrust, ArduPilot's CTUN) are not interpolated but held, so the
impulse is not kept: a step at the silence's start is missed until its end, and the error is then
S(t) - S(t - g) (S the step response), which grows with g at every t. The same criterion therefore
gives exactly the ceiling: a held stream is bridged up to ``GapPolicy.ceiling_s`` only.
"""
from __future__ import annotations

import math

import numpy as np

from dobwind.io.resample import gaps

# Twice the longest silence the tolerance interpolates (GapPolicy.ceiling_s): see the module docstring.
BRIDGE_CAP_S = 1.0
_GRID = 201  # instants per axis when searching the worst case; the errors are smooth in both


def estimator_lags_s(gains: tuple[float, ...], mass_kg: float, cutoffs_hz: tuple[float, ...]) -> tuple[float, float]:
    """The time constants (s) of the estimator's fastest observer axis (mass / gain) and of its fastest
    low-pass cutoff: the fastest pair lets the most of an input error through, so the bound derived
    from it holds for every axis and every scheduled cutoff."""
    return mass_kg / max(gains), 1.0 / (2.0 * math.pi * max(cutoffs_hz))


def _step_response(t: np.ndarray, lags: tuple[float, float]) -> np.ndarray:
    """Unit step response of two first-order lags in cascade, zero for t < 0."""
    a, b = lags
    t = np.maximum(t, 0.0)
    if abs(a - b) < 1e-9 * max(a, b):  # equal lags: the limit of the formula below
        return 1.0 - (1.0 + t / a) * np.exp(-t / a)
    return 1.0 - (a * np.exp(-t / a) - b * np.exp(-t / b)) / (a - b)


def _errors(g: float, lags: tuple[float, float], t: np.ndarray) -> np.ndarray:
    """|true - interpolated| estimate at instants t (rows) from the start of a silence [0, g], for a force
    step at each s0 of the grid (columns). The truth is the step response from s0. The interpolation
    sees the same impulse spread evenly: the constant c = (g - s0) / g from 0 to g, then the true 1; its
    response is c S(t) + (1 - c) S(t - g). After g the inputs agree, but the cascade's low-pass still
    catches up with its observer, so the error may grow for a while after the silence (one lag would not)."""
    s0 = np.linspace(0.0, g, _GRID)[None, :]
    t = t[:, None]
    c = (g - s0) / g
    return np.abs(_step_response(t - s0, lags) - c * _step_response(t, lags) - (1 - c) * _step_response(t - g, lags))


def _horizon_s(lags: tuple[float, float]) -> float:
    return 10.0 * max(lags)  # both lags have settled far below any error of interest by then


def after_error(g: float, lags: tuple[float, float]) -> float:
    """The worst error a silence of length g leaves in the rows after it (the first trusted ones), as a
    fraction of the force step."""
    return float(_errors(g, lags, np.linspace(g, g + _horizon_s(lags), 2 * _GRID)).max())


def tolerated_error(ceiling_s: float, lags: tuple[float, float]) -> float:
    """The worst error in any row inside or after a tolerated silence of ``ceiling_s`` (rows replay
    trusts)."""
    return float(_errors(ceiling_s, lags, np.linspace(0.0, ceiling_s + _horizon_s(lags), 3 * _GRID)).max())


def bridge_bound_s(lags: tuple[float, float], ceiling_s: float, cap_s: float = BRIDGE_CAP_S) -> float:
    """The longest silence whose after error is at most the tolerated one (bisection: the after error
    grows with the silence), never below ``ceiling_s`` (which the tolerance already covers) nor above
    ``cap_s``."""
    accepted = tolerated_error(ceiling_s, lags)
    if after_error(cap_s, lags) <= accepted:
        return cap_s
    lo, hi = ceiling_s, cap_s  # after_error(ceiling) <= tolerated_error(ceiling): its rows are among them
    for _ in range(12):  # to 1/4096 of the interval (0.12 ms for 0.5 s): below the millisecond rounded to
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if after_error(mid, lags) <= accepted else (lo, mid)
    return round(lo, 3)  # to the millisecond: ULog and DataFlash clocks are microseconds, rows far coarser


def bridged_rows(streams: dict[str, tuple[np.ndarray, float]], t_dst: np.ndarray,
                 bounds: dict[str, float]) -> np.ndarray:
    """Rows of t_dst inside a gap (``resample.gaps``) of some stream where every stream with a gap there
    has samples on both sides no more than its bound (``bounds[name]``) apart. Rows outside a stream's
    span (before its first or after its last sample) are never bridged: there is nothing to interpolate
    towards. Silences of several streams that overlap or touch make one silence (``_within_bounds``)."""
    in_gap = np.zeros(len(t_dst), dtype=bool)
    bridgeable = np.ones(len(t_dst), dtype=bool)
    first = np.full(len(t_dst), np.inf)    # per row: the earliest sample before a silence it is in
    last = np.full(len(t_dst), -np.inf)    # and the latest sample after one
    bound = np.zeros(len(t_dst))           # and the longest bound among those silences' streams
    for name, (t_src, max_gap) in streams.items():
        covers = t_src[0] <= t_dst[0] and t_src[-1] >= t_dst[-1]
        if covers and (len(t_src) < 2 or float(np.diff(t_src).max()) <= max_gap):
            continue  # no silence beyond its tolerance: no gap row (the cheap test first; gaps() searches)
        own = gaps(t_src, t_dst, max_gap)
        if not own.any():
            continue
        idx = np.searchsorted(t_src, t_dst, side="right")
        inside = (idx > 0) & (t_dst <= t_src[-1])
        before = t_src[np.clip(idx - 1, 0, len(t_src) - 1)]
        after = t_src[np.clip(idx, 0, len(t_src) - 1)]
        in_gap |= own
        bridgeable &= ~own | (inside & (after - before <= bounds[name]))
        first = np.where(own, np.minimum(first, before), first)
        last = np.where(own, np.maximum(last, after), last)
        bound = np.where(own, np.maximum(bound, bounds[name]), bound)
    rows = in_gap & bridgeable
    return rows & _within_bounds(rows, first, last, bound)


def _within_bounds(rows: np.ndarray, first: np.ndarray, last: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """False on each maximal run of ``rows`` whose silences, joined, last longer than the longest bound
    among them. The bound's derivation assumes one silence of at most the bound, with interpolated
    inputs from its first sample to its last; a chain of overlapping silences (the position, then the
    attitude, then the position again) is interpolated without a break over its whole length, so it is
    one silence of that length. A silence of one stream alone is within its bound already."""
    keep = np.ones(len(rows), dtype=bool)
    if not rows.any():
        return keep
    edges = np.diff(np.r_[0, rows.astype(np.int8), 0])
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    # reduceat runs from one start to the next: the rows between two runs are masked out.
    latest = np.maximum.reduceat(np.where(rows, last, -np.inf), starts)
    length = latest - np.minimum.reduceat(np.where(rows, first, np.inf), starts)
    longest = np.maximum.reduceat(np.where(rows, bound, 0.0), starts)
    for start, end, too_long in zip(starts, ends, length > longest):
        keep[start:end] = not too_long
    return keep


def hold_bridged(values: np.ndarray, bridged: np.ndarray) -> np.ndarray:
    """``values`` with each bridged row replaced by the last row before it that is not bridged: a bridged
    row reports the estimate from before the silence, as any row without data does."""
    if not bridged.any():
        return values
    rows = np.arange(len(values))
    source = np.maximum.accumulate(np.where(bridged, 0, rows))
    return values[source]


def airframe_bound_s(af) -> float:
    """``bridge_bound_s`` for an airframe (model.airframe.Airframe), with the resampler's own ceiling."""
    from dobwind.io.resample import DEFAULT_GAP_POLICY

    lags = estimator_lags_s(af.observer.gains, af.mass_kg, af.filter.cutoffs_hz)
    return bridge_bound_s(lags, DEFAULT_GAP_POLICY.ceiling_s)


def largest_silences(streams: dict[str, tuple[np.ndarray, float]], clock: np.ndarray) -> tuple[tuple[str, float, float], ...]:
    """(name, its gap tolerance, its longest interval between samples within the clock's span) per stream:
    which topic to log faster, and whether its silences are within the bridge's bound."""
    out = []
    for name, (t_src, tol) in streams.items():
        inside = t_src[(t_src >= clock[0]) & (t_src <= clock[-1])]
        edges = np.r_[t_src[t_src < clock[0]][-1:], inside, t_src[t_src > clock[-1]][:1]]
        out.append((name, float(tol), float(np.diff(edges).max()) if len(edges) > 1 else 0.0))
    return tuple(out)


def bridge(af, streams: dict[str, tuple[np.ndarray, float]], clock: np.ndarray, gap_rows: np.ndarray,
           not_bridged: np.ndarray, held: tuple[str, ...] = ()) -> tuple[np.ndarray, list[str]]:
    """(rows to bridge, a note) for a reader: ``bridged_rows`` at the airframe's bound for interpolated
    streams and at the ceiling for ``held`` ones (see the module docstring), among ``gap_rows``
    (``resample.source_gaps``) except rows that have another reason not to be fed (``not_bridged``: on
    the ground, a dead ESC). Without such rows nothing is computed (a log without gaps costs nothing)."""
    from dobwind.io.resample import DEFAULT_GAP_POLICY

    if not (gap_rows & ~not_bridged).any():
        return np.zeros(len(clock), dtype=bool), []
    bound = airframe_bound_s(af)
    bounds = {name: DEFAULT_GAP_POLICY.ceiling_s if name in held else bound for name in streams}
    rows = bridged_rows(streams, clock, bounds) & ~not_bridged
    if not rows.any():
        return rows, []
    held_note = f"; held {', '.join(sorted(set(held) & set(streams)))}: {DEFAULT_GAP_POLICY.ceiling_s:g} s" \
        if set(held) & set(streams) else ""
    return rows, [f"{int(rows.sum())} of {len(rows)} instants in silences of at most {bound:g} s{held_note} "
                  "bridged (dobwind/io/bridge.py): the observer runs on through inputs interpolated across "
                  "them, so settling does not restart; the rows stay NO_DATA and repeat the estimate from before"]


def blanked(no_data: np.ndarray, landed: np.ndarray, bridged: np.ndarray | None) -> np.ndarray:
    """Rows a reader blanks (NaN inputs, rejected by the step): no data or on the ground, unless bridged."""
    skip = no_data | landed
    return skip if bridged is None else skip & ~bridged
