"""Refusing special files among a command's arguments, by type, before anything opens them.

Every path-like argument that is not an output is checked (dobwind/model/inputfiles.py says why and
how); outputs are checked by dobwind.io.outputs, which replaces them.
"""
from __future__ import annotations

import argparse

from dobwind.model.errors import InputError
from dobwind.model.inputfiles import refuse_special

# Arguments that name files the command writes.
OUTPUT_DESTS = frozenset({"output", "plot", "px4_wind"})
# Arguments that name files or folders the command reads. An empty one is the current folder to Path() and
# os.stat: `replay af.toml "$LOG"` with LOG unset replayed every log in the working folder, and `check ""`
# said '.: cannot read: Is a directory'.
# Each as the command line names it.
INPUT_PATHS = {"airframe": "AIRFRAME", "log": "LOG", "logs": "LOG", "truth": "--truth", "vehicle": "--vehicle",
               "c_dir": "--c-dir"}


def refuse_special_inputs(args: argparse.Namespace) -> None:
    """Checks every string (or list of strings) argument but the outputs."""
    for dest, value in vars(args).items():
        if dest in OUTPUT_DESTS:
            continue
        for item in value if isinstance(value, list) else [value]:
            if item == "" and dest in INPUT_PATHS:
                raise InputError(INPUT_PATHS[dest], None, "an empty path '', which would name the current folder (an "
                                 "unset shell variable?)")
            if isinstance(item, str) and item:
                refuse_special(item)
