"""The scalar quaternion fast paths of :mod:`.rotations`, compiled (numba ``njit``) for the
compiled step kernels: the same Python functions, so a kernel and a Python caller compute
the same bits. Quaternions are (x, y, z, w) tuples (:mod:`.rotations`' conventions).

:func:`euler321_from_quat` is :func:`.rotations.euler321_from_quat`'s maths with a fixed
error message (a compiled function cannot format one)."""
from __future__ import annotations

import math

from numba import njit

from . import rotations

quat_from_euler321 = njit(cache=True)(rotations.quat_from_euler321)
quat_canonical = njit(cache=True)(rotations.quat_canonical)
quat_mul = njit(cache=True)(rotations.quat_mul)
quat_conj = njit(cache=True)(rotations.quat_conj)
quat_from_rotation_vector = njit(cache=True)(rotations.quat_from_rotation_vector)
rotation_vector_from_quat = njit(cache=True)(rotations.rotation_vector_from_quat)


@njit(cache=True)
def euler321_from_quat(x: float, y: float, z: float, w: float) -> tuple:
    """(roll, pitch, yaw) [rad] of the (x, y, z, w) quaternion of b relative to n (normalised
    here); ``ValueError`` for a zero or non-finite quaternion and at pitch ±90°::

        φ = atan2(2(yz + xw), 1 − 2(x² + y²)),  θ = asin(−2(xz − yw)),  ψ = atan2(2(xy + zw), 1 − 2(y² + z²))
    """
    n2 = x * x + y * y + z * z + w * w
    if not (1e-24 <= n2 < math.inf):
        raise ValueError("euler321_from_quat: expected a finite non-zero quaternion")
    s = 2.0 / n2
    sp = -s * (x * z - y * w)
    if abs(sp) > 1.0 - 1e-12:
        raise ValueError("euler321_from_quat: pitch is ±90°, roll and yaw are not separable")
    return (math.atan2(s * (y * z + x * w), 1.0 - s * (x * x + y * y)),
            math.asin(sp),
            math.atan2(s * (x * y + z * w), 1.0 - s * (y * y + z * z)))
