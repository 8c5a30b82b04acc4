"""Comparisons with a constant as sets of IEEE 754 bit patterns: exact for every input, NaN included.

A rejection test ``x <= c`` holds for a set of floats; on the raw bit patterns u of x (as unsigned
integers) that set is at most two intervals: the non-negative floats order as their patterns from 0
(+0) to the infinity's, the negative ones from 0x80..0 (-0) to -inf's, and the NaNs lie above each
infinity. ``x <= 0.1`` is u in [0, bits(0.1)] or u in [bits(-0), bits(-inf)]; a NaN is in neither, so
the test fails for it as the IEEE comparison does. The tests of one value combine exactly: ``1e-5 <= dt
<= 0.1`` is the one interval [bits(1e-5), bits(0.1)]. One interval is one subtraction and one unsigned
comparison in C, with no flag (-funsafe-math-optimizations' flush to zero, -ffinite-math-only) able to
change the decision, and no separate NaN-exact path (issue #32: the step's flash).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dobwind.model.kinds import Precision

Interval = tuple[int, int]  # inclusive bounds on the unsigned bit pattern


@dataclass(frozen=True)
class Format:
    """One precision's bit layout."""
    bits: int  # 32 or 64

    @property
    def top(self) -> int:
        return (1 << self.bits) - 1

    @property
    def sign(self) -> int:
        return 1 << (self.bits - 1)

    @property
    def inf(self) -> int:
        return int(np.array(np.inf, dtype=self.dtype).view(self.utype))

    @property
    def dtype(self) -> type:
        return np.float32 if self.bits == 32 else np.float64

    @property
    def utype(self) -> type:
        return np.uint32 if self.bits == 32 else np.uint64

    def pattern(self, value: float) -> int:
        return int(np.array(value, dtype=self.dtype).view(self.utype))

    def value(self, pattern: int) -> float:
        return float(np.array(pattern, dtype=self.utype).view(self.dtype))


def fmt(precision: Precision) -> Format:
    return Format(32 if precision == Precision.SINGLE else 64)


def _key_interval(f: Format, lo_key: int, hi_key: int) -> tuple[Interval, ...]:
    """The patterns of the non-NaN floats whose order key (-|x| for negative x, |x| otherwise; both
    zeros 0) lies in [lo_key, hi_key]."""
    out: list[Interval] = []
    if hi_key >= 0 and lo_key <= f.inf:
        out.append((max(lo_key, 0), min(hi_key, f.inf)))
    if lo_key <= 0 and hi_key >= -f.inf:
        out.append((f.sign + max(-hi_key, 0), f.sign + min(-lo_key, f.inf)))
    return normalized(tuple(out))


def comparison(f: Format, constant_on_left: bool, strict: bool, constant: float) -> tuple[Interval, ...]:
    """The patterns u with ``c < x``, ``c <= x``, ``x < c`` or ``x <= c`` for x the float of u; ``constant``
    is already a float of the format (the caller rounds it to the safe side)."""
    c = f.pattern(constant)
    key = -(c & ~f.sign & f.top) if c & f.sign else c
    if constant_on_left:  # c < x or c <= x
        return _key_interval(f, key + strict, f.inf)
    return _key_interval(f, -f.inf, key - strict)


def normalized(intervals: tuple[Interval, ...]) -> tuple[Interval, ...]:
    """Sorted, merged where they touch or overlap, empty ones dropped."""
    merged: list[list[int]] = []
    for lo, hi in sorted(i for i in intervals if i[0] <= i[1]):
        if merged and lo <= merged[-1][1] + 1:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return tuple((lo, hi) for lo, hi in merged)


def intersection(f: Format, a: tuple[Interval, ...], b: tuple[Interval, ...]) -> tuple[Interval, ...]:
    return normalized(tuple((max(x[0], y[0]), min(x[1], y[1])) for x in a for y in b))


def union(f: Format, a: tuple[Interval, ...], b: tuple[Interval, ...]) -> tuple[Interval, ...]:
    return normalized(a + b)


def complement(f: Format, a: tuple[Interval, ...]) -> tuple[Interval, ...]:
    out, start = [], 0
    for lo, hi in a:
        out.append((start, lo - 1))
        start = hi + 1
    out.append((start, f.top))
    return normalized(tuple(out))


def contains(intervals: tuple[Interval, ...], pattern: int) -> bool:
    return any(lo <= pattern <= hi for lo, hi in intervals)


def wrapped(f: Format, intervals: tuple[Interval, ...]) -> tuple[Interval, ...]:
    """The intervals as printed: one that ends at the top pattern and one that starts at 0 are one interval
    that wraps around (lo > hi), tested with the same subtraction modulo 2^bits."""
    if len(intervals) >= 2 and intervals[0][0] == 0 and intervals[-1][1] == f.top:
        return ((intervals[-1][0], intervals[0][1]),) + intervals[1:-1]
    return intervals
