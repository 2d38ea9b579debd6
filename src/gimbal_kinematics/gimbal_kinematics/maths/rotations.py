"""Rotations: elementary frame rotations, 3-2-1 Euler angles, DCMs and quaternions.

Conventions (docs/spec.md section 2):

* ``C_ab`` is the direction-cosine matrix that maps a vector resolved in frame b to
  frame a: ``vec_a = C_ab @ vec_b``.
* ``rot1/rot2/rot3(angle)`` are *frame* rotations: when frame b is frame a turned by
  ``angle`` about a's axis i, then ``C_ba = rot_i(angle)``.
* 3-2-1 Euler angles (yaw ψ, pitch θ, roll φ) of frame b relative to frame n give
  ``C_bn = rot1(φ) @ rot2(θ) @ rot3(ψ)`` and ``C_nb = C_bn.T``.
* Quaternions are (x, y, z, w), scalar last, as on ROS messages and in
  ``scipy.spatial.transform.Rotation``. The quaternion of b relative to n is the one whose
  rotation matrix is ``C_nb``; this is what ``sensor_msgs/Imu.orientation`` carries.

All angles are radians; all matrices are numpy arrays of shape (3, 3).
"""
from __future__ import annotations

import math

import numpy as np

#: Largest deviation of ``C @ C.T`` from the identity accepted as a rotation matrix.
ORTHONORMAL_TOL = 1e-6


def rot1(angle: float) -> np.ndarray:
    """Frame rotation by ``angle`` [rad] about axis 1 (x); shape (3, 3)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])


def rot2(angle: float) -> np.ndarray:
    """Frame rotation by ``angle`` [rad] about axis 2 (y); shape (3, 3)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])


def rot3(angle: float) -> np.ndarray:
    """Frame rotation by ``angle`` [rad] about axis 3 (z); shape (3, 3)."""
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def skew(vec: np.ndarray) -> np.ndarray:
    """Cross-product matrix: ``skew(a) @ b == np.cross(a, b)``; (3,) -> (3, 3)."""
    x, y, z = vec
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def unskew(mat: np.ndarray, tol: float = 1e-9) -> np.ndarray:
    """Inverse of :func:`skew`; (3, 3) -> (3,).

    Raises ``ValueError`` when ``mat`` is not skew-symmetric to ``tol`` (absolute), because
    silently taking half of a non-skew matrix hides sign and frame mistakes.
    """
    mat = np.asarray(mat, dtype=float)
    asym = np.max(np.abs(mat + mat.T)) if mat.shape == (3, 3) else math.inf
    if asym > tol:
        raise ValueError(f"unskew: matrix is not skew-symmetric (|M + M^T| = {asym:.3g})")
    return np.array([mat[2, 1], mat[0, 2], mat[1, 0]])


def check_dcm(C: np.ndarray, name: str = "DCM", tol: float = ORTHONORMAL_TOL) -> np.ndarray:
    """Return ``C`` as a float array after checking it is a proper rotation matrix.

    Raises ``ValueError`` naming ``name`` when the shape is not (3, 3), the matrix is not
    orthonormal to ``tol`` or its determinant is not +1 (a reflection).
    """
    C = np.asarray(C, dtype=float)
    if C.shape != (3, 3):
        raise ValueError(f"{name}: expected shape (3, 3), got {C.shape}")
    if not np.all(np.isfinite(C)):
        raise ValueError(f"{name}: contains NaN or inf")
    err = np.max(np.abs(C @ C.T - np.eye(3)))
    if err > tol:
        raise ValueError(f"{name}: not orthonormal (max |C C^T - I| = {err:.3g} > {tol:g})")
    if np.linalg.det(C) < 0.0:
        raise ValueError(f"{name}: determinant is -1, a reflection rather than a rotation")
    return C


def orthonormalize(C: np.ndarray) -> np.ndarray:
    """Nearest rotation matrix to ``C`` in the Frobenius norm (polar decomposition).

    Used to remove the drift that numerical integration of a DCM accumulates. Raises
    ``ValueError`` when ``C`` is singular or closer to a reflection than to a rotation.
    """
    C = np.asarray(C, dtype=float)
    u, s, vt = np.linalg.svd(C)
    if s[-1] <= 1e-12 * max(s[0], 1e-300):
        raise ValueError("orthonormalize: matrix is singular")
    if np.linalg.det(u @ vt) < 0.0:
        raise ValueError("orthonormalize: matrix is nearer a reflection than a rotation")
    return u @ vt


