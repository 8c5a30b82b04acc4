"""What several command modules share: the help texts of the common arguments, the type of the
subcommand factory, JSON printing and the many-log options."""
from __future__ import annotations

import argparse
from typing import Any, Callable

from dobwind.core.resources import shipped_airframe_names

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
