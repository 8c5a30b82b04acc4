"""Calibration logs reduced a block of rows at a time, so that `fit`'s memory does not grow with the
logs' length at full rate (issue #13): only what the fit finally reads is kept (decimated drag samples,
chunk means).

A log is read again for each pass it needs (``LogSource.blocks``): a first pass for what every block
needs to know of the whole log (its row count and median sample time), then the calibration step with
its state carried, feeding the drag-law samples (dragfit.LogSampler) and the polynomial family's chunk
means (calpoints.PointsReducer) at once; the results are those of the whole-log functions
(fit.calibration_points, fitfamily.drag_samples), bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator

import numpy as np

from dobwind.calibrate import dragfit
from dobwind.replay.backends import rolled_reference
from dobwind.calibrate.calpoints import PointsReducer
from dobwind.io.csvchunks import BLOCK_BYTES
from dobwind.core.errors import InputError
from dobwind.io.logs import TRUTH_BOUNDS, TRUTH_COLUMNS, FlightLog, heading_yaw, iter_log, required_columns, step_inputs
from dobwind.model import reference
from dobwind.model.airframe import Airframe
from dobwind.model.status import accepted
from dobwind.model.step import StepModel
from dobwind.model.kinds import DragFrame
from dobwind.model.signals import log_signals


@dataclass(frozen=True)
class LogSource:
    """One calibration log, readable from its start as often as needed, a block of rows at a time."""
    path: str
    read: Callable[[], Iterator[FlightLog]]

    def blocks(self) -> Iterator[FlightLog]:
        return self.read()


def _with_zero_truth(log: FlightLog) -> FlightLog:
    zero = np.zeros(log.rows)
    return FlightLog(log.path, {**log.columns, **{c: zero for c in TRUTH_COLUMNS}})


def file_source(path: str, needed: list[tuple[str, str]], bounds: dict[str, float] | None,
                still_air: bool, block_bytes: int = BLOCK_BYTES) -> LogSource:
    """A CSV log read through ``iter_log`` (every check of ``read_log``); still-air logs get zero wind."""
    def read() -> Iterator[FlightLog]:
        for chunk in iter_log(path, needed, block_bytes, bounds=bounds):
            yield _with_zero_truth(chunk.log) if still_air else chunk.log
    return LogSource(path, read)


def memory_source(log: FlightLog, block_rows: int) -> LogSource:
    """A log already in memory (an autopilot log, or a test's), cut into blocks of ``block_rows`` rows."""
    def read() -> Iterator[FlightLog]:
        for lo in range(0, log.rows, block_rows):
            yield FlightLog(log.path, {k: v[lo:lo + block_rows] for k, v in log.columns.items()})
    return LogSource(log.path, read)


def calibration_sources(af: Airframe, log_paths: list[str], still_air: bool = False,
                        block_bytes: int = BLOCK_BYTES,
                        log_reader: Callable[[str, Airframe], FlightLog] | None = None) -> list[LogSource]:
    """fit.read_calibration_logs as sources: the same checks, in the same order (an autopilot log is
    decoded whole: its topics are resampled onto one time base). ``log_reader``: as read_calibration_logs'."""
    from dobwind.io.autopilot import is_autopilot_log, read_autopilot

    if log_reader is not None:
        rows = max(1, block_bytes // 200)
        return [memory_source(log_reader(path, af), rows) for path in log_paths]

    if not still_air:
        needed = required_columns(af) + [(c, "the true wind (fit needs it)") for c in TRUTH_COLUMNS]
        for path in log_paths:
            if is_autopilot_log(path):  # autopilot logs carry no true wind
                raise InputError(path, "wind_n", "an autopilot log has no true wind: give it with --wind SPEED@FROM, "
                                 "--truth FILE.csv, --truth sitl or --wind unknown (or --still-air)")
        return [file_source(path, needed, TRUTH_BOUNDS, False, block_bytes) for path in log_paths]
    rows = max(1, block_bytes // 200)  # about the rows of a CSV block
    return [memory_source(_with_zero_truth(read_autopilot(path, af).log), rows) if is_autopilot_log(path)
            else file_source(path, required_columns(af), None, True, block_bytes) for path in log_paths]


@dataclass(frozen=True)
class LogShape:
    """What every block needs to know of its whole log."""
    rows: int
    dt_s: float   # median sample time (dragfit.median_step)


def sample_rate_hz(shapes: list[LogShape]) -> float:
    """The drag samples' rate for these logs (dragfit.sample_rate_hz of their whole duration)."""
    return dragfit.sample_rate_hz(sum(shape.rows * shape.dt_s for shape in shapes))


def log_shape(source: LogSource, af: Airframe) -> LogShape:
    """A first pass over the log (it also raises any input error before the fit starts). Its times are
    kept for the median only: 8 bytes a row, freed before the fit's larger arrays are made."""
    t = np.concatenate([block.time_s for block in source.blocks()])
    return LogShape(len(t), dragfit.median_step(t, af))


class StepStream:
    """A step model over one log's consecutive blocks with its state carried (reference.run_columns
    on each block: the numbers of one pass)."""

    def __init__(self, model: StepModel) -> None:
        # The reference as CasADi's compiled C when a compiler builds it: the VM's numbers (backends).
        self.model, self.rolled = model, rolled_reference(model)
        self.state: np.ndarray | None = None
        self.previous_t: float | None = None

    def run(self, log: FlightLog, outputs: slice) -> reference.Trajectory:
        """Every state column and the ``outputs`` columns of the block."""
        traj = reference.run_columns(self.model, step_inputs(self.model, log, self.previous_t), slice(None),
                                     outputs, self.state, self.rolled)
        self.state, self.previous_t = traj.states[-1].copy(), float(log.time_s[-1])
        return traj


class DragReducer:
    """fitfamily.drag_samples for one log, block by block: the step's rejections carried (a row is
    usable a settling time after the last one) and one LogSampler per drag-law frame."""

    def __init__(self, cal: Airframe, settle_s: float, dt_s: float, frames: tuple[DragFrame, ...],
                 rate_hz: float = dragfit.DECIMATED_RATE_HZ) -> None:
        self.cal, self.settle = cal, settle_s
        self.samplers = {frame: dragfit.LogSampler(cal, cal.filter.cutoffs_hz[0], dt_s, frame, rate_hz=rate_hz)
                         for frame in frames}
        self.last_reject: float | None = None

    def add(self, log: FlightLog, force: np.ndarray, status: np.ndarray) -> None:
        t = log.time_s
        q = log.stack("q_w", "q_x", "q_y", "q_z")
        yaw = heading_yaw(log, q)
        rejected = ~accepted(status)
        if self.last_reject is None:
            rejected[0] = True
        last_reject = np.maximum.accumulate(np.r_[-np.inf if self.last_reject is None else self.last_reject, np.where(rejected, t, -np.inf)])[1:]
        self.last_reject = float(last_reject[-1])
        usable = ~rejected & (t - last_reject >= self.settle)
        airflow = log.true_wind - log.stack("vel_n", "vel_e", "vel_d")
        af = self.cal
        rpm = log.stack(*log_signals(af).rpm_columns()) if log_signals(af).rotor_speeds else None
        thrust = dragfit.thrust_ned(af, rpm, log.columns.get("thrust"), q)
        for frame, sampler in self.samplers.items():
            sampler.add(t, force, airflow, thrust, yaw, usable, q, log.columns.get("segment"))

    def result(self, frame: DragFrame) -> dict[str, np.ndarray]:
        return self.samplers[frame].result()


def points_reducer(model: StepModel, shape: LogShape, dynamic: bool, group_base: int) -> PointsReducer:
    return PointsReducer(model.settling_time_s + 1.0, shape.dt_s, shape.rows, dynamic, group_base)


@dataclass(frozen=True)
class Reduced:
    """A pass over every log: each drag-law frame's samples per log, and the chunk means (with their
    settling time) when asked for."""
    samples: dict[str, list[dict[str, np.ndarray]]]
    chunks: list[dict[str, float]] | None
    settle_s: float


def reduce_logs(af: Airframe, sources: list[LogSource], shapes: list[LogShape], frames: tuple[DragFrame, ...],
                dynamic: bool, points: bool) -> Reduced:
    """The calibration airframe's step over each log a block at a time (one pass for the drag samples
    and the chunk means alike, as fit.calibration_run is shared)."""
    from dobwind.calibrate.fit import calibration_airframe, heading_rows
    from dobwind.model.step import build_step

    cal = calibration_airframe(af)
    model = build_step(cal)
    force_columns, v_columns = model.outputs.slice("force_ned"), model.state.slice("v_filt")
    samples: dict[str, list[dict[str, np.ndarray]]] = {frame: [] for frame in frames}
    chunks: list[dict[str, float]] = []
    group_base = 0
    rate_hz = sample_rate_hz(shapes)
    for source, shape in zip(sources, shapes):
        stepper = StepStream(model)
        drag = DragReducer(cal, model.settling_time_s, shape.dt_s, frames, rate_hz)
        reducer = points_reducer(model, shape, dynamic, group_base) if points else None
        for block in source.blocks():
            traj = stepper.run(block, force_columns)
            drag.add(block, traj.outputs, traj.status)
            if reducer is not None:
                reducer.add(*heading_rows(block, traj.outputs, traj.states[:, v_columns], traj.status))
        for frame in frames:
            samples[frame].append(drag.result(frame))
        if reducer is not None:
            log_chunks, group_base = reducer.finish()
            chunks += log_chunks
    return Reduced(samples, chunks if points else None, model.settling_time_s + 1.0)
