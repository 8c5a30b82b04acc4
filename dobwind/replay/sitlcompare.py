"""dobwind against the wind an ArduPilot SITL simulator was told to blow (dobwind/io/sitlwind.py): the
figures `replay` prints and puts under `sitl_wind` in `--json`, and `report` tabulates (docs/field-logs.md).

The comparison is over the trusted airborne rows (status 0: accepted, settled, inside the calibration, not
on the ground). An uncalibrated prior has no trusted row (UNCALIBRATED on every estimate): then it is over
the accepted airborne rows, and `rows_used` says so, rather than comparing nothing."""
from __future__ import annotations

import numpy as np

from dobwind.io.sitlwind import SitlLog, sitl_wind_ned
from dobwind.model.forceair import wind_from_deg
from dobwind.model.status import accepted
from dobwind.replay.scoring import wrap_deg

SOURCE = "ArduPilot SITL SIM_WIND_* parameters"


def compared_rows(status: np.ndarray) -> tuple[np.ndarray, str]:
    """The rows to compare over and their name: the trusted ones, else the accepted airborne ones."""
    trusted = status == 0
    if trusted.any():
        return trusted, "trusted"
    return accepted(status), "accepted (no trusted row)"  # accepted rows are never LANDED


def compare_with_sitl(wind: np.ndarray, truth: np.ndarray, status: np.ndarray) -> dict:
    """Mean speed (mean of each row's horizontal speed), direction (where the mean vector blows from) and
    the mean of |ours - truth| row by row (horizontal), for dobwind and the simulator over the same rows."""
    rows, name = compared_rows(status)
    return {"rows_used": name, **_figures(wind[rows], truth[rows])}


def _figures(ours: np.ndarray, true: np.ndarray) -> dict:
    """compare_with_sitl's figures over the rows given (only the count when there is none)."""
    out: dict = {"compared_rows": len(ours)}
    if not len(ours):
        return out
    mean_ours, mean_true = ours.mean(axis=0), true.mean(axis=0)
    speed = float(np.mean(np.hypot(ours[:, 0], ours[:, 1])))
    true_speed = float(np.mean(np.hypot(true[:, 0], true[:, 1])))
    from_ours = float(wind_from_deg(mean_ours[0], mean_ours[1]))
    from_true = float(wind_from_deg(mean_true[0], mean_true[1]))
    out.update(mean_speed_mps=speed, true_mean_speed_mps=true_speed, speed_difference_mps=speed - true_speed,
               from_deg=from_ours, true_from_deg=from_true, direction_difference_deg=float(wrap_deg(from_ours - from_true)),
               mean_vector_error_mps=float(np.mean(np.hypot(*(ours[:, :2] - true[:, :2]).T))),
               mean_up_mps=_up(mean_ours[2]), true_mean_up_mps=_up(mean_true[2]))
    return out


def _up(mean_down: float) -> float | None:
    """A mean down wind as up, positive; None where it is not estimated (NaN: see sitl_summary)."""
    return float(-mean_down) + 0.0 if np.isfinite(mean_down) else None  # + 0.0: no "-0.0"


def sitl_summary(sitl: SitlLog, clock_s: np.ndarray, wind: np.ndarray, status: np.ndarray,
                 vertical_estimated: bool = True) -> tuple[dict, np.ndarray]:
    """(`sitl_wind` of replay's JSON, the simulator's wind on every row, NED): the parameters at the end
    of the log, where the altitude came from, and the comparison. ``vertical_estimated`` False (an airframe
    whose vertical law is the zero-wind fallback): the step's vertical wind is 0 by construction, not a
    measurement, so dobwind's mean vertical wind is null rather than a 0 that "agrees" with the simulator."""
    truth = sitl_wind_ned(sitl, clock_s)
    if not vertical_estimated:
        wind = np.column_stack([wind[:, :2], np.full(len(wind), np.nan)])
    # The log holds the parameters as float32: their shortest float32 text (0.01, not 0.009999999776).
    parameters = {name: float(str(np.float32(value))) for name, value in sitl.final_parameters().items()}
    block = {"source": SOURCE, "parameters": parameters, "altitude_source": sitl.altitude_source,
             "approximate": sitl.turbulent(), **compare_with_sitl(wind, truth, status)}
    # The same figures over every accepted airborne row: with a turbulent simulator wind (or a wind beyond
    # the calibrated airflow) the trusted rows are those where the airflow stayed inside the calibration,
    # so their mean speed falls short of the steady truth even when every row is right
    # (docs/field-calibration.md, "The SITL stand-in as DataFlash logs").
    block["accepted_rows"] = _figures(wind[accepted(status)], truth[accepted(status)])
    return block, truth


# Below this share of trusted rows among the accepted airborne ones, the trusted rows are a selection
# (those whose airflow stayed inside the calibration, issue #36's 90 % goal) whose mean can fall short of
# the steady truth: replay then prints the figures over every accepted airborne row beside them.
TRUSTED_SHARE_FOR_ONE_LINE = 0.9


def _figures_text(figures: dict) -> str:
    return (f"dobwind {figures['mean_speed_mps']:.2f} m/s from {figures['from_deg']:.1f} deg, simulator "
            f"{figures['true_mean_speed_mps']:.2f} m/s from {figures['true_from_deg']:.1f} deg; speed "
            f"{figures['speed_difference_mps']:+.2f} m/s, direction {figures['direction_difference_deg']:+.1f} deg, "
            f"mean vector error {figures['mean_vector_error_mps']:.2f} m/s")


def sitl_line(block: dict | None) -> list[str]:
    """The text lines replay prints (none without a SITL comparison): the trusted rows', and every accepted
    airborne row's when fewer than TRUSTED_SHARE_FOR_ONE_LINE of them are trusted."""
    if not block:
        return []
    if not block["compared_rows"]:
        return ["simulator wind (SIM_WIND_*): no accepted airborne row to compare with"]
    note = " (approximate: SIM_WIND_TURB > 0, compared with its mean wind)" if block["approximate"] else ""
    lines = [f"simulator wind (SIM_WIND_*) over {block['compared_rows']} {block['rows_used']} airborne rows: "
             f"{_figures_text(block)}{note}"]
    every = block.get("accepted_rows", {})
    if (block["rows_used"] == "trusted" and every.get("compared_rows", 0)
            and block["compared_rows"] < TRUSTED_SHARE_FOR_ONE_LINE * every["compared_rows"]):
        lines.append(f"  over all {every['compared_rows']} accepted airborne rows (only "
                     f"{block['compared_rows'] / every['compared_rows']:.0%} trusted: the trusted ones are those inside "
                     f"the calibration, a selection): {_figures_text(every)}")
    return lines
