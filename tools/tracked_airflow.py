"""The figures of docs/verification.md on the tracked airflow (state ``air_prev``) of a body-frame drag
airframe: ``python -m tools.tracked_airflow AIRFRAME [--precision single|double] [--steps N]``.

- offsets: the smallest offset of air_prev (added to the C's state on every accepted row of a flight)
  that verify's comparison fails, element by element as before and through the law as now;
- from zero: the tracked inversion from zero airflow against the converged one, for small vertical
  forces at hover thrust (the overshoot of a law with lz = 0);
- hover: the reference step from model/boundaries.py's neutral row (a settled estimator at zero airflow)
  over hover samples with 0.01 m/s^2 of acceleration noise: the first sample's airflow and wind;
- calm: the tracked inversion, sample by sample, at hover thrust and level, of a body-frame force that is
  low-passed noise around zero (a hover in still air), against the converged inversion;
- flight: the step's tracked airflow against the converged inversion of the same force on verify's
  flight (model/exercise.py), after its first 100 samples.
"""
from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

from dobwind.codegen.generate import generate_code, write_files
from dobwind.codegen.tolerance import TOLERANCE
from dobwind.harness.build import build_shared_library
from dobwind.harness.compare import RowStarts, compare
from dobwind.harness.cstep import CStep
from dobwind.harness.verify import ReferenceChecks
from dobwind.model import forceair, reference
from dobwind.model.airframe import load_airframe
from dobwind.model.airstate import step_signals
from dobwind.model.exercise import flight_inputs
from dobwind.model.boundaries import neutral_row
from dobwind.model.kinds import Precision
from dobwind.model.reference import Trajectory
from dobwind.model.status import REJECTED_MASK
from dobwind.model.step import StepModel, body_drag_target, build_step

OFFSETS = np.logspace(-13, 0, 131)  # m/s, ten per decade


def _c_flight(model: StepModel, precision: Precision, checks: ReferenceChecks) -> Trajectory:
    with tempfile.TemporaryDirectory(prefix="dobwind-tracked-") as tmp:
        write_files(generate_code(model.airframe, precision, model).files, Path(tmp))
        return CStep(model, build_shared_library(model, precision, Path(tmp), Path(tmp), ())).run(checks.flight_inputs)


def smallest_failing_offsets(model: StepModel, precision: Precision, steps: int) -> dict[tuple[int, bool], float]:
    """(axis, judged through the law) -> the smallest offset in OFFSETS that fails (inf: none)."""
    checks = ReferenceChecks.build(model, precision, steps, 1)
    flight = _c_flight(model, precision, checks)
    column = model.state.slice("air_prev").start
    accepted = (flight.status & REJECTED_MASK) == 0

    def fails(delta: float, axis: int, judged: bool) -> bool:
        states = flight.states.copy()
        states[accepted, column + axis] += delta
        got = Trajectory(states, flight.outputs, flight.status)
        starts = RowStarts.flight(model, checks.flight_inputs, got, checks.flight) if judged else None
        return not compare(model, got, checks.flight, TOLERANCE[precision], starts).passed()

    return {(axis, judged): next((d for d in OFFSETS if fails(d, axis, judged)), np.inf)
            for axis in range(3) for judged in (False, True)}


def from_zero(model: StepModel, forces_z: tuple[float, ...] = (1e-5, 1e-4, 1e-3, 1e-2)) -> list[tuple[float, float, float]]:
    """(vertical force N, tracked vertical airflow from zero, converged one) at hover thrust, level."""
    tracked, solved = _inversions(model)
    return [(fz, float(tracked([0, 0, fz], [0, 0, 0])[2]), float(solved([0, 0, fz])[2])) for fz in forces_z]


def _inversions(model: StepModel) -> tuple[ca.Function, ca.Function]:
    """(force, previous airflow) -> tracked body-frame airflow, and force -> converged; level, hover thrust."""
    law, f, previous = model.airframe.drag, ca.SX.sym("f", 3), ca.SX.sym("previous", 3)
    rot, rotor = ca.SX.eye(3), ca.SX(1.0)
    tracked = ca.Function("tracked", [f, previous],
                          [forceair.body_drag_airflow_tracking(law, f, rot, rotor, previous, ca.SX(1))[1]])
    return tracked, ca.Function("solved", [f], [forceair.body_drag_airflow(law, f, rot, rotor)])


