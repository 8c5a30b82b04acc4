"""The tracked airflow read through the law: the force the body-frame drag law gives at an airflow, and
the force the step inverted, for a step's (state, input).

The body-frame step keeps the last accepted sample's body-frame airflow (``air_prev``) only as the start
of the next inversion (model/forceair.py, ``body_drag_airflow_tracking``). Where the law is nearly flat
along an axis (no linear vertical term and almost no airflow: slope qz |a| of about 0.01 N per m/s),
that airflow moves by tenths of a m/s for a force within the force tolerance (1e-3 N), and a comparison
of the airflow itself with a tolerance in m/s says little about the estimate. What the airflow means is
the force it explains; the harness (harness/compare.py) judges it there, in newtons.
"""
from __future__ import annotations

import casadi as ca

from dobwind.model import forceair
from dobwind.model.step import StepModel, body_drag_target

Signals = dict[str, ca.SX]


def step_signals(model: StepModel, x: ca.SX, u: ca.SX) -> Signals:
    """Every signal up to the force-air stage, from the model's own stage functions (the same
    expressions the step composes)."""
    signals: Signals = {f"in.{f.name}": u[model.inputs.slice(f.name)] for f in model.inputs.fields}
    signals.update({f"state.{f.name}": x[model.state.slice(f.name)] for f in model.state.fields})
    for stage in (model.validate, *model.stages):
        values = stage.function.call([signals[name] for name in stage.inputs])
        signals.update(zip(stage.outputs, values))
        if stage.name == "force_air":
            break
    return signals


def tracked_airflow_force(model: StepModel) -> ca.Function | None:
    """(state before the step, input, body-frame airflow) -> (the law's body-frame force at that
    airflow, the body-frame force the step inverted), both in N; None for an airframe whose step
    tracks no airflow (no ``air_prev``)."""
    if "air_prev" not in model.state:
        return None
    x, u, air = ca.SX.sym("state", model.state.size), ca.SX.sym("input", model.inputs.size), ca.SX.sym("air", 3)
    signals = step_signals(model, x, u)
    force_ned, rotor = body_drag_target(model.airframe, signals)
    rot = ca.reshape(signals["rot_body_to_ned"], 3, 3)
    law = forceair.body_law_at(model.airframe.drag, air, rotor)
    return ca.Function("tracked_airflow_force", [x, u, air], [law, rot.T @ force_ned])
