"""The nested parts of the fit report (`FitReport` in fit.py), each a frozen dataclass whose ``as_dict()``
is the object `fit --json` prints for it: the same keys in the same order as the schema's `$defs`
(docs/schemas/fit-report.schema.json, tests/test_fit_schema.py). Units are in the field names.

The builders fill these (selfcheck.py, holdcv.py, fitfamily.py, hovernoise's low-pass change in
fitfamily._quiet_hover, accelroute.py); the text report (fitreport.py) and the command (cli/fit.py) read
them. Nothing here computes: a part only holds figures and says how they are printed."""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from dobwind.calibrate.verticalskill import VerticalSkill


@dataclass(frozen=True)
class Segment:
    """One replayed segment of a calibration log in the self-check: its mean errors after settling."""
    segment: int                       # the log's segment label (or window index)
    true_speed_mps: float              # size of the segment's mean true horizontal wind
    speed_error_mps: float             # estimated minus true mean horizontal wind speed
    direction_error_deg: float | None  # None below the speed where a direction means anything
    vertical_error_mps: float
    points: int                        # samples scored

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class LogCheck:
    """One calibration log replayed through the fitted airframe's step (selfcheck.check_log)."""
    log: str
    rows: int
    fit_samples: int            # decimated samples the fit took from this log
    points_kept: int            # replayed samples scored (accepted, settled)
    segments: list[Segment] = field(default_factory=list)
    speed_rms_mps: float | None = None
    speed_max_mps: float | None = None
    direction_mean_deg: float | None = None
    direction_max_deg: float | None = None
    # The scored samples' scatter about their segment means (envelope.observer_noise) and its dof.
    noise_h_mps: float = 0.0
    noise_up_mps: float = 0.0
    noise_dof: int = 0
    # The same scatter per horizontal axis (north and east pooled) on low-airflow segments only.
    still_noise_mps: float = 0.0
    still_dof: int = 0
    # The direction errors above as distances: the chord 2 v sin(angle / 2) the angle alone makes at the
    # segment's true speed v (at 10 deg and 2.4 m/s, 0.42 m/s), averaged like direction_mean_deg.
    direction_mean_mps: float | None = None

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class SelfCheck:
    """The self-check's verdict on a fitted airframe (selfcheck.verdict): `self_check` of the report."""
    passed: bool
    reasons: list[str]
    cv_mps: float | None          # the CV judged: hold-level (the family's raw CV when that is missing)
    speed_range_mps: float
    cv_limit_mps: float
    replay_limit_mps: float
    direction_limit_deg: float
    logs: list[LogCheck]
    noise_h_mps: float = 0.0   # the observer noise over every log (horizontal speed, vertical wind)
    noise_up_mps: float = 0.0
    still_noise_mps: float | None = None  # per-axis horizontal noise at low airflow (None: no such segment)
    outlier_logs: list[str] = field(default_factory=list)  # replayed, not judged (Thresholds.outlier_logs)
    warnings: list[str] = field(default_factory=list)      # said, not refused (selfcheck.direction_tail_warnings)
    cv_diverged: str | None = None   # why cv_mps measures nothing (Thresholds.cv_diverged), None when it does

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class HoldCvBySpeed:
    """The hold-level CV by band of true airflow speed (holdcv.HoldCV.band_table): `hold_cv_by_speed`."""
    speeds_mps: tuple[float, ...]          # mean true speed of each band, increasing
    rms_mps: tuple[float, ...]             # RMS hold-mean speed error in the band
    bias_mps: tuple[float, ...]            # the part a hold of any length keeps
    noise_mps_sqrt_s: tuple[float, ...]    # the noise of a 1 s hold (falls as 1/sqrt(T))
    window_s: float | None                 # median scored length of the held-out windows (None: unknown)

    def as_dict(self) -> dict[str, Any]:
        return {"speeds_mps": list(self.speeds_mps), "rms_mps": list(self.rms_mps), "bias_mps": list(self.bias_mps),
                "noise_mps_sqrt_s": list(self.noise_mps_sqrt_s), "window_s": self.window_s}

    @staticmethod
    def from_json(table: Mapping[str, Any] | None) -> HoldCvBySpeed | None:
        """The part back from a report read as JSON (benchmarks read fit reports from files); missing
        bands, bias or noise: empty."""
        if table is None:
            return None
        window = table.get("window_s")
        return HoldCvBySpeed(*(tuple(table.get(k, ())) for k in ("speeds_mps", "rms_mps", "bias_mps", "noise_mps_sqrt_s")),
                             None if window is None or not math.isfinite(window) else float(window))


