"""`dobwind inspect LOG`: what a log holds for the estimator (dobwind/inspect/)."""
from __future__ import annotations

import argparse

from dobwind.cli.common import JSON_HELP, Command, print_json


def add(command: Command) -> None:
    p = command("inspect", "what an autopilot or CSV log holds for the estimator: streams and rates, airborne "
                "time, the autopilot's wind, parameters, vehicle, and the inputs replay would use")
    p.add_argument("log", help="flight log: PX4 ULog (.ulg), ArduPilot DataFlash (.bin), ROS 2 bag (.mcap, "
                   ".db3 or its folder) or CSV (docs/formats.md)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dobwind.inspect.anylog import inspect_log
    from dobwind.inspect.loginspect import text_report

    summary = inspect_log(args.log)
    if args.json:
        print_json(summary.as_dict())
    else:
        print(text_report(summary))
    return 0
