"""The body-frame drag law regrouped for its inversion: the value and the Jacobian that the step's Newton
steps evaluate, written so that their shared parts are computed once.

``forceair.body_drag_force`` writes the law as a sum over coefficients (one basis vector each: what the
fit needs). Every in-plane term is a scalar times the airflow a_xy or times a_xy turned 90 deg, so

    F_xy = P a_xy + Q (-a_y, a_x),    F_z = R a_z + i1 s_h + i2 s_h^2,    R = lz + qz s

with P and Q scalars of the airflow (docs/model.md has the law), plus the per-axis pair (qax |a_x|^(p-1) a_x,
qay |a_y|^(p-1) a_y), which is added as it is (each component depends on its own airflow component only, so
its Jacobian is diagonal), and its front/back pair, the same times cos theta = a_x / s_h (whose Jacobian
is not: cos theta depends on a_y too):

    P = l0 + lr rotor + q0 g + (l2c + q2c g) cos 2theta + q1c k a_x + q4c g cos 4theta
    Q = (l2s + q2s g) sin 2theta + q4s g sin 4theta,      g = s^(p-1), k = s^(p-2)

    (qax + qax1c a_x / s_h) |a_x|^(p-1) a_x,  (qay + qay1c a_x / s_h) |a_y|^(p-1) a_y

The Jacobian then needs only the gradients of the three scalars P, Q and F_z (automatic
differentiation of a scalar shares its parts; of the summed vector law it repeats them per coefficient
and per component):

    J_xy = [[P, -Q], [Q, P]] (first two columns) + a_xy (grad P)^T + (-a_y, a_x) (grad Q)^T

The same law to rounding (tests/test_dragform.py compares it with body_drag_force and with a finite-
difference Jacobian). Works on SX only; the coefficient fields of ``law`` are floats or SX symbols.
"""
from __future__ import annotations

import casadi as ca

# Smoothing of |a_x| in the per-axis terms of an exponent other than 2 (m/s): far below any airflow read.
PER_AXIS_EPS_MPS = 1e-6


def _present(value) -> bool:
    """A term is kept when its coefficient is a symbol or a nonzero number."""
    return isinstance(value, ca.SX) or value != 0.0


def _is_two(exponent) -> bool:
    return not isinstance(exponent, ca.SX) and exponent == 2.0


def _sum(terms: list) -> ca.SX:
    total = ca.SX(0) if not terms else terms[0]
    for term in terms[1:]:
        total = total + term
    return total


def body_law_scalars(law, a: ca.SX, rotor: ca.SX, eps: float) -> tuple[ca.SX, ca.SX, ca.SX]:
    """(P, Q, F_z) of the body-frame law at the body-frame airflow ``a`` (3 x 1), both speeds smoothed
    by ``eps`` as in the Newton steps of forceair."""
    ax, ay, az = a[0], a[1], a[2]
    sh2 = ax * ax + ay * ay + eps * eps
    s = ca.sqrt(sh2 + az * az)
    inv = 1 / sh2  # one division for both double-angle terms
    cos2, sin2 = (ax * ax - ay * ay) * inv, 2 * ax * ay * inv
    quadratic = _is_two(law.exponent)
    g = s if quadratic else s ** (law.exponent - 1.0)
    p_terms = [law.l0 + law.lr * rotor if _present(law.lr) else ca.SX(law.l0)]
    if _present(law.q0):
        p_terms.append(law.q0 * g)
    aniso = [c for c in (law.l2c if _present(law.l2c) else None, law.q2c * g if _present(law.q2c) else None)
             if c is not None]
    if aniso:
        p_terms.append(_sum(aniso) * cos2)
    if _present(law.q1c):
        p_terms.append(law.q1c * (ax if quadratic else s ** (law.exponent - 2.0) * ax))
    skew = [c for c in (law.l2s if _present(law.l2s) else None, law.q2s * g if _present(law.q2s) else None)
            if c is not None]
    q_terms = [_sum(skew) * sin2] if skew else []
    if _present(law.q4c) or _present(law.q4s):
        cos4, sin4 = cos2 * cos2 - sin2 * sin2, 2 * sin2 * cos2
        if _present(law.q4c):
            p_terms.append(law.q4c * g * cos4)
        if _present(law.q4s):
            q_terms.append(law.q4s * g * sin4)
    fz_terms = [(law.lz + law.qz * s if _present(law.qz) else ca.SX(law.lz)) * az]
    if _present(law.i1):
        fz_terms.append(law.i1 * ca.sqrt(sh2))
    if _present(law.i2):
        fz_terms.append(law.i2 * sh2)
    return _sum(p_terms), _sum(q_terms), _sum(fz_terms)


