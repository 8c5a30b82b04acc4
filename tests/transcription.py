"""An independent NumPy transcription of the estimator, written from the equations in
docs/model.md (and the paper), not from the CasADi code.

It shares only bookkeeping with the model (the Layout that says which column is which); every equation
is written again here, in a different way where possible (rotation by quaternion products, the
schedule by np.interp, terms by a separate little evaluator), so a mistake in one is unlikely to be
repeated in the other.
"""
from __future__ import annotations

import functools
import math
import re

import numpy as np

from dobwind.model.airframe import Airframe


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Body vector v into NED: q (0, v) q*."""
    q = q / np.linalg.norm(q)
    conj = q * np.array([1, -1, -1, -1])
    return quat_mul(quat_mul(q, np.concatenate([[0.0], v])), conj)[1:]


def eval_term(text: str, env: dict[str, float]) -> float:
    if text.strip() == "1":
        return 1.0
    value = 1.0
    for factor in text.replace(" ", "").split("*"):
        base_text, _, power_text = factor.partition("^")
        inner = re.fullmatch(r"abs\((\w+)\)", base_text)
        base = abs(env[inner.group(1)]) if inner else env[base_text]
        power = float(power_text) if power_text else 1.0
        if power < 0:
            base = math.copysign(max(abs(base), 1e-3), base if base != 0 else 1.0)
        value *= base ** power
    return value


def eval_poly(terms, coefficients, env) -> float:
    return sum(c * eval_term(t, env) for t, c in zip(terms, coefficients))


def settling_time(af: Airframe) -> float:
    # Held as the nearest float32, so that single- and double-precision C decide SETTLING alike.
    return float(np.float32(_settling_time(af.observer.sample_time_s, min(af.observer.gains) / af.mass_kg,
                                           min(af.filter.cutoffs_hz), af.observer.discretization)))


@functools.lru_cache(maxsize=64)
def _settling_time(dt: float, w: float, cutoff_hz: float, disc: str) -> float:
    """Observer then low-pass, slowest axis and cutoff, stepped sample by sample until the output
    stays within 2 %: the accepted time at the first sample that stays inside."""
    alpha = 1 - math.exp(-2 * math.pi * cutoff_hz * dt)
    obs = filt = 0.0
    last_outside, k, previous_input = -1, 0, 0.0
    while k < last_outside + 20000 or k < 100:
        if disc == "tustin":
            kk = w * dt / 2
            obs = ((1 - kk) * obs + kk * (1.0 + previous_input)) / (1 + kk)
            previous_input = 1.0
        else:
            a = {"paper": dt * w / 2, "euler": dt * w, "zoh": 1 - math.exp(-dt * w)}[disc]
            obs = (1 - a) * obs + a
        filt = (1 - alpha) * filt + alpha * obs
        if abs(filt - 1) > 0.02:
            last_outside = k
        k += 1
    return (last_outside + 1 + 0.5618) * dt  # between samples: see model/settling.py


def quality_of(af: Airframe, run_s: float, dt: float, force_c: np.ndarray, airflow: float) -> tuple[float, int]:
    """(new run_s, quality bits) of an accepted sample."""
    settle = settling_time(af)
    run = min(run_s + dt, settle)
    bits = 64 if run < settle else 0
    env = af.envelope
    if env is not None and not (math.hypot(force_c[0], force_c[1]) <= env.force_h_max_n
                                and env.force_z_n[0] <= force_c[2] <= env.force_z_n[1]
                                and airflow <= env.airflow_h_max_mps):
        bits |= 128
    return run, bits


def sigmas(af: Airframe, airflow: float) -> tuple[float, float]:
    unc = af.uncertainty
    if unc is None:
        return -1.0, -1.0
    return (float(np.interp(airflow, unc.speeds_mps, unc.sigma_h_mps)),
            float(np.interp(airflow, unc.speeds_mps, unc.sigma_up_mps)))


def status_of(af: Airframe, inp: dict[str, np.ndarray]) -> int:
    everything = np.concatenate([np.atleast_1d(np.asarray(v, float)) for v in inp.values()])
    status = 0
    if not (np.all(np.isfinite(everything)) and np.all(np.abs(everything) <= 1e6)):
        status |= 1
    dt = float(inp["dt"])
    if not (1e-5 <= dt <= af.limits.max_dt_s * 1.0001):
        status |= 2
    norm = float(np.linalg.norm(inp["q"]))
    if not (0.9 <= norm <= 1.1):
        status |= 4
    with np.errstate(invalid="ignore", divide="ignore"):
        z_down = rotate(np.asarray(inp["q"], float), np.array([0.0, 0.0, 1.0]))[2] if norm > 0 else np.nan
        tilt_deg = math.degrees(math.acos(max(-1.0, min(1.0, z_down)))) if np.isfinite(z_down) else np.inf
    if norm != 0 and not tilt_deg <= af.limits.max_tilt_deg:  # a zero quaternion has no tilt to judge
        status |= 8
    thrust = inp["rotor_rpm"] if af.thrust.source == "rpm" else inp["thrust"]
    if not np.all(np.asarray(thrust) >= 0):
        status |= 16
    if _implausible(af, inp):
        status |= 2048
    return status


def _implausible(af: Airframe, inp: dict[str, np.ndarray]) -> bool:
    """Issue #37's bounds: 150 m/s over ground, 10 standard g, 1.5 max_rpm, 20 weights of thrust."""
    with np.errstate(invalid="ignore", over="ignore"):
        tests = [np.linalg.norm(inp["vel_ned"]) > 150.0]
        for name in ("acc_ned", "specific_force"):
            if name in inp:
                tests.append(np.linalg.norm(inp[name]) > 10 * 9.80665)
        if af.thrust.source == "rpm":
            tests.append(np.any(np.asarray(inp["rotor_rpm"], float) > 1.5 * af.thrust.max_rpm))
        else:
            tests.append(float(inp["thrust"]) > 20 * af.mass_kg * af.gravity_mps2)
    return bool(any(tests))


