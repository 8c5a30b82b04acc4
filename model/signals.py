"""Which measured signals an airframe's estimator needs: the one map from the airframe to its log
signals, read by the step's input layout, every log reader (CSV, ULog, DataFlash, ROS 2 bags), the
simulator and the calibration, instead of each testing the thrust source and the acceleration input.

Two choices in the airframe decide it: ``thrust.source`` (rotor speeds, one column per rotor, or the
collective thrust) and ``observer.acceleration`` (none, the velocity is differenced; the NED
acceleration; or the accelerometer's specific force, body FRD). Ground velocity, attitude and the time
are always needed."""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dobwind.model.airframe import Airframe

ALWAYS = (("t", "sample time"), ("vel_n", "ground velocity"), ("vel_e", "ground velocity"),
          ("vel_d", "ground velocity"), ("q_w", "attitude"), ("q_x", "attitude"), ("q_y", "attitude"),
          ("q_z", "attitude"))
NED_ACCELERATION_COLUMNS = ("acc_n", "acc_e", "acc_d")
SPECIFIC_FORCE_COLUMNS = ("sf_x", "sf_y", "sf_z")


@dataclass(frozen=True)
class LogSignals:
    rotors: int          # rotor speeds measured, rpm_1 .. rpm_N; 0: the collective thrust instead
    acceleration: str    # the observer's input: "velocity" (none measured), "ned" or "specific_force"

    @property
    def rotor_speeds(self) -> bool:
        return self.rotors > 0

    @property
    def ned_acceleration(self) -> bool:
        return self.acceleration == "ned"

    @property
    def specific_force(self) -> bool:
        return self.acceleration == "specific_force"

    @property
    def measured_acceleration(self) -> bool:
        """An acceleration input is read from the log (else the velocity is differenced)."""
        return self.ned_acceleration or self.specific_force

    def rpm_columns(self) -> tuple[str, ...]:
        return tuple(f"rpm_{i + 1}" for i in range(self.rotors))

    def columns(self) -> list[tuple[str, str]]:
        """(CSV column, what it is for) of every signal (docs/formats.md)."""
        cols = list(ALWAYS)
        if self.rotor_speeds:
            cols += [(c, "rotor speed") for c in self.rpm_columns()]
        else:
            cols.append(("thrust", "collective thrust"))
        if self.ned_acceleration:
            cols += [(c, "acceleration (observer.acceleration = \"ned\")") for c in NED_ACCELERATION_COLUMNS]
        elif self.specific_force:
            cols += [(c, "specific force (observer.acceleration = \"specific_force\")") for c in SPECIFIC_FORCE_COLUMNS]
        return cols


def log_signals(af: Airframe) -> LogSignals:
    return LogSignals(af.thrust.rotors if af.thrust.source == "rpm" else 0, af.observer.acceleration)
