"""The per-axis pair's front/back pair (qax1c, qay1c in model/forceair.py): per-axis drag times cos theta,
for a body whose per-axis drag differs with the air from the front and from the back (the simulator's
cos1 shape on per-axis drag, benchmarks/anisovehicles/nv_longthin).

Pinned: the forward law against a transcription of the formula in docs/formats.md (both frames, three
exponents); what the pair holds of such a body that q1c cannot (a least-squares fit on a direction grid,
then the step's inversion); the inversion's round trip on a direction x speed grid, and the start and the
Newton step it takes; the monotonicity check on the pair; the airframe keys; the C against the reference;
and the fit adding the pair for a front/back per-axis body and not for one without the front/back shape."""
from __future__ import annotations

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest

from dobwind.calibrate import dragfit, holdcv
from dobwind.model import forceair
from dobwind.model.forceair import (DragLaw, body_drag_airflow_numpy, body_drag_force, drag_airflow_numpy,
                                    drag_force, horizontal_drag_basis, law_decreasing)
from tests.helpers import hold_samples, random_body_flight

THETA = np.linspace(0.0, 2 * math.pi, 720, endpoint=False)
PAIR = ("l0", "q0", "l2c", "q2c", "l2s", "q2s", "q1c", "qax", "qay")


def _shaped(vx: np.ndarray, vy: np.ndarray, cx: float, cy: float, cos1: float) -> tuple[np.ndarray, np.ndarray]:
    """The simulator's per-axis quadratic drag times its gain 1 + cos1 cos theta, written out."""
    gain = 1.0 + cos1 * vx / np.hypot(vx, vy)
    return gain * cx * np.abs(vx) * vx, gain * cy * np.abs(vy) * vy


LAW = DragLaw(0.1, 0.03, l2c=-0.01, q2c=0.02, l2s=0.01, q2s=-0.01, q1c=0.004, lz=0.1, qz=0.2, qax=0.02, qay=0.09,
              qax1c=-0.004, qay1c=-0.02)


