"""`dobwind report AIRFRAME LOG -o PAGE.html`: one self-contained HTML page of a replayed flight."""
from __future__ import annotations

import argparse

from dobwind.model.kinds import PRECISIONS, Precision
from dobwind.cli.common import AIRFRAME_HELP, Command
from dobwind.io.outputs import OutputFiles, Target, check_targets

# The page is HTML with its figures inlined; no other format is written, so a name that promises one
# (r.pdf, r.png) would hold HTML under the wrong extension and open as a broken file.
PAGE_SUFFIXES = (".html", ".htm")


def add(command: Command) -> None:
    p = command("report", "one self-contained HTML page: airframe, estimate vs truth or the autopilot, errors, "
                "status counts, analysis figures")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("log", help="flight log: CSV (docs/formats.md), PX4 ULog (.ulg), ArduPilot DataFlash (.bin) or ROS 2 bag")
    p.add_argument("-o", "--output", required=True, help="the HTML file to write, named .html or .htm (required; figures are inlined)")
    p.add_argument("--backend", choices=("python", "c"), default="python",
                   help="run the CasADi reference (python) or the generated C, compiled on the fly (c)")
    p.add_argument("--precision", choices=PRECISIONS, default=Precision.SINGLE, help="C backend precision")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.report.report import flight_report

    target = Target("-o", args.output, suffixes=PAGE_SUFFIXES)
    check_targets([target], [args.airframe, args.log])
    af = load_airframe(args.airframe)
    page, summary = flight_report(af, args.airframe, args.log, args.backend, args.precision)
    with OutputFiles([target]) as out:
        from dobwind.io.atomic import write_text_atomically

        write_text_atomically(out.stage(args.output), lambda handle: handle.write(page))
    print(f"wrote {args.output} ({len(page) // 1024} KiB): {summary}")
    return 0
