"""`dobwind inspect LOG`: the reader for the log's kind. Its own module, because the readers
(inspect_ulog, inspect_dataflash, inspect_other) import loginspect's summary types: the dispatch
sitting in loginspect made an import cycle."""
from __future__ import annotations

from dataclasses import replace

from dobwind.core.errors import InputError
from dobwind.inspect.loginspect import LogSummary
from dobwind.io.position import Geo


def inspect_log(path: str) -> LogSummary:
    summary, geo = _inspect(path)
    return replace(summary.with_rpm_usability(), position=_position(path, summary.format, geo))


def _position(path: str, kind: str, geo: Geo | None = None) -> dict:
    """Where replay's NetCDF and profile would take position, height and UTC from (dobwind/io/position.py),
    so a meteorologist learns before the campaign, not after it, whether the logs carry UTC and a position.
    ``geo``: already read with the log's summary (None: read here)."""
    from dobwind.io.position import read_geo

    if kind == "csv":
        return {"position": "the lat, lon, alt columns where the log has them (else the height integrated from vel_d)",
                "utc": None, "time_source": "no UTC in CSV logs: time is the log's own t column"}
    if geo is None:
        try:
            geo = read_geo(path)
        except InputError as exc:
            return {"position": None, "utc": None, "time_source": f"not read: {exc}"}
    where = (geo.track.source if geo.track is not None
             else f"none (heights from {geo.local.source})" if geo.local is not None else None)
    return {"position": where, "utc": geo.utc_offset_s is not None, "time_source": geo.time_source}


def _inspect(path: str) -> tuple[LogSummary, Geo | None]:
    """The log's summary by its kind's reader, and its position where that reader read it in the same pass."""
    from dobwind.io.autopilot import log_kind

    kind = log_kind(path)
    if kind == "ulog":
        from dobwind.inspect.inspect_ulog import inspect_ulog_and_position

        return inspect_ulog_and_position(path)
    if kind == "dataflash":
        from dobwind.inspect.inspect_dataflash import inspect_dataflash_and_position

        return inspect_dataflash_and_position(path)
    from dobwind.inspect.inspect_other import inspect_csv, inspect_rosbag

    return (inspect_rosbag(path) if kind == "rosbag" else inspect_csv(path)), None
