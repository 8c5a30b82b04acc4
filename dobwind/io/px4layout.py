"""Where PX4 put the collective thrust in its ULogs across versions, and what each source adds: the one
table the ULog reader (ulog.py) and `dobwind inspect` (inspect_ulog.py) share; ulog.collective_source
is the one choice among them, which both call, so that both take the same source and name it the same way. The survey behind it: docs/autopilot-logs.md, *Versions the readers accept*.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ThrustSource:
    """One topic field holding the normalised collective thrust. ``up`` is the sign that makes it positive
    upwards (PX4's body z points down, so the z components are negative in hover); ``battery_scaled``:
    PX4's rate controller multiplies it by the battery scale when MC_BAT_SCALE_EN is set."""
    topic: str
    field: str
    up: float
    battery_scaled: bool
    what: str

    @property
    def name(self) -> str:
        return f"{self.topic}.{self.field}"


# In order of preference. The first two are what dobwind read before the others were added: a log that
# has them is read exactly as before (the shared field logs of ../shared/data/ among them). The attitude
# setpoint's thrust comes before actuator_controls_0: the same collective, but without the battery scale,
# which the hover thrust it is divided by does not carry either.
THRUST_SOURCES = (
    ThrustSource("vehicle_thrust_setpoint", "xyz[2]", -1.0, True,
                 "the rate controller's collective (PX4 v1.13 with SYS_CTRL_ALLOC, v1.14 and later)"),
    ThrustSource("vehicle_attitude_setpoint", "thrust_body[2]", -1.0, False,
                 "the attitude setpoint's collective (PX4 v1.9 to v1.17)"),
    ThrustSource("vehicle_attitude_setpoint", "thrust", 1.0, False,
                 "the attitude setpoint's scalar collective, 0..1 upwards (PX4 v1.8 and earlier)"),
    ThrustSource("actuator_controls_0", "control[3]", 1.0, True,
                 "the rate controller's throttle, 0..1 upwards, before the mixer (PX4 up to v1.13): the value "
                 "v1.14 logs as vehicle_thrust_setpoint.xyz[2], sign aside"),
)


def older_layout(source: ThrustSource) -> str | None:
    """What an older layout's source is (its ``what``), for the notes; None for the first two sources,
    which were read before the older layouts were added and so need no word."""
    return None if source in THRUST_SOURCES[:2] else source.what


# Logged, but not a collective thrust: the mixer's (control allocator's) per-motor outputs come after
# airmode, saturation, the thrust curve (THR_MDL_FAC) and, for actuator_outputs, the PWM range. Their mean
# is not the collective the hover thrust scales, so replay never reads them; it names them when it refuses.
NOT_COLLECTIVE = ("actuator_motors", "actuator_outputs")

BATTERY_SCALE_PARAM = "MC_BAT_SCALE_EN"


def battery_scale_note(source: ThrustSource, params: dict) -> str | None:
    """What a battery-scaled source adds when PX4 applied the scale: the hover thrust (estimate or
    MPC_THR_HOVER) is in the unscaled units of the position controller, so m g x setpoint / hover reads
    high by the battery scale (1 on a full battery, above 1 as it sags)."""
    if not source.battery_scaled or not params.get(BATTERY_SCALE_PARAM, 0):
        return None
    return (f"{BATTERY_SCALE_PARAM} is set: {source.name} includes PX4's battery scale and the hover thrust does "
            "not, so the collective thrust reads high by that scale (1 on a full battery, more as it sags)")

