"""The polynomial family's calibration points (fit.calibration_points) from one log fed a block of rows
at a time, with what one pass over the whole log gives, bit for bit.

The cleaning smooths the airflow and the yaw with centred moving means, so a row's smoothed value needs
rows after it: ``MovingMean`` holds rows back until their window is complete and keeps the last window
of rows as the next block's history. Everything after the smoothing runs in time order with its state
carried (the last change, the run count, the previous smoothed row); a steady run's rows are kept until
the run ends, since its 2 s chunks are laid out from its first to its last steady row.
"""
from __future__ import annotations

import math

import numpy as np

CHUNK_S = 2.0
YAW_RATE_CHANGE_DEG_S = 2.0
AIRFLOW_CHANGE_MPS2 = 0.25
MIN_CHUNK_ROWS = 5
POINT_KEYS = ("m", "n", "fz", "speed_h", "air_z", "air_angle", "group")


def moving_mean(x: np.ndarray, window: int) -> np.ndarray:
    """Centred moving mean of each column (np.convolve "same"); ``window`` at most len(x)."""
    kernel = np.ones(window) / window
    return np.column_stack([np.convolve(x[:, i], kernel, mode="same") for i in range(x.shape[1])])


class MovingMean:
    """moving_mean over consecutive blocks: a row comes out once the rows after it that its window
    reaches have come in (all of them at ``finish``). Each window is computed over the same rows by
    the same convolution as in one pass; the convolution always sees at least a window of rows (a
    shorter input would swap its operands)."""

    def __init__(self, window: int, columns: int) -> None:
        self.window, self.ahead = window, (window - 1) // 2
        self.history = np.empty((0, columns))  # the last rows already out (none before the first output)
        self.pending = np.empty((0, columns))

    def add(self, x: np.ndarray) -> np.ndarray:
        self.pending = np.concatenate([self.pending, x])
        if len(self.history) + len(self.pending) < self.window + self.ahead:
            return self.pending[:0]
        return self._emit(len(self.pending) - self.ahead)

    def finish(self) -> np.ndarray:
        return self._emit(len(self.pending))

    def _emit(self, count: int) -> np.ndarray:
        rows = np.concatenate([self.history, self.pending])
        out = moving_mean(rows, self.window)[len(self.history):len(self.history) + count]
        done = len(self.history) + count
        self.history, self.pending = rows[max(0, done - self.window):done], rows[done:]
        return out


class Unwrap:
    """np.unwrap (default period 2 pi) over consecutive blocks: the correction's running sum carried."""

    def __init__(self) -> None:
        self.last: float | None = None
        self.total = 0.0

    def __call__(self, p: np.ndarray) -> np.ndarray:
        rows = p if self.last is None else np.r_[self.last, p]
        dd = np.diff(rows)
        ddmod = np.mod(dd + math.pi, 2 * math.pi) - math.pi
        np.copyto(ddmod, math.pi, where=(ddmod == -math.pi) & (dd > 0))
        correction = ddmod - dd
        np.copyto(correction, 0, where=np.abs(dd) < math.pi)
        summed = np.cumsum(np.r_[self.total, correction])[1:] if self.last is not None else np.cumsum(correction)
        out = rows[1:] + summed if self.last is not None else np.r_[rows[:1], rows[1:] + summed]
        self.last = float(p[-1])
        self.total = float(summed[-1]) if len(summed) else self.total
        return out


class _Rows:
    """Rows of several named arrays waiting for their smoothed values."""

    def __init__(self) -> None:
        self.parts: dict[str, list[np.ndarray]] = {}

    def push(self, **arrays: np.ndarray) -> None:
        for key, value in arrays.items():
            self.parts.setdefault(key, []).append(value)

    def pop(self, count: int) -> dict[str, np.ndarray]:
        whole = {k: np.concatenate(v) for k, v in self.parts.items()}
        self.parts = {k: [v[count:]] for k, v in whole.items()}
        return {k: v[:count] for k, v in whole.items()}


