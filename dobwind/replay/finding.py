"""A plausibility finding: what replay's checks of a whole flight say (dobwind/replay/plausibility.py,
logconventions.py), in a module of its own so that both can make one."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Finding:
    check: str           # hover_thrust, vertical_wind, envelope, wind_speed, acceleration, yaw_ref
    message: str         # what is wrong, in a sentence (stderr, notes)
    value: float         # the measured figure (ratio, m/s, share)
    limit: float         # the threshold it crossed
    rows: np.ndarray     # rows that get SUSPECT (empty for a streamed log: its rows are already written)
    count: int = -1      # rows concerned, when ``rows`` cannot say (streamed)

    def as_dict(self) -> dict:
        return {"check": self.check, "message": self.message, "value": self.value, "limit": self.limit,
                "rows": self.count if self.count >= 0 else int(self.rows.sum())}
