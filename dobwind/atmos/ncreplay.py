"""The replay command's NetCDF output (`replay ... -o OUT.nc`): position and UTC read beside the
estimate, the Dataset built by dobwind/io/netcdf.py and written to the staged temporary name."""
from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dobwind.model.airframe import Airframe
from dobwind.model.reference import Trajectory
from dobwind.io.netcdf import Source, require_xarray, replay_dataset, write_dataset
from dobwind.io.position import Geo, read_geo


def require_netcdf(output: str) -> None:
    """Before any log is read: the libraries are there (one line naming the output otherwise)."""
    require_xarray(output)


def warn_without_position(command: str, log_path: str, geo: Geo) -> None:
    if geo.track is None:
        reason = "; ".join(geo.notes) or "no global position"
        sys.stderr.write(f"dobwind {command}: warning: {log_path}: {reason}: the NetCDF has no latitude, "
                         "longitude or height (its position_note attribute says so)\n")


def write_replay_netcdf(staged: Path, af: Airframe, args: argparse.Namespace, t_log: np.ndarray, traj: Trajectory,
                        landed: np.ndarray | None = None) -> None:
    """An autopilot log's replay (held whole, as replay_ulog returns it) to NetCDF."""
    geo = read_geo(str(args.log))
    warn_without_position("replay", str(args.log), geo)
    ds = replay_dataset(t_log, traj.outputs, traj.status, geo, Source(af, str(args.airframe), str(args.log),
                                                                      args.backend), landed)
    write_dataset(staged, ds)


@dataclass(frozen=True)
class CsvReplay:
    """What cmd_replay prints for a CSV log, as ``replay_stream``'s result gives it."""
    metrics: dict
    scored: bool
    findings: tuple = ()  # plausibility findings, as replay_stream gives them for a CSV output


def replay_csv_netcdf(args: argparse.Namespace, af: Airframe, out, block_bytes: int | None = None) -> CsvReplay:
    """A CSV log to NetCDF, streamed (dobwind/atmos/ncstream.py) and scored as ``replay_stream`` scores it."""
    from dobwind.replay.backends import Runner
    from dobwind.io.csvchunks import BLOCK_BYTES
    from dobwind.io.logs import TRUTH_BOUNDS, iter_log, required_columns, step_inputs
    from dobwind.model.status import accepted
    from dobwind.model.step import build_step
    from dobwind.atmos.ncstream import stream_csv_netcdf
    from dobwind.replay.plausibility import FlightSeries, StreamedChecks
    from dobwind.replay.rejections import count_rejections
    from dobwind.replay.scoring import WindScore

    model = build_step(af)
    checks = StreamedChecks(af)
    runner = Runner(model, args.backend, args.precision)
    scorer, counts, kept = WindScore(), {"rows": 0, "rejected_rows": 0}, []
    rejections: dict[str, int] = {}
    last: dict[str, float | None] = {"t": None, "truth": None}  # the previous chunk's last time; true wind seen

    def step(log):
        traj = runner.run(step_inputs(model, log, last["t"]))
        last["t"] = float(log.time_s[-1])
        wind = traj.outputs[:, model.outputs.slice("wind_ned")]
        checks.add(FlightSeries.replayed(log, traj.outputs[:, model.outputs.slice("force_ned")], wind, traj.status), log)
        if log.true_wind is not None:
            scorer.add(log.time_s, wind, log.true_wind, traj.status, log.columns.get("segment"))
            last["truth"] = 1.0
        counts["rows"] += log.rows
        counts["rejected_rows"] += int((~accepted(traj.status)).sum())
        rejections.update(count_rejections(traj.status, rejections))
        if args.plot is not None:
            kept.append((log.time_s, wind, log.true_wind))
        return traj

    chunks = (c.log for c in iter_log(str(args.log), required_columns(af), block_bytes or BLOCK_BYTES,
                                      bounds=TRUTH_BOUNDS))  # true wind bounded as replay_stream and fit bound it
    stream_csv_netcdf(out.stage(args.output), Source(af, str(args.airframe), str(args.log), args.backend), chunks,
                      step, lambda geo: warn_without_position("replay", str(args.log), geo))
    scored = last["truth"] is not None
    if args.plot is not None:
        from dobwind.io.plots import published, replay_plot

        truth = None if kept[0][2] is None else np.concatenate([k[2] for k in kept])
        wind = published(np.concatenate([k[1] for k in kept]), af.vertical_law)
        replay_plot(np.concatenate([k[0] for k in kept]), wind, truth,
                    f"{af.name}: wind estimated over {os.path.basename(args.log)}", str(out.stage(args.plot)))
    return CsvReplay({**(scorer.result() if scored else counts), "rejections": rejections}, scored,
                     tuple(checks.findings()))