def euler321_to_dcm(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``C_nb`` (body to navigation) from 3-2-1 Euler angles [rad]; shape (3, 3) (the compiled
    :func:`.rotation_kernels.euler321_to_dcm`)."""
    from . import rotation_kernels as rk  # lazily: numba loads only where a kernel runs

    return rk.euler321_to_dcm(float(roll), float(pitch), float(yaw))


def dcm_to_euler321(C_nb: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] from ``C_nb``; yaw and roll in (-π, π], pitch in [-π/2, π/2].

    Raises ``ValueError`` when ``C_nb`` is not a rotation matrix, or at pitch ±90° where
    roll and yaw are not separable (gimbal lock).
    """
    C_nb = check_dcm(C_nb, "C_nb")
    sp = -C_nb[2, 0]
    if abs(sp) > 1.0 - 1e-12:
        raise ValueError("dcm_to_euler321: pitch is ±90°, roll and yaw are not separable")
    pitch = math.asin(max(-1.0, min(1.0, sp)))
    roll = math.atan2(C_nb[2, 1], C_nb[2, 2])
    yaw = math.atan2(C_nb[1, 0], C_nb[0, 0])
    return roll, pitch, yaw


def quat_to_dcm(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of the quaternion (x, y, z, w); normalises ``q`` first.

    For the orientation of b relative to n this is ``C_nb``. Raises ``ValueError`` for a
    zero or non-finite quaternion.
    """
    q = np.asarray(q, dtype=float)
    norm = math.sqrt(float(q @ q)) if q.shape == (4,) else 0.0
    if not math.isfinite(norm) or norm < 1e-12:
        raise ValueError(f"quat_to_dcm: expected a finite non-zero (4,) quaternion, got {q}")
    x, y, z, w = q / norm
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def dcm_to_quat(C: np.ndarray) -> np.ndarray:
    """Quaternion (x, y, z, w) with w ≥ 0 of a rotation matrix; shape (4,).

    Shepperd's method: it picks the largest of the four squared components so that no
    branch divides by a small number (the compiled :func:`.rotation_kernels.dcm_to_quat`).
    """
    from . import rotation_kernels as rk  # lazily: numba loads only where a kernel runs

    return rk.dcm_to_quat(check_dcm(C, "C"))


def euler321_to_quat(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Quaternion (x, y, z, w) of b relative to n from 3-2-1 Euler angles [rad]."""
    return dcm_to_quat(euler321_to_dcm(roll, pitch, yaw))


def quat_to_euler321(q: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] from a quaternion (x, y, z, w) of b relative to n."""
    return dcm_to_euler321(quat_to_dcm(q))


def small_angles_from_dcm(C: np.ndarray, max_angle_rad: float = 0.1) -> np.ndarray:
    """Small rotation vector ``e`` [rad] with ``C ≈ I + skew(e)``; shape (3,).

    This is the attitude-error extraction used by the filters: for an estimate
    ``C_hat = (I - skew(psi)) @ C_true``, ``small_angles_from_dcm(C_true @ C_hat.T)``
    returns ``psi`` to first order. Raises ``ValueError`` when ``C`` is not a rotation or
    is further than ``max_angle_rad`` from the identity, where the first-order form would
    silently mislead.
    """
    C = check_dcm(C, "C")
    e = 0.5 * np.array([C[2, 1] - C[1, 2], C[0, 2] - C[2, 0], C[1, 0] - C[0, 1]])
    angle = math.acos(max(-1.0, min(1.0, 0.5 * (np.trace(C) - 1.0))))
    if angle > max_angle_rad:
        raise ValueError(
            f"small_angles_from_dcm: rotation of {angle:.4g} rad exceeds the small-angle "
            f"limit {max_angle_rad:g} rad"
        )
    return e


def euler_rates_to_body_rates(roll: float, pitch: float, euler_rates: np.ndarray) -> np.ndarray:
    """Body angular rate (p, q, r) [rad/s] from (φ̇, θ̇, ψ̇) [rad/s]; shape (3,)."""
    dr, dp, dy = euler_rates
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    return np.array([dr - sp * dy, cr * dp + sr * cp * dy, -sr * dp + cr * cp * dy])


def body_rates_to_euler_rates(roll: float, pitch: float, omega_b: np.ndarray) -> np.ndarray:
    """(φ̇, θ̇, ψ̇) [rad/s] from body rate (p, q, r) [rad/s]; shape (3,).

    Raises ``ValueError`` at pitch ±90°, where Euler rates are undefined.
    """
    cp = math.cos(pitch)
    if abs(cp) < 1e-9:
        raise ValueError("body_rates_to_euler_rates: pitch is ±90° (gimbal lock)")
    p, q, r = omega_b
    cr, sr = math.cos(roll), math.sin(roll)
    tp = math.sin(pitch) / cp
    return np.array([p + (q * sr + r * cr) * tp, q * cr - r * sr, (q * sr + r * cr) / cp])


def dcm_from_rotation_vector(rotvec: np.ndarray) -> np.ndarray:
    """Rotation matrix ``exp(skew(v))`` of a rotation vector ``v`` [rad]; (3,) -> (3, 3).

    With ``C_ab = dcm_from_rotation_vector(v)``, frame b is frame a turned by |v| about v.
    Rodrigues' formula with series coefficients near zero, so tiny angles stay exact (the
    compiled :func:`.rotation_kernels.rotation_vector_to_dcm`).
    """
    from . import rotation_kernels as rk  # lazily: numba loads only where a kernel runs

    return rk.rotation_vector_to_dcm(float(rotvec[0]), float(rotvec[1]), float(rotvec[2]))


def rotation_vector_from_dcm(C: np.ndarray) -> np.ndarray:
    """Rotation vector ``v`` [rad], |v| ≤ π, with ``exp(skew(v)) = C``; (3, 3) -> (3,).

    Exact inverse of :func:`dcm_from_rotation_vector` (the matrix logarithm), computed
    through the quaternion so it stays accurate near 0 and near π.
    """
    q = dcm_to_quat(C)
    vec_norm = math.sqrt(float(q[0] ** 2 + q[1] ** 2 + q[2] ** 2))
    if vec_norm < 1e-300:
        return np.zeros(3)
    angle = 2.0 * math.atan2(vec_norm, q[3])
    return q[:3] * (angle / vec_norm)


# ----------------------------------------------------------------------------------------
# Scalar fast paths: the same rotations on tuples of floats, for code that runs every
# simulation step. A numpy call on a 3-vector costs about a microsecond of overhead, more
# than the arithmetic; these cost a fraction of that. Plain float arithmetic also gives the
# same bits on every machine, whereas a 3×3 ``@`` goes through the BLAS kernel chosen for
# the CPU (FMA or not). Quaternions are (x, y, z, w) tuples and compose like their
# matrices: ``quat_to_dcm(quat_mul(a, b)) == quat_to_dcm(a) @ quat_to_dcm(b)``.
# ----------------------------------------------------------------------------------------

Quat = tuple[float, float, float, float]


def quat_from_euler321(roll: float, pitch: float, yaw: float) -> Quat:
    """(x, y, z, w) of ``euler321_to_dcm(roll, pitch, yaw)`` from the half angles [rad];
    w may be negative (see :func:`quat_canonical`)."""
    hr, hp, hy = 0.5 * roll, 0.5 * pitch, 0.5 * yaw
    cr, sr = math.cos(hr), math.sin(hr)
    cp, sp = math.cos(hp), math.sin(hp)
    cy, sy = math.cos(hy), math.sin(hy)
    return (sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)


def quat_canonical(q: Quat) -> Quat:
    """The same rotation with w ≥ 0 (the sign :func:`dcm_to_quat` returns)."""
    return q if q[3] >= 0.0 else (-q[0], -q[1], -q[2], -q[3])


def quat_mul(a: Quat, b: Quat) -> Quat:
    """Hamilton product a ⊗ b of (x, y, z, w) quaternions: the rotation matrix of a then b."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def quat_conj(q: Quat) -> Quat:
    """Conjugate: the quaternion of the transposed matrix."""
    return (-q[0], -q[1], -q[2], q[3])


def quat_from_rotation_vector(x: float, y: float, z: float) -> Quat:
    """(x, y, z, w) of ``dcm_from_rotation_vector((x, y, z))`` [rad]; series for small angles."""
    a2 = x * x + y * y + z * z
    if a2 < 1e-6:
        s = 0.5 - a2 / 48.0 + a2 * a2 / 3840.0  # sin(a/2)/a
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
    else:
        a = math.sqrt(a2)
        s = math.sin(0.5 * a) / a
        c = math.cos(0.5 * a)
    return (s * x, s * y, s * z, c)


def rotation_vector_from_quat(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """Rotation vector [rad] (|v| ≤ π) of a unit quaternion (x, y, z, w)."""
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    k = 2.0 if s < 1e-12 else 2.0 * math.atan2(s, w) / s
    return (k * x, k * y, k * z)


def quat_rotate(q: Quat, v: tuple[float, float, float]) -> tuple[float, float, float]:
    """``quat_to_dcm(q) @ v`` for a unit quaternion q: v + 2w (u × v) + 2 u × (u × v)."""
    x, y, z, w = q
    v0, v1, v2 = v
    t0 = 2.0 * (y * v2 - z * v1)
    t1 = 2.0 * (z * v0 - x * v2)
    t2 = 2.0 * (x * v1 - y * v0)
    return (v0 + w * t0 + y * t2 - z * t1, v1 + w * t1 + z * t0 - x * t2, v2 + w * t2 + x * t1 - y * t0)


def euler321_from_quat(q: Quat) -> tuple[float, float, float]:
    """(roll, pitch, yaw) [rad] of a quaternion (x, y, z, w) of b relative to n, as
    :func:`quat_to_euler321` (normalises ``q``; same ranges and the same ``ValueError`` for a
    zero or non-finite quaternion and at pitch ±90°)."""
    x, y, z, w = q
    n2 = x * x + y * y + z * z + w * w
    if not (1e-24 <= n2 < math.inf):
        raise ValueError(f"euler321_from_quat: expected a finite non-zero (4,) quaternion, got {q}")
    s = 2.0 / n2
    sp = -s * (x * z - y * w)  # −C20
    if abs(sp) > 1.0 - 1e-12:
        raise ValueError("euler321_from_quat: pitch is ±90°, roll and yaw are not separable")
    return (math.atan2(s * (y * z + x * w), 1.0 - s * (x * x + y * y)),
            math.asin(sp),
            math.atan2(s * (x * y + z * w), 1.0 - s * (y * y + z * z)))
