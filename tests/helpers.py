"""Shared test helpers: airframe variants built from a plain dict, so each test states its vehicle."""
from __future__ import annotations

import copy
import itertools
from pathlib import Path
from typing import Any

from dobwind.model.airframe import Airframe, parse_airframe
from dobwind.model.airframe_toml import dumps

ROOT = Path(__file__).resolve().parents[1]
M300 = ROOT / "airframes" / "m300.toml"

BASE: dict[str, Any] = {
    "name": "testcraft",
    "mass": 2.5,
    "thrust": {"source": "rpm", "scale": 0.98, "rotors": 4, "max_rpm": 10000.0, "coefficients": [0.0, 1.5, 22.0]},
    "observer": {"sample_time": 0.02, "gains": [20.0, 25.0, 30.0], "discretization": "paper", "acceleration": "ned",
                 "force_offset": [0.1, -0.2, 0.3]},
    "force_air": {
        "horizontal": {"terms": ["1", "m", "n", "m^2", "n^2", "fh^0.5"], "coefficients": [0.2, 0.05, -0.03, 0.08, 0.06, 0.9]},
        "vertical": {"terms": ["fz", "fz*abs(fz)"], "coefficients": [0.6, 0.05]},
    },
    "filter": {"speeds": [0.0, 4.0, 12.0], "cutoffs": [0.3, 0.6, 1.0]},
    "limits": {"max_dt": 0.1, "max_tilt_deg": 50.0},
}


def airframe_dict(**changes: Any) -> dict[str, Any]:
    """BASE with dotted-key changes, e.g. airframe_dict(**{"observer.gains": [1, 2, 3]})."""
    doc = copy.deepcopy(BASE)
    for dotted, value in changes.items():
        *path, leaf = dotted.split(".")
        table = doc
        for key in path:
            table = table[key]
        if value is None:
            table.pop(leaf, None)
        else:
            table[leaf] = value
    return doc


def make_airframe(**changes: Any) -> Airframe:
    return parse_airframe(dumps(airframe_dict(**changes)), "<test>")


def collective(doc: dict[str, Any]) -> dict[str, Any]:
    doc = copy.deepcopy(doc)
    doc["thrust"] = {"source": "collective", "scale": 1.03}
    return doc


def all_modes() -> list[dict[str, Any]]:
    """Every discretization x acceleration mode x thrust source (rotor count varied too); the
    velocity-aided acceleration bias estimate is on for half of the acceleration-input modes, so that
    each discretization meets it with both inputs and the two thrust sources share it."""
    out = []
    for i, (disc, acc, src) in enumerate(itertools.product(
            ("paper", "euler", "zoh", "tustin"), ("ned", "specific_force", "velocity"), ("rpm", "collective"))):
        doc = airframe_dict(**{"observer.discretization": disc, "observer.acceleration": acc})
        bias = acc != "velocity" and (i + i // 6) % 2 == 0
        if bias:
            doc["observer"]["acceleration_bias_time"] = 3.0
        if src == "collective":
            doc = collective(doc)
        else:
            doc["thrust"]["rotors"] = (4, 6, 8, 3)[i % 4]
        doc["name"] = f"mode_{disc}_{acc}_{src}" + ("_bias" if bias else "")
        out.append(doc)
    return out
