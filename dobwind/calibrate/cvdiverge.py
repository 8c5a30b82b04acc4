"""What a cross-validation fold whose held-out predictions diverged says about the flight.

A fold fits the law on the other blocks and inverts it on the held-out one. When the other blocks hold
next to no variety of airflow (a short flight whose second block is a hover in a steady wind: every
sample at the same airflow), the horizontal drag is not pinned down there: the fit puts it in the force
offset and the thrust scale, the drag terms go to zero, and the step's inversion of such a law reads
any force as an airflow of thousands of m/s. dragfit.prediction_error counts each such sample as its clip
(1000 m/s), so the hold-level CV becomes a mixture of clips and real errors: on the 37 s PX4 drag-fusion
field log, 480.693 m/s. That number measures nothing; what the user needs is which fold diverged and
what its fitted blocks lacked (this module), which the self-check says instead of the number.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dobwind.calibrate import dragfit

# Airflow speeds (m/s) whose 5-95 % spread is under this teach a law nothing about how drag grows.
NARROW_SPEED_SPREAD_MPS = 0.5


@dataclass(frozen=True)
class FoldDivergence:
    """One CV fold whose held-out predictions diverged: its blocks, counts and airflow speeds (m/s)."""
    held_out_blocks: tuple[int, ...]
    fitted_blocks: tuple[int, ...]
    diverged: int                          # held-out samples whose horizontal error reached the clip
    held_out: int
    fitted: int                            # samples the fold's law was fitted on
    fitted_speed_mps: tuple[float, float]  # 5th and 95th percentiles of the fitted samples' airflow speed
    held_speed_mps: tuple[float, float]    # the same of the held-out samples
    median_read_mps: float                 # median horizontal airflow speed the law read there (inf: none)

    def lacked(self) -> str:
        """What the fitted blocks lacked, from their airflow speeds against the held-out ones'."""
        low, high = self.fitted_speed_mps
        if high - low < NARROW_SPEED_SPREAD_MPS:
            return (f"too little airflow-speed variety in the other block{_s(self.fitted_blocks)} "
                    f"({low:.1f}-{high:.1f} m/s: a hover in a steady wind reads as one airflow), which leaves the "
                    "drag not pinned down")
        if self.held_speed_mps[1] > high:
            return (f"the held-out airflow ({self.held_speed_mps[0]:.1f}-{self.held_speed_mps[1]:.1f} m/s) lies beyond "
                    f"the other block{_s(self.fitted_blocks)}' ({low:.1f}-{high:.1f} m/s)")
        return f"the other block{_s(self.fitted_blocks)} do not pin the law down ({self.fitted} samples)"

    def text(self) -> str:
        read = "infinite" if not np.isfinite(self.median_read_mps) else f"{self.median_read_mps:.3g} m/s"
        return (f"the law fitted without block{_s(self.held_out_blocks)} {_blocks(self.held_out_blocks)} (on "
                f"{self.fitted} samples of block{_s(self.fitted_blocks)} {_blocks(self.fitted_blocks)}) reads "
                f"{'its' if len(self.held_out_blocks) == 1 else 'their'} airflow at a median {read} "
                f"({self.diverged} of {self.held_out} samples diverged): {self.lacked()}")


def _s(blocks: tuple[int, ...]) -> str:
    return "" if len(blocks) == 1 else "s"


def _blocks(blocks: tuple[int, ...]) -> str:
    return ", ".join(str(b) for b in blocks)


def _speed_percentiles(airflow: np.ndarray) -> tuple[float, float]:
    speed = np.hypot(airflow[:, 0], airflow[:, 1])
    return (float(np.percentile(speed, 5)), float(np.percentile(speed, 95))) if speed.size else (np.nan, np.nan)


def fold_divergence(split: dragfit.Split, error: np.ndarray) -> FoldDivergence | None:
    """The fold's divergence from its held-out errors (dragfit.prediction_error's, clipped), or None when
    no held-out sample's horizontal error reached the clip."""
    fitted, held = split
    at_clip = (np.abs(error[:, :2]) >= dragfit.ERROR_CLIP_MPS).any(axis=1)
    if not at_clip.any():
        return None
    with np.errstate(invalid="ignore", over="ignore"):
        read = np.hypot(held.airflow[:, 0] + error[:, 0], held.airflow[:, 1] + error[:, 1])
    return FoldDivergence(tuple(int(g) for g in np.unique(held.group)), tuple(int(g) for g in np.unique(fitted.group)),
                          int(at_clip.sum()), len(held), len(fitted), _speed_percentiles(fitted.airflow),
                          _speed_percentiles(held.airflow), float(np.median(read)))


def unpredicted(raw: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """The held-out errors as the divergence test reads them: raw predictions minus truth, NaN and
    overflow counted as the clip (dragfit.prediction_error), but the size of a finite error kept for the
    median read (clipping it would report the clip, not what the law read)."""
    with np.errstate(invalid="ignore", over="ignore"):
        error = raw - truth
    return np.where(np.isfinite(error), error, dragfit.ERROR_CLIP_MPS)


def summary(folds: tuple[FoldDivergence, ...], total_folds: int, cv_mps: float) -> str | None:
    """The self-check's sentence for a hold-level CV some of whose folds diverged (None when none did)."""
    if not folds:
        return None
    return (f"held-out predictions diverged in {len(folds)} of {total_folds} cross-validation folds, so the figure "
            f"({cv_mps:.3f} m/s, each diverged sample counted as {dragfit.ERROR_CLIP_MPS:g} m/s) measures nothing "
            f"(blocks: {dragfit.BLOCK_S:g} s of a log's fit samples each, numbered in time order across the logs): "
            + "; ".join(f.text() for f in folds))
