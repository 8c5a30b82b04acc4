"""A CSV log to NetCDF in bounded memory: the log is read, stepped and appended chunk by chunk along an
unlimited time dimension, as `replay -o OUT.csv` streams (an hour at 100 Hz held whole took 380 MB).

Each chunk's rows become a Dataset with the same variables and attributes (dobwind/io/netcdf.py); the
first is written with xarray, the rest appended with netCDF4. The position of a CSV row is in the row
itself (lat, lon, alt columns), so no chunk needs another's, except the take-off altitude: the first
finite altitude of the log, carried over.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

import numpy as np

from dobwind.io.csvchunks import BLOCK_BYTES
from dobwind.io.logs import ESTIMATE_COLUMNS, estimate_rows
from dobwind.io.netcdf import Source, dataset_encoding, estimate_dataset, global_attrs, require_xarray
from dobwind.io.position import Geo, RowPosition

POSITION_COLUMNS = ("lat", "lon", "alt")
NO_UTC = "no UTC in CSV logs: time is the log's own t column"


class _Position:
    """The rows' position from their own columns; the take-off altitude is the log's first finite one."""

    def __init__(self) -> None:
        self.takeoff_m: float | None = None

    def rows(self, columns: dict[str, np.ndarray]) -> RowPosition:
        lat, lon, alt = (np.asarray(columns[c], float) for c in POSITION_COLUMNS)
        fix = np.isfinite(lat) & np.isfinite(lon) & (np.abs(lat) <= 90) & ((lat != 0) | (lon != 0))
        lat, lon, alt = (np.where(fix, v, np.nan) for v in (lat, lon, alt))
        if self.takeoff_m is None and np.isfinite(alt).any():
            self.takeoff_m = float(alt[np.flatnonzero(np.isfinite(alt))[0]])
        ground = np.nan if self.takeoff_m is None else self.takeoff_m
        return RowPosition(lat, (lon + 180.0) % 360.0 - 180.0, alt, alt - ground,
                           "altitude above the log's first position (no take-off in the log)")


def stream_csv_netcdf(path: Path, src: Source, chunks, step: Callable, warn: Callable[[Geo], None]) -> None:
    """``chunks``: the log's FlightLog chunks; ``step(log) -> Trajectory`` runs the estimator on one."""
    xr = require_xarray(src.log_path)
    import netCDF4

    position, handle, rows = None, None, 0
    try:
        for log in chunks:
            if handle is None and all(c in log.columns for c in POSITION_COLUMNS):
                position = _Position()
            geo = _geo(position)
            traj = step(log)
            table = estimate_rows(log.time_s, traj.outputs, traj.status)
            cols = {name: table[:, k] for k, name in enumerate(ESTIMATE_COLUMNS)}
            pos = position.rows(log.columns) if position is not None else None
            ds = estimate_dataset(cols, log.time_s, pos, geo, src, xr)
            if handle is None:
                warn(geo)
                title = f"dobwind wind estimate: {src.airframe.name} over {Path(src.log_path).name}"
                ds.attrs = {**global_attrs(src, geo, title), **ds.attrs}
                ds.to_netcdf(path, engine="netcdf4", format="NETCDF4", encoding=dataset_encoding(ds),
                              unlimited_dims=list(ds.dims))
                handle = netCDF4.Dataset(path, "a")
            else:
                _append(handle, ds, rows)
            rows += log.rows
    finally:
        if handle is not None:
            handle.close()


def _geo(position: _Position | None) -> Geo:
    from dobwind.io.position import Track

    if position is None:
        return Geo(None, None, NO_UTC, ("no global position in the log (no lat, lon, alt columns)",))
    empty = np.zeros(0)
    return Geo(Track(empty, empty, empty, empty, "lat, lon, alt columns"), None, NO_UTC)


def _append(handle, ds, start: int) -> None:
    (rows,) = ds.sizes.values()  # one dimension: the rows (time, or log_time without GPS time)
    stop = start + rows
    for name, var in ds.variables.items():
        if var.ndim == 1:
            handle.variables[name][start:stop] = var.values
