"""Flight logs (CSV, docs/formats.md) in, estimates (the same page) out.

Packing a log into the step's inputs is ``dobwind.io.inputs`` (re-exported here for the older import path);
the quaternion maths is ``dobwind.model.attitude``.

Logs are read in bounded chunks (``iter_log``, see csvchunks.py) so that replay's memory does not grow
with the log; ``read_log`` joins them for the commands that need the whole log. Empty cells and the
words nan/inf are values (the estimator rejects those rows with a status); text that is not a number is
an input error naming its true line and column.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, TextIO

import numpy as np

from dobwind.io.atomic import write_text_atomically as write_atomically
from dobwind.io.csvchunks import BLOCK_BYTES, read_blocks, read_header
from dobwind.core.errors import InputError
from dobwind.model.airframe import Airframe

TRUTH_COLUMNS = ("wind_n", "wind_e", "wind_d")
# The largest true wind component a calibration log may hold (m/s): hurricanes reach 70 m/s and no
# multirotor flies in 100 (the airframe's filter.speeds stop there too). Beyond it a value is a unit or
# export error, and fitting it gives coefficients of 1e299 and an infinite RMSE (issue #16).
TRUE_WIND_MAX_MPS = 100.0
TRUTH_BOUNDS = {name: TRUE_WIND_MAX_MPS for name in TRUTH_COLUMNS}
# The step's outputs in their order, with status inserted where the original format had it last: new
# outputs are appended after it so that readers of the older columns keep working.
ESTIMATE_COLUMNS = ("t", "force_n", "force_e", "force_d", "wind_n", "wind_e", "wind_d", "wind_speed_h",
                    "wind_speed_up", "wind_from_deg", "status", "wind_sigma_h", "wind_sigma_up")
_OUTPUTS_BEFORE_STATUS = ESTIMATE_COLUMNS.index("status") - 1


@dataclass(frozen=True)
class FlightLog:
    path: str
    columns: dict[str, np.ndarray]  # every numeric column by name

    @property
    def time_s(self) -> np.ndarray:
        return self.columns["t"]

    @property
    def rows(self) -> int:
        return len(self.time_s)

    def has(self, *names: str) -> bool:
        return all(n in self.columns for n in names)

    def stack(self, *names: str) -> np.ndarray:
        return np.column_stack([self.columns[n] for n in names])

    @property
    def true_wind(self) -> np.ndarray | None:
        return self.stack(*TRUTH_COLUMNS) if self.has(*TRUTH_COLUMNS) else None


def airframe_given_as_log(path: str) -> str:
    """What to add to a missing-column error when the "log" is a TOML file: most likely the airframe,
    given where the log belongs (arguments swapped, or the airframe given twice)."""
    if not str(path).lower().endswith(".toml"):
        return ""
    return ("; a .toml file is an airframe, not a flight log (replay, fit and report take AIRFRAME then LOG; "
            "inspect and init take the log alone)")


# What only dobwind's own estimate (replay -o) holds: a flight log has none of these.
_ESTIMATE_SIGNATURE = ("force_n", "status", "wind_sigma_h")


def refuse_an_estimate(path: str, header: list[str] | tuple[str, ...]) -> None:
    """An estimate CSV given where a flight log belongs (`replay A e.csv`, `init e.csv`): said as such, not
    as a missing ground velocity or thrust column."""
    if all(name in header for name in _ESTIMATE_SIGNATURE) and "vel_n" not in header:
        raise InputError(path, None, "is a dobwind estimate (replay's -o: force_n, wind_n, status, ... columns), "
                         "not a flight log: give the flight log it was replayed from")


def required_columns(af: Airframe) -> list[tuple[str, str]]:
    """(column, what it is for) that the airframe needs (model/signals.py)."""
    return log_signals(af).columns()


@dataclass(frozen=True)
class LogChunk:
    """A run of consecutive rows of a log: ``log`` holds them (same columns as the whole log), ``lines``
    their file line numbers, ``first_row`` the index of the first one in the whole log."""
    log: FlightLog
    lines: np.ndarray
    first_row: int


def iter_log(path: str | Path, needed: list[tuple[str, str]] | None = None,
             block_bytes: int = BLOCK_BYTES, progress: Callable[[int], None] | None = None,
             bounds: dict[str, float] | None = None) -> Iterator[LogChunk]:
    """The log in bounded chunks, every check of ``read_log`` applied (time increasing across chunks
    too). ``progress`` is told how many bytes each chunk took. ``bounds``: column -> largest magnitude
    a value may have (NaN, an empty cell, stays a missing value)."""
    path = str(path)
    try:
        handle = open(path, "rb")
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    with handle:
        header = read_header(handle, path)
        refuse_an_estimate(path, header.names)
        for name, purpose in needed or [("t", "sample time")]:
            if name not in header.names:
                raise InputError(path, f"column {name}", f"missing ({purpose}){airframe_given_as_log(path)}")
        done, rows, last_t = handle.tell(), 0, -math.inf
        for block in read_blocks(handle, header, path, block_bytes):
            columns = {name: block.data[:, i] for i, name in enumerate(header.names)}
            last_t = _check_time(columns["t"], last_t, block.lines, path)
            _check_labels(columns, "segment", path, block.lines)
            _check_bounds(columns, bounds or {}, path, block.lines)
            yield LogChunk(FlightLog(path, columns), block.lines, rows)
            rows += len(block.lines)
            if progress is not None:
                progress(handle.tell() - done)
                done = handle.tell()
        if rows == 0:
            raise InputError(path, None, "no data rows after the header")


def _check_time(t: np.ndarray, previous: float, lines: np.ndarray, path: str) -> float:
    """Finite and strictly increasing, from the previous chunk's last time on; returns the last time."""
    if not np.all(np.isfinite(t)):
        bad = int(np.flatnonzero(~np.isfinite(t))[0])
        raise InputError(path, f"line {lines[bad]}, column t", "time must be a finite number")
    steps = np.diff(t, prepend=previous)
    if np.any(steps <= 0):
        bad = int(np.flatnonzero(steps <= 0)[0])
        raise InputError(path, f"line {lines[bad]}, column t", "time must be strictly increasing")
    return float(t[-1])