@pytest.mark.parametrize("exponent", [1.8, 2.0, 2.2])
def test_forward_law_adds_the_pair_as_documented(exponent):
    law = dataclasses.replace(LAW, exponent=exponent)
    speed = np.geomspace(0.05, 15, THETA.size)
    vx, vy = speed * np.cos(THETA), speed * np.sin(THETA)
    fx, fy, _ = drag_force(law, vx, vy, np.zeros_like(vx))
    bx, by, _ = drag_force(dataclasses.replace(law, qax1c=0.0, qay1c=0.0), vx, vy, np.zeros_like(vx))
    # docs/formats.md: qax1c cos theta |a_x|^(p-1) a_x along x, qay1c cos theta |a_y|^(p-1) a_y along y
    cos1 = np.cos(THETA)
    np.testing.assert_allclose(fx - bx, law.qax1c * cos1 * np.abs(vx) ** (exponent - 1) * vx, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(fy - by, law.qay1c * cos1 * np.abs(vy) ** (exponent - 1) * vy, rtol=1e-9, atol=1e-12)
    # the body frame: the same pair of the body-frame components, cos theta of the in-plane airflow
    body = dataclasses.replace(law, frame="body")
    level = np.column_stack(body_drag_force(body, vx, vy, np.zeros_like(vx), np.ones_like(vx)))
    np.testing.assert_allclose(level[:, :2], np.column_stack([fx, fy]), rtol=1e-9, atol=1e-12)
    up = np.full_like(vx, 3.0)
    tilted = np.column_stack(body_drag_force(body, vx, vy, up, np.ones_like(vx)))
    plain = np.column_stack(body_drag_force(dataclasses.replace(body, qax1c=0.0, qay1c=0.0), vx, vy, up, np.ones_like(vx)))
    np.testing.assert_allclose(tilted[:, 1] - plain[:, 1], law.qay1c * cos1 * np.abs(vy) ** (exponent - 1) * vy,
                               rtol=1e-9, atol=1e-12)


def _fitted(cx: float, cy: float, cos1: float, keys: tuple[str, ...]) -> DragLaw:
    """The law of ``keys`` closest (least squares, 0.5 deg grid, 0.5-8 m/s) to the shaped per-axis drag
    plus 0.05 N/(m/s) of linear drag."""
    s = np.repeat(np.linspace(0.5, 8.0, 16), THETA.size)
    t = np.tile(THETA, 16)
    vx, vy = s * np.cos(t), s * np.sin(t)
    per = horizontal_drag_basis(vx, vy, s)
    design = np.column_stack([np.concatenate([np.broadcast_to(per[k][0], s.shape), np.broadcast_to(per[k][1], s.shape)])
                              for k in keys])
    fx, fy = _shaped(vx, vy, cx, cy, cos1)
    coefficients = np.linalg.lstsq(design, np.concatenate([fx + 0.05 * vx, fy + 0.05 * vy]), rcond=None)[0]
    return DragLaw(**{"l0": 0.0, "q0": 0.0, "lz": 0.1, **dict(zip(keys, map(float, coefficients)))})


def _read_errors(law: DragLaw, cx: float, cy: float, cos1: float, speed: float) -> tuple[float, float]:
    """Largest direction (deg) and speed (m/s) errors of the step's inversion of the true shaped force."""
    vx, vy = speed * np.cos(THETA), speed * np.sin(THETA)
    fx, fy = _shaped(vx, vy, cx, cy, cos1)
    back = drag_airflow_numpy(law, fx + 0.05 * vx, fy + 0.05 * vy, np.zeros_like(fx))
    turn = np.angle(np.exp(1j * (np.arctan2(back[:, 1], back[:, 0]) - THETA)))
    return float(np.degrees(np.abs(turn)).max()), float(np.abs(np.hypot(back[:, 0], back[:, 1]) - speed).max())


@pytest.mark.parametrize("cx, cy, cos1", [(0.025, 0.15, -0.2), (0.15, 0.025, 0.3)])
def test_the_pair_holds_what_q1c_cannot(cx, cy, cos1):
    """Per-axis drag 6:1 (and 1:6) shaped front/back: with q1c and the per-axis pair the law reads it
    degrees and decimetres per second off at 6 m/s; with the front/back pair too it is the body's own
    law: read exactly, and increasing."""
    without = _fitted(cx, cy, cos1, PAIR)
    angle, speed = _read_errors(without, cx, cy, cos1, 6.0)
    assert angle > 1.0 and speed > 0.1
    both = _fitted(cx, cy, cos1, PAIR + forceair.FRONT_BACK_AXIS_KEYS)
    assert law_decreasing(both, 30.0) is None
    assert max(_read_errors(both, cx, cy, cos1, 6.0)) < 1e-6
    np.testing.assert_allclose([both.qax1c, both.qay1c], [cos1 * cx, cos1 * cy], rtol=1e-6)


ROUND_TRIP_LAWS = {
    "6:1 cos1 -0.2": DragLaw(0.02, 0.0, qax=0.025, qay=0.15, qax1c=-0.005, qay1c=-0.03, lz=0.4, qz=0.2),
    "1:6 cos1 0.5": DragLaw(0.02, 0.0, qax=0.15, qay=0.025, qax1c=0.075, qay1c=0.0125, lz=0.4, qz=0.2),
    "no linear drag": DragLaw(0.0, 0.0, qax=0.025, qay=0.15, qax1c=-0.01, qay1c=-0.06, lz=0.4, qz=0.2),
    # the pair alone beside drag along the airflow
    "without qax, qay": DragLaw(0.25, 0.05, qax1c=-0.006, qay1c=-0.01, lz=0.4, qz=0.2),
    # a fit's mix: the pairs of opposite signs beside the harmonics and q1c
    "mixed": DragLaw(0.2331, 0.0116, l2c=-0.008, q2c=0.0692, l2s=0.0168, q2s=-0.0335, q1c=-0.01, qax=-0.0492,
                     qay=0.1793, qax1c=0.004, qay1c=-0.03, lz=0.4, qz=0.2),
}


@pytest.mark.parametrize("exponent", [1.7, 2.0])
@pytest.mark.parametrize("name", sorted(ROUND_TRIP_LAWS))
def test_inversion_round_trips_with_the_pair(name, exponent):
    """Forward law, then the step's inversion, 0.02 to 20 m/s in random directions, -4..4 m/s vertical;
    the body frame at tilted attitudes with rotor drag."""
    law = dataclasses.replace(ROUND_TRIP_LAWS[name], exponent=exponent)
    # increasing (without linear drag the slope across an axis is 0 on it, which the check refuses)
    assert law.l0 == 0.0 or law_decreasing(law, 30.0) is None
    a, rot, rotor = random_body_flight(np.geomspace(0.02, 20, 3000), 2)
    fx, fy, fz = drag_force(law, a[:, 0], a[:, 1], a[:, 2])
    np.testing.assert_allclose(drag_airflow_numpy(law, fx, fy, fz), a, atol=1e-5)
    body = dataclasses.replace(law, frame="body", lr=0.1)
    force_b = np.column_stack(body_drag_force(body, a[:, 0], a[:, 1], a[:, 2], rotor))
    back = body_drag_airflow_numpy(body, np.einsum("nij,nj->ni", rot, force_b), rot, rotor)
    np.testing.assert_allclose(back, np.einsum("nij,nj->ni", rot, a), atol=1e-4)


def _start(law: DragLaw, fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
    m, n = ca.SX.sym("m"), ca.SX.sym("n")
    start = ca.Function("start", [m, n], [ca.vertcat(*forceair._planar_start(law, m, n, law.l0))])
    return np.asarray(start.map(len(fx))(fx.reshape(1, -1), fy.reshape(1, -1))).T


def test_the_start_solves_each_axis_on_the_axes():
    """On the axes the shaped per-axis drag is each axis's law alone, front (cos theta 1) and back (-1)
    apart on x: the start is its exact inverse there, from the front and from the back."""
    law = ROUND_TRIP_LAWS["6:1 cos1 -0.2"]
    speed = np.geomspace(0.02, 20, 50)
    zero = np.zeros_like(speed)
    a = np.vstack([np.column_stack([speed, zero]), np.column_stack([-speed, zero]),
                   np.column_stack([zero, speed]), np.column_stack([zero, -speed])])
    fx, fy, _ = drag_force(law, a[:, 0], a[:, 1], np.zeros(len(a)))
    np.testing.assert_allclose(_start(law, fx, fy), a, rtol=1e-9, atol=1e-12)


def test_the_pair_takes_two_more_newton_steps(monkeypatch):
    """The per-axis pair's step and one more, with or without qax, qay; with one only, the fit-like mixed
    law is read 1e-4 m/s off; a law without the pair keeps its step count (the C of every earlier
    airframe is unchanged)."""
    law = ROUND_TRIP_LAWS["mixed"]
    assert law.newton_steps(3) == 5 and dataclasses.replace(law, qax1c=0.0, qay1c=0.0).newton_steps(3) == 4
    assert ROUND_TRIP_LAWS["without qax, qay"].newton_steps(3) == 5
    monkeypatch.setattr(forceair, "FRONT_BACK_EXTRA_STEPS", 0)
    forceair._heading_inversion.cache_clear()
    try:
        a, _, _ = random_body_flight(np.geomspace(0.02, 20, 3000), 2)
        fx, fy, fz = drag_force(law, a[:, 0], a[:, 1], a[:, 2])
        assert np.abs(drag_airflow_numpy(law, fx, fy, fz) - a).max() > 1e-5
    finally:
        forceair._heading_inversion.cache_clear()


@pytest.mark.parametrize("frame", ["heading", "body"])
def test_a_pair_that_outweighs_the_law_from_behind_decreases(frame):
    """From behind (cos theta = -1) the law below is, along -x, 0.1 u + (0.05 - 0.06) u^2 at u = |a_x|:
    its slope 0.1 - 0.02 u is zero at 5 m/s, so the check must refuse it by then (30 deg off the axis,
    where cos theta also turns with a_y, it turns first, at 4.2 m/s); from the front it increases, and
    without the pair everywhere."""
    law = DragLaw(0.1, 0.05, qax1c=0.06, lz=0.2, frame=frame)
    assert law_decreasing(law, 4.0) is None
    where = law_decreasing(law, 20.0)
    assert where is not None and 4.0 < float(where.split(" at ")[1].split(" m/s")[0]) <= 5.0
    assert 90 < float(where.split(" deg")[0]) < 270
    assert law_decreasing(dataclasses.replace(law, qax1c=0.0), 20.0) is None


def _median_errors(samples: dragfit.DragSamples, theta: np.ndarray) -> tuple[float, float]:
    """Median direction (deg) and speed (m/s) errors of the law's airflow over the samples above 3 m/s."""
    got, true = dragfit.predicted_airflow(samples, theta), samples.airflow
    fast = np.hypot(true[:, 0], true[:, 1]) > 3.0
    turn = np.angle(np.exp(1j * (np.arctan2(got[fast, 1], got[fast, 0]) - np.arctan2(true[fast, 1], true[fast, 0]))))
    speed = np.abs(np.hypot(got[fast, 0], got[fast, 1]) - np.hypot(true[fast, 0], true[fast, 1]))
    return float(np.degrees(np.median(np.abs(turn)))), float(np.median(speed))


def _body(cos1: float):
    def body(vx, vy, vz):
        fx, fy = _shaped(vx, vy, 0.025, 0.15, cos1)
        return fx + 0.02 * vx, fy + 0.08 * vy, 0.2 * vz + 0.1 * np.abs(vz) * vz
    return body


def test_the_fit_adds_the_pair_for_a_front_back_per_axis_body():
    """nv_longthin's drag (6:1 per axis, linear 0.02 / 0.08) shaped front/back by cos1 = -0.3: the
    front/back pair is added after the per-axis pair, and the law reads the airflow better than the same
    set without it."""
    samples = hold_samples(_body(-0.3), 0.05, seed=5)
    choice = dragfit.choose_drag_law(samples, holdcv.prefer_on_holds)
    assert set(forceair.FRONT_BACK_AXIS_KEYS + forceair.PER_AXIS_KEYS) <= set(choice.active)
    without = tuple(k for k in choice.active if k not in forceair.FRONT_BACK_AXIS_KEYS)
    angle, speed = _median_errors(samples, choice.theta)
    angle_without, speed_without = _median_errors(samples, dragfit.robust_fit(samples, without))
    assert speed < 0.5 * speed_without and angle < angle_without


def test_the_fit_leaves_the_pair_out_without_a_front_back_shape():
    samples = hold_samples(_body(0.0), 0.05, seed=5)
    choice = dragfit.choose_drag_law(samples, holdcv.prefer_on_holds)
    assert set(forceair.PER_AXIS_KEYS) <= set(choice.active)
    assert not set(forceair.FRONT_BACK_AXIS_KEYS) & set(choice.active)
