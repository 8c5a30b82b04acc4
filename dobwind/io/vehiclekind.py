"""Whether a log is a multirotor's: what its autopilot says of the vehicle (ArduPilot's firmware banner,
PX4's MAV_TYPE). dobwind's step models a multirotor; the readers and `init` refuse any other vehicle."""
from __future__ import annotations

import re

# Why another vehicle gets no estimate (inspect's line, the refusals).
MULTIROTORS_ONLY = ("dobwind's estimator models a multirotor (the rotors' thrust along the body axis carries the "
                    "weight at hover)")

# The firmware's banner (MSG "ArduPlane V4.5.1 (...)"), written at boot: a plane has no FRAME_CLASS, so
# the banner is what says a log is not a multirotor's. A quadplane (Q_ENABLE 1) hovers on its lift rotors.
BANNER = re.compile(r"^(Ardu\w+|Rover|Blimp|AntennaTracker) V\d")
NOT_MULTIROTOR_FIRMWARE = {"ArduPlane": "a fixed-wing plane", "ArduRover": "a ground or surface vehicle",
                           "Rover": "a ground or surface vehicle", "ArduSub": "a submarine",
                           "AntennaTracker": "an antenna tracker", "Blimp": "a blimp"}
# PX4's MAV_TYPE of vehicles that are no multirotor at all (VTOL types 19-25 hover on lift rotors: not here).
MAV_TYPE_NOT_MULTIROTOR = {1: "a fixed-wing plane", 10: "a ground rover", 11: "a surface boat", 12: "a submarine"}


def firmware(rows: list[dict]) -> str:
    """ArduPilot's banner from its MSG rows, without the git hash ("ArduPlane V3.8.2-dev"); "" if none."""
    for r in rows:
        text = str(r.get("Message", ""))
        if BANNER.match(text):
            return text.split(" (")[0].strip()
    return ""


def ardupilot_not_multirotor(banner: str, params: dict[str, float]) -> str:
    """Why the vehicle is not a multirotor, from its banner ("" when it is one, or unknown)."""
    kind = NOT_MULTIROTOR_FIRMWARE.get(banner.split(" ")[0]) if banner else None
    if kind is None:
        return ""
    if banner.startswith("ArduPlane"):
        if params.get("Q_ENABLE", 0.0) >= 1:
            return ""  # a quadplane: a multirotor while it hovers
        return f"{banner} with Q_ENABLE {params.get('Q_ENABLE', 0):g}: {kind} without VTOL lift rotors"
    return f"{banner}: {kind}"


def px4_not_multirotor(params: dict[str, float]) -> str:
    mav_type = int(params.get("MAV_TYPE", -1))
    return f"MAV_TYPE {mav_type}: {MAV_TYPE_NOT_MULTIROTOR[mav_type]}" if mav_type in MAV_TYPE_NOT_MULTIROTOR else ""