def _check_bounds(columns: dict[str, np.ndarray], bounds: dict[str, float], path: str, lines: np.ndarray) -> None:
    for name, limit in bounds.items():
        if name not in columns:
            continue
        with np.errstate(invalid="ignore"):
            bad = np.abs(columns[name]) > limit  # NaN compares False: a missing value, not an error
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise InputError(path, f"line {lines[row]}, column {name}",
                             f"{columns[name][row]:g} is beyond +-{limit:g}")


def read_log(path: str | Path, needed: list[tuple[str, str]] | None = None,
             bounds: dict[str, float] | None = None) -> FlightLog:
    """The whole log in memory (fit and the plots need it); replay streams with ``iter_log``."""
    chunks = [chunk.log.columns for chunk in iter_log(path, needed, bounds=bounds)]
    names = list(chunks[0])
    if len(chunks) == 1:
        return FlightLog(str(path), chunks[0])
    return FlightLog(str(path), {n: np.concatenate([c.pop(n) for c in chunks]) for n in names})


def _check_labels(columns: dict[str, np.ndarray], name: str, path: str, lines: np.ndarray) -> None:
    """A label column (segment) holds whole numbers on every row: it groups rows, it is not a measurement."""
    if name not in columns:
        return
    values = columns[name]
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(values) | (values != np.round(values)) | (np.abs(values) > 2**31)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(path, f"line {lines[row]}, column {name}", "must be a whole number on every row")


WRITE_ROWS = 4096  # rows per formatting call: bounded memory, and few enough calls to cost nothing


