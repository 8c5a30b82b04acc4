"""`replay -o OUT.nc`: the estimate as a CF-1.8 NetCDF trajectory (xarray + netCDF4, extra `netcdf`).

One row per estimate row, on the log's own clock: UTC (``time``, seconds since 1970-01-01) where the
log has GPS time, else seconds since the autopilot booted (``time`` in s, no reference date). Latitude,
longitude, altitude and height above take-off come from the log's global position (dobwind/io/position.py);
a log without one is still written, without them, and says so in ``position_note``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.io import cfnames
from dobwind.core.errors import InputError
from dobwind.io.logs import ESTIMATE_COLUMNS, estimate_rows
from dobwind.model.airframe import Airframe
from dobwind.io.position import Geo, RowPosition, on_rows

NETCDF_SUFFIXES = (".nc", ".nc4", ".netcdf")
UNKNOWN_SIGMA = -1.0  # what the step outputs when the airframe has no [uncertainty] table


def is_netcdf(path: str | Path | None) -> bool:
    return path is not None and str(path).lower().endswith(NETCDF_SUFFIXES)


@dataclass(frozen=True)
class Source:
    """What the file says about where its numbers come from (global attributes)."""
    airframe: Airframe
    airframe_path: str
    log_path: str
    backend: str


def require_xarray(path: str):
    try:
        import xarray
        import netCDF4  # noqa: F401 - the engine; without it xarray would pick another or fail later
    except ImportError:
        raise InputError(path, None, "writing NetCDF needs xarray and netCDF4 (pip install 'dobwind[netcdf]')") from None
    return xarray


def _version() -> str:
    from dobwind import __version__

    return __version__


def calibration_text(af: Airframe) -> str:
    """The airframe's calibration provenance, as far as the file records it."""
    parts = [f"force-air model {af.force_air_model}"]
    parts.append("calibrated envelope present (written by dobwind fit)" if af.envelope is not None
                 else "no calibrated envelope (an uncalibrated prior or a hand-written model)")
    parts.append("uncertainty table present" if af.uncertainty is not None else "no uncertainty table (sigma unknown)")
    return "; ".join(parts)


def time_response_text(af: Airframe, rate_hz: float | None = None) -> str:
    """How much of the past each estimate averages (an attribute a meteorologist needs to compare rows with
    a mast's 1 s or 10 min means): the output of causal filters, not a block mean. ``rate_hz``: the rows'
    own rate (an autopilot log replayed with --rate), by default the airframe's observer rate."""
    rate = 1.0 / af.observer.sample_time_s if rate_hz is None or not np.isfinite(rate_hz) else rate_hz
    steps = ", ".join(f"{c:g} Hz at {v:g} m/s (time constant {1.0 / (2.0 * np.pi * c):.2f} s)"
                      for v, c in zip(af.filter.speeds_mps, af.filter.cutoffs_hz))
    return (f"each row is the output of causal filters at {rate:.4g} Hz, not a block "
            f"mean: the disturbance observer, then a first-order low-pass whose cutoff follows the estimated "
            f"horizontal wind speed ({steps}, linear between, held outside): neighbouring rows are correlated "
            "and the estimate lags the wind (`dobwind analyze AIRFRAME` gives the bandwidth and the ramp lag)")


def rows_rate_hz(t: np.ndarray) -> float | None:
    """The rows' rate from their clock's median step (None under two rows)."""
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    return 1.0 / step if step > 0.0 else None