def step(af: Airframe, st: dict[str, np.ndarray], inp: dict[str, np.ndarray]):
    """Returns (new state dict, output dict, status)."""
    status = status_of(af, inp)
    if status:
        return _rejected(st, status)
    m, g = af.mass_kg, af.gravity_mps2
    dt = float(inp["dt"])
    q = np.asarray(inp["q"], float)
    v = np.asarray(inp["vel_ned"], float)
    started = float(st["initialized"]) > 0.5
    follows = float(st["run_s"]) > 0  # the previous sample was accepted: no gap to difference across
    if af.thrust.source == "rpm":
        u_f = sum(np.polynomial.polynomial.polyval(r / af.thrust.max_rpm, af.thrust.coefficients) for r in inp["rotor_rpm"])
    else:
        u_f = float(inp["thrust"])
    u_f *= af.thrust.scale
    z_b = rotate(q, np.array([0.0, 0.0, 1.0]))
    mode = af.observer.acceleration
    if mode == "specific_force":
        f_e = m * rotate(q, np.asarray(inp["specific_force"], float)) + u_f * z_b  # gravity cancels
    else:
        if mode == "ned":
            acc = np.asarray(inp["acc_ned"], float)
        else:
            acc = (v - st["vel_prev"]) / dt if follows else np.zeros(3)
        f_e = m * acc - m * g * np.array([0, 0, 1.0]) + u_f * z_b  # slip 1: "- m g0 e3", not "- g"
    bias = check = None
    tau = af.observer.acceleration_bias_time_s
    if tau > 0:
        # The measured kinematic acceleration, then its disagreement with the velocity's slope.
        kinematic = (np.asarray(inp["acc_ned"], float) if mode == "ned"
                     else rotate(q, np.asarray(inp["specific_force"], float)) + np.array([0, 0, g]))
        f_e = f_e - m * st["acc_bias"]
        bias = st["acc_bias"].copy()
        slope = (v - st["vel_prev"]) / dt
        if follows:
            bias = bias + (1 - math.exp(-dt / tau)) * (kinematic - slope - bias)
        check = _acceleration_check(st, kinematic - st["acc_bias"] - slope, dt, v)

    w = np.asarray(af.observer.gains) / m
    disc = af.observer.discretization
    if disc == "tustin":
        k = w * dt / 2
        fe_prev, v_prev = (st["fe_prev"], st["vel_prev"]) if follows else (f_e, v)
        f_obs = ((1 - k) * st["f_obs"] + k * (f_e + fe_prev)) / (1 + k)
        v_obs = ((1 - k) * st["v_obs"] + k * (v + v_prev)) / (1 + k)
    else:
        a = {"paper": dt * w / 2, "euler": dt * w, "zoh": 1 - np.exp(-dt * w)}[disc]
        f_obs = (1 - a) * st["f_obs"] + a * f_e
        v_obs = (1 - a) * st["v_obs"] + a * v
    if not started:
        f_obs, v_obs = f_e.copy(), v.copy()

    cutoff = np.interp(float(st["last.wind_speed_h"]), af.filter.speeds_mps, af.filter.cutoffs_hz)
    alpha = 1 - math.exp(-2 * math.pi * cutoff * dt)
    if started:
        f_filt = (1 - alpha) * st["f_filt"] + alpha * f_obs
        v_filt = (1 - alpha) * st["v_filt"] + alpha * v_obs
    else:
        f_filt, v_filt = f_obs.copy(), v_obs.copy()

    psi = float(inp["yaw_ref"])
    rz = np.array([[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]])
    fc = rz.T @ f_filt - np.asarray(af.observer.force_offset_n)
    env = {"m": fc[0], "n": fc[1], "fz": fc[2], "fh": math.hypot(fc[0], fc[1])}
    speed = max(eval_poly(af.horizontal.term_texts, af.horizontal.coefficients, env), 0.0)
    run_s, quality = quality_of(af, float(st["run_s"]), dt, fc, speed)
    sigma_h, sigma_up = sigmas(af, speed)
    horizontal = speed * fc[:2] / math.sqrt(env["fh"] ** 2 + 1e-6)
    rel_c = np.array([horizontal[0], horizontal[1], eval_poly(af.vertical.term_texts, af.vertical.coefficients, env)])
    wind = rz @ rel_c + v_filt  # slip 3: the air's velocity relative to the vehicle plus the ground velocity
    out = {
        "force_ned": f_filt,
        "wind_ned": wind,
        "wind_speed_h": math.hypot(wind[0], wind[1]),
        "wind_speed_up": -wind[2],  # slip 4: NED down -> up positive
        "wind_from_deg": math.degrees(math.atan2(-wind[1], -wind[0])) % 360.0,  # slip 4: from, not towards
        "wind_sigma_h": sigma_h,
        "wind_sigma_up": sigma_up,
    }
    new = dict(st)
    new.update(f_obs=f_obs, v_obs=v_obs, f_filt=f_filt, v_filt=v_filt, initialized=1.0, run_s=run_s)
    if "fe_prev" in st:
        new["fe_prev"] = f_e
    if "vel_prev" in st:
        new["vel_prev"] = v
    if bias is not None:
        new["acc_bias"] = bias
    for key, value in out.items():
        new[f"last.{key}"] = value
    checked = np.concatenate([f_filt, wind, [out["wind_speed_h"]]] + ([] if bias is None else [bias]))
    if not np.sum(np.abs(checked)) <= 1e30:
        return _rejected(st, 32, check)
    if check is not None and check.pop("trips"):
        return _rejected(st, 2048, check)  # the acceleration disagrees with the velocity: IMPLAUSIBLE
    if check is not None:
        new.update(check)
    if np.linalg.norm(wind) > 50.0:  # beyond any calibration: flagged, not rejected
        quality |= 128
    return new, out, quality