class PointsReducer:
    """One log's chunk means. ``add`` takes a block's time, heading-frame force and true relative
    airflow, yaw (rad) and acceptance by the step; ``finish`` returns the chunks (dicts of POINT_KEYS)
    and the next log's group base. ``rows`` and ``dt_s`` are the whole log's row count and median step."""

    def __init__(self, settle_s: float, dt_s: float, rows: int, dynamic: bool, group_base: int) -> None:
        self.settle, self.dynamic, self.group_base = settle_s, dynamic, group_base
        # Smoothed over the settling time: turbulence must not count as a change, a wind step must. Smoothed
        # over a second: attitude noise on a real log is several deg/s sample to sample.
        self.air = MovingMean(max(1, min(int(round(max(settle_s, 3.0) / dt_s)), rows)), 3)
        self.yaw = MovingMean(max(1, min(int(round(1.0 / dt_s)), rows)), 1)
        self.unwrap = Unwrap()
        self.rows = _Rows()
        self.ready: dict[str, list[np.ndarray]] = {"air": [], "yaw": []}
        self.previous: tuple[float, np.ndarray, float] | None = None  # t, smoothed airflow, smoothed yaw
        self.last_change, self.run_count = -math.inf, 0   # the last change's time, the runs so far
        self.open_run = -1                                  # the run whose steady rows are kept
        self.run: dict[str, list[np.ndarray]] = {}
        self.chunks: list[dict[str, float]] = []

    def add(self, t: np.ndarray, f_c: np.ndarray, rel_c: np.ndarray, yaw: np.ndarray, ok: np.ndarray) -> None:
        self.rows.push(t=t, f_c=f_c, rel_c=rel_c, ok=ok)
        self._smoothed(self.air.add(rel_c), self.yaw.add(self.unwrap(yaw)[:, None]))

    def finish(self) -> tuple[list[dict[str, float]], int]:
        self._smoothed(self.air.finish(), self.yaw.finish())
        self._close_run()
        return self.chunks, self.group_base + self.run_count + 1

    def _smoothed(self, air: np.ndarray, yaw: np.ndarray) -> None:
        """Rows whose both smoothed values are known go on to the change detection."""
        self.ready["air"].append(air)
        self.ready["yaw"].append(yaw[:, 0])
        air_all, yaw_all = (np.concatenate(self.ready[k]) for k in ("air", "yaw"))
        count = min(len(air_all), len(yaw_all))
        self.ready = {"air": [air_all[count:]], "yaw": [yaw_all[count:]]}
        if count:
            self._changes(self.rows.pop(count), air_all[:count], yaw_all[:count])

    def _changes(self, rows: dict[str, np.ndarray], smooth: np.ndarray, smooth_yaw: np.ndarray) -> None:
        t = rows["t"]
        if self.previous is None:
            airflow_rate = np.r_[0.0, np.linalg.norm(np.diff(smooth, axis=0), axis=1) / np.diff(t)]
            yaw_rate = np.r_[0.0, np.degrees(np.abs(np.diff(smooth_yaw))) / np.diff(t)]
        else:
            t0, air0, yaw0 = self.previous
            airflow_rate = np.linalg.norm(np.diff(np.r_[air0[None], smooth], axis=0), axis=1) / np.diff(np.r_[t0, t])
            yaw_rate = np.degrees(np.abs(np.diff(np.r_[yaw0, smooth_yaw]))) / np.diff(np.r_[t0, t])
        change = (yaw_rate > YAW_RATE_CHANGE_DEG_S) | ~rows["ok"]
        if not self.dynamic:
            change |= airflow_rate > AIRFLOW_CHANGE_MPS2
        if self.previous is None:
            change[0] = True
        self.previous = (float(t[-1]), smooth[-1].copy(), float(smooth_yaw[-1]))
        last_change = np.maximum.accumulate(np.r_[self.last_change, np.where(change, t, -np.inf)])[1:]
        self.last_change = float(last_change[-1])
        steady = (t - last_change) >= self.settle
        run_id = self.run_count + np.cumsum(change)
        self.run_count = int(run_id[-1])
        steady_rows = np.flatnonzero(steady)
        # A run's rows are consecutive: the steady rows split where their run changes.
        for piece in np.split(steady_rows, np.flatnonzero(np.diff(run_id[steady_rows])) + 1):
            if not len(piece):
                continue
            if run_id[piece[0]] != self.open_run:
                self._close_run()
                self.open_run = int(run_id[piece[0]])
            for key in ("t", "f_c", "rel_c"):
                self.run.setdefault(key, []).append(rows[key][piece])

    def _close_run(self) -> None:
        """The current run's 2 s chunks (from its first steady row), when it had steady rows."""
        run = {k: np.concatenate(v) for k, v in self.run.items()}
        self.run = {}
        if not run or not len(run["t"]):
            return
        t, f_c, rel_c = run["t"], run["f_c"], run["rel_c"]
        bounds = np.arange(t[0], t[-1] + 1e-9, CHUNK_S / 2 if self.dynamic else CHUNK_S)
        for a, b in zip(bounds[:-1], bounds[1:]):
            sel = np.flatnonzero((t >= a) & (t < b))
            if len(sel) < MIN_CHUNK_ROWS:
                continue
            fm, rm = f_c[sel].mean(axis=0), rel_c[sel].mean(axis=0)
            self.chunks.append({"m": fm[0], "n": fm[1], "fz": fm[2], "speed_h": math.hypot(rm[0], rm[1]),
                                "air_z": rm[2], "air_angle": math.atan2(rm[1], rm[0]),
                                "group": self.group_base + self.open_run})