def global_attrs(src: Source, geo: Geo, title: str, rate_hz: float | None = None) -> dict[str, str]:
    """``rate_hz``: the rows' own rate (rows_rate_hz), for dobwind_time_response; None: the airframe's
    observer rate (a CSV log streamed in chunks: its file must not depend on the chunk size)."""
    af = src.airframe
    return {"Conventions": cfnames.CONVENTIONS, "title": title,
            "source": f"dobwind {_version()} disturbance-observer wind estimate from a multirotor flight log",
            "history": f"dobwind {_version()} ({src.backend} backend): airframe {Path(src.airframe_path).name}, "
                       f"log {Path(src.log_path).name}",
            "references": "dobwind docs/atmospheric.md",
            "dobwind_version": _version(), "dobwind_airframe": af.name,
            "dobwind_airframe_file": Path(src.airframe_path).name, "dobwind_airframe_sha256": af.content_sha256,
            "dobwind_calibration": calibration_text(af), "dobwind_log": Path(src.log_path).name,
            "dobwind_time_response": time_response_text(af, rate_hz), "time_source": geo.time_source}


def row_dimension(geo: Geo) -> str:
    return "time" if geo.utc_offset_s is not None else "log_time"


def _coords(t_log: np.ndarray, geo: Geo) -> dict[str, tuple]:
    """``time`` (UTC) where the log has GPS time, and always ``log_time``, the log's own clock. Without a
    reference date there is no CF time coordinate at all (a coordinate named time in plain seconds is an
    error to CF checkers): the rows' dimension is then ``log_time``, and every variable runs along it."""
    dim = row_dimension(geo)
    # "Since boot" is what PX4 and ArduPilot flight controllers stamp, but a SITL may count from 1970 (PX4's
    # sample_px4_events.ulg starts at 1.71e9 s) and a ROS 2 bag keeps its recorder's clock: say what it is not.
    coords = {"log_time": (dim, t_log, {"long_name": "the log's own clock, as it stamps its rows (a flight "
                                        "controller's: time since boot); not corrected to UTC", "units": "s"})}
    if geo.utc_offset_s is not None:
        coords["time"] = ("time", t_log + geo.utc_offset_s,
                          {"standard_name": "time", "long_name": "time (UTC)", "axis": "T",
                           "units": "seconds since 1970-01-01 00:00:00", "calendar": "standard"})
    return coords


def _sigma(values: np.ndarray) -> np.ndarray:
    return np.where(values == UNKNOWN_SIGMA, np.nan, values)


def estimate_dataset(cols: dict[str, np.ndarray], t_log: np.ndarray, pos: RowPosition | None, geo: Geo,
                     src: Source, xr):
    """The xarray Dataset of one replay. ``cols``: the estimate CSV's columns by name (logs.ESTIMATE_COLUMNS)."""
    coords, dim = _coords(t_log, geo), row_dimension(geo)
    data = {}
    vertical = src.airframe.vertical_law == "fitted"
    names = {"eastward_wind": cols["wind_e"], "northward_wind": cols["wind_n"],
             "upward_air_velocity": cols["wind_speed_up"], "wind_speed": cols["wind_speed_h"],
             "wind_from_direction": cols["wind_from_deg"]}
    if not vertical:
        # The zero-wind fallback writes exactly 0: under a CF name that reads as a measured calm, which it is
        # not. The variable and its standard error are left out and the file says why (vertical_note).
        del names["upward_air_velocity"]
    ancillary = "status wind_speed_standard_error"
    for var, values in names.items():
        std, units, long = cfnames.WIND[var]
        anc = ancillary.replace("wind_speed_", "upward_air_velocity_") if var == "upward_air_velocity" else ancillary
        data[var] = (dim, values.astype(np.float32), {"standard_name": std, "units": units, "long_name": long,
                                                         "ancillary_variables": anc})
    sigmas = (("wind_speed_standard_error", "wind_sigma_h"), ("upward_air_velocity_standard_error", "wind_sigma_up"))
    for var, column in sigmas[:2 if vertical else 1]:
        std, units, long = cfnames.SIGMA[var]
        data[var] = (dim, _sigma(cols[column]).astype(np.float32), {"standard_name": std, "units": units,
                                                                       "long_name": long})
    for axis in "ned":
        data[f"force_{axis}"] = (dim, cols[f"force_{axis}"].astype(np.float32),
                                 {"long_name": f"filtered external force on the vehicle, {dict(n='north', e='east', d='down')[axis]}",
                                  "units": "N"})
    data["status"] = (dim, cols["status"].astype(np.int32), cfnames.flag_attrs())
    attrs = {"position_note": _position(coords, pos, geo, dim)}
    if not vertical:
        attrs["vertical_note"] = ("no upward_air_velocity: the airframe's vertical law is the zero-wind fallback "
                                  "(force_air.vertical_law), so the vertical wind is not estimated")
    ds = xr.Dataset(data, coords=coords, attrs=attrs)
    if pos is not None:
        ds.attrs["featureType"] = "trajectory"
        ds["trajectory"] = ((), Path(src.log_path).name, {"cf_role": "trajectory_id", "long_name": "flight log"})
        # Every coordinate of the rows, log_time too: one left out of every variable's list is written by
        # xarray as a global "coordinates" attribute, which CF does not have (cfchecks: "non-standard").
        rows = dim if dim == "log_time" else f"{dim} log_time"
        for var in ds.data_vars:
            if ds[var].dims == (dim,):
                ds[var].attrs["coordinates"] = f"{rows} lat lon alt height"
    return ds


