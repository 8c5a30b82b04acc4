"""A flight log's columns packed into the step's input rows (the layout of ``StepModel.inputs``)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from dobwind.model.attitude import yaw_from_quaternion
from dobwind.model.step import StepModel
from dobwind.model.signals import log_signals

if TYPE_CHECKING:  # logs.py re-exports this module's functions, so it cannot be imported here at run time
    from dobwind.io.logs import FlightLog


def heading_yaw(log: FlightLog, q: np.ndarray) -> np.ndarray:
    """The heading frame's yaw (rad): the log's yaw_ref, else the vehicle's own yaw from ``q``."""
    return log.columns["yaw_ref"] if log.has("yaw_ref") else yaw_from_quaternion(q)


def step_inputs(model: StepModel, log: FlightLog, previous_t: float | None = None) -> np.ndarray:
    """The step's input rows from a log; the first row's dt is the nominal sample time, or the time since
    ``previous_t`` (the previous chunk's last row) when the log is read in chunks."""
    af = model.airframe
    t = log.time_s
    dt = np.empty_like(t)
    dt[0] = af.observer.sample_time_s if previous_t is None else t[0] - previous_t
    dt[1:] = np.diff(t)
    q = log.stack("q_w", "q_x", "q_y", "q_z")
    values = {"dt": dt, "vel_ned": log.stack("vel_n", "vel_e", "vel_d"), "q": q,
              "yaw_ref": heading_yaw(log, q)}
    if "acc_ned" in model.inputs:
        values["acc_ned"] = log.stack("acc_n", "acc_e", "acc_d")
    if "specific_force" in model.inputs:
        values["specific_force"] = log.stack("sf_x", "sf_y", "sf_z")
    if "rotor_rpm" in model.inputs:
        values["rotor_rpm"] = log.stack(*log_signals(af).rpm_columns())
    if "thrust" in model.inputs:
        values["thrust"] = log.columns["thrust"]
    return model.inputs.pack(values, rows=log.rows)
