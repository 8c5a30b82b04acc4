"""`--json` output that every strict JSON parser accepts: no NaN or Infinity, ever.

Non-finite floats become null, and the paths where that happened are listed under
``non_finite_as_null`` so that a reader can tell "no value" from "a value that was not a number"
(an unstable observer's noise gain is infinite, for example).
"""
from __future__ import annotations

import dataclasses
import json
import math
import sys
from typing import Any, TextIO

import numpy as np

NULL_PATHS_KEY = "non_finite_as_null"


def strict(value: Any, path: str = "", nulled: list[str] | None = None) -> Any:
    """A copy of ``value`` made of JSON types only, non-finite floats replaced by None (paths in ``nulled``)."""
    nulled = [] if nulled is None else nulled
    if isinstance(value, (np.generic, np.ndarray)):
        value = value.tolist()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = dataclasses.asdict(value)
    if isinstance(value, dict):
        return {str(k): strict(v, f"{path}.{k}" if path else str(k), nulled) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict(v, f"{path}[{i}]", nulled) for i, v in enumerate(value)]
    if isinstance(value, complex):
        return [strict(value.real, f"{path}.real", nulled), strict(value.imag, f"{path}.imag", nulled)]
    if isinstance(value, float) and not math.isfinite(value):
        nulled.append(path or "<top>")
        return None
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    return str(value)  # paths and other plain objects: their text


def dumps(obj: dict[str, Any], indent: int | None = 2) -> str:
    nulled: list[str] = []
    clean = strict(obj, "", nulled)
    if nulled:
        clean[NULL_PATHS_KEY] = nulled
    return json.dumps(clean, indent=indent, allow_nan=False)


def print_json(obj: dict[str, Any], stream: TextIO | None = None) -> None:
    (stream or sys.stdout).write(dumps(obj) + "\n")
