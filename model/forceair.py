"""The force-air model in one place: heading frame, term variables, force -> relative airflow for both
model families, and the meteorological "wind from" direction.

Two families map the observed external force (heading frame c, offset removed) to the relative airflow
(air velocity minus vehicle velocity, heading frame, NED sense):

- ``polynomial`` (the paper's): the horizontal airflow SPEED is a polynomial in force terms and the air
  is assumed to move along the horizontal force; the vertical airflow is a polynomial too.
- ``drag`` (physically structured): the FORCE is a drag law of the airflow, fitted in that direction
  (where the noise is), and inverted here, so the airflow direction comes out of the model. With v the
  horizontal airflow (heading frame), s = |v|, theta its angle from the heading, u = v/s and e = u turned
  90 deg (left of the airflow):

      F_h = [l0 s + q0 s^p + (l2c s + q2c s^p) cos 2theta + q1c s^p cos theta + q4c s^p cos 4theta] u
          + [(l2s s + q2s s^p) sin 2theta + q4s s^p sin 4theta] e
      F_z = lz v_z + qz |v_z| v_z + i1 s + i2 s^2

  l0, q0: linear (rotor, momentum) and quadratic (body) drag; the cos 2theta terms make drag along body
  x differ from body y, the cos theta term front from back, and the sin 2theta terms turn the force off
  the airflow. The cos 4theta and sin 4theta terms carry the four-fold shape of drag that each body
  axis makes on its own airflow component (|a_x| a_x, |a_y| a_y: flat plates, a simulator's per-face
  drag): even with equal coefficients its force leans up to 12 deg off the airflow at 30 and 60 deg,
  which the 2theta terms cannot hold (they vanish there by symmetry); with the 4theta pair the airflow
  is read within 1 deg at 60 deg and 3.5 deg next to the axes, at a body-y / body-x ratio up to 1.5
  (tests/test_fourfold.py). A body whose axes differ more (side drag 4-6x the frontal) has a series that
  does not stop at 4theta; the per-axis pair holds it directly, one more force

      + (qax |v_x|^(p-1) v_x, qay |v_y|^(p-1) v_y)       (heading frame; the body frame's a_x, a_y alike)

  (tests/test_peraxis.py), and its front/back pair, the same per-axis drag times cos theta = v_x / s:

      + cos theta (qax1c |v_x|^(p-1) v_x, qay1c |v_y|^(p-1) v_y)

  for a per-axis body whose drag differs front from back (a simulator's cos1 shape on per-axis drag, which
  q1c, drag along the airflow times cos theta, cannot follow; tests/test_frontback.py). Per-axis LINEAR
  drag (PX4's EKF2_BCOEF_X/_Y, EKF2_MCOEF) is the case l2s = -l2c, q2s = -q2c; a drag MAGNITUDE that depends on direction is l2s = q2s = 0. i1, i2: the vertical force that horizontal
  airflow causes (rotors in edgewise flow make more thrust). The horizontal law is inverted by a fixed
  number of Newton steps from the isotropic closed form; the vertical one in closed form given s. Both
  are branch-free.

  p, the law's ``exponent``, is 2 (Newtonian drag) unless the fit finds the bluff-body drag growing
  faster or slower (a Reynolds-dependent drag coefficient): only then does the step raise s to a power.

Everything symbolic is CasADi SX; the NumPy helpers map the same symbolic expressions, so calibration,
analysis and flight share one definition. Frames and signs: docs/model.md.
"""
from __future__ import annotations

from typing import Callable

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import casadi as ca
import numpy as np

from dobwind.model.dragform import axis_power, body_law_and_jacobian, body_law_scalars, body_law_value, per_axis_force
from dobwind.model.numeric import bisect_increasing
from dobwind.model.sxvector import VectorFunction
from dobwind.model.terms import Term, polynomial_expr, term_expr
from dobwind.model.kinds import DragFrame

if TYPE_CHECKING:  # the airframe module imports this one; the functions below only read its fields
    from dobwind.model.airframe import Airframe

# Below this horizontal force (N) the force direction is noise; the polynomial family scales the
# airflow down smoothly instead of dividing by ~0.
FORCE_DIRECTION_EPS_N = 1e-3
# Smoothing of |v_h| in the drag law's Jacobian (m/s): keeps the Newton step finite at zero airflow.
DRAG_SPEED_EPS_MPS = 1e-3
# Newton steps after the isotropic closed form: anisotropy 1.5 converges to float precision in 3.
DRAG_NEWTON_STEPS = 3
# Floor of the drag law's Jacobian determinant and of the closed forms' denominators; a calibrated
# law is strictly increasing, so this only guards zero force on a zero law.
_DENOMINATOR_FLOOR = 1e-9

HORIZONTAL_DRAG_KEYS = ("l0", "q0", "l2c", "q2c", "q1c", "l2s", "q2s", "q4c", "q4s", "qax", "qay", "qax1c", "qay1c")
# The four-fold harmonics: written to the airframe file, and given symbols, only when a law has them.
FOURFOLD_KEYS = ("q4c", "q4s")
# The per-axis pair: drag that each axis of the law's frame makes on its own airflow component, c_x
# |a_x|^(p-1) a_x along x and c_y |a_y|^(p-1) a_y along y (flat sides, PX4 EKF2's and ArduPilot SITL's
# per-axis drag). Its Fourier series in the airflow direction does not stop at 4 theta: a 4-6:1 per-axis
# body leaves 14 deg that no truncation of the harmonics above holds while still increasing
# (benchmarks/lawreach.py). Written and given symbols only when a law has it, like the four-fold pair.
PER_AXIS_KEYS = ("qax", "qay")
# The per-axis pair's front/back pair: the same per-axis drag times cos theta = a_x / s_h (s_h the in-plane
# airflow speed), so that the drag of each axis may differ with the air from the front and from the back.
# A per-axis body shaped front/back (benchmarks/anisovehicles/nv_longthin) leaves what neither q1c (drag
# ALONG the airflow times cos theta) nor the pair can follow; fitted freely, the force offset took part of
# it (dobwind/calibrate/zerooffset.py). Written and given symbols only when a law has it.
FRONT_BACK_AXIS_KEYS = ("qax1c", "qay1c")
VERTICAL_DRAG_KEYS = ("lz", "qz", "i1", "i2")
# The body-frame law's one extra coefficient: rotor (momentum) drag, which grows with rotor speed.
ROTOR_DRAG_KEY = "lr"
# Newton steps of the body-frame inversion (3-D, coupled through |a| and the inflow terms).
BODY_NEWTON_STEPS = 4
# The step's: Newton steps per sample from the previous sample's airflow (body_drag_airflow_tracking).
TRACKING_NEWTON_STEPS = 2
# The isotropic start solves the quadratic law; with another exponent it is off by (F / q0)^(1/2 - 1/p)
# (about 45 % at 20 m/s for p = 1.6), and two more steps bring it to float precision up to 40 m/s
# (tests/test_drag_exponent.py); far beyond, where the step flags the airflow, it converges less.
EXPONENT_EXTRA_STEPS = 2
# The exponents a law may have: drag coefficients that fall or rise with Reynolds number over the
# airflow range of small vehicles give effective exponents in about this range.
EXPONENT_RANGE = (1.5, 2.5)
# One more Newton step when the law has the four-fold harmonics: the isotropic start is then up to
# about 12 deg and 15 % off (tests/test_fourfold.py measures the convergence).
FOURFOLD_EXTRA_STEPS = 1
# One more Newton step when the law has the per-axis pair: it starts from each axis solved alone (exact
# for pure per-axis drag), and a fitted law that mixes the pair with the harmonics is then up to 4 mm/s
# off after three steps, 2e-6 m/s after four (tests/test_peraxis.py).
PER_AXIS_EXTRA_STEPS = 1
# A law with the front/back pair takes the same start and the same one step more (with or without qax,
# qay), and one more again: the start then holds its value on the axes only, and a fitted law that mixes
# both pairs with the harmonics was 1e-4 m/s off after four steps, 2e-6 m/s after five
# (tests/test_frontback.py).
FRONT_BACK_EXTRA_STEPS = 1


