"""How far the drag law's terms can follow a simulated vehicle's true level force, noise-free.

For one vehicle file (dobwind/simulate/vehicle.py) the true body force of level flight (hover thrust) is
sampled on a grid of airflow directions (every 5 deg) and speeds (0.5 to 8.5 m/s). Each horizontal term
set is fitted to it by least squares in FORCE space (as the drag fit does, without noise, the filter or
tilt), and the fitted law is inverted by the step's own heading-frame inversion (model/forceair.py).
What is left, the airflow direction and speed errors at 2 m/s and faster, is what no calibration
flight can remove with those terms: the reach of the law. A law that does not increase everywhere up to
12 m/s (law_decreasing) is one the fit drops.

    .venv/bin/python -m benchmarks.lawreach benchmarks/anisovehicles/nv_longthin.vehicle.toml
"""
from __future__ import annotations

import sys

import numpy as np

from dobwind.model import forceair
from dobwind.simulate.vehicle import body_force, load_vehicle

SETS = (("l0", "q0"), ("l0", "q0", "l2c", "q2c", "l2s", "q2s"), ("l0", "q0", "l2c", "q2c", "l2s", "q2s", "q1c"),
        ("l0", "q0", "l2c", "q2c", "l2s", "q2s", "q4c", "q4s"),
        ("l0", "q0", "l2c", "q2c", "l2s", "q2s", "q1c", "q4c", "q4s"), ("l0", "q0", "qax", "qay"),
        ("l0", "q0", "l2c", "q2c", "l2s", "q2s", "qax", "qay"), ("l0", "q0", "l2c", "q2c", "l2s", "q2s", "q1c", "qax", "qay"),
        ("l0", "q0", "l2c", "q2c", "l2s", "q2s", "q1c", "qax", "qay", "qax1c", "qay1c"))
SCORED_FROM_MPS = 2.0   # below it a direction error is a small distance
CHECKED_UP_TO_MPS = 12.0


def grid() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Airflow (N, 2) in the body frame, its direction (rad) and speed (m/s)."""
    theta, speed = np.meshgrid(np.radians(np.arange(0.0, 360.0, 5.0)), np.arange(0.5, 8.51, 0.5))
    theta, speed = theta.ravel(), speed.ravel()
    return np.column_stack([speed * np.cos(theta), speed * np.sin(theta)]), theta, speed


def fitted_law(keys: tuple[str, ...], airflow: np.ndarray, force: np.ndarray) -> tuple[forceair.DragLaw, float]:
    """The least-squares law of ``keys`` on the force, and its RMS force residual (N)."""
    s = np.hypot(airflow[:, 0], airflow[:, 1])
    basis = forceair.horizontal_drag_basis(airflow[:, 0], airflow[:, 1], s)
    columns = np.column_stack([np.concatenate([np.broadcast_to(basis[k][0], s.shape),
                                               np.broadcast_to(basis[k][1], s.shape)]) for k in keys])
    target = np.concatenate([force[:, 0], force[:, 1]])
    coefficients = np.linalg.lstsq(columns, target, rcond=None)[0]
    law = forceair.DragLaw(**{"l0": 0.0, "q0": 0.0, **{k: float(c) for k, c in zip(keys, coefficients)}})
    return law, float(np.sqrt(np.mean((columns @ coefficients - target) ** 2)))


def reach_line(keys: tuple[str, ...], airflow: np.ndarray, theta: np.ndarray, speed: np.ndarray,
               force: np.ndarray) -> str:
    law, residual = fitted_law(keys, airflow, force)
    with np.errstate(all="ignore"):
        read = forceair.drag_airflow_numpy(law, force[:, 0], force[:, 1], np.zeros(len(speed)))
        angle = np.degrees(np.abs((np.arctan2(read[:, 1], read[:, 0]) - theta + np.pi) % (2 * np.pi) - np.pi))
        speed_error = np.hypot(read[:, 0], read[:, 1]) - speed
        scored = speed >= SCORED_FROM_MPS
        rms = float(np.sqrt(np.mean(speed_error[scored] ** 2)))
    angle = np.where(np.isfinite(angle), angle, 180.0)[scored]
    where = forceair.law_decreasing(law, CHECKED_UP_TO_MPS)
    return (f"  {'+'.join(keys):54s} force RMS {residual:.3f} N; direction mean {angle.mean():5.2f} max "
            f"{angle.max():6.2f} deg; speed RMS {rms:.3f} m/s; " + ("increasing" if where is None else f"decreases at {where}"))


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        sys.stderr.write("usage: python -m benchmarks.lawreach VEHICLE.vehicle.toml\n")
        return 2
    spec = load_vehicle(args[0])
    airflow, theta, speed = grid()
    force = body_force(spec, np.column_stack([airflow, np.zeros(len(speed))]), np.ones(len(speed)))[:, :2]
    print(f"{args[0]}: the best law of each term set on the true level force (errors at {SCORED_FROM_MPS:g} m/s and faster)")
    for keys in SETS:
        print(reach_line(keys, airflow, theta, speed, force))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
