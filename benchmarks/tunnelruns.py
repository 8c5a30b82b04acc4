"""The Neural-Fly wind-tunnel runs: which files are there, and their conversion into dobwind's flight logs.

The public data set flies one figure-8 at five tunnel settings with several controllers, one file per
run, named ``custom_figure8_<controller>_<wind>.csv`` or ``<controller>_<wind>.csv`` (some copies
gzipped). Every such file is found, whichever controller flew it, so runs dropped into the folder later
are scored rather than ignored. A file that cannot be read is reported in one line naming it and the
column at fault, and left out; the others go on. Nothing here fits or scores (realdata.py and accuracy_real.py do).
"""
from __future__ import annotations

import ast
import csv
import gzip
import re
import sys
import zlib
from pathlib import Path
from typing import Callable, Iterator, TextIO

import numpy as np
from scipy.spatial.transform import Rotation

from dobwind.core.errors import InputError
from dobwind.io.logs import write_csv

NOMINAL_MPS = {"nowind": 0.0, "35wind": 4.2, "70wind": 8.5, "70p20sint": 8.5, "100wind": 12.1}
BASELINE = "baseline"  # the controller the calibration protocol was written for (issue #12)
FLIP = np.diag([1.0, -1.0, -1.0])  # world (x, y, z up) -> NED, and body FLU -> FRD
RUN_FILE = re.compile(r"custom_figure8_(?P<controller>.+)_(?P<wind>[^_]+)\.csv(?:\.gz)?")
# Some commits of the public repository name the same runs without the trajectory prefix
# (baseline_nowind.csv); a controller name then holds no underscore, so other trajectories' files
# (custom_random_..._nowind.csv) are not taken for figure-8 runs.
SHORT_RUN_FILE = re.compile(r"(?P<controller>[^_]+)_(?P<wind>[^_]+)\.csv(?:\.gz)?")
# The columns the conversion reads, with the numbers each cell holds.
CELL_SIZES = {"t": 1, "v": 3, "R": 9, "T_sp": 1, "hover_throttle": 1}

Runs = dict[str, dict[str, Path]]  # controller -> wind setting -> file


def _stderr(line: str) -> None:
    sys.stderr.write(line + "\n")


def discover(data_dir: Path, warn: Callable[[str], None] = _stderr) -> Runs:
    """Every run file in ``data_dir``, the baseline controller first, then the others by name.

    A run present twice (plain and gzipped, or with and without the custom_figure8_ prefix) is read once
    (the first name in sorted order); a custom_figure8_ file at a wind setting with no known nominal
    speed cannot be scored. Both are said, not dropped silently.
    """
    found: Runs = {}
    for path in sorted(data_dir.glob("*.csv*")) if data_dir.is_dir() else []:
        match = RUN_FILE.fullmatch(path.name) or SHORT_RUN_FILE.fullmatch(path.name)
        if match is None or (match.re is SHORT_RUN_FILE and match["wind"] not in NOMINAL_MPS):
            continue
        controller, wind = match["controller"], match["wind"]
        if wind not in NOMINAL_MPS:
            warn(f"realdata: {path}: wind setting {wind!r} has no nominal speed ({', '.join(NOMINAL_MPS)}); not scored")
            continue
        runs = found.setdefault(controller, {})
        if wind in runs:
            warn(f"realdata: {path}: the same run as {runs[wind].name}; only that one is read")
            continue
        runs[wind] = path
    order = sorted(found, key=lambda c: (c != BASELINE, c))
    return {c: {w: found[c][w] for w in NOMINAL_MPS if w in found[c]} for c in order}


def training_controller(runs: Runs, winds: tuple[str, ...]) -> str | None:
    """The controller whose runs train the fit: the baseline's when it has all of ``winds``, else the
    first other controller that has them (same vehicle, same tunnel), else None."""
    return next((c for c in sorted(runs, key=lambda c: (c != BASELINE, c)) if all(w in runs[c] for w in winds)), None)


def _open(path: Path) -> TextIO:
    return gzip.open(path, "rt", newline="") if path.suffix == ".gz" else open(path, newline="")


def _cell(text: str, size: int) -> np.ndarray:
    """One cell: a plain number, or a bracketed list ("[a, b, c]", nested for R) of ``size`` numbers."""
    try:
        values = np.ravel(np.array(float(text) if size == 1 and "[" not in text else ast.literal_eval(text),
                                   dtype=float))
    except (ValueError, SyntaxError, TypeError, RecursionError):
        values = np.empty(0)
    if values.size != size:
        raise ValueError
    return values


