"""The analysis in wind units: what the observer and the scheduled low-pass do to the WIND estimate at
a given airspeed, through the airframe's calibrated force-air law (model/forceair.py, any family).

The linear analysis speaks in newtons; a user tuning gains asks how much wind noise and lag there is at
2, 5 and 10 m/s. The two differ by the law's local slope (m/s of airflow per N of force), which for a
drag law is steep near zero airflow (a pure quadratic law's is infinite there). So, at each schedule
breakpoint and each requested airspeed, with the schedule frozen at that speed:

- slope: d(airflow)/d(force) along and across the airflow, by central differences of the law's
  inversion (the step's own); the Bode of force to wind is the force path's times the slope;
- -3 dB bandwidth and group delay of the force path (the law is static: for small signals the wind
  path has the same frequency response up to the slope); the ramp lag is the group delay at DC (the
  estimate of a slow ramp trails it by that much), and the ramp error is the lag times the ramp rate;
- wind noise: the 1-sigma scatter of the wind component along and across the airflow, for per-axis
  Gaussian force noise of the size the linear noise gain gives, pushed through the law's inversion by
  Gauss-Hermite quadrature: not linearized, so it holds at zero airflow too, where the law is flattest.

The force noise is referred to the observer's input (white, per sample, in the acceleration input's
units, what ``figures.noise_gain`` multiplies): so the same noise serves any gains, which the gain
design needs. It comes from ``--force-noise`` (the observer's force-estimate scatter before the low-pass,
per horizontal axis, N, at the airframe's gains), or from the wind noise the fit measured (the airframe's
[uncertainty] noise_h, taken as measured at the schedule's first breakpoint, where the fit's still-air
segments fly), or it is unknown and the noise figures are left out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.optimize

from dobwind.analysis.figures import bandwidth_hz, gain_phase, group_delay_s, noise_gain
from dobwind.analysis.linear import Linearization, jacobian_function, linearize
from dobwind.analysis.ramp import RAMP_RATE_MPS2, force_for_airflow, hover_attitude
from dobwind.core.errors import InputError
from dobwind.model import forceair
from dobwind.model.airframe import Airframe
from dobwind.model.step import StepModel
from dobwind.model.signals import log_signals

# Gauss-Hermite points per axis of the 2-D force noise: 24^2 airflow inversions per airspeed; the
# scatter of a square-root law at zero airflow converges to 0.1 % with 16.
QUADRATURE_POINTS = 24
# Central-difference force step of the slope, as a share of the weight (floored for tiny vehicles).
SLOPE_STEP_WEIGHTS = 1e-4


@dataclass(frozen=True)
class NoiseSource:
    """Input-referred white noise (acceleration input units, per sample) and where it came from."""
    input_sigma: float | None
    source: str


def _airflow(af: Airframe, force_ned: np.ndarray, yaw: float) -> np.ndarray:
    """The step's reading of a hovering vehicle's force: its tilt and thrust follow the force."""
    yaws = np.full(len(force_ned), yaw)
    rot, thrust = hover_attitude(af, force_ned, yaws)
    rotor = np.sqrt(thrust / (af.mass_kg * af.gravity_mps2))
    return forceair.airframe_airflow(af, force_ned, yaws, rot.as_matrix(), rotor)


def _operating_force(af: Airframe, speed_mps: float) -> np.ndarray:
    """The NED force (offset included) of a hover in an airflow of ``speed_mps`` along north, yaw 0."""
    return force_for_airflow(af, np.array([[speed_mps, 0.0, 0.0]]), np.zeros(1))[0]


def local_slope(af: Airframe, speed_mps: float) -> tuple[float, float]:
    """(along, across) m/s of airflow per N of horizontal force at ``speed_mps`` (airflow along north,
    yaw 0): central differences of the law's inversion; one-sided from zero airflow."""
    f0 = _operating_force(af, speed_mps)
    step = max(SLOPE_STEP_WEIGHTS * af.mass_kg * af.gravity_mps2, 1e-6)
    if speed_mps > 0:
        shifts = np.array([[step, 0, 0], [-step, 0, 0], [0, step, 0], [0, -step, 0]])
        air = _airflow(af, f0 + shifts, 0.0)
        return float((air[0, 0] - air[1, 0]) / (2 * step)), float((air[2, 1] - air[3, 1]) / (2 * step))
    air = _airflow(af, f0 + np.array([[step, 0, 0], [0, step, 0]]), 0.0)
    return float(air[0, 0] / step), float(air[1, 1] / step)


