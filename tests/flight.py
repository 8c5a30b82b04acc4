"""Test-side physics helpers: attitudes and thrust that realise a chosen external force exactly."""
from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation

from dobwind.model.airframe import Airframe


def quat_wxyz(rotation: Rotation) -> np.ndarray:
    x, y, z, w = rotation.as_quat()
    return np.array([w, x, y, z])


def attitude_for(z_body_down: np.ndarray, yaw: float) -> np.ndarray:
    """Quaternion (w, x, y, z) whose body z axis (down) is the given NED direction, with heading yaw."""
    z = z_body_down / np.linalg.norm(z_body_down)
    heading = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    y = np.cross(z, heading)
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    return quat_wxyz(Rotation.from_matrix(np.column_stack([x, y, z])))


def rpm_for_thrust(af: Airframe, total_n: float) -> float:
    """Equal rotor speed (rpm) that gives this collective thrust through the airframe's curve."""
    per_rotor = total_n / af.thrust.rotors / af.thrust.scale
    curve = lambda omega: np.polynomial.polynomial.polyval(omega, af.thrust.coefficients) - per_rotor
    return brentq(curve, 0.0, 10.0) * af.thrust.max_rpm


def balance(af: Airframe, force_ned: np.ndarray, yaw: float) -> tuple[np.ndarray, float]:
    """Attitude and thrust that hold the vehicle unaccelerated under an external force:
    -u_f z_b + m g e3 + f = 0."""
    need = af.mass_kg * af.gravity_mps2 * np.array([0, 0, 1.0]) + force_ned
    return attitude_for(need, yaw), float(np.linalg.norm(need))


def thrust_inputs(af: Airframe, thrust_n: float) -> dict[str, np.ndarray | float]:
    if af.thrust.source == "rpm":
        return {"rotor_rpm": np.full(af.thrust.rotors, rpm_for_thrust(af, thrust_n))}
    return {"thrust": thrust_n / af.thrust.scale}


def accel_inputs(af: Airframe, q: np.ndarray, acc_ned: np.ndarray) -> dict[str, np.ndarray]:
    mode = af.observer.acceleration
    if mode == "ned":
        return {"acc_ned": acc_ned}
    if mode == "specific_force":
        rot = Rotation.from_quat([q[1], q[2], q[3], q[0]])
        return {"specific_force": rot.inv().apply(acc_ned - af.gravity_mps2 * np.array([0, 0, 1.0]))}
    return {}


def force_for_airflow(af: Airframe, air_rel_ned: np.ndarray, yaw: float) -> np.ndarray:
    """External force (NED) that the airframe's force-air model maps to this relative airflow:
    horizontal force along the horizontal airflow, magnitude solving the model's speed; vertical by
    solving the vertical model. Uses the test transcription's term evaluator."""
    from tests.transcription import eval_poly

    c, s = math.cos(yaw), math.sin(yaw)
    rel_c = np.array([c * air_rel_ned[0] + s * air_rel_ned[1], -s * air_rel_ned[0] + c * air_rel_ned[1]])
    speed = float(np.hypot(*rel_c))
    direction = rel_c / speed if speed > 0 else np.array([1.0, 0.0])
    off = af.observer.force_offset_n

    def speed_error(fh: float) -> float:
        m, n = fh * direction
        return eval_poly(af.horizontal.term_texts, af.horizontal.coefficients, {"m": m, "n": n, "fh": fh, "fz": 0.0}) - speed

    fh = brentq(speed_error, 1e-9, 500.0) if speed > 0 else 0.0
    fz = brentq(lambda z: eval_poly(af.vertical.term_texts, af.vertical.coefficients,
                                    {"m": 0.0, "n": 0.0, "fh": 0.0, "fz": z}) - air_rel_ned[2], -500.0, 500.0)
    m, n = fh * direction + np.array(off[:2])
    return np.array([c * m - s * n, s * m + c * n, fz + off[2]])
