"""`dobwind init LOG --mass KG -o AIRFRAME.toml`: a starter airframe, an uncalibrated prior
(dobwind/inspect/initframe.py)."""
from __future__ import annotations

import argparse

from dobwind.cli.common import JSON_HELP, Command


def add(command: Command) -> None:
    p = command("init", "a starter airframe (an uncalibrated prior) for the vehicle that flew a log")
    p.add_argument("log", help="flight log: PX4 ULog (.ulg), ArduPilot DataFlash (.bin), ROS 2 bag or CSV")
    p.add_argument("--mass", type=float, required=True, help="the vehicle's take-off mass, kg (required)")
    p.add_argument("-o", "--output", required=True, help="the airframe TOML to write (required; never the log)")
    p.add_argument("--name", default=None, help="airframe name, [a-z][a-z0-9_]* with no '__' and no trailing '_' (default: from "
                   "the output file name)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dobwind.inspect.initframe import run_init

    return run_init(args.log, args.mass, args.output, args.name, args.json)
