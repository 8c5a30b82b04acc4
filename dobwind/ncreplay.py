"""The replay command's NetCDF output (`replay ... -o OUT.nc`): position and UTC read beside the
estimate, the Dataset built by dobwind/netcdf.py and written to the staged temporary name."""
from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.model.airframe import Airframe
from dobwind.model.reference import Trajectory
from dobwind.netcdf import Source, require_xarray, replay_dataset, write_dataset
from dobwind.position import Geo, read_geo


def require_netcdf(output: str) -> None:
    """Before any log is read: the libraries are there (one line naming the output otherwise)."""
    require_xarray(output)


def warn_without_position(command: str, log_path: str, geo: Geo) -> None:
    if geo.track is None:
        reason = "; ".join(geo.notes) or "no global position"
        sys.stderr.write(f"dobwind {command}: warning: {log_path}: {reason}: the NetCDF has no latitude, "
                         "longitude or height (its position_note attribute says so)\n")


def write_replay_netcdf(staged: Path, af: Airframe, args: argparse.Namespace, t_log: np.ndarray, traj: Trajectory,
                        landed: np.ndarray | None = None, columns: dict[str, np.ndarray] | None = None) -> None:
    geo = read_geo(str(args.log), columns)
    warn_without_position("replay", str(args.log), geo)
    ds = replay_dataset(t_log, traj.outputs, traj.status, geo, Source(af, str(args.airframe), str(args.log),
                                                                      args.backend), landed)
    write_dataset(staged, ds)


@dataclass(frozen=True)
class CsvReplay:
    """What cmd_replay prints for a CSV log, as ``replay_stream``'s result gives it."""
    metrics: dict
    scored: bool


def replay_csv_netcdf(args: argparse.Namespace, af: Airframe, out) -> CsvReplay:
    """A CSV log to NetCDF: in memory (the file is written whole), scored as the streaming path scores."""
    from dobwind.model.status import accepted
    from dobwind.replay import replay, score

    model, log, traj = replay(af, str(args.log), args.backend, args.precision)
    write_replay_netcdf(out.stage(args.output), af, args, log.time_s, traj, columns=log.columns)
    if args.plot is not None:
        from dobwind.plots import replay_plot

        replay_plot(log.time_s, traj.outputs[:, model.outputs.slice("wind_ned")], log.true_wind,
                    f"{af.name}: wind estimated over {os.path.basename(args.log)}", str(out.stage(args.plot)))
    if log.true_wind is not None:
        return CsvReplay(score(log, traj, model), True)
    return CsvReplay({"rows": log.rows, "rejected_rows": int((~accepted(traj.status)).sum())}, False)
