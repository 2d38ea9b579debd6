"""Compiled rotation kernels (numba ``njit``): plain functions over floats and float64
arrays. :mod:`.rotations` checks its inputs and calls these (``euler321_to_dcm``,
``dcm_to_quat``, ``rotation_vector_to_dcm``), the platform kernels build the stable
element's attitude with them, and the gyro-bias EKF's kernels its error transition."""
from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def euler321_to_dcm(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """C_nb of 3-2-1 Euler angles [rad], (3, 3)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    C = np.empty((3, 3))
    C[0, 0], C[0, 1], C[0, 2] = cp * cy, sr * sp * cy - cr * sy, cr * sp * cy + sr * sy
    C[1, 0], C[1, 1], C[1, 2] = cp * sy, sr * sp * sy + cr * cy, cr * sp * sy - sr * cy
    C[2, 0], C[2, 1], C[2, 2] = -sp, sr * cp, cr * cp
    return C


@njit(cache=True)
def dcm_to_quat(C: np.ndarray) -> np.ndarray:
    """Quaternion (x, y, z, w), w ≥ 0, of a rotation matrix by Shepperd's method (the
    largest of the four squared components; ties to the first), normalised."""
    tr = C[0, 0] + C[1, 1] + C[2, 2]
    k, best = 0, tr
    for j in range(3):
        if C[j, j] > best:
            k, best = j + 1, C[j, j]
    q = np.empty(4)
    if k == 0:
        w = 0.5 * math.sqrt(1.0 + tr)
        f = 0.25 / w
        q[0], q[1], q[2], q[3] = (C[2, 1] - C[1, 2]) * f, (C[0, 2] - C[2, 0]) * f, (C[1, 0] - C[0, 1]) * f, w
    elif k == 1:
        x = 0.5 * math.sqrt(1.0 + 2.0 * C[0, 0] - tr)
        f = 0.25 / x
        q[0], q[1], q[2], q[3] = x, (C[0, 1] + C[1, 0]) * f, (C[0, 2] + C[2, 0]) * f, (C[2, 1] - C[1, 2]) * f
    elif k == 2:
        y = 0.5 * math.sqrt(1.0 + 2.0 * C[1, 1] - tr)
        f = 0.25 / y
        q[0], q[1], q[2], q[3] = (C[0, 1] + C[1, 0]) * f, y, (C[1, 2] + C[2, 1]) * f, (C[0, 2] - C[2, 0]) * f
    else:
        z = 0.5 * math.sqrt(1.0 + 2.0 * C[2, 2] - tr)
        f = 0.25 / z
        q[0], q[1], q[2], q[3] = (C[0, 2] + C[2, 0]) * f, (C[1, 2] + C[2, 1]) * f, z, (C[1, 0] - C[0, 1]) * f
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    q = q / n
    return -q if q[3] < 0.0 else q


@njit(cache=True)
def rotation_vector_to_dcm(x: float, y: float, z: float) -> np.ndarray:
    """exp([v×]) of the rotation vector v = (x, y, z) [rad], (3, 3): Rodrigues' formula with
    series coefficients near zero, so tiny angles stay exact."""
    a2 = x * x + y * y + z * z
    if a2 < 1e-8:
        s = 1.0 - a2 / 6.0 + a2 * a2 / 120.0
        c = 0.5 - a2 / 24.0 + a2 * a2 / 720.0
    else:
        a = math.sqrt(a2)
        s = math.sin(a) / a
        c = (1.0 - math.cos(a)) / a2
    out = np.empty((3, 3))
    out[0, 0], out[0, 1], out[0, 2] = 1.0 - c * (y * y + z * z), c * x * y - s * z, c * x * z + s * y
    out[1, 0], out[1, 1], out[1, 2] = c * x * y + s * z, 1.0 - c * (x * x + z * z), c * y * z - s * x
    out[2, 0], out[2, 1], out[2, 2] = c * x * z - s * y, c * y * z + s * x, 1.0 - c * (x * x + y * y)
    return out