@dataclass(frozen=True)
class DragLaw:
    """Coefficients of the ``drag`` family (see the module docstring); SI units."""
    l0: float
    q0: float
    l2c: float = 0.0
    q2c: float = 0.0
    q1c: float = 0.0
    l2s: float = 0.0
    q2s: float = 0.0
    lz: float = 0.0
    qz: float = 0.0
    i1: float = 0.0
    i2: float = 0.0
    lr: float = 0.0          # body frame only: N per m/s at hover thrust, times sqrt(u_f / (m g))
    frame: DragFrame = DragFrame.HEADING  # HEADING: the law of the level heading-frame airflow; BODY: of the
    #                          body-frame airflow at the real attitude (tilt included)
    exponent: float = 2.0    # p: the quadratic terms q0, q2c, q2s, q1c, q4c, q4s grow as s^p, qax, qay as
    #                          |a_x|^p, |a_y|^p (1.5 to 2.5)
    q4c: float = 0.0         # the four-fold harmonics (last: positional construction stays as it was)
    q4s: float = 0.0
    qax: float = 0.0         # the per-axis pair (PER_AXIS_KEYS), N/(m/s)^p
    qay: float = 0.0
    qax1c: float = 0.0       # the per-axis pair's front/back pair (FRONT_BACK_AXIS_KEYS), N/(m/s)^p
    qay1c: float = 0.0

    def keys(self) -> tuple[str, ...]:
        extra = (ROTOR_DRAG_KEY,) if self.frame == DragFrame.BODY else ()
        return HORIZONTAL_DRAG_KEYS + extra + VERTICAL_DRAG_KEYS

    def as_dict(self) -> dict[str, float | str]:
        values: dict[str, float | str] = {k: getattr(self, k) for k in self.keys()
                                          if (k not in FOURFOLD_KEYS or _fourfold(self))
                                          and (k not in PER_AXIS_KEYS or _per_axis(self))
                                          and (k not in FRONT_BACK_AXIS_KEYS or _front_back_axis(self))}
        if self.frame != DragFrame.HEADING:
            values["frame"] = self.frame
        if isinstance(self.exponent, ca.SX) or self.exponent != 2.0:
            values["exponent"] = self.exponent
        return values

    def newton_steps(self, steps: int) -> int:
        """``steps`` for a quadratic law; more when the exponent is another (or a symbol)."""
        extra = (0 if _quadratic(self) else EXPONENT_EXTRA_STEPS) + (FOURFOLD_EXTRA_STEPS if _fourfold(self) else 0)
        extra += FRONT_BACK_EXTRA_STEPS if _front_back_axis(self) else 0
        return steps + extra + (PER_AXIS_EXTRA_STEPS if _per_axis(self) or _front_back_axis(self) else 0)


def _quadratic(law: DragLaw) -> bool:
    return _is_two(law.exponent)


def _fourfold(law: DragLaw) -> bool:
    """The law has a four-fold harmonic (a symbol counts: the symbolic variant with them)."""
    return any(isinstance(getattr(law, k), ca.SX) or getattr(law, k) != 0.0 for k in FOURFOLD_KEYS)


def _per_axis(law: DragLaw) -> bool:
    """The law has a per-axis term (a symbol counts, as in _fourfold)."""
    return any(isinstance(getattr(law, k), ca.SX) or getattr(law, k) != 0.0 for k in PER_AXIS_KEYS)


def _front_back_axis(law: DragLaw) -> bool:
    """The law has a term of the per-axis front/back pair (a symbol counts, as in _fourfold)."""
    return any(isinstance(getattr(law, k), ca.SX) or getattr(law, k) != 0.0 for k in FRONT_BACK_AXIS_KEYS)


def _is_two(exponent) -> bool:
    """A numeric exponent of exactly 2: the quadratic law, printed without any power."""
    return not isinstance(exponent, ca.SX) and exponent == 2.0


def speed_power(s, exponent):
    """s^(p - 1), the factor of the quadratic terms: s itself for p = 2 (no power in the step's C).
    SX or NumPy; s > 0 (smoothed or floored by the callers)."""
    if _is_two(exponent):
        return s
    return s ** (exponent - 1.0)


def _front_back(x, y, s, exponent):
    """The q1c term's basis, x (x, y) s^(p-2): of degree p like the other quadratic terms. Were it s^2
    under a lower p, it would outgrow them beyond the calibration: the force against the airflow would
    peak and fall, and the inversion run off (a review found a p = 1.6 law reading -5e6 m/s)."""
    if _is_two(exponent):
        return x * x, x * y
    k = s ** (exponent - 2.0)
    return k * x * x, k * x * y


def symbolic_law(frame: DragFrame, quadratic: bool = True, fourfold: bool = False, per_axis: bool = False,
                 front_back: bool = False) -> DragLaw:
    """A law whose coefficients are SX symbols named by their keys: the NumPy inversions below are built
    once on it and take the coefficients as inputs, instead of rebuilding the expression per law.
    ``quadratic``: exponent 2, the step's very expression; else the exponent is a symbol too.
    ``fourfold``: the q4c, q4s terms are symbols; else they are absent (exact zeros), as in the step
    of a law without them. ``per_axis``: the same for qax, qay; ``front_back`` for qax1c, qay1c."""
    symbols: dict = {k: ca.SX.sym(k) for k in _symbolic_keys(frame, fourfold, per_axis, front_back)}
    return DragLaw(**symbols, frame=frame, exponent=2.0 if quadratic else ca.SX.sym("exponent"))