class CsvWriter:
    """Writes rows a block at a time, as one %-format over a whole block would (np.savetxt's text byte
    for byte: the same printf conversions). The compiled row formatter (harness/cformat.py) prints
    those bytes when a compiler is there, about four times faster; else, or with ``compiled=False``,
    `%` does."""

    def __init__(self, handle: TextIO, header: list[str], formats: list[str], comments: list[str] | None = None,
                 compiled: bool = True) -> None:
        if len(formats) != len(header):
            raise ValueError(f"{len(formats)} formats for {len(header)} columns")
        self._handle = handle
        self._row = ",".join(formats) + "\n"
        self._compiled = None
        if compiled:
            from dobwind.harness.cformat import row_formatter

            self._compiled = row_formatter(formats)
        for line in comments or []:
            handle.write(f"# {line}\n")
        handle.write(",".join(header) + "\n")

    def write(self, data: np.ndarray) -> None:
        for start in range(0, len(data), WRITE_ROWS):
            block = data[start:start + WRITE_ROWS]
            text = self._compiled.format(block) if self._compiled is not None else None
            if text is not None:
                self._handle.write(text.decode("ascii"))
            else:  # no compiler, or a value only `%` prints (or refuses, with Python's own error)
                self._handle.write((self._row * len(block)) % tuple(block.ravel().tolist()))


def write_csv(path: str | Path, header: list[str], data: np.ndarray, formats: list[str],
              comments: list[str] | None = None) -> None:
    write_atomically(path, lambda handle: CsvWriter(handle, header, formats, comments).write(data))


def write_columns(path: str | Path, header: list[str], columns: dict[str, np.ndarray], formats: list[str],
                  comments: list[str] | None = None) -> None:
    """write_csv from named columns, stacked a block at a time (no second copy of a long log)."""
    def write(handle: TextIO) -> None:
        writer = CsvWriter(handle, header, formats, comments)
        rows = len(columns[header[0]])
        for start in range(0, rows, WRITE_ROWS):
            writer.write(np.column_stack([columns[n][start:start + WRITE_ROWS] for n in header]))

    write_atomically(path, write)


def estimate_rows(t: np.ndarray, outputs: np.ndarray, status: np.ndarray, estimated_before: bool = False) -> np.ndarray:
    """The estimate file's rows (section 3's column order) from the step's outputs. Rows before the
    first accepted sample hold no estimate: NaN values and sigma -1 (unknown), not the step's initial
    zeros, which read as a calm, perfectly known wind. ``estimated_before``: an earlier chunk of the
    same log already had an accepted sample."""
    if outputs.shape[1] != len(ESTIMATE_COLUMNS) - 2:
        raise ValueError(f"{outputs.shape[1]} output columns for {len(ESTIMATE_COLUMNS) - 2} named ones")
    k = _OUTPUTS_BEFORE_STATUS
    rows = np.column_stack([t, outputs[:, :k], status, outputs[:, k:]])
    if not estimated_before:
        from dobwind.model.status import accepted

        ok = accepted(status)
        first = int(np.argmax(ok)) if ok.any() else len(rows)
        rows[:first, 1:k + 1] = np.nan
        rows[:first, k + 2:] = -1.0
    return rows


def estimate_writer(handle: TextIO) -> CsvWriter:
    k = _OUTPUTS_BEFORE_STATUS
    formats = ["%.6f"] + ["%.6g"] * k + ["%d"] + ["%.6g"] * (len(ESTIMATE_COLUMNS) - 2 - k)
    return CsvWriter(handle, list(ESTIMATE_COLUMNS), formats)


def write_estimates(path: str | Path, t: np.ndarray, outputs: np.ndarray, status: np.ndarray,
                    t0_s: float = 0.0) -> None:
    """``t0_s``: the log's own clock at t = 0 (autopilot logs), so that `t` lines up with the log's tools."""
    rows = estimate_rows(t + t0_s, outputs, status)
    write_atomically(path, lambda handle: estimate_writer(handle).write(rows))


# The older import path of the input packing (dobwind.io.inputs imports nothing from this module at run time).
from dobwind.io.inputs import heading_yaw, step_inputs  # noqa: E402,F401
from dobwind.model.attitude import yaw_from_quaternion  # noqa: E402,F401
from dobwind.model.signals import log_signals