def wind_scatter(af: Airframe, speed_mps: float, sigma_n: tuple[float, float]) -> tuple[float, float]:
    """1-sigma scatter (m/s) of the airflow along and across, for independent Gaussian force noise of
    ``sigma_n`` (N; x = along, y = across) about the force of ``speed_mps``: Gauss-Hermite quadrature
    through the law's inversion."""
    nodes, weights = np.polynomial.hermite_e.hermegauss(QUADRATURE_POINTS)
    weights = weights / weights.sum()
    gx, gy = np.meshgrid(nodes, nodes, indexing="ij")
    w = np.outer(weights, weights).ravel()
    shifts = np.column_stack([gx.ravel() * sigma_n[0], gy.ravel() * sigma_n[1], np.zeros(gx.size)])
    air = _airflow(af, _operating_force(af, speed_mps) + shifts, 0.0)
    spread = []
    for axis in (0, 1):
        mean = float(np.sum(w * air[:, axis]))
        spread.append(math.sqrt(max(float(np.sum(w * (air[:, axis] - mean) ** 2)), 0.0)))
    return spread[0], spread[1]


def _noise_gains(lin_noise: Linearization, with_filter: bool = True) -> tuple[float, float]:
    return noise_gain(lin_noise.axis(0, with_filter)), noise_gain(lin_noise.axis(1, with_filter))


def noise_source(af: Airframe, model: StepModel, force_noise_n: float | None) -> NoiseSource:
    """The input-referred noise: from --force-noise, else from the fit's recorded wind noise."""
    noise_jac = jacobian_function(model, "noise")
    if force_noise_n is not None:
        observer_gain = _noise_gains(linearize(model, function=noise_jac), with_filter=False)[0]
        return NoiseSource(force_noise_n / observer_gain, f"--force-noise {force_noise_n:g} N at the file's gains")
    recorded = af.uncertainty.noise_h_mps if af.uncertainty is not None else 0.0
    if not recorded > 0:
        return NoiseSource(None, "unknown (give --force-noise N, or fit the airframe)")
    speed = af.filter.speeds_mps[0]
    gains = _noise_gains(linearize(model, speed, function=noise_jac))
    along = lambda s: wind_scatter(af, speed, (s * gains[0], s * gains[1]))[0] - recorded  # noqa: E731
    hi = 1.0
    while along(hi) < 0 and hi < 1e6:
        hi *= 10
    sigma = float(scipy.optimize.brentq(along, 0.0, hi, xtol=1e-12, rtol=1e-6)) if along(hi) >= 0 else None
    return NoiseSource(sigma, f"the fit's wind noise {recorded:.3g} m/s ([uncertainty] noise_h), "
                              f"taken at {speed:g} m/s")


def _cutoff_at(af: Airframe, speed: float) -> float:
    return float(np.interp(speed, af.filter.speeds_mps, af.filter.cutoffs_hz))