def _symbolic_keys(frame: DragFrame, fourfold: bool, per_axis: bool = False, front_back: bool = False) -> tuple[str, ...]:
    absent = (() if fourfold else FOURFOLD_KEYS) + (() if per_axis else PER_AXIS_KEYS) \
        + (() if front_back else FRONT_BACK_AXIS_KEYS)
    return tuple(k for k in DragLaw(0.0, 0.0, frame=frame).keys() if k not in absent)


def _variant(law: DragLaw) -> tuple[bool, bool, bool, bool]:
    """Which symbolic inversion stands for ``law``: (quadratic, fourfold, per_axis, front_back)."""
    return _quadratic(law), _fourfold(law), _per_axis(law), _front_back_axis(law)


def _used(law: DragLaw, keys: tuple[str, ...]) -> list[str]:
    """The keys whose terms the law has: a numeric zero drops its term, a symbol is always kept."""
    return [k for k in keys if isinstance(getattr(law, k), ca.SX) or getattr(law, k) != 0.0]


def _symbols(law: DragLaw) -> list[ca.SX]:
    """The law's symbolic coefficients and exponent (none for a numeric law): inputs of the Newton
    steps' inner Functions, which may not have free symbols."""
    return [v for v in (*(getattr(law, k) for k in law.keys()), law.exponent) if isinstance(v, ca.SX)]


def heading_force(force_ned, cos_yaw, sin_yaw, offset: tuple[float, float, float]):
    """NED force -> heading frame (rotation by -yaw about down), minus the calibrated offset.
    Works on CasADi SX and on NumPy arrays (columns)."""
    m = cos_yaw * force_ned[0] + sin_yaw * force_ned[1] - offset[0]
    n = -sin_yaw * force_ned[0] + cos_yaw * force_ned[1] - offset[1]
    return m, n, force_ned[2] - offset[2]


def heading_to_ned(x, y, cos_yaw, sin_yaw):
    """Heading-frame horizontal vector -> NED north and east."""
    return cos_yaw * x - sin_yaw * y, sin_yaw * x + cos_yaw * y


def _sqrt(x):
    """Square root of SX or of NumPy values alike."""
    return ca.sqrt(x) if isinstance(x, (ca.SX, ca.MX)) else np.sqrt(x)


def horizontal_force(m, n):
    """fh, the magnitude of the heading-frame horizontal force (a term variable). SX or NumPy."""
    return _sqrt(m * m + n * n)


def term_variables(m: ca.SX, n: ca.SX, fz: ca.SX) -> dict[str, ca.SX]:
    """The variables force-air terms are written in (docs/formats.md, force_air)."""
    return {"m": m, "n": n, "fh": horizontal_force(m, n), "fz": fz}


def along_force_scale(speed_h, fh_squared):
    """k such that the horizontal airflow (x, y) = k (m, n): speed ``speed_h`` along the horizontal force,
    of squared magnitude ``fh_squared``. The guard makes (m, n)/fh -> 0 instead of 0/0 below about
    FORCE_DIRECTION_EPS_N. SX or NumPy: the step, the fit and the drag calibration use this one form."""
    return speed_h / _sqrt(fh_squared + FORCE_DIRECTION_EPS_N ** 2)


def polynomial_airflow(horizontal: tuple[tuple[Term, ...], tuple[float, ...]],
                       vertical: tuple[tuple[Term, ...], tuple[float, ...]], m: ca.SX, n: ca.SX, fz: ca.SX):
    """The paper's family: airflow (x, y, z), heading frame, from the heading-frame force, the modelled
    horizontal airflow speed, and the factor k with (x, y) = k (m, n)."""
    variables = term_variables(m, n, fz)
    fh = variables["fh"]
    speed_h = ca.fmax(polynomial_expr(*horizontal, variables), 0)
    # The air moves along the horizontal force.
    scale = along_force_scale(speed_h, fh * fh)
    return scale * m, scale * n, polynomial_expr(*vertical, variables), speed_h, scale


def horizontal_drag_basis(vx, vy, s, exponent=2.0):
    """Heading-frame force per unit of each horizontal coefficient, in HORIZONTAL_DRAG_KEYS order, with
    s the (possibly smoothed) airflow speed. SX or NumPy."""
    cos2 = (vx * vx - vy * vy) / (s * s)
    sin2 = 2 * vx * vy / (s * s)
    cos4, sin4 = cos2 * cos2 - sin2 * sin2, 2 * sin2 * cos2
    g = speed_power(s, exponent)
    return {
        "l0": (vx, vy), "q0": (g * vx, g * vy),
        "l2c": (cos2 * vx, cos2 * vy), "q2c": (g * cos2 * vx, g * cos2 * vy),
        "q1c": _front_back(vx, vy, s, exponent),
        "l2s": (-sin2 * vy, sin2 * vx), "q2s": (-g * sin2 * vy, g * sin2 * vx),
        "q4c": (g * cos4 * vx, g * cos4 * vy), "q4s": (-g * sin4 * vy, g * sin4 * vx),
        "qax": (axis_power(vx, exponent) * vx, 0 * vx), "qay": (0 * vy, axis_power(vy, exponent) * vy),
        "qax1c": (vx / s * axis_power(vx, exponent) * vx, 0 * vx), "qay1c": (0 * vy, vx / s * axis_power(vy, exponent) * vy),
    }


def _horizontal_drag(law: DragLaw, vx, vy, s):
    basis = horizontal_drag_basis(vx, vy, s, law.exponent)
    used = _used(law, HORIZONTAL_DRAG_KEYS)
    fx = sum(getattr(law, k) * basis[k][0] for k in used)
    fy = sum(getattr(law, k) * basis[k][1] for k in used)
    return fx, fy


def drag_force(law: DragLaw, vx, vy, vz):
    """The drag law forward: heading-frame force (N) of the relative airflow (m/s). NumPy."""
    s = np.sqrt(vx * vx + vy * vy)
    safe = np.maximum(s, 1e-12)
    fx, fy = _horizontal_drag(law, vx, vy, safe)
    fz = law.lz * vz + law.qz * np.abs(vz) * vz + law.i1 * s + law.i2 * s * s
    return fx + 0 * vx, fy + 0 * vy, fz


