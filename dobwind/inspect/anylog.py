"""`dobwind inspect LOG`: the reader for the log's kind. Its own module, because the readers
(inspect_ulog, inspect_dataflash, inspect_other) import loginspect's summary types: the dispatch
sitting in loginspect made an import cycle."""
from __future__ import annotations

from dobwind.inspect.loginspect import LogSummary


def inspect_log(path: str) -> LogSummary:
    return _inspect(path).with_rpm_usability()


def _inspect(path: str) -> LogSummary:
    from dobwind.io.autopilot import log_kind

    kind = log_kind(path)
    if kind == "ulog":
        from dobwind.inspect.inspect_ulog import inspect_ulog

        return inspect_ulog(path)
    if kind == "dataflash":
        from dobwind.inspect.inspect_dataflash import inspect_dataflash

        return inspect_dataflash(path)
    from dobwind.inspect.inspect_other import inspect_csv, inspect_rosbag

    return inspect_rosbag(path) if kind == "rosbag" else inspect_csv(path)
