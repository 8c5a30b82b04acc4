"""CSV replay's checks of a log's conventions: a column in the wrong unit or frame, which no status bit sees.

A CSV flight log is exported by its user, and the common slips leave every sample inside the step's bounds:
yaw_ref in degrees, a quaternion written NED to body (its conjugate) or in x, y, z, w order, an acceleration
in g, a velocity in the body frame or in ENU. Each sample then looks like a flight, the estimate is
trusted, and the wind is wrong by metres per second (on the simulated outdoor flight, 1-4 m/s on average
through the fitted m300, 0.4 without the slip). The autopilot readers write these columns themselves
(dobwind/io/ulog.py, dataflash.py), so only a CSV log is checked. Two checks, each a warning and a note
(a streamed log's rows are already written, as dobwind/replay/plausibility.py's StreamedChecks says):

- yaw_ref against the attitude's yaw. The yaw reference is the vehicle's yaw setpoint, which the vehicle
  follows within degrees: on the shared field logs the two differ by a median of 0.01-1.9 deg (0.07-0.11
  on the simulated flights). A median beyond ``yaw_median_deg`` means the two are not in the same unit or
  convention (yaw_ref in degrees: 81 deg; the quaternion's conjugate: 77; x, y, z, w order: 133).
- the logged acceleration against the velocity's derivative in the estimate's band (dobwind/io/accelcheck.py,
  the check replay already makes on an autopilot log): acceleration in g reads 0.28 m/s² RMS, its sign
  flipped 0.63, a body-frame velocity 0.40, ENU velocity 0.48, against 0.01 on the simulated flights and
  the 0.20 limit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind.io.accelcheck import LIMIT_MPS2, AccelCheck, check_acceleration
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import Airframe
from dobwind.model.attitude import yaw_from_quaternion
from dobwind.model.signals import log_signals
from dobwind.model.status import accepted
from dobwind.replay.finding import Finding


@dataclass(frozen=True)
class ConventionLimits:
    yaw_median_deg: float = 45.0   # median |yaw_ref - yaw of q| beyond this: not one unit or convention
    yaw_min_s: float = 5.0         # judged over at least this much accepted time with both


def _yaw_text(median: float, seconds: float, lim: ConventionLimits) -> str:
    return (f"yaw_ref and the attitude's yaw (from q_w, q_x, q_y, q_z) differ by {median:.0f} deg at the median over "
            f"{seconds:.0f} s (limit {lim.yaw_median_deg:g} deg), where a vehicle follows its yaw setpoint within "
            "degrees: yaw_ref in degrees rather than radians or not the yaw setpoint, or the quaternion in another "
            "convention (NED to body rather than body to NED, x, y, z, w order, ENU): the attitude or the heading "
            "frame (the force-air law's and the force offset's) is not the vehicle's, and the wind with it")


def _acceleration_text(check: AccelCheck) -> str:
    return (f"{check.text()}: the acceleration and the velocity columns do not describe one motion (acceleration in g "
            "rather than m/s², a sign or an axis swapped, a velocity in the body frame or in ENU, or aliased "
            "vibration); the observer reads the difference as an external force")


class ConventionChecks:
    """The checks over a CSV log read chunk by chunk: a histogram of the yaw difference (1 deg bins) for its
    median, and the acceleration check's mean square weighted by each chunk's time."""

    def __init__(self, af: Airframe, limits: ConventionLimits = ConventionLimits()) -> None:
        self._af, self._limits = af, limits
        self._yaw_hist = np.zeros(181, dtype=np.int64)
        self._yaw_s = 0.0
        self._acc_square_s = self._acc_s = 0.0
        self._acc_rows = 0   # accepted rows of the chunks the acceleration check judged

    def add(self, log: FlightLog, status: np.ndarray) -> None:
        ok = accepted(status)
        if log.rows > 1 and log.has("yaw_ref"):
            self._add_yaw(log, ok)
        if log_signals(self._af).measured_acceleration:
            check = check_acceleration(log, ok, self._af.observer.acceleration, max(self._af.filter.cutoffs_hz))
            if check is not None:
                self._acc_square_s += check.disagreement_mps2 ** 2 * check.seconds
                self._acc_s += check.seconds
                self._acc_rows += int(ok.sum())

    def _add_yaw(self, log: FlightLog, ok: np.ndarray) -> None:
        yaw = yaw_from_quaternion(log.stack("q_w", "q_x", "q_y", "q_z"))
        with np.errstate(invalid="ignore"):
            diff = np.degrees(np.abs(np.angle(np.exp(1j * (log.columns["yaw_ref"] - yaw)))))
        use = ok & np.isfinite(diff)
        np.add.at(self._yaw_hist, np.round(diff[use]).astype(np.int64), 1)
        self._yaw_s += float(use.sum()) * float(np.median(np.diff(log.time_s)))

    def findings(self) -> list[Finding]:
        out, none, lim = [], np.zeros(0, dtype=bool), self._limits
        if self._yaw_s >= lim.yaw_min_s:
            cum = np.cumsum(self._yaw_hist)
            median = float(np.searchsorted(cum, cum[-1] / 2.0))
            if median > lim.yaw_median_deg:
                out.append(Finding("yaw_ref", _yaw_text(median, self._yaw_s, lim), median, lim.yaw_median_deg, none,
                                   int(cum[-1])))
        if self._acc_s > 0.0:
            check = AccelCheck(self._af.observer.acceleration, math.sqrt(self._acc_square_s / self._acc_s),
                               max(self._af.filter.cutoffs_hz), self._acc_s)
            if check.broken:
                out.append(Finding("acceleration", _acceleration_text(check), check.disagreement_mps2, LIMIT_MPS2,
                                   none, self._acc_rows))
        return out