def _newton_step(law: DragLaw, vx: ca.SX, vy: ca.SX, m: ca.SX, n: ca.SX) -> tuple[ca.SX, ca.SX]:
    sx, sy = ca.SX.sym("vx"), ca.SX.sym("vy")
    s = ca.sqrt(sx * sx + sy * sy + DRAG_SPEED_EPS_MPS ** 2)
    fx, fy = _horizontal_drag(law, sx, sy, s)
    force = ca.vertcat(fx, fy)
    coefficients = _symbols(law)
    law_and_slope = ca.Function("drag_law", [sx, sy, *coefficients], [force, ca.jacobian(force, ca.vertcat(sx, sy))])
    value, j = law_and_slope(vx, vy, *coefficients)
    rx, ry = value[0] - m, value[1] - n
    j11, j12, j21, j22 = j[0, 0], j[0, 1], j[1, 0], j[1, 1]
    inv_det = 1 / ca.fmax(j11 * j22 - j12 * j21, _DENOMINATOR_FLOOR)
    return vx - inv_det * (j22 * rx - j12 * ry), vy - inv_det * (j11 * ry - j21 * rx)


def _root(lin, quad, force):
    """The airflow of the law (lin + quad |v|) v = force, in the cancellation-free form of the quadratic's
    root, v = 2 force / (lin + sqrt(lin^2 + 4 quad |force|)) (``force`` >= 0 or a component: odd in it)."""
    return 2 * force / ca.fmax(lin + ca.sqrt(lin * lin + 4 * quad * ca.fabs(force)), _DENOMINATOR_FLOOR)


