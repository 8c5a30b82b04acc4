"""Whether an airframe's force-air law is sized for its mass: the static check `check` and `generate` print.

A law calibrated on another vehicle, or written for a mass in other units, reads absurd airflows from the
forces this vehicle feels, and nothing else in the airframe shows it: the step compiles, is stable, and
flags every such wind EXTRAPOLATED only when it is flown. The law is read here as the step reads it
(model/forceair.py ``airframe_airflow``: heading frame, level attitude, hover thrust) at a horizontal
force of a tenth of the weight, in eight directions. Real multirotors feel that force in a moderate wind
(the repository's airframes and fits read 3 to 14 m/s there; a multirotor's drag is dominated by its
rotors and frame, not streamlined), so a law that reads beyond the wind no multirotor flies in
(plausibility.MAX_WIND_MPS) there is a law for another vehicle. A law that reads zero (an uncalibrated
prior) says nothing and is not judged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from dobwind.model.forceair import airframe_airflow, law_decreasing
from dobwind.model.plausibility import MAX_WIND_MPS

if TYPE_CHECKING:
    from dobwind.model.airframe import Airframe


@dataclass(frozen=True)
class LawScaleLimits:
    force_share_of_weight: float = 0.1   # the horizontal force the law is read at, as a share of m g
    max_airflow_mps: float = MAX_WIND_MPS  # beyond it at that force: a law for another vehicle
    directions: int = 8                  # evenly spaced airflow directions, from the nose
    # a drag law must increase over the airflows this share of the weight reaches (about the force a
    # multirotor at its tilt limit leans into) ...
    envelope_share_of_weight: float = 0.5
    # ... or, for a calibrated [envelope], up to this multiple of its airflow_h_max only: beyond it the
    # step flags every wind EXTRAPOLATED (`fit` checks its own laws a little further, to 1.5 times its
    # samples' fastest airflow on a grid: dobwind/calibrate/dragfit.py, LAW_CHECK_SPEED_SHARE)
    calibrated_speed_share: float = 1.0


def airflow_at_share(af: "Airframe", limits: LawScaleLimits = LawScaleLimits()) -> np.ndarray:
    """The horizontal airflow speed (m/s) the law reads at ``force_share_of_weight`` of the weight, per
    direction (heading frame, offset included, level attitude, hover thrust)."""
    weight_n = af.mass_kg * af.gravity_mps2
    angle = 2.0 * np.pi * np.arange(limits.directions) / limits.directions
    offset = np.asarray(af.observer.force_offset_n, float)
    force = np.column_stack([offset[0] + limits.force_share_of_weight * weight_n * np.cos(angle),
                             offset[1] + limits.force_share_of_weight * weight_n * np.sin(angle),
                             np.full(limits.directions, offset[2])])
    with np.errstate(all="ignore"):
        air = airframe_airflow(af, force, np.zeros(limits.directions))
    return np.hypot(air[:, 0], air[:, 1])


def law_scale_problem(af: "Airframe", limits: LawScaleLimits = LawScaleLimits(),
                      speed: np.ndarray | None = None) -> str | None:
    """One line saying the law reads an absurd airflow at a small force, or None. A non-finite reading
    (a law that cannot be inverted there) counts as absurd. ``speed``: airflow_at_share's reading when the
    caller already has it."""
    speed = airflow_at_share(af, limits) if speed is None else speed
    worst = float(np.max(np.where(np.isfinite(speed), speed, np.inf)))
    if worst <= limits.max_airflow_mps:
        return None
    weight_n = af.mass_kg * af.gravity_mps2
    return (f"force_air: the law reads {worst:.3g} m/s of airflow at a horizontal force of "
            f"{limits.force_share_of_weight * weight_n:.3g} N ({limits.force_share_of_weight:g} of the weight of "
            f"mass = {af.mass_kg:g} kg), beyond the {limits.max_airflow_mps:g} m/s no multirotor flies in: a law "
            "calibrated on another vehicle, or a mass in other units?")


def law_fold_problem(af: "Airframe", limits: LawScaleLimits = LawScaleLimits()) -> str | None:
    """One line saying the drag law stops increasing inside the airflows it is trusted on, or None. Where
    the law folds, two airflows give one force and the step's Newton inversion can read a far faster air
    (model/forceair.py law_decreasing); `fit` never writes a law that folds inside its calibration, so
    such a law comes from a hand edit or a mistyped coefficient. Checked up to the airflow the law reads at
    ``envelope_share_of_weight`` of the weight (never beyond ``max_airflow_mps``; a law that never reaches
    that force is checked to it), and with an [envelope] not past ``calibrated_speed_share`` of its
    airflow_h_max."""
    if af.drag is None:
        return None
    reach = airflow_at_share(af, LawScaleLimits(limits.envelope_share_of_weight, limits.max_airflow_mps,
                                                limits.directions))
    checked = float(np.max(np.where(np.isfinite(reach), np.minimum(reach, limits.max_airflow_mps),
                                    limits.max_airflow_mps)))
    if af.envelope is not None:
        checked = min(checked, limits.calibrated_speed_share * af.envelope.airflow_h_max_mps)
    where = law_decreasing(af.drag, checked)
    if where is None:
        return None
    return (f"force_air.drag: the law stops increasing at {where}, inside the {checked:.3g} m/s it is checked to: "
            "one force is two airflows there and the step may read the faster (a hand-edited or mistyped "
            "coefficient?)")
