"""`fit --truth sitl`: the wind an ArduPilot SITL simulator was told to blow, from the log's parameters.

The truth itself (which parameters, which altitude, the profiles, the direction convention) is
dobwind/io/sitlwind.py, shared with `replay` and `report`; this module reads it for the fit, with the
fit's own refusals and warnings."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from dobwind.calibrate.directionshape import ARDUPILOT_SITL, DirectionShape
from dobwind.calibrate.fieldtruth import LogTime
from dobwind.core.errors import InputError
from dobwind.io.sitlwind import MESSAGES, REQUIRED, SitlLog, describe, sitl_from_messages, sitl_wind_ned


def read_sitl_log(path: str) -> SitlLog:
    """The SIM_WIND_* parameters and the altitude of a DataFlash log; a log without SIM_WIND_SPD and
    SIM_WIND_DIR is not a SITL log with a known wind (InputError, exit 2)."""
    if not str(path).lower().endswith(".bin"):
        raise InputError(path, None, "--truth sitl needs an ArduPilot SITL DataFlash log (.bin)")
    from dobwind.io.dataflash import load_messages

    log = sitl_from_messages(path, load_messages(path, MESSAGES))
    if log is None:
        raise InputError(path, "parameter " + ", ".join(REQUIRED),
                         "missing: not an ArduPilot SITL log with a simulated wind (--truth sitl needs SIM_WIND_SPD "
                         "and SIM_WIND_DIR)")
    return log


@dataclass(frozen=True)
class SitlTruth:
    """`--truth sitl`: each log's own SIM_WIND_* parameters (read once per log)."""
    logs: dict[str, SitlLog] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    # The logs are the simulator's: the drag law's direction shape where the flight does not identify it.
    direction_shape: ClassVar[DirectionShape] = ARDUPILOT_SITL

    def _log(self, path: str) -> SitlLog:
        if path not in self.logs:
            self.logs[path] = log = read_sitl_log(path)
            if log.turbulent():
                turb = float(log.value("SIM_WIND_TURB", log.t_alt_s).max())
                self.warnings.append(f"{path}: SIM_WIND_TURB {turb:g} > 0: the simulator's turbulence is "
                                     "not in the log, the truth is its mean wind (approximate)")
        return self.logs[path]

    def wind(self, path: str, flight: LogTime) -> tuple[np.ndarray, np.ndarray]:
        log = self._log(path)
        return sitl_wind_ned(log, flight.clock_s), np.ones(flight.log.rows, dtype=bool)

    def describe(self) -> str:
        parts = [f"{path}: {describe(log)}" for path, log in self.logs.items()]
        return "ArduPilot SITL parameters (--truth sitl): " + "; ".join(parts)

    def describe_log(self, path: str) -> str:
        values = describe(self.logs[path]) if path in self.logs else "not read"
        return f"the wind the simulator was told to blow, from the log's own parameters (--truth sitl): {values}"
