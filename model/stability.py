"""Stability of the observer and low-pass at the airframe's nominal sample time and at max_dt."""
from __future__ import annotations

import math

from dobwind.model.errors import InputError
from dobwind.model.airframe import Airframe
from dobwind.model.discretization import first_order


def observer_poles(af: Airframe, dt: float | None = None) -> list[float]:
    dt = af.observer.sample_time_s if dt is None else dt
    return [float(first_order(af.observer.discretization, g / af.mass_kg, dt).pole) for g in af.observer.gains]


def unstable_reason(af: Airframe) -> str | None:
    """None when every observer pole lies strictly inside the unit circle at the nominal sample time
    and at limits.max_dt (the C step accepts any dt up to that); else a one-line reason."""
    for label, dt in (("sample_time", af.observer.sample_time_s), ("limits.max_dt", af.limits.max_dt_s)):
        for axis, pole in zip("xyz", observer_poles(af, dt)):
            if not abs(pole) < 1.0 or not math.isfinite(pole):
                return (f"observer pole {pole:.6g} on axis {axis} at dt = {dt:g} s ({label}) is not inside the unit "
                        f"circle (gain {af.observer.gains['xyz'.index(axis)]:g})")
    return None


def require_stable(af: Airframe, action: str, source: str | None = None) -> None:
    """The one gate that `check` and `generate` share, so they can never disagree on the same gains:
    an unstable observer is bad input (exit 2), named by its airframe key."""
    reason = unstable_reason(af)
    if reason:
        raise InputError(source or af.name, "observer.gains", f"{action}: {reason}")