def _rows(handle: TextIO, path: Path) -> Iterator[tuple[int, dict[str, str]]]:
    reader = csv.DictReader(handle)
    missing = [c for c in CELL_SIZES if c not in (reader.fieldnames or [])]
    if missing:
        raise InputError(str(path), f"column{'s' if len(missing) > 1 else ''} {', '.join(map(repr, missing))}",
                         "missing from the header")
    while True:
        first_line = reader.line_num + 1  # a broken quote makes one record span many lines: name its first
        record = next(reader, None)
        if record is None:
            return
        yield first_line, record


def read_run(path: Path) -> dict[str, np.ndarray]:
    """The columns the conversion needs, each as rows x values; InputError names the file, line and column."""
    cells: dict[str, list[np.ndarray]] = {c: [] for c in CELL_SIZES}
    try:
        with _open(path) as handle:
            for line, record in _rows(handle, path):
                for column, size in CELL_SIZES.items():
                    text = record.get(column) or ""
                    try:
                        cells[column].append(_cell(text, size))
                    except ValueError:
                        shown = text if len(text) <= 40 else text[:37] + "..."
                        raise InputError(str(path), f"line {line}, column {column!r}",
                                         f"{shown!r} is not {size} number{'s' if size > 1 else ''}") from None
    except (OSError, EOFError, zlib.error, UnicodeDecodeError, csv.Error) as exc:
        raise InputError(str(path), None, f"not readable ({type(exc).__name__}: {exc})") from None
    if len(cells["t"]) < 2:
        raise InputError(str(path), None, f"{len(cells['t'])} data rows (need 2 or more)")
    return {c: np.array(v) for c, v in cells.items()}


def convert(path: Path, nominal_mps: float, mass_kg: float, gravity: float, out: Path) -> Path:
    """Their columns -> our flight-log CSV (NED, FRD), with the nominal wind (along world -x) as truth."""
    table = read_run(path)
    t = table["t"][:, 0]
    vel = table["v"] @ FLIP
    rot = FLIP @ table["R"].reshape(-1, 3, 3) @ FLIP
    # A row with a NaN in R keeps a NaN attitude, which the estimator rejects by its status.
    finite = np.isfinite(rot).all(axis=(1, 2))
    xyzw = np.full((len(t), 4), np.nan)
    try:
        xyzw[finite] = Rotation.from_matrix(rot[finite]).as_quat()
    except ValueError as exc:
        raise InputError(str(path), "column 'R'", f"not rotation matrices ({exc})") from None
    thrust = mass_kg * gravity * (table["T_sp"][:, 0] / table["hover_throttle"][:, 0])
    wind = np.tile(np.array([-nominal_mps, 0.0, 0.0]), (len(t), 1))  # world -x is NED -x
    cols = {"t": t - t[0], "vel_n": vel[:, 0], "vel_e": vel[:, 1], "vel_d": vel[:, 2], "q_w": xyzw[:, 3],
            "q_x": xyzw[:, 0], "q_y": xyzw[:, 1], "q_z": xyzw[:, 2], "thrust": thrust,
            "wind_n": wind[:, 0], "wind_e": wind[:, 1], "wind_d": wind[:, 2]}
    keep = np.r_[True, np.diff(cols["t"]) > 0]
    write_csv(out, list(cols), np.column_stack([v[keep] for v in cols.values()]), ["%.6f"] + ["%.7g"] * (len(cols) - 1))
    return out


def convert_all(runs: Runs, mass_kg: float, gravity: float, folder: Path,
                warn: Callable[[str], None] = _stderr) -> tuple[Runs, list[dict[str, str]]]:
    """Every run converted into ``folder``; a run that cannot be read is skipped with its reason (one
    line through ``warn``, and listed in the second result)."""
    logs: Runs = {}
    skipped: list[dict[str, str]] = []
    for controller, winds in runs.items():
        for wind, path in winds.items():
            out = folder / f"{controller}_{wind}.csv"
            try:
                logs.setdefault(controller, {})[wind] = convert(path, NOMINAL_MPS[wind], mass_kg, gravity, out)
            except InputError as exc:
                warn(f"realdata: {exc}; run skipped")
                skipped.append({"controller": controller, "wind": wind, "file": str(path), "reason": str(exc)})
    return {c: w for c, w in logs.items() if w}, skipped