def _position(coords: dict, pos: RowPosition | None, geo: Geo, dim: str) -> str:
    if pos is None:
        return "; ".join(geo.notes) or "no global position in the log"
    for var, values in (("lat", pos.lat_deg), ("lon", pos.lon_deg), ("alt", pos.alt_m), ("height", pos.height_m)):
        std, units, long = cfnames.POSITION[var]
        attrs = {"standard_name": std, "units": units, "long_name": long}
        attrs.update({"axis": "Y"} if var == "lat" else {"axis": "X"} if var == "lon" else {"positive": "up"})
        if var == "height":
            attrs["comment"] = pos.height_source
        coords[var] = (dim, values, attrs)
    return f"position from {geo.track.source}; height: {pos.height_source}" if geo.track else ""


def dataset_encoding(ds) -> dict[str, dict]:
    """NaN marks missing data, except where CF forbids a fill value: coordinate and bounds variables."""
    bounds = {var.attrs["bounds"] for var in ds.variables.values() if "bounds" in var.attrs}
    plain = {"time", "log_time", *ds.dims, *bounds}
    enc: dict[str, dict] = {}
    for name, var in ds.variables.items():
        if var.dtype.kind == "f":
            enc[name] = {"_FillValue": None if name in plain else np.nan}
        elif name == "status":
            enc[name] = {"_FillValue": None}
        elif var.dtype.kind in "UO":
            # Text as a char array, not NetCDF-4's variable-length string: CF's classic form, which every
            # reader takes (cfchecks 4.1.0 refuses the vlen string: "vlen types not supported").
            enc[name] = {"dtype": "S1"}
        if var.ndim:
            enc.setdefault(name, {})["zlib"] = True
    return enc


def write_dataset(path: str | Path, ds) -> None:
    """To ``path`` as it is (the caller stages it under a temporary name and renames it in)."""
    ds.to_netcdf(path, engine="netcdf4", format="NETCDF4", encoding=dataset_encoding(ds))


def replay_dataset(t_log: np.ndarray, outputs: np.ndarray, status: np.ndarray, geo: Geo, src: Source,
                   landed: np.ndarray | None = None):
    """The Dataset of one replay from the step's outputs and status on the log's clock ``t_log``."""
    xr = require_xarray(src.log_path)
    rows = estimate_rows(t_log, outputs, status)
    cols = {name: rows[:, k] for k, name in enumerate(ESTIMATE_COLUMNS)}
    pos = on_rows(geo.track, t_log, landed) if geo.track is not None else None
    title = f"dobwind wind estimate: {src.airframe.name} over {Path(src.log_path).name}"
    ds = estimate_dataset(cols, t_log, pos, geo, src, xr)
    ds.attrs = {**global_attrs(src, geo, title, rows_rate_hz(t_log)), **ds.attrs}
    return ds
