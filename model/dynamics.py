"""Rigid-body dynamics of a multirotor, symbolically (CasADi SX), and the external force solved
from them.

Frames: NED inertial, FRD body; q = (w, x, y, z) rotates body to NED. Thrust acts along -z_b.
Translation:  m p'' = -u_f z_b + m g0 e3 + f_e
Rotation (ZYX Euler angles eta = (phi, theta, psi), Euler-Lagrange): M(eta) eta'' + C(eta, eta') eta'
= W(eta)^T (u_tau + tau_e), with M = W^T J W and C from the Christoffel symbols of M.
"""
from __future__ import annotations

import casadi as ca

E3 = ca.DM([0.0, 0.0, 1.0])


def quaternion_to_rotation_any_norm(q: ca.SX) -> ca.SX:
    """R(q / |q|) for any nonzero q, without a square root: the homogeneous form M(q) / |q|^2."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    inv = 1 / (ww + xx + yy + zz)
    return inv * ca.vertcat(
        ca.horzcat(ww + xx - yy - zz, 2 * (x * y - w * z), 2 * (x * z + w * y)),
        ca.horzcat(2 * (x * y + w * z), ww - xx + yy - zz, 2 * (y * z - w * x)),
        ca.horzcat(2 * (x * z - w * y), 2 * (y * z + w * x), ww - xx - yy + zz),
    )


def euler_zyx_rotation(eta: ca.SX) -> ca.SX:
    """R = Rz(psi) Ry(theta) Rx(phi), body to NED."""
    phi, theta, psi = eta[0], eta[1], eta[2]
    rx = ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, ca.cos(phi), -ca.sin(phi)), ca.horzcat(0, ca.sin(phi), ca.cos(phi)))
    ry = ca.vertcat(ca.horzcat(ca.cos(theta), 0, ca.sin(theta)), ca.horzcat(0, 1, 0), ca.horzcat(-ca.sin(theta), 0, ca.cos(theta)))
    rz = ca.vertcat(ca.horzcat(ca.cos(psi), -ca.sin(psi), 0), ca.horzcat(ca.sin(psi), ca.cos(psi), 0), ca.horzcat(0, 0, 1))
    return rz @ ry @ rx


def euler_rate_matrix(eta: ca.SX) -> ca.SX:
    """W(eta) with body angular rate omega = W(eta) eta' for ZYX angles."""
    phi, theta = eta[0], eta[1]
    return ca.vertcat(
        ca.horzcat(1, 0, -ca.sin(theta)),
        ca.horzcat(0, ca.cos(phi), ca.sin(phi) * ca.cos(theta)),
        ca.horzcat(0, -ca.sin(phi), ca.cos(phi) * ca.cos(theta)),
    )


def rotational_inertia_matrix(inertia: ca.DM | ca.SX, eta: ca.SX) -> ca.SX:
    w = euler_rate_matrix(eta)
    return w.T @ inertia @ w


def coriolis_matrix(inertia: ca.DM | ca.SX, eta: ca.SX, eta_dot: ca.SX) -> ca.SX:
    """C(eta, eta') from the Christoffel symbols of M(eta): C_kj = sum_i c_ijk eta'_i."""
    m = rotational_inertia_matrix(inertia, eta)
    dm = [ca.jacobian(m[:, j], eta) for j in range(3)]  # dm[j][k, i] = d M_kj / d eta_i
    rows = []
    for k in range(3):
        row = []
        for j in range(3):
            c_kj = 0
            for i in range(3):
                c_kj += 0.5 * (dm[j][k, i] + dm[i][k, j] - ca.jacobian(m[i, j], eta)[k]) * eta_dot[i]
            row.append(c_kj)
        rows.append(ca.horzcat(*row))
    return ca.vertcat(*rows)


def translational_residual(mass: float, gravity: float, p_ddot: ca.SX, u_f: ca.SX, z_b: ca.SX, f_e: ca.SX) -> ca.SX:
    """m p'' - (-u_f z_b + m g0 e3 + f_e): zero when the dynamics hold."""
    return mass * p_ddot - (-u_f * z_b + mass * gravity * E3 + f_e)


def wrench_residual(mass: float, gravity: float, inertia: ca.DM, eta: ca.SX, eta_dot: ca.SX, q_ddot: ca.SX,
                    u: ca.SX, d_e: ca.SX) -> ca.SX:
    """The compact 6-DOF form B q'' + D(q, q') q' + g - G(q) u - d_e (zero when the dynamics hold).

    q = (p, eta); u = (u_f, u_tau); d_e = (f_e, tau_e). B = diag(m I, M(eta)) and D = diag(0, C): the
    Euler-Lagrange form of the paper's rotational equation, so the observer error stays e' = -K_I B^-1 e.
    """
    z_b = euler_zyx_rotation(eta)[:, 2]
    b = ca.diagcat(mass * ca.SX.eye(3), rotational_inertia_matrix(inertia, eta))
    d = ca.diagcat(ca.SX.zeros(3, 3), coriolis_matrix(inertia, eta, eta_dot))
    g = ca.vertcat(-mass * gravity * E3, ca.SX.zeros(3, 1))
    w = euler_rate_matrix(eta)
    g_u = ca.vertcat(-u[0] * z_b, w.T @ u[1:4])
    q_dot = ca.vertcat(ca.SX.zeros(3, 1), eta_dot)
    return b @ q_ddot + d @ q_dot + g - g_u - d_e


def solve_external_force(mass: float, gravity: float, p_ddot: ca.SX, u_f: ca.SX, z_b: ca.SX) -> ca.SX:
    """f_e solved from the translational dynamics (never typed in): the residual is affine in f_e."""
    f_e = ca.SX.sym("f_e", 3)
    residual = translational_residual(mass, gravity, p_ddot, u_f, z_b, f_e)
    jac = ca.evalf(ca.jacobian(residual, f_e))  # constant: -I
    at_zero = ca.substitute(residual, f_e, ca.SX.zeros(3, 1))
    return ca.mtimes(ca.inv(jac), -at_zero)
