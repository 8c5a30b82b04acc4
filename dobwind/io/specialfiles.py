"""Refusing special files among a command's arguments, by type, before anything opens them.

Every path-like argument that is not an output is checked (dobwind/model/inputfiles.py says why and
how); outputs are checked by dobwind.io.outputs, which replaces them.
"""
from __future__ import annotations

import argparse

from dobwind.model.inputfiles import refuse_special

# Arguments that name files the command writes.
OUTPUT_DESTS = frozenset({"output", "plot", "px4_wind"})


def refuse_special_inputs(args: argparse.Namespace) -> None:
    """Checks every string (or list of strings) argument but the outputs."""
    for dest, value in vars(args).items():
        if dest in OUTPUT_DESTS:
            continue
        for item in value if isinstance(value, list) else [value]:
            if isinstance(item, str) and item:
                refuse_special(item)
