"""Flight logs (CSV, docs/formats.md) in, estimates (the same page) out.

Reading is fast on the common path (numpy's C parser); when that fails, a careful pass finds the first
bad cell and names its line and column. Empty cells and the words nan/inf are values (the estimator
rejects those rows with a status); text that is not a number is an input error.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.atomic import write_text_atomically as write_atomically
from dobwind.errors import InputError
from dobwind.model.airframe import Airframe
from dobwind.model.step import StepModel

TRUTH_COLUMNS = ("wind_n", "wind_e", "wind_d")
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


def required_columns(af: Airframe) -> list[tuple[str, str]]:
    """(column, what it is for) that the airframe needs."""
    cols = [("t", "sample time"), ("vel_n", "ground velocity"), ("vel_e", "ground velocity"),
            ("vel_d", "ground velocity"), ("q_w", "attitude"), ("q_x", "attitude"), ("q_y", "attitude"),
            ("q_z", "attitude")]
    if af.thrust.source == "rpm":
        cols += [(f"rpm_{i + 1}", "rotor speed") for i in range(af.thrust.rotors)]
    else:
        cols.append(("thrust", "collective thrust"))
    if af.observer.acceleration == "ned":
        cols += [(c, "acceleration (observer.acceleration = \"ned\")") for c in ("acc_n", "acc_e", "acc_d")]
    elif af.observer.acceleration == "specific_force":
        cols += [(c, "specific force (observer.acceleration = \"specific_force\")") for c in ("sf_x", "sf_y", "sf_z")]
    return cols


def _parse_slow(lines: list[str], first_line: int, header: list[str], path: str) -> np.ndarray:
    """Cell by cell, to name the first bad cell exactly."""
    data = np.empty((len(lines), len(header)))
    for r, line in enumerate(lines):
        cells = line.rstrip("\r\n").split(",")
        if len(cells) != len(header):
            raise InputError(path, f"line {first_line + r}", f"has {len(cells)} fields, the header has {len(header)}")
        for c, cell in enumerate(cells):
            text = cell.strip()
            if text == "":
                data[r, c] = math.nan
                continue
            try:
                data[r, c] = float(text)
            except ValueError:
                raise InputError(path, f"line {first_line + r}, column {header[c]}", f"not a number: {text[:40]!r}") from None
    return data


def read_log(path: str | Path, needed: list[tuple[str, str]] | None = None) -> FlightLog:
    path = str(path)
    try:
        with open(path, encoding="utf-8-sig") as handle:  # -sig: a spreadsheet's byte-order mark is not a column name
            text = handle.read()
    except OSError as exc:
        raise InputError(path, None, f"cannot read: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise InputError(path, None, "not UTF-8 text") from None
    lines = text.splitlines()
    start = 0
    while start < len(lines) and (lines[start].startswith("#") or not lines[start].strip()):
        start += 1
    if start >= len(lines):
        raise InputError(path, None, "no header row")
    header = [h.strip() for h in lines[start].split(",")]
    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise InputError(path, f"line {start + 1}, column {dup}", "appears twice in the header")
    body = [ln for ln in lines[start + 1:] if ln.strip()]
    if not body:
        raise InputError(path, None, "no data rows after the header")
    for name, purpose in needed or [("t", "sample time")]:
        if name not in header:
            raise InputError(path, f"column {name}", f"missing ({purpose})")
    try:
        data = np.loadtxt(io.StringIO("\n".join(body)), delimiter=",", ndmin=2, dtype=float)
        if data.shape[1] != len(header):
            raise ValueError
    except ValueError:
        data = _parse_slow(body, start + 2, header, path)
    columns = {name: data[:, i] for i, name in enumerate(header)}
    t = columns["t"]
    if not np.all(np.isfinite(t)):
        bad = int(np.flatnonzero(~np.isfinite(t))[0])
        raise InputError(path, f"line {start + 2 + bad}, column t", "time must be a finite number")
    steps = np.diff(t)
    if np.any(steps <= 0):
        bad = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InputError(path, f"line {start + 2 + bad}, column t", "time must be strictly increasing")
    _check_labels(columns, "segment", path, start + 2)
    return FlightLog(path, columns)


def _check_labels(columns: dict[str, np.ndarray], name: str, path: str, first_line: int) -> None:
    """A label column (segment) holds whole numbers on every row: it groups rows, it is not a measurement."""
    if name not in columns:
        return
    values = columns[name]
    with np.errstate(invalid="ignore"):
        bad = ~np.isfinite(values) | (values != np.round(values)) | (np.abs(values) > 2**31)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(path, f"line {first_line + row}, column {name}", "must be a whole number on every row")


def yaw_from_quaternion(q: np.ndarray) -> np.ndarray:
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def step_inputs(model: StepModel, log: FlightLog) -> np.ndarray:
    """The step's input rows from a log; the first row's dt is the nominal sample time."""
    af = model.airframe
    t = log.time_s
    dt = np.empty_like(t)
    dt[0] = af.observer.sample_time_s
    dt[1:] = np.diff(t)
    q = log.stack("q_w", "q_x", "q_y", "q_z")
    values = {"dt": dt, "vel_ned": log.stack("vel_n", "vel_e", "vel_d"), "q": q,
              "yaw_ref": log.columns["yaw_ref"] if log.has("yaw_ref") else yaw_from_quaternion(q)}
    if "acc_ned" in model.inputs:
        values["acc_ned"] = log.stack("acc_n", "acc_e", "acc_d")
    if "specific_force" in model.inputs:
        values["specific_force"] = log.stack("sf_x", "sf_y", "sf_z")
    if "rotor_rpm" in model.inputs:
        values["rotor_rpm"] = log.stack(*[f"rpm_{i + 1}" for i in range(af.thrust.rotors)])
    if "thrust" in model.inputs:
        values["thrust"] = log.columns["thrust"]
    return model.inputs.pack(values, rows=log.rows)


def write_csv(path: str | Path, header: list[str], data: np.ndarray, formats: list[str],
              comments: list[str] | None = None) -> None:
    def write(handle) -> None:
        for line in comments or []:
            handle.write(f"# {line}\n")
        handle.write(",".join(header) + "\n")
        np.savetxt(handle, data, fmt=formats, delimiter=",")

    write_atomically(path, write)


def write_estimates(path: str | Path, t: np.ndarray, outputs: np.ndarray, status: np.ndarray) -> None:
    if outputs.shape[1] != len(ESTIMATE_COLUMNS) - 2:
        raise ValueError(f"{outputs.shape[1]} output columns for {len(ESTIMATE_COLUMNS) - 2} named ones")
    k = _OUTPUTS_BEFORE_STATUS
    data = np.column_stack([t, outputs[:, :k], status, outputs[:, k:]])
    formats = ["%.6f"] + ["%.6g"] * k + ["%d"] + ["%.6g"] * (outputs.shape[1] - k)
    write_csv(path, list(ESTIMATE_COLUMNS), data, formats)