def wind_point(af: Airframe, model: StepModel, speed: float, freqs_hz: list[float], noise: NoiseSource,
               jacobians: tuple) -> dict[str, Any]:
    """The wind-unit figures at one airspeed, schedule frozen there (axis x: along the airflow)."""
    force_jac, noise_jac = jacobians
    sys_ = linearize(model, speed, function=force_jac).axis(0)
    along, across = local_slope(af, speed)
    delay = group_delay_s(sys_)
    bode = []
    for f in freqs_hz:
        db, deg = gain_phase(sys_, f)
        gain = db + 20 * math.log10(abs(along)) if along != 0 and math.isfinite(along) else None  # JSON: no inf
        bode.append({"freq_hz": f, "gain_db_re_1mps_per_n": gain, "phase_deg": deg})
    point: dict[str, Any] = {
        "airspeed_mps": speed, "cutoff_hz": _cutoff_at(af, speed),
        "slope_along_mps_per_n": along, "slope_across_mps_per_n": across,
        "bandwidth_hz": None if math.isinf(bw := bandwidth_hz(sys_)) else bw, "group_delay_s": delay,
        "ramp_lag_s": delay, "ramp_error_mps": delay * RAMP_RATE_MPS2, "bode": bode,
        "force_noise_n": None, "wind_noise_along_mps": None, "wind_noise_across_mps": None,
    }
    if noise.input_sigma is not None:
        gains = _noise_gains(linearize(model, speed, function=noise_jac))
        sigma = (noise.input_sigma * gains[0], noise.input_sigma * gains[1])
        scatter = wind_scatter(af, speed, sigma)
        point.update({"force_noise_n": sigma[0], "wind_noise_along_mps": scatter[0],
                      "wind_noise_across_mps": scatter[1]})
    return point


# How far the law's reading of the operating force may fall from the airspeed asked (m/s): a polynomial
# law that saturates, or is searched only up to the weight, cannot make every airspeed.
REACH_TOLERANCE_MPS = 0.01


def reaches(af: Airframe, speed_mps: float) -> bool:
    """The law reads ``speed_mps`` back from the force made for it (within REACH_TOLERANCE_MPS)."""
    air = _airflow(af, _operating_force(af, speed_mps)[None, :], 0.0)[0]
    return abs(float(np.hypot(air[0], air[1])) - speed_mps) <= REACH_TOLERANCE_MPS


def _check_airspeeds(af: Airframe, airspeeds_mps: list[float]) -> None:
    for speed in airspeeds_mps:
        if not reaches(af, speed):
            raise InputError(af.name, "--airspeed", f"the force-air law does not reach {speed:g} m/s within a "
                                                   f"force of the vehicle's weight")


def wind_units(af: Airframe, model: StepModel, freqs_hz: list[float], airspeeds_mps: list[float],
               force_noise_n: float | None = None, noise: NoiseSource | None = None) -> dict[str, Any]:
    """The report's "wind_units" block: per breakpoint and per requested airspeed. ``noise`` (input-
    referred, e.g. found at another airframe's gains before a design) overrides ``force_noise_n``."""
    _check_airspeeds(af, airspeeds_mps)
    noise = noise or noise_source(af, model, force_noise_n)
    jacobians = (jacobian_function(model, "force"), jacobian_function(model, "noise"))
    point = lambda s: wind_point(af, model, s, freqs_hz, noise, jacobians)  # noqa: E731
    unit = "m/s" if not log_signals(af).measured_acceleration else "m/s^2"  # of the acceleration input, per sample
    return {"noise_source": noise.source, "input_noise": noise.input_sigma, "input_noise_unit": unit,
            "ramp_rate_mps2": RAMP_RATE_MPS2,
            "breakpoints": [point(s) for s in af.filter.speeds_mps],
            "airspeeds": [point(s) for s in airspeeds_mps]}


def _fmt(value: float | None, spec: str = ".3g") -> str:
    return "-" if value is None else format(value, spec)


def wind_text(block: dict[str, Any]) -> list[str]:
    """The text report's lines for the wind-unit block."""
    lines = ["", f"In wind units (axis x along the airflow; noise from {block['noise_source']}):",
             "  airspeed m/s  cutoff Hz  slope m/s/N  -3dB Hz  delay = ramp lag s  ramp error m/s  "
             "wind noise along/across m/s"]
    rows = [("breakpoint", p) for p in block["breakpoints"]] + [("asked", p) for p in block["airspeeds"]]
    for kind, p in rows:
        lines.append(f"  {p['airspeed_mps']:12g}  {p['cutoff_hz']:9.3g}  {p['slope_along_mps_per_n']:11.3g}  "
                     f"{_fmt(p['bandwidth_hz'], '7.3f')}  {p['ramp_lag_s']:18.3f}  {p['ramp_error_mps']:14.3f}  "
                     f"{_fmt(p['wind_noise_along_mps'])}/{_fmt(p['wind_noise_across_mps'])}  ({kind})")
    return lines