def _acceleration_check(st: dict, disagreement: np.ndarray, dt: float, v: np.ndarray) -> dict:
    """The acceleration check of docs/c-api.md: the disagreement averaged over 0.1 s (weight dt / (0.1 + dt));
    IMPLAUSIBLE when its squared norm exceeds 36 times its mean square (20 s) plus (2 m/s^2)^2; the mean square takes in at most
    that bound. Nothing moves when the previous sample failed validation (vel_prev is not its velocity)."""
    mean = np.array(st["acc_check"], float)
    spread = float(st["acc_noise"])
    limit = 36.0 * spread + 4.0
    if float(st["check_follows"]) > 0.5:
        mean = mean + dt / (0.1 + dt) * (disagreement - mean)  # backward Euler
        spread = spread + (1 - math.exp(-dt / 20.0)) * (min(float(mean @ mean), limit) - spread)
    return {"acc_check": mean, "acc_noise": spread, "check_follows": 1.0, "vel_prev": v,
            "trips": float(mean @ mean) > limit}


def _rejected(st: dict, status: int, check: dict | None = None):
    """The estimate and the last output kept; only the gap bookkeeping drops to zero (and, after
    validation, the acceleration check follows the sample)."""
    kept = dict(st)
    kept["run_s"] = 0.0
    if "check_follows" in kept:
        kept["check_follows"] = 0.0
    if check is not None:
        kept.update({k: v for k, v in check.items() if k != "trips"})
    return kept, {k[5:]: v for k, v in st.items() if k.startswith("last.")}, status
