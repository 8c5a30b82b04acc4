"""Replay's error metrics, accumulated chunk by chunk so that scoring a log needs no whole-log arrays.

A whole log scored at once is one chunk: the streaming replay and ``replay.score_wind`` share this code.
Means are sums over counts, so a log scored in chunks agrees with one pass to rounding (about 1e-15).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from dobwind.model.forceair import wind_from_deg
from dobwind.model.status import accepted, trusted

WARMUP_S = 5.0           # the observer and filter start up: not scored
SEGMENT_SETTLE_S = 5.0   # the start of every segment (a transition) is not scored per segment
MIN_SPEED_FOR_DIRECTION = 1.0
MIN_SEGMENT_SAMPLES = 10


def wrap_deg(a: np.ndarray) -> np.ndarray:
    return (a + 180.0) % 360.0 - 180.0


def from_deg(wind: np.ndarray) -> np.ndarray:
    """Where the wind (rows, NED) blows from, deg clockwise from north, [0, 360)."""
    return wind_from_deg(wind[:, 0], wind[:, 1])


@dataclass
class _Sum:
    """Sum, maximum and count of one error."""
    total: float = 0.0
    peak: float = -math.inf
    count: int = 0

    def add(self, values: np.ndarray) -> None:
        if values.size:
            self.total += float(values.sum())
            self.peak = max(self.peak, float(values.max()))
            self.count += int(values.size)

    def mean(self) -> float | None:
        return self.total / self.count if self.count else None


@dataclass
class _Segments:
    """Per label: the time of its first row, and the count and sums of its scored rows."""
    start: dict[int, float] = field(default_factory=dict)
    count: dict[int, int] = field(default_factory=dict)
    est: dict[int, np.ndarray] = field(default_factory=dict)
    true: dict[int, np.ndarray] = field(default_factory=dict)
    scored: dict[int, list[float]] = field(default_factory=dict)   # first and last scored time (s)

    def add(self, seg: np.ndarray, t: np.ndarray, valid: np.ndarray, wind: np.ndarray, truth: np.ndarray) -> None:
        labels, first, inverse = np.unique(seg, return_index=True, return_inverse=True)
        for label, row in zip(labels.tolist(), first.tolist()):
            self.start.setdefault(int(label), float(t[row]))  # time increases: the first row seen is the first
        starts = np.array([self.start[int(label)] for label in labels.tolist()])
        use = valid & (t >= starts[inverse] + SEGMENT_SETTLE_S)
        idx = inverse[use]
        n = np.bincount(idx, minlength=len(labels))
        sums = [np.column_stack([np.bincount(idx, a[use, k], len(labels)) for k in range(3)]) for a in (wind, truth)]
        first_s, last_s = np.full(len(labels), np.inf), np.full(len(labels), -np.inf)
        np.minimum.at(first_s, idx, t[use])
        np.maximum.at(last_s, idx, t[use])
        for i, label in enumerate(labels.tolist()):
            if n[i]:
                key = int(label)
                self.count[key] = self.count.get(key, 0) + int(n[i])
                self.est[key] = self.est.get(key, np.zeros(3)) + sums[0][i]
                self.true[key] = self.true.get(key, np.zeros(3)) + sums[1][i]
                span = self.scored.setdefault(key, [float(first_s[i]), float(last_s[i])])
                span[1] = float(last_s[i])

    def _scored_s(self, label: int) -> float:
        """The scored length: the span of the scored rows plus one sample period."""
        first, last = self.scored[label]
        n = self.count[label]
        return (last - first) * n / (n - 1) if n > 1 else 0.0

    def table(self) -> list[dict]:
        rows = []
        for s in sorted(self.count):
            if self.count[s] < MIN_SEGMENT_SAMPLES:
                continue
            est_mean, true_mean = self.est[s] / self.count[s], self.true[s] / self.count[s]
            est_speed, true_speed = math.hypot(*est_mean[:2]), math.hypot(*true_mean[:2])
            direction = (abs(float(wrap_deg(from_deg(est_mean[None])[0] - from_deg(true_mean[None])[0])))
                         if true_speed >= MIN_SPEED_FOR_DIRECTION else None)
            rows.append({"segment": s, "true_speed": true_speed, "est_speed": est_speed,
                         "speed_error": est_speed - true_speed, "direction_error": direction,
                         "vertical_error": float(est_mean[2] - true_mean[2]), "samples": self.count[s],
                         "scored_s": self._scored_s(s)})
        return rows


# Unit-named twins of the error keys (issue #15: one JSON style, units in the key names). The short
# names stay beside them: scripts and the demo already read them.
UNIT_KEYS = {"speed_mean": "speed_error_mean_mps", "speed_max": "speed_error_max_mps",
             "direction_mean": "direction_error_mean_deg", "direction_max": "direction_error_max_deg",
             "vertical_mean": "vertical_error_mean_mps", "vertical_max": "vertical_error_max_mps",
             "true_speed": "true_speed_mps", "est_speed": "est_speed_mps", "speed_error": "speed_error_mps",
             "direction_error": "direction_error_deg", "vertical_error": "vertical_error_mps"}


def with_unit_keys(block: dict) -> dict:
    """The block with each short error key followed by its unit-named twin (same value)."""
    out: dict = {}
    for key, value in block.items():
        out[key] = value
        if key in UNIT_KEYS:
            out[UNIT_KEYS[key]] = value
    return out



class WindScore:
    """Feed ``add`` the chunks of a log in order; ``result`` gives replay's metrics dictionary."""

    def __init__(self) -> None:
        self._t0: float | None = None
        self._rows = self._rejected = self._trusted = 0
        self._speed, self._direction, self._vertical = _Sum(), _Sum(), _Sum()
        self._h, self._true_h, self._up = _Sum(), _Sum(), _Sum()
        self._segments = _Segments()
        self._has_segments = False

    def add(self, t: np.ndarray, wind: np.ndarray, truth: np.ndarray, status: np.ndarray,
            segment: np.ndarray | None = None) -> None:
        if self._t0 is None:
            self._t0 = float(t[0])
        ok = accepted(status)
        valid = ok & (t >= self._t0 + WARMUP_S)
        self._rows += len(t)
        self._rejected += int((~ok).sum())
        self._trusted += int(trusted(status[valid]).sum())
        est, true = wind[valid], truth[valid]
        est_h, true_h = np.hypot(est[:, 0], est[:, 1]), np.hypot(true[:, 0], true[:, 1])
        self._speed.add(np.abs(est_h - true_h))
        self._vertical.add(np.abs(est[:, 2] - true[:, 2]))
        strong = true_h >= MIN_SPEED_FOR_DIRECTION
        self._direction.add(np.abs(wrap_deg(from_deg(est[strong]) - from_deg(true[strong]))))
        self._h.add(est_h)
        self._true_h.add(true_h)
        self._up.add(np.abs(est[:, 2]))
        if segment is not None:
            self._has_segments = True
            self._segments.add(segment, t, valid, wind, truth)

    def result(self) -> dict:
        scored = self._speed.count
        result: dict = {"rows": self._rows, "scored_rows": scored, "rejected_rows": self._rejected}
        if not scored:
            return result
        result["trusted_share"] = self._trusted / scored
        result["per_sample"] = with_unit_keys({
            "speed_mean": self._speed.mean(), "speed_max": self._speed.peak,
            "direction_mean": self._direction.mean(), "direction_max": self._direction.peak if self._direction.count else None,
            "vertical_mean": self._vertical.mean(), "vertical_max": self._vertical.peak, "count": scored})
        result["mean_estimated_wind"] = {"horizontal_mps": self._h.mean(), "vertical_mps": self._up.mean(),
                                         "true_horizontal_mps": self._true_h.mean()}
        rows = self._segments.table() if self._has_segments else []
        if rows:
            result["per_segment"] = _segment_summary(rows)
        return result


def _segment_summary(rows: list[dict]) -> dict:
    speed = np.abs([r["speed_error"] for r in rows])
    dirs = np.array([r["direction_error"] for r in rows if r["direction_error"] is not None])
    vert = np.abs([r["vertical_error"] for r in rows])
    return with_unit_keys({"segments": len(rows), "speed_mean": float(speed.mean()), "speed_max": float(speed.max()),
                           "direction_mean": float(dirs.mean()) if dirs.size else None,
                           "direction_max": float(dirs.max()) if dirs.size else None,
                           "vertical_mean": float(vert.mean()), "vertical_max": float(vert.max()),
                           "table": [with_unit_keys(row) for row in rows]})
