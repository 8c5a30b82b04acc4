"""Airframe -> TOML text, the inverse of ``airframe.parse_airframe`` (used by ``fit`` and tests)."""
from __future__ import annotations

import dataclasses
import hashlib
import math
from typing import Any

from dobwind.model.airframe import Airframe


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write non-finite number {v!r}")
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__}")


def dumps(document: dict[str, Any]) -> str:
    """A nested dict as TOML: scalars and arrays first, then sub-tables as [a.b] sections."""
    lines: list[str] = []

    def table(prefix: str, body: dict[str, Any]) -> None:
        scalars = {k: v for k, v in body.items() if not isinstance(v, dict)}
        tables = {k: v for k, v in body.items() if isinstance(v, dict)}
        if prefix and scalars:
            lines.append(f"\n[{prefix}]")
        for key, value in scalars.items():
            lines.append(f"{key} = {_value(value)}")
        for key, value in tables.items():
            table(f"{prefix}.{key}" if prefix else key, value)

    table("", document)
    return "\n".join(lines).lstrip("\n") + "\n"


def airframe_document(af: Airframe) -> dict[str, Any]:
    thrust: dict[str, Any] = {"source": af.thrust.source, "scale": af.thrust.scale}
    if af.thrust.source == "rpm":
        thrust.update(rotors=af.thrust.rotors, max_rpm=af.thrust.max_rpm, coefficients=list(af.thrust.coefficients))
    document: dict[str, Any] = {
        "name": af.name,
        "mass": af.mass_kg,
        "gravity": af.gravity_mps2,
        "thrust": thrust,
        "observer": {
            "sample_time": af.observer.sample_time_s,
            "gains": list(af.observer.gains),
            "discretization": af.observer.discretization,
            "acceleration": af.observer.acceleration,
            "force_offset": list(af.observer.force_offset_n),
            "acceleration_bias_time": af.observer.acceleration_bias_time_s,
        },
        "force_air": _force_air_document(af),
        "filter": {"speeds": list(af.filter.speeds_mps), "cutoffs": list(af.filter.cutoffs_hz)},
        "limits": {"max_dt": af.limits.max_dt_s, "max_tilt_deg": af.limits.max_tilt_deg},
    }
    if af.envelope is not None:
        document["envelope"] = {"force_h_max": af.envelope.force_h_max_n, "force_z": list(af.envelope.force_z_n),
                                "airflow_h_max": af.envelope.airflow_h_max_mps}
    if af.uncertainty is not None:
        document["uncertainty"] = {"speeds": list(af.uncertainty.speeds_mps),
                                   "sigma_h": list(af.uncertainty.sigma_h_mps),
                                   "sigma_up": list(af.uncertainty.sigma_up_mps)}
        for key, value in (("noise_h", af.uncertainty.noise_h_mps), ("noise_up", af.uncertainty.noise_up_mps)):
            if value > 0:  # absent means 0: files written before the noise terms read back the same
                document["uncertainty"][key] = value
    if af.uncalibrated:  # absent means calibrated: fit's output (calibrated) never carries the table
        document["calibration"] = {"status": af.calibration}
    if af.ros2_topics:  # fit rewrites the whole airframe: keep the user's topic names
        document["ros2_topics"] = dict(af.ros2_topics)
    return document


def _force_air_document(af: Airframe) -> dict[str, Any]:
    if af.vertical_law != "fitted":  # absent means fitted: files written before the key read back the same
        return {"vertical_law": af.vertical_law, **_force_air_law(af)}
    return _force_air_law(af)


def _force_air_law(af: Airframe) -> dict[str, Any]:
    if af.drag is not None:
        return {"model": "drag", "drag": af.drag.as_dict()}
    return {
        "horizontal": {"terms": list(af.horizontal.term_texts), "coefficients": list(af.horizontal.coefficients)},
        "vertical": {"terms": list(af.vertical.term_texts), "coefficients": list(af.vertical.coefficients)},
    }


def dump_airframe(af: Airframe) -> str:
    return dumps(airframe_document(af))


def rehashed(af: Airframe) -> Airframe:
    """``af`` naming the text it is written as: content_sha256 of its dumped TOML. An airframe made in
    memory (a fit's result) otherwise carries the hash of the file it was fitted from, and C generated
    from it would name the wrong airframe (issue #33)."""
    return dataclasses.replace(af, content_sha256=hashlib.sha256(dump_airframe(af).encode()).hexdigest())
