"""What several command modules share: the help texts of the common arguments, the type of the
subcommand factory, JSON printing and the many-log options."""
from __future__ import annotations

import argparse
from typing import Any, Callable

from dobwind.core import options as opt
from dobwind.core.resources import shipped_airframe_names
from dobwind.model.kinds import PRECISIONS, Precision

AIRFRAME_HELP = ("airframe TOML file (see docs/formats.md for its keys and units), or the name of a shipped one "
                 f"({', '.join(shipped_airframe_names())}) when no such file exists")
JSON_HELP = "print the results as JSON (indent 2, units in the key names) instead of text"
# adds one subcommand: (name, one-line description) -> its parser (dobwind/cli/app.py builds it)
Command = Callable[[str, str], argparse.ArgumentParser]


def print_json(obj: dict[str, Any]) -> None:
    from dobwind.io.jsonout import print_json as print_indented  # imported when a command prints JSON

    print_indented(obj)


def add_many_options(p: argparse.ArgumentParser, what: str) -> None:
    from dobwind.cli.campaign import JOBS, default_jobs

    p.add_argument("--jobs", type=JOBS, default=default_jobs(), metavar="N",
                   help=f"several logs: {what} N logs at once in worker processes ({JOBS.text()}; default: one "
                   "per core)")


def add_backend_options(p: argparse.ArgumentParser) -> None:
    """--backend, --precision and --rate: how replay and profile run the step over a log."""
    p.add_argument("--backend", choices=("python", "c"), default="python",
                   help="run the CasADi reference (python) or the generated C, compiled on the fly (c)")
    p.add_argument("--precision", choices=PRECISIONS, default=Precision.SINGLE, help="C backend precision")
    p.add_argument("--rate", type=opt.ULOG_RATE,
                   help=f"autopilot logs only: resample at this rate, Hz ({opt.ULOG_RATE.text()}) (default: none, "
                   "the airframe's observer rate, 1/observer.sample_time)")
