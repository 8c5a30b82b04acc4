"""One airframe of each force-air family (polynomial, heading-frame drag, body-frame drag), written
by hand in the airframe format (docs/formats.md), for tests that run every family through the same
experiment. ``pure_quadratic`` gives each family a law F = a s^2 (s the airflow speed), whose
analysis has closed forms."""
from __future__ import annotations

from typing import Any

from dobwind.model.airframe import Airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from tests.helpers import airframe_dict

FAMILIES = ("polynomial", "drag-heading", "drag-body")


def _drag(law: dict[str, Any], **changes: Any) -> dict[str, Any]:
    return airframe_dict(**{"force_air.horizontal": None, "force_air.vertical": None, "force_air.model": "drag",
                            "force_air.drag": law, **changes})


def family_doc(family: str, **changes: Any) -> dict[str, Any]:
    """A plausible 2.5 kg airframe of the family (drag of a small quadrotor: about 1 N at 5 m/s)."""
    if family == "polynomial":
        return airframe_dict(**changes)
    if family == "drag-heading":
        return _drag({"l0": 0.12, "q0": 0.02, "l2c": 0.01, "q2c": 0.003, "lz": 0.2, "qz": 0.04}, **changes)
    if family == "drag-body":
        return _drag({"frame": "body", "l0": 0.08, "lr": 0.04, "q0": 0.02, "q2c": 0.003, "lz": 0.2, "qz": 0.04,
                      "i1": 0.02}, **changes)
    raise ValueError(family)


def family_airframe(family: str, **changes: Any) -> Airframe:
    return parse_airframe(dumps(family_doc(family, **changes)), f"<{family}>")


def pure_quadratic(family: str, a: float, **changes: Any) -> Airframe:
    """F = a s^2 along the airflow, no offset: the polynomial family as s = fh^0.5 / sqrt(a); the drag
    laws as q0 alone (the body frame's with qz = q0: isotropic in 3-D, so the tilt changes nothing)."""
    changes = {"observer.force_offset": [0.0, 0.0, 0.0], **changes}
    if family == "polynomial":
        changes.update({"force_air.horizontal.terms": ["fh^0.5"], "force_air.horizontal.coefficients": [a ** -0.5],
                        "force_air.vertical.terms": ["fz"], "force_air.vertical.coefficients": [0.5]})
        return parse_airframe(dumps(airframe_dict(**changes)), "<quadratic>")
    law = {"q0": a, "qz": a} if family == "drag-body" else {"q0": a, "lz": 0.2}
    if family == "drag-body":
        law["frame"] = "body"
    return parse_airframe(dumps(_drag(law, **changes)), "<quadratic>")