def calm(model: StepModel, sigma_n: float, samples: int = 20000, seed: int = 1) -> str:
    """Tracking through low-passed force noise of about ``sigma_n`` around zero: how often it is off."""
    tracked, solved = _inversions(model)
    rng = np.random.default_rng(seed)
    previous, force, errors = np.asarray(solved([0, 0, 0])).ravel(), np.zeros(3), np.zeros((samples, 2))
    for k in range(samples):
        force = 0.95 * force + 0.05 * rng.normal(0, sigma_n / np.sqrt(0.05), 3)  # std about sigma_n
        previous, converged = np.asarray(tracked(force, previous)).ravel(), np.asarray(solved(force)).ravel()
        errors[k] = np.abs(previous - converged).max(), np.abs(previous[:2] - converged[:2]).max()
    return (f"force noise {sigma_n:g} N, {samples} samples: {int(np.sum(errors[:, 0] > 1))} off by more than 1 m/s "
            f"(worst {errors[:, 0].max():.3g}), {int(np.sum(errors[:, 1] > 0.1))} off by more than 0.1 m/s "
            f"horizontally (worst {errors[:, 1].max():.3g})")


def flight(model: StepModel, steps: int) -> str:
    """The step's airflow against the converged inversion of the force it inverted, row by row."""
    x, u = ca.SX.sym("state", model.state.size), ca.SX.sym("input", model.inputs.size)
    signals = step_signals(model, x, u)
    force, rotor = body_drag_target(model.airframe, signals)
    converged = forceair.body_drag_airflow(model.airframe.drag, force, ca.reshape(signals["rot_body_to_ned"], 3, 3), rotor)
    both = ca.Function("both", [x, u], [signals["air_rel_ned"], converged])
    inputs = flight_inputs(model, steps, 1)
    traj = reference.run(model, inputs)
    before = np.vstack([model.initial_state(), traj.states[:-1]])
    got, want = (np.asarray(v).T for v in both.map(steps)(before.T, inputs.T))
    rows = (traj.status & REJECTED_MASK) == 0
    rows[:100] = False
    error = np.abs(got - want).max(axis=1)[rows]
    return (f"{int(rows.sum())} accepted rows after the first 100: median {np.median(error):.3g}, 99.9th percentile "
            f"{np.quantile(error, 0.999):.3g}, worst {error.max():.3g} m/s")


def hover(model: StepModel, rows: int = 200, seed: int = 2) -> str:
    """The first hover sample from a settled state at zero airflow, against the converged inversion."""
    state, row = neutral_row(model)
    inputs = np.tile(row, (rows, 1))
    inputs[:, model.inputs.slice("acc_ned")] += np.random.default_rng(seed).normal(0, 0.01, (rows, 3))
    traj = reference.run(model, inputs, state)
    u_f = inputs[:, model.inputs.slice("thrust")].ravel() * model.airframe.thrust.scale
    rotor = np.sqrt(u_f / (model.airframe.mass_kg * model.airframe.gravity_mps2))
    converged = forceair.airframe_airflow(model.airframe, traj.states[:, model.state.slice("f_filt")],
                                          inputs[:, model.inputs.slice("yaw_ref")].ravel(), None, rotor)
    air = traj.states[0, model.state.slice("air_prev")]
    speed = float(traj.outputs[0, model.outputs.slice("wind_speed_h")][0])
    return (f"first sample: tracked body airflow {np.array2string(air, precision=4)} m/s, converged "
            f"{np.array2string(converged[0], precision=4)}; wind_speed_h {speed:.3g} m/s (from the converged "
            f"airflow {np.hypot(*converged[0, :2]):.3g}), status {int(traj.status[0])}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools.tracked_airflow", description=__doc__.split("\n\n")[0])
    parser.add_argument("airframe")
    parser.add_argument("--precision", choices=("single", "double"), default="single")
    parser.add_argument("--steps", type=int, default=5000)
    parser.add_argument("--calm-samples", type=int, default=20000)
    args = parser.parse_args(argv)
    model = build_step(load_airframe(args.airframe))
    if "air_prev" not in model.state:
        print(f"{args.airframe}: no tracked airflow (not a body-frame drag law)")
        return 0
    for (axis, judged), delta in smallest_failing_offsets(model, Precision(args.precision), args.steps).items():
        print(f"offsets: axis {axis}, {'through the law' if judged else 'element by element'}: smallest failing "
              f"offset {delta:.2g} m/s")
    for fz, tracked, solved in from_zero(model):
        print(f"from zero: vertical force {fz:g} N: tracked {tracked:.4g} m/s, converged {solved:.4g} m/s")
    print(f"flight: {flight(model, 20000)}")
    for sigma in (1e-3, 1e-2, 0.05):
        print(f"calm: {calm(model, sigma, args.calm_samples)}")
    if "acc_ned" in model.inputs and "thrust" in model.inputs:
        print(f"hover: {hover(model)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