def _planar_start(law: DragLaw, fx: ca.SX, fy: ca.SX, lin: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Where the in-plane Newton steps start. The isotropic law (lin + q0 s) s = |F| solved along the
    force, (fx, fy) s / |F| without dividing by |F|; exact for a law along the airflow. A law with the
    per-axis pair: each axis's law solved alone on its own force component (lin +- l2c, and every
    quadratic term's value along that axis), exact for pure per-axis drag, where the isotropic start
    leaves the inversion metres per second off after three more steps (tests/test_peraxis.py). With the
    front/back pair too, the x axis's law has q1c + qax1c times the sign of its force (cos theta = +-1 on
    it); on the y axis cos theta is 0."""
    if _per_axis(law) or _front_back_axis(law):
        quadratic_x = law.q0 + law.q2c + law.q4c + law.qax
        if _front_back_axis(law):  # the sign is 0 at zero force, where the root is 0 anyway
            quadratic_x = quadratic_x + (law.q1c + law.qax1c) * (fx / ca.fmax(ca.fabs(fx), _DENOMINATOR_FLOOR))
        return (_root(ca.fmax(lin + law.l2c, 0), ca.fmax(quadratic_x, 0), fx),
                _root(ca.fmax(lin - law.l2c, 0), ca.fmax(law.q0 - law.q2c + law.q4c + law.qay, 0), fy))
    fh = ca.sqrt(fx * fx + fy * fy)
    scale = 2 / ca.fmax(lin + ca.sqrt(lin * lin + 4 * law.q0 * fh), _DENOMINATOR_FLOOR)
    return scale * fx, scale * fy


def drag_airflow(law: DragLaw, m: ca.SX, n: ca.SX, fz: ca.SX):
    """The drag law inverted: airflow (x, y, z), heading frame, from the heading-frame force."""
    vx, vy = _planar_start(law, m, n, law.l0)
    for _ in range(law.newton_steps(DRAG_NEWTON_STEPS)):
        vx, vy = _newton_step(law, vx, vy, m, n)
    s = ca.sqrt(vx * vx + vy * vy)
    # lz v + qz |v| v = r, solved for v with the root's sign taken from r (the law is odd in v).
    r = fz - law.i1 * s - law.i2 * s * s
    vz = 2 * r / ca.fmax(law.lz + ca.sqrt(law.lz * law.lz + 4 * law.qz * ca.fabs(r)), _DENOMINATOR_FLOOR)
    return vx, vy, vz


@functools.lru_cache(maxsize=None)
def _heading_inversion(quadratic: bool, fourfold: bool, per_axis: bool = False, front_back: bool = False) -> VectorFunction:
    """``drag_airflow`` on the symbolic law, built once: (m, n, fz, coefficients) -> airflow."""
    law, sm, sn, sz = symbolic_law(DragFrame.HEADING, quadratic, fourfold, per_axis, front_back), ca.SX.sym("m"), ca.SX.sym("n"), ca.SX.sym("fz")
    return VectorFunction(ca.Function("drag_airflow", [sm, sn, sz, ca.vertcat(*_symbols(law))],
                                      [ca.vertcat(*drag_airflow(law, sm, sn, sz))]))


def _coefficients(law: DragLaw, frame: DragFrame) -> np.ndarray:
    """The law's coefficients in the order of ``symbolic_law(frame, *_variant(law))``'s symbols."""
    keys = _symbolic_keys(frame, *_variant(law)[1:])
    return np.array([float(getattr(law, k)) for k in keys] + ([] if _quadratic(law) else [float(law.exponent)]))


def drag_airflow_numpy(law: DragLaw, m: np.ndarray, n: np.ndarray, fz: np.ndarray) -> np.ndarray:
    """``drag_airflow`` over arrays: (N, 3) airflow, through the same symbolic expressions (the law's
    coefficients as inputs; a zero coefficient then adds an exact 0 instead of dropping its term)."""
    rows = len(m)
    if rows == 0:
        return np.zeros((0, 3))
    force = [np.asarray(v, float).reshape(1, rows) for v in (m, n, fz)]
    return _heading_inversion(*_variant(law))([*force, _coefficients(law, DragFrame.HEADING)], rows)[0].T


def body_drag_basis(ax, ay, az, rotor, eps: float = 0.0, exponent=2.0) -> dict[str, tuple]:
    """Body-frame force (x, y, z; FRD, N) per unit of each coefficient of the body-frame law, for the
    body-frame airflow a (m/s) and rotor = sqrt(u_f / (m g)). s = |a| (3-D: quadratic drag grows with
    the whole airspeed), s_h = the in-plane speed, theta its angle from body x. ``eps`` smooths both
    speeds (the inversion's Jacobian); 0 for data. SX or NumPy.

        F_xy = [l0 + lr rotor + q0 s^(p-1) + (l2c + q2c s^(p-1)) cos 2theta] a_xy + q1c s^(p-2) a_x a_xy
               + (l2s + q2s s^(p-1)) sin 2theta (-a_y, a_x)
               + q4c s^(p-1) cos 4theta a_xy + q4s s^(p-1) sin 4theta (-a_y, a_x)
               + (qax |a_x|^(p-1) a_x, qay |a_y|^(p-1) a_y) + (a_x / s_h) (qax1c |a_x|^(p-1) a_x, qay1c |a_y|^(p-1) a_y)
        F_z  = lz a_z + qz s a_z + i1 s_h + i2 s_h^2
    """
    sh2 = ax * ax + ay * ay + eps * eps
    s = (sh2 + az * az) ** 0.5
    sh = sh2 ** 0.5
    cos2 = (ax * ax - ay * ay) / sh2
    sin2 = 2 * ax * ay / sh2
    cos4, sin4 = cos2 * cos2 - sin2 * sin2, 2 * sin2 * cos2
    zero = 0 * ax
    g = speed_power(s, exponent)
    return {
        "l0": (ax, ay, zero), "q0": (g * ax, g * ay, zero),
        "l2c": (cos2 * ax, cos2 * ay, zero), "q2c": (g * cos2 * ax, g * cos2 * ay, zero),
        "q1c": (*_front_back(ax, ay, s, exponent), zero),
        "l2s": (-sin2 * ay, sin2 * ax, zero), "q2s": (-g * sin2 * ay, g * sin2 * ax, zero),
        "q4c": (g * cos4 * ax, g * cos4 * ay, zero), "q4s": (-g * sin4 * ay, g * sin4 * ax, zero),
        "qax": (axis_power(ax, exponent) * ax, zero, zero), "qay": (zero, axis_power(ay, exponent) * ay, zero),
        "qax1c": (ax / sh * axis_power(ax, exponent) * ax, zero, zero),
        "qay1c": (zero, ax / sh * axis_power(ay, exponent) * ay, zero),
        "lr": (rotor * ax, rotor * ay, zero),
        "lz": (zero, zero, az), "qz": (zero, zero, s * az), "i1": (zero, zero, sh), "i2": (zero, zero, sh2),
    }


def body_drag_force(law: DragLaw, ax, ay, az, rotor, eps: float = 0.0):
    """The body-frame law forward: body-frame force (N) of the body-frame airflow. SX or NumPy."""
    basis = body_drag_basis(ax, ay, az, rotor, eps, law.exponent)
    used = _used(law, law.keys())
    return tuple(sum(getattr(law, k) * basis[k][i] for k in used) for i in range(3))


def _body_newton_step(law: DragLaw, a: ca.SX, rotor: ca.SX, force_b: ca.SX) -> ca.SX:
    return _body_newton_chord(law, a, rotor, force_b)[0]


def body_law_at(law: DragLaw, a: ca.SX, rotor: ca.SX) -> ca.SX:
    """The body-frame law's force at the airflow ``a`` as the inversion evaluates it (the same speed
    smoothing): the chord's and the start rule's residuals, and what the step's tracked airflow explains
    (model/airstate.py)."""
    sa, sr = ca.SX.sym("a", 3), ca.SX.sym("rotor")
    value = body_law_value(*body_law_scalars(law, sa, sr, DRAG_SPEED_EPS_MPS), sa, per_axis_force(law, sa, DRAG_SPEED_EPS_MPS))  # regrouped (dragform.py)
    coefficients = _symbols(law)
    return ca.Function("body_drag_value", [sa, sr, *coefficients], [value])(a, rotor, *coefficients)


def _body_newton_chord(law: DragLaw, a: ca.SX, rotor: ca.SX, force_b: ca.SX) -> tuple[ca.SX, Callable[[ca.SX], ca.SX]]:
    """One Newton step from ``a``, and the correction J(a)^-1 r of that same Jacobian for a later
    iterate (a chord step: the Jacobian reused, only the law's value evaluated again)."""
    sa, sr = ca.SX.sym("a", 3), ca.SX.sym("rotor")
    # The law regrouped into three scalars and their gradients (dragform.py): the same value and Jacobian
    # as differentiating body_drag_force, in about half the operations.
    value, jacobian = body_law_and_jacobian(law, sa, sr, DRAG_SPEED_EPS_MPS)
    coefficients = _symbols(law)
    law_and_slope = ca.Function("body_drag_law", [sa, sr, *coefficients], [value, jacobian])
    f, slope = law_and_slope(a, rotor, *coefficients)
    # J^-1 r by the adjugate of J divided by its trace t: products of three Jacobian entries stay
    # within single precision at any airflow the validation lets through. J^-1 r = adj(J/t) r /
    # (t det(J/t)): the residual itself is not divided (one product instead of three divisions per
    # step, the chord's included; the same step to rounding). The determinant is floored (a calibrated
    # law is strictly increasing along every axis).
    trace = ca.fmax(slope[0, 0] + slope[1, 1] + slope[2, 2], _DENOMINATOR_FLOOR)
    j = slope / trace
    adj = ca.vertcat(
        ca.horzcat(j[1, 1] * j[2, 2] - j[1, 2] * j[2, 1], j[0, 2] * j[2, 1] - j[0, 1] * j[2, 2], j[0, 1] * j[1, 2] - j[0, 2] * j[1, 1]),
        ca.horzcat(j[1, 2] * j[2, 0] - j[1, 0] * j[2, 2], j[0, 0] * j[2, 2] - j[0, 2] * j[2, 0], j[0, 2] * j[1, 0] - j[0, 0] * j[1, 2]),
        ca.horzcat(j[1, 0] * j[2, 1] - j[1, 1] * j[2, 0], j[0, 1] * j[2, 0] - j[0, 0] * j[2, 1], j[0, 0] * j[1, 1] - j[0, 1] * j[1, 0]))
    det = j[0, 0] * adj[0, 0] + j[0, 1] * adj[1, 0] + j[0, 2] * adj[2, 0]
    scale = ca.fmax(det, _DENOMINATOR_FLOOR) * trace

    def chord(later: ca.SX) -> ca.SX:
        return later - (adj @ (body_law_at(law, later, rotor) - force_b)) / scale

    return a - (adj @ (f - force_b)) / scale, chord


def _body_isotropic_start(law: DragLaw, f_b: ca.SX, rotor: ca.SX) -> ca.SX:
    """Each axis's isotropic law solved alone (the in-plane pair along its force), as in the heading
    frame: the body-frame airflow Newton starts from when nothing better is known."""
    ax, ay = _planar_start(law, f_b[0], f_b[1], law.l0 + law.lr * rotor)
    sh = ca.sqrt(ax * ax + ay * ay)
    rz = f_b[2] - law.i1 * sh - law.i2 * sh * sh
    az = 2 * rz / ca.fmax(law.lz + ca.sqrt(law.lz * law.lz + 4 * law.qz * ca.fabs(rz)), _DENOMINATOR_FLOOR)
    return ca.vertcat(ax, ay, az)


def body_drag_airflow(law: DragLaw, force_ned: ca.SX, rot: ca.SX, rotor: ca.SX) -> ca.SX:
    """The body-frame law inverted: relative airflow (NED, m/s) from the NED force (offset removed),
    the attitude ``rot`` (body -> NED, 3x3) and rotor = sqrt(u_f / (m g)). Converged from the
    isotropic start (calibration and analysis; the step tracks, see body_drag_airflow_tracking)."""
    f_b = rot.T @ force_ned
    a = _body_isotropic_start(law, f_b, rotor)
    for _ in range(law.newton_steps(BODY_NEWTON_STEPS)):
        a = _body_newton_step(law, a, rotor, f_b)
    return rot @ a


def body_drag_airflow_tracking(law: DragLaw, force_ned: ca.SX, rot: ca.SX, rotor: ca.SX, previous: ca.SX,
                               warm: ca.SX) -> tuple[ca.SX, ca.SX]:
    """The step's inversion of the body-frame law: (NED airflow, body-frame airflow) after
    TRACKING_NEWTON_STEPS steps (more for laws that need them, DragLaw.newton_steps), the last a chord
    step (the Jacobian of the step before reused: near the solution it barely changes, and the law's
    value alone is half the cost) from the previous sample's body-frame airflow (``warm`` = 1; the
    attitude turns little between samples, and Newton absorbs it), or from the isotropic start on the
    first sample (``warm`` = 0), after a jump, or when the isotropic start explains the force better.
    The force is low-passed, so from one sample to the next the solution moves little and Newton,
    quadratic near it, tracks it in fewer steps than a cold start needs: each sample continues the
    iteration of the one before (the first samples, within the settling time, may be a few steps short
    of converged)."""
    f_b = rot.T @ force_ned
    cold = _body_isotropic_start(law, f_b, rotor)
    # A jump of the force (a gust, the end of a gap) can leave the previous airflow far from the new
    # solution, where Newton may not converge in a few steps (or overflow in single precision): then the
    # isotropic start, which is near the solution at any size. The test, in 1-norms (no squares to
    # overflow): the previous airflow within half the start's size (plus 1 m/s) of it.
    distance = ca.sum1(ca.fabs(previous - cold))
    near = ca.logic_and(warm > 0, distance <= 0.5 * ca.sum1(ca.fabs(cold)) + 1.0)
    # And only when it explains the force at least as well as the closed form (law residuals, 1-norms).
    # Near zero airflow a law without a linear term along an axis (lz = 0) is flat there: the Jacobian
    # at the previous airflow has a slope of qz times the speed smoothing, and the Newton and chord
    # steps from it overshot by orders of magnitude (1e-3 N of vertical force gave -3.7e4 m/s in a hover
    # in still air; docs/verification.md). The closed form solves each axis's quadratic exactly.
    miss_previous = ca.sum1(ca.fabs(body_law_at(law, previous, rotor) - f_b))
    miss_cold = ca.sum1(ca.fabs(body_law_at(law, cold, rotor) - f_b))
    near = ca.logic_and(near, miss_previous <= miss_cold)
    start = cold + near * (previous - cold)  # a product, not a select: smaller code on a Cortex-M
    a, chord = _body_newton_chord(law, start, rotor, f_b)
    for _ in range(law.newton_steps(TRACKING_NEWTON_STEPS) - 2):
        a, chord = _body_newton_chord(law, a, rotor, f_b)
    a = chord(a)  # the last step reuses the Jacobian of the one before
    return rot @ a, a


@functools.lru_cache(maxsize=None)
def _body_inversion(quadratic: bool, fourfold: bool, per_axis: bool = False, front_back: bool = False) -> VectorFunction:
    """``body_drag_airflow`` on the symbolic law, built once: (force, rot, rotor, coefficients) -> airflow."""
    law, sf, sr, sq = symbolic_law(DragFrame.BODY, quadratic, fourfold, per_axis, front_back), ca.SX.sym("f", 3), ca.SX.sym("rot", 9), ca.SX.sym("rotor")
    return VectorFunction(ca.Function("body_drag_airflow", [sf, sr, sq, ca.vertcat(*_symbols(law))],
                                      [body_drag_airflow(law, sf, ca.reshape(sr, 3, 3), sq)]))


def body_drag_airflow_numpy(law: DragLaw, force_ned: np.ndarray, rot: np.ndarray, rotor: np.ndarray) -> np.ndarray:
    """``body_drag_airflow`` over arrays: force (N, 3), rot (N, 3, 3), rotor (N,) -> (N, 3) NED airflow
    (the law's coefficients as inputs, as in ``drag_airflow_numpy``)."""
    rows = len(force_ned)
    if rows == 0:
        return np.zeros((0, 3))
    # ca.reshape is column-major: row k of the (9, N) input is rot[:, k % 3, k // 3].
    flat = np.transpose(rot, (2, 1, 0)).reshape(9, rows)
    inputs = [np.asarray(force_ned, float).T, flat, np.asarray(rotor, float).reshape(1, rows), _coefficients(law, DragFrame.BODY)]
    return _body_inversion(*_variant(law))(inputs, rows)[0].T


def term_matrix(terms: list[Term], m: np.ndarray, n: np.ndarray, fz: np.ndarray) -> np.ndarray:
    """Values of force-air terms over arrays, (N, len(terms)), through the step's grammar."""
    sm, sn, sz = ca.SX.sym("m"), ca.SX.sym("n"), ca.SX.sym("fz")
    env = term_variables(sm, sn, sz)
    f = ca.Function("terms", [sm, sn, sz], [ca.vertcat(*[term_expr(t, env) for t in terms])])
    return np.asarray(f.map(len(m))(m, n, fz)).T.reshape(len(m), len(terms))


def wind_from_deg(north, east):
    """Meteorological direction (deg, [0, 360)) the wind blows FROM, clockwise from north. NumPy."""
    towards = np.degrees(np.arctan2(-np.asarray(east), -np.asarray(north)))
    from_deg = np.where(towards < 0, towards + 360.0, towards)
    return np.where(from_deg >= 360.0, 0.0, from_deg)


def wind_from_ne(speed_mps, from_deg) -> np.ndarray:
    """North and east components (N, 2) of a horizontal wind of ``speed_mps`` blowing FROM ``from_deg``
    (clockwise from north): the air moves towards from + 180 deg. The inverse of ``wind_from_deg``. NumPy."""
    speed, rad = np.broadcast_arrays(np.asarray(speed_mps, dtype=float), np.radians(from_deg))
    return np.column_stack([-speed * np.cos(rad), -speed * np.sin(rad)])


def wind_from_deg_sx(north: ca.SX, east: ca.SX) -> ca.SX:
    """``wind_from_deg`` for the step."""
    towards = ca.atan2(-east, -north) * (180 / math.pi)  # (-180, 180]
    from_deg = towards + ca.if_else(towards < 0, 360, 0)
    return ca.if_else(from_deg >= 360, 0, from_deg)  # -tiny + 360 rounds to 360 in float


# The grid on which a fitted drag law must increase: horizontal directions every 5 degrees, speeds from
# LAW_CHECK_MIN_MPS up in geometric steps; below it the linear part alone decides (_linear_part).
LAW_CHECK_DIRECTIONS = 72
LAW_CHECK_SPEEDS = 48
LAW_CHECK_MIN_MPS = 0.01
# The terms that grow as s^p (the bluff-body drag): the linear part is the law without them, and the
# fit rescales their columns for another exponent (dragfit.with_exponent).
QUADRATIC_KEYS = ("q0", "q2c", "q2s", "q1c") + FOURFOLD_KEYS + PER_AXIS_KEYS + FRONT_BACK_AXIS_KEYS


@functools.lru_cache(maxsize=None)
def _law_slope(frame: DragFrame, quadratic: bool, fourfold: bool, per_axis: bool = False,
               front_back: bool = False) -> VectorFunction:
    """The horizontal block of the forward law's Jacobian, d(F_x, F_y)/d(a_x, a_y), at level airflow, on
    symbolic coefficients: (airflow, rotor, coefficients) -> 2 x 2 (column-major), smoothed as in Newton.
    At a_z = 0 the body frame's 3 x 3 Jacobian is block-triangular, so this block is what the horizontal
    terms decide; the vertical law (lz, qz >= 0) is checked apart (fitfamily)."""
    law, a, rotor = symbolic_law(frame, quadratic, fourfold, per_axis, front_back), ca.SX.sym("a", 2), ca.SX.sym("rotor")
    if frame == DragFrame.BODY:
        force = ca.vertcat(*body_drag_force(law, a[0], a[1], 0 * a[0], rotor, DRAG_SPEED_EPS_MPS)[:2])
    else:
        s = ca.sqrt(a[0] * a[0] + a[1] * a[1] + DRAG_SPEED_EPS_MPS ** 2)
        force = ca.vertcat(*_horizontal_drag(law, a[0], a[1], s))
    return VectorFunction(ca.Function("drag_law_slope", [a, rotor, ca.vertcat(*_symbols(law))],
                                      [ca.jacobian(force, a)]))


def _first_bad(law: DragLaw, ux: np.ndarray, uy: np.ndarray, speed: np.ndarray, rotor: float,
               strict: bool) -> int | None:
    """Index of the first grid point where the slope along the airflow or the determinant is negative
    (``strict``: not positive), or None."""
    j = _law_slope(law.frame, *_variant(law))([np.vstack([ux * speed, uy * speed]), np.array([rotor]),
                               _coefficients(law, law.frame)], ux.size)[0]
    jac = j.T.reshape(-1, 2, 2).transpose(0, 2, 1)  # column-major nonzeros -> (rows, i, j) = dF_i / da_j
    radial = ux * (jac[:, 0, 0] * ux + jac[:, 0, 1] * uy) + uy * (jac[:, 1, 0] * ux + jac[:, 1, 1] * uy)
    det = np.linalg.det(jac)
    bad = ~((det > 0) & (radial > 0)) if strict else ~((det >= 0) & (radial >= 0))
    return int(np.flatnonzero(bad)[0]) if bad.any() else None


def law_decreasing(law: DragLaw, speed_max_mps: float, rotors: tuple[float, ...] = (1.0,)) -> str | None:
    """Where the law's horizontal force stops increasing with the level airflow up to ``speed_max_mps``
    (the body frame at each rotor term of ``rotors``), or None. Increasing: a positive Jacobian
    determinant and a positive slope along the airflow; otherwise two airflows give one force there and
    the step's Newton inversion can run off (the same force read as far faster air). Next to zero only
    the linear part counts (it decides the slope as s -> 0): it may be zero, never negative."""
    theta = np.linspace(0.0, 2 * math.pi, LAW_CHECK_DIRECTIONS, endpoint=False)
    speed = np.geomspace(LAW_CHECK_MIN_MPS, max(speed_max_mps, 2 * LAW_CHECK_MIN_MPS), LAW_CHECK_SPEEDS)
    t, s = np.meshgrid(theta, speed)
    ux, uy, s = np.cos(t).ravel(), np.sin(t).ravel(), s.ravel()
    linear = dataclasses.replace(law, **{k: 0.0 for k in QUADRATIC_KEYS})
    for rotor in (rotors if law.frame == DragFrame.BODY else (1.0,)):
        where = None
        k = _first_bad(linear, np.cos(theta), np.sin(theta), np.ones_like(theta), rotor, strict=False)
        if k is not None:
            where = f"{math.degrees(theta[k]):.0f} deg from x next to zero airflow (its linear part)"
        elif (k := _first_bad(law, ux, uy, s, rotor, strict=True)) is not None:
            where = f"{math.degrees(theta[k % LAW_CHECK_DIRECTIONS]):.0f} deg from x at {s[k]:.3g} m/s"
        if where is not None:
            return where + (f", rotor term {rotor:.2f}" if law.frame == DragFrame.BODY else "")
    return None


# --- every family, NumPy: the force-air law of an airframe forward and inverted ---------------------
# Analysis (dobwind/analysis) makes the force a given airflow would cause and reads the airflow a force
# maps to through these two functions only, so that a new family added to the step is added here once
# and every experiment follows (issue #33: the ramp once rebuilt the polynomial family alone).

# The polynomial family's horizontal force is searched up to this multiple of the weight: far beyond
# any calibrated airflow, so a target the law cannot reach clamps visibly instead of wrapping.
POLYNOMIAL_FORCE_SEARCH_WEIGHTS = 1.0
_VERTICAL_GRID_POINTS = 4001


@functools.lru_cache(maxsize=16)
def _polynomial_function(horizontal, vertical) -> ca.Function:
    """(m, n, fz) -> (x, y, z airflow, heading frame; horizontal speed) of the polynomial family, per
    pair of (frozen) ForceAirModel tables: built once, however many times a bisection asks."""
    m, n, fz = ca.SX.sym("m"), ca.SX.sym("n"), ca.SX.sym("fz")
    x, y, z, speed_h, _ = polynomial_airflow((horizontal.terms, horizontal.coefficients),
                                             (vertical.terms, vertical.coefficients), m, n, fz)
    return ca.Function("polynomial_airflow", [m, n, fz], [ca.vertcat(x, y, z, speed_h)])


def _polynomial_numpy(af: "Airframe", m: np.ndarray, n: np.ndarray, fz: np.ndarray) -> np.ndarray:
    """(N, 4): heading-frame airflow x, y, z and the horizontal speed, of the polynomial family."""
    rows = len(m)
    out = _polynomial_function(af.horizontal, af.vertical).map(rows)(*(np.asarray(v, float).reshape(1, rows) for v in (m, n, fz)))
    return np.asarray(out).T


def family(af: "Airframe") -> str:
    """The airframe's force-air family, as `fit --model` names them."""
    if af.drag is None:
        return "polynomial"
    return f"drag-{af.drag.frame}"


def needs_attitude(af: "Airframe") -> bool:
    """The airframe's law reads the attitude and thrust (the body-frame drag law): a caller that makes a
    force for an airflow must then balance the tilt that force causes."""
    return af.drag is not None and af.drag.frame == DragFrame.BODY


def _hover_attitude(rows: int, rot, rotor) -> tuple[np.ndarray, np.ndarray]:
    """Level attitude and hover rotor term where the caller gives none."""
    rot = np.tile(np.eye(3), (rows, 1, 1)) if rot is None else np.asarray(rot, float)
    rotor = np.ones(rows) if rotor is None else np.broadcast_to(np.asarray(rotor, float), (rows,))
    return rot, rotor


def airframe_airflow(af: "Airframe", force_ned: np.ndarray, yaw: np.ndarray, rot: np.ndarray | None = None,
                     rotor: np.ndarray | None = None) -> np.ndarray:
    """The airframe's force-air law inverted as the step inverts it: relative airflow (N, 3; NED, air
    minus vehicle) from the NED external force (N, 3; offset included), heading ``yaw`` (rad), attitude
    ``rot`` (N, 3, 3 body -> NED; level if None) and rotor = sqrt(u_f / (m g)) (1 if None); the last
    two matter to the body-frame law only."""
    force_ned = np.atleast_2d(np.asarray(force_ned, float))
    yaw = np.broadcast_to(np.asarray(yaw, float), (len(force_ned),))
    c, s = np.cos(yaw), np.sin(yaw)
    m, n, fz = heading_force(force_ned.T, c, s, af.observer.force_offset_n)
    if needs_attitude(af):
        rot, rotor = _hover_attitude(len(force_ned), rot, rotor)
        fn, fe = heading_to_ned(m, n, c, s)
        return body_drag_airflow_numpy(af.drag, np.column_stack([fn, fe, fz]), rot, rotor)
    if af.drag is not None:
        air = drag_airflow_numpy(af.drag, m, n, fz)
    else:
        air = _polynomial_numpy(af, m, n, fz)[:, :3]
    north, east = heading_to_ned(air[:, 0], air[:, 1], c, s)
    return np.column_stack([north, east, air[:, 2]])


def airframe_force(af: "Airframe", air_rel_ned: np.ndarray, yaw: np.ndarray, rot: np.ndarray | None = None,
                   rotor: np.ndarray | None = None) -> np.ndarray:
    """The airframe's force-air law forward: the NED external force (N, 3; offset included) that
    ``airframe_airflow`` maps back to the relative airflow ``air_rel_ned`` (N, 3), same arguments.
    The drag laws are forward laws; the polynomial family is inverted by bisection along the airflow
    (its model: the air moves along the horizontal force)."""
    air = np.atleast_2d(np.asarray(air_rel_ned, float))
    yaw = np.broadcast_to(np.asarray(yaw, float), (len(air),))
    c, s = np.cos(yaw), np.sin(yaw)
    x, y, vz = heading_force(air.T, c, s, (0.0, 0.0, 0.0))
    if needs_attitude(af):
        rot, rotor = _hover_attitude(len(air), rot, rotor)
        a = np.einsum("nji,nj->ni", rot, air)  # NED -> body: rot^T a
        # eps: a finite angle at zero in-plane airflow (whose terms then vanish anyway).
        f_b = np.column_stack(body_drag_force(af.drag, a[:, 0], a[:, 1], a[:, 2], rotor, 1e-9))
        f = np.einsum("nij,nj->ni", rot, f_b)
        m, n, fz = heading_force(f.T, c, s, (0.0, 0.0, 0.0))
    elif af.drag is not None:
        m, n, fz = drag_force(af.drag, x, y, vz)
    else:
        m, n, fz = _polynomial_force(af, x, y, vz)
    off = af.observer.force_offset_n
    north, east = heading_to_ned(m + off[0], n + off[1], c, s)
    return np.column_stack([north, east, fz + off[2]])


def _polynomial_force(af: "Airframe", x: np.ndarray, y: np.ndarray, vz: np.ndarray):
    """Heading-frame force (m, n, fz) of the polynomial family for the airflow (x, y, vz): the horizontal
    force along the airflow with the magnitude whose modelled speed is |(x, y)|; the vertical force on
    the vertical model's monotone branch through zero force (at zero horizontal force)."""
    weight = af.mass_kg * af.gravity_mps2
    speed = np.hypot(x, y)
    ux = np.where(speed > 0, x / np.maximum(speed, 1e-300), 1.0)
    uy = np.where(speed > 0, y / np.maximum(speed, 1e-300), 0.0)
    along = lambda fh: _polynomial_numpy(af, fh * ux, fh * uy, np.zeros_like(fh))[:, 3]  # noqa: E731
    fh = bisect_increasing(along, speed, 0.0, POLYNOMIAL_FORCE_SEARCH_WEIGHTS * weight)
    grid = np.linspace(-weight, weight, _VERTICAL_GRID_POINTS)
    zeros = np.zeros_like(grid)
    v_grid = _polynomial_numpy(af, zeros, zeros, grid)[:, 2]
    # A vertical model that ignores fz cannot be inverted: no vertical force.
    fz = np.zeros_like(vz) if np.ptp(v_grid) == 0.0 else _monotone_inverse(v_grid, grid, len(grid) // 2, vz)
    return fh * ux, fh * uy, fz


def _monotone_inverse(values: np.ndarray, grid: np.ndarray, zero: int, target: np.ndarray) -> np.ndarray:
    """Invert a sampled function on the monotone branch through grid[zero] (targets off it clamp)."""
    step = np.sign(np.diff(values))
    direction = step[zero] if step[zero] != 0 else 1.0
    lo = zero
    while lo > 0 and step[lo - 1] == direction:
        lo -= 1
    hi = zero
    while hi < len(step) and step[hi] == direction:
        hi += 1
    branch_v, branch_g = values[lo:hi + 1], grid[lo:hi + 1]
    if direction < 0:
        branch_v, branch_g = branch_v[::-1], branch_g[::-1]
    return np.interp(target, branch_v, branch_g)