def axis_power(x, exponent):
    """|x|^(p-1), the per-axis terms' factor: |x| itself for p = 2 (no power in the step's C); for another
    p smoothed by PER_AXIS_EPS_MPS, (x^2 + eps^2)^((p-1)/2), whose derivative stays finite at x = 0 where
    |x|^(p-2) would not (the Newton step's Jacobian). SX or NumPy."""
    if _is_two(exponent):
        return abs(x)
    return (x * x + PER_AXIS_EPS_MPS ** 2) ** ((exponent - 1.0) / 2.0)


def _front_back(law) -> bool:
    return _present(law.qax1c) or _present(law.qay1c)


def per_axis_force(law, a: ca.SX, eps: float = 0.0) -> tuple[ca.SX, ca.SX] | None:
    """The per-axis pair's in-plane force at the airflow ``a`` (with its front/back pair, cos theta of the
    in-plane speed smoothed by ``eps``), or None when the law has no such term."""
    if not _front_back(law):
        if not (_present(law.qax) or _present(law.qay)):
            return None
        return law.qax * axis_power(a[0], law.exponent) * a[0], law.qay * axis_power(a[1], law.exponent) * a[1]
    cos1 = a[0] / ca.sqrt(a[0] * a[0] + a[1] * a[1] + eps * eps)
    return ((law.qax + law.qax1c * cos1) * axis_power(a[0], law.exponent) * a[0],
            (law.qay + law.qay1c * cos1) * axis_power(a[1], law.exponent) * a[1])


def body_law_value(p: ca.SX, q: ca.SX, fz: ca.SX, a: ca.SX, axis: tuple[ca.SX, ca.SX] | None = None) -> ca.SX:
    """The law's body-frame force from its scalars (and the per-axis pair's force, when it has one)."""
    fx, fy = p * a[0] - q * a[1], p * a[1] + q * a[0]
    if axis is not None:
        fx, fy = fx + axis[0], fy + axis[1]
    return ca.vertcat(fx, fy, fz)


def body_law_and_jacobian(law, a: ca.SX, rotor: ca.SX, eps: float) -> tuple[ca.SX, ca.SX]:
    """(force, 3 x 3 Jacobian d force / d a), symbolic in ``a`` (an SX symbol: the gradients need it)."""
    p, q, fz = body_law_scalars(law, a, rotor, eps)
    gp, gq, gz = ca.gradient(p, a), ca.gradient(q, a), ca.gradient(fz, a)
    ax, ay = a[0], a[1]
    jx = [ax * gp[j] - ay * gq[j] for j in range(3)]
    jy = [ay * gp[j] + ax * gq[j] for j in range(3)]
    jx[0], jx[1] = p + jx[0], jx[1] - q
    jy[0], jy[1] = q + jy[0], p + jy[1]
    axis = per_axis_force(law, a, eps)
    if axis is not None and _front_back(law):  # cos theta couples the axes: a full in-plane block
        gx, gy = ca.gradient(axis[0], a), ca.gradient(axis[1], a)
        jx = [jx[j] + gx[j] for j in range(3)]
        jy = [jy[j] + gy[j] for j in range(3)]
    elif axis is not None:  # a diagonal block: each component's derivative along its own axis
        jx[0], jy[1] = jx[0] + ca.jacobian(axis[0], ax), jy[1] + ca.jacobian(axis[1], ay)
    jacobian = ca.vertcat(ca.horzcat(*jx), ca.horzcat(*jy), gz.T)
    return body_law_value(p, q, fz, a, axis), jacobian
