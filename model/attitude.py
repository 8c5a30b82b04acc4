"""Attitude on arrays (NumPy, rows): quaternions from Euler angles and to rotation matrices, the heading
a quaternion implies, and the attitude that points the thrust along a wanted direction at a heading. Conventions: q = (w, x, y, z) rotates body FRD to
NED; the thrust acts along -z_body (docs/model.md, frames)."""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # SciPy's import takes 0.27 s, a sixth of a replay that never builds an attitude
    from scipy.spatial.transform import Rotation


def euler_to_quaternion(roll: np.ndarray, pitch: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """ZYX Euler angles -> (w, x, y, z), body FRD to NED. Rows are samples."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.stack([
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ], axis=-1)


def rotation_matrices(q: np.ndarray) -> np.ndarray:
    """(..., 3, 3) body-to-NED rotation matrices of unit quaternions (..., 4) (w, x, y, z)."""
    w, x, y, z = (q[..., i] for i in range(4))
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], -2)


def yaw_from_quaternion(q: np.ndarray) -> np.ndarray:
    """Yaw (rad, ZYX Euler angle) of each quaternion row (w, x, y, z)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    # A damaged log's huge finite component (1e308) overflows to inf or NaN: that row's yaw is no number,
    # and the step rejects the row by its quaternion's norm anyway; numpy's warning would only print
    # its own lines on stderr.
    with np.errstate(over="ignore", invalid="ignore"):
        return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def attitude_with_body_down(z_b: np.ndarray, yaw: np.ndarray) -> Rotation:
    """The attitudes whose body z axis (down) is the unit row ``z_b`` (NED) and whose body x axis lies in
    the vertical plane of heading ``yaw`` (rad): how a multirotor tilts to point its thrust, -z_b."""
    heading = np.stack([np.cos(yaw), np.sin(yaw), np.zeros(len(yaw))], 1)
    y = np.cross(z_b, heading)
    y /= np.linalg.norm(y, axis=1)[:, None]
    x = np.cross(y, z_b)
    from scipy.spatial.transform import Rotation

    return Rotation.from_matrix(np.stack([x, y, z_b], axis=2))


def quaternion_wxyz(rot: Rotation) -> np.ndarray:
    """Rows (w, x, y, z) of ``rot`` (SciPy orders them x, y, z, w)."""
    xyzw = rot.as_quat()
    return np.column_stack([xyzw[:, 3], xyzw[:, :3]])