@dataclass(frozen=True)
class HoldScores:
    """A family's hold-level figures (holdcv.py): printed flat in its scores, as `hold_cv_*`."""
    cv_speed_mps: float | None              # `hold_cv_speed_mps`
    by_speed: HoldCvBySpeed                 # `hold_cv_by_speed`
    extrapolation_speed_mps: float | None   # `hold_extrapolation_speed_mps`: top holds held out
    diverged: str | None = None             # why cv_speed_mps measures nothing (holdcv.HoldCV.diverged_text); not printed


@dataclass(frozen=True)
class FamilyScores:
    """How one force-air family scored (fitfamily._family_scores), one entry of `families`. The per-sample
    figures are None where not finite; ``hold`` is None when the hold-level CV could not be made,
    ``run_loss`` only for a drag family fitted on the logs' means, ``exponent`` only for drag families.
    A field left None after the four per-sample figures is not printed at all."""
    cv_h_mps: float | None = None             # grouped CV of the horizontal airflow (per sample)
    cv_v_mps: float | None = None
    extrapolation_h_mps: float | None = None  # fitted below the top holds, tested on them
    score_mps: float | None = None            # the two combined (dragfit.combined)
    hold: HoldScores | None = None
    run_loss: float | None = None             # robust loss of the logs' mean errors (runmeans.cauchy_loss)
    exponent: float | None = None             # the drag law's exponent (dragexponent.py)
    # The vertical law's share of the held-out vertical mean square left unexplained and its standard error
    # over the CV blocks (verticalskill.py): what decides whether it is identified. Not printed here: the
    # chosen family's figures are the report's vertical_unexplained_share and its _se.
    vertical_skill: VerticalSkill | None = None

    def as_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"cv_h_mps": self.cv_h_mps, "cv_v_mps": self.cv_v_mps,
                               "extrapolation_h_mps": self.extrapolation_h_mps, "score_mps": self.score_mps}
        if self.hold is not None:
            out.update({"hold_cv_speed_mps": self.hold.cv_speed_mps, "hold_cv_by_speed": self.hold.by_speed.as_dict(),
                        "hold_extrapolation_speed_mps": self.hold.extrapolation_speed_mps})
        optional = {"run_loss": self.run_loss, "exponent": self.exponent}
        return {**out, **{k: v for k, v in optional.items() if v is not None}}


def family_dict(scores: FamilyScores | None) -> dict[str, Any]:
    """One entry of `families`: an empty object for a family fitted but not scored (too few samples)."""
    return {} if scores is None else scores.as_dict()


@dataclass(frozen=True)
class LowPassChange:
    """The low-pass's first cutoff lowered for the noise at low airflow (fitfamily._quiet_hover): `low_pass`."""
    cutoff_hz: tuple[float, float]                     # before, after
    still_noise_mps: tuple[float | None, float | None]  # the noise at low airflow before, after (per axis)
    target_mps: float                                  # --hover-noise

    def as_dict(self) -> dict[str, Any]:
        return {"cutoff_hz": list(self.cutoff_hz), "still_noise_mps": list(self.still_noise_mps),
                "target_mps": self.target_mps}


@dataclass(frozen=True)
class AccelerationRoute:
    """The acceleration input compared with it blended with the velocity's derivative
    (accelroute.blend_record): `acceleration_route`."""
    acceleration: str                                  # the airframe's observer.acceleration
    bias_time_s: tuple[float, float]                   # the airframe's acceleration_bias_time, the blend's
    still_noise_mps: tuple[float | None, float | None]  # the noise at low airflow of each fit
    blend_passed: bool | None                          # None: the blended fit itself failed
    blend_reasons: list[str]                           # why it failed its self-check (or could not be fitted)
    kept: bool
    predicted_ratio: float | None = None               # predicted RMS ratio of the acceleration noise

    def as_dict(self) -> dict[str, Any]:
        return {"acceleration": self.acceleration, "bias_time_s": list(self.bias_time_s),
                "still_noise_mps": list(self.still_noise_mps), "blend_passed": self.blend_passed,
                "blend_reasons": list(self.blend_reasons), "kept": self.kept, "predicted_ratio": self.predicted_ratio}


def part_dict(part: LowPassChange | AccelerationRoute | SelfCheck | None) -> dict[str, Any]:
    """A part the fit may not have made (the low-pass kept, no blend tried, no self-check yet): `{}`."""
    return {} if part is None else part.as_dict()
