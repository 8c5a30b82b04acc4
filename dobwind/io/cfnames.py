"""The CF (Climate and Forecast conventions 1.8) names, units and flags dobwind's NetCDF files use.

One home for them, so the replay file, the profile file and the tests agree. Standard names are from
the CF standard name table; a 1-sigma error is the "standard_error" modifier of the quantity's name
(CF 1.8, appendix C); a sample count has the standard name "number_of_observations".
"""
from __future__ import annotations

import numpy as np

CONVENTIONS = "CF-1.8"

# variable -> (standard_name, units, long_name)
WIND = {
    "eastward_wind": ("eastward_wind", "m s-1", "wind towards the east (velocity of the air over ground)"),
    "northward_wind": ("northward_wind", "m s-1", "wind towards the north (velocity of the air over ground)"),
    "upward_air_velocity": ("upward_air_velocity", "m s-1", "vertical wind, positive up"),
    "wind_speed": ("wind_speed", "m s-1", "horizontal wind speed"),
    "wind_from_direction": ("wind_from_direction", "degree", "direction the wind blows from, clockwise from north"),
}
SIGMA = {  # the step's 1-sigma outputs: of the horizontal speed (isotropic per axis) and of the vertical wind
    "wind_speed_standard_error": ("wind_speed standard_error", "m s-1",
                                  "1-sigma error of the horizontal wind (speed, and each horizontal component) "
                                  "from the airframe's calibration"),
    "upward_air_velocity_standard_error": ("upward_air_velocity standard_error", "m s-1",
                                           "1-sigma error of the vertical wind from the airframe's calibration"),
}
POSITION = {
    "lat": ("latitude", "degrees_north", "latitude"),
    "lon": ("longitude", "degrees_east", "longitude"),
    "alt": ("altitude", "m", "altitude above mean sea level"),
    "height": ("height", "m", "height above the take-off point"),
}
# Every (standard_name, canonical units) pair written, for the tests' fallback check.
USED = {name: units for name, units, _ in (*WIND.values(), *SIGMA.values(), *POSITION.values())}
USED.update({"time": "s", "number_of_observations": "1"})


def status_flags() -> tuple[list[int], list[str]]:
    """(flag_masks, flag_meanings) of the status variable: every named bit of model/status.py, the
    step's and replay's, lower-case (CF flag meanings are single words). Bits added there later by
    name (STATUS_<NAME> = 1 << k) are picked up without an edit here."""
    from dobwind.model import status

    bits = {b.value: b.name for b in status.STATUS_BITS}
    for name, value in vars(status).items():
        if name.startswith("STATUS_") and name != "STATUS_BITS" and isinstance(value, int) and value > 0 \
                and value & (value - 1) == 0:
            bits.setdefault(value, name.removeprefix("STATUS_"))
    order = sorted(bits)
    return order, [bits[v].lower() for v in order]


def flag_attrs() -> dict[str, object]:
    masks, meanings = status_flags()
    return {"long_name": "dobwind status bits (0: estimate valid and trusted)",
            "flag_masks": np.array(masks, dtype=np.int32), "flag_meanings": " ".join(meanings),
            "comment": "docs/c-api.md, the status: rejection bits mean the estimate was not updated"}
