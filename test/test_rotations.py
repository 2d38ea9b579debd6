"""Rotations against scipy.spatial.transform.Rotation and closed forms."""
import math

import numpy as np
import pytest
from scipy.linalg import polar
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths import rotations as rt

RNG_SEED = 20261121


def _random_euler(rng, n):
    return np.column_stack(
        [rng.uniform(-math.pi, math.pi, n), rng.uniform(-1.5, 1.5, n), rng.uniform(-math.pi, math.pi, n)]
    )


def test_elementary_rotations_are_frame_rotations():
    for angle in np.linspace(-3.0, 3.0, 13):
        for fn, axis in ((rt.rot1, "x"), (rt.rot2, "y"), (rt.rot3, "z")):
            # scipy rotates vectors (active); a frame rotation is its transpose.
            np.testing.assert_allclose(fn(angle), Rotation.from_euler(axis, angle).as_matrix().T, atol=1e-15)


def test_euler321_dcm_quat_match_scipy():
    rng = np.random.default_rng(RNG_SEED)
    for roll, pitch, yaw in _random_euler(rng, 200):
        ref = Rotation.from_euler("ZYX", [yaw, pitch, roll])
        C_nb = rt.euler321_to_dcm(roll, pitch, yaw)
        np.testing.assert_allclose(C_nb, ref.as_matrix(), atol=1e-13)
        q = rt.dcm_to_quat(C_nb)
        q_ref = ref.as_quat()
        assert min(np.max(np.abs(q - q_ref)), np.max(np.abs(q + q_ref))) < 1e-12
        assert q[3] >= 0.0
        np.testing.assert_allclose(rt.euler321_to_quat(roll, pitch, yaw), q, atol=1e-15)
        np.testing.assert_allclose(rt.quat_to_dcm(q_ref), ref.as_matrix(), atol=1e-13)
        np.testing.assert_allclose(rt.dcm_to_euler321(C_nb), (roll, pitch, yaw), atol=1e-10)
        np.testing.assert_allclose(rt.quat_to_euler321(q_ref), (roll, pitch, yaw), atol=1e-10)


def test_dcm_to_quat_every_branch():
    # Rotations by ~π about each axis force Shepperd's x, y and z branches.
    for rotvec in ([3.1, 0.1, 0.0], [0.0, 3.1, 0.1], [0.1, 0.0, 3.1], [0.2, -0.1, 0.3]):
        ref = Rotation.from_rotvec(rotvec)
        q = rt.dcm_to_quat(ref.as_matrix())
        q_ref = ref.as_quat()
        assert min(np.max(np.abs(q - q_ref)), np.max(np.abs(q + q_ref))) < 1e-12


def test_skew_unskew():
    rng = np.random.default_rng(RNG_SEED + 1)
    a, b = rng.normal(size=3), rng.normal(size=3)
    np.testing.assert_allclose(rt.skew(a) @ b, np.cross(a, b), atol=1e-15)
    np.testing.assert_array_equal(rt.unskew(rt.skew(a)), a)
    with pytest.raises(ValueError, match="skew-symmetric"):
        rt.unskew(np.eye(3))


def test_small_angles_from_dcm_first_order():
    rng = np.random.default_rng(RNG_SEED + 2)
    for _ in range(50):
        v = rng.normal(scale=1e-3, size=3)
        e = rt.small_angles_from_dcm(Rotation.from_rotvec(v).as_matrix())
        # exact: e = sin|v| v/|v|, so the error is third order
        assert np.max(np.abs(e - v)) < np.linalg.norm(v) ** 3
    with pytest.raises(ValueError, match="small-angle"):
        rt.small_angles_from_dcm(Rotation.from_rotvec([0.5, 0.0, 0.0]).as_matrix())


def test_attitude_error_convention():
    # C_hat = (I - skew(psi)) C  =>  small_angles(C C_hat^T) = psi to first order
    rng = np.random.default_rng(RNG_SEED + 3)
    C = Rotation.random(random_state=rng).as_matrix()
    psi = rng.normal(scale=1e-4, size=3)
    C_hat = Rotation.from_rotvec(-psi).as_matrix() @ C
    np.testing.assert_allclose(rt.small_angles_from_dcm(C @ C_hat.T), psi, atol=1e-11)


def test_orthonormalize_is_polar_factor():
    rng = np.random.default_rng(RNG_SEED + 4)
    C = Rotation.random(random_state=rng).as_matrix() + rng.normal(scale=1e-3, size=(3, 3))
    u, _ = polar(C)
    np.testing.assert_allclose(rt.orthonormalize(C), u, atol=1e-13)
    rt.check_dcm(rt.orthonormalize(C), tol=1e-12)


def test_degenerate_inputs_name_the_cause():
    with pytest.raises(ValueError, match="not orthonormal"):
        rt.check_dcm(np.eye(3) * 1.01, "C_nb")
    with pytest.raises(ValueError, match="reflection"):
        rt.check_dcm(np.diag([1.0, 1.0, -1.0]))
    with pytest.raises(ValueError, match="shape"):
        rt.check_dcm(np.eye(2))
    with pytest.raises(ValueError, match="NaN"):
        rt.check_dcm(np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="not orthonormal"):
        rt.dcm_to_euler321(np.ones((3, 3)))
    with pytest.raises(ValueError, match="gimbal lock|±90"):
        rt.dcm_to_euler321(rt.euler321_to_dcm(0.1, math.pi / 2, 0.2))
    with pytest.raises(ValueError, match="gimbal lock"):
        rt.body_rates_to_euler_rates(0.0, math.pi / 2, np.ones(3))
    with pytest.raises(ValueError, match="singular"):
        rt.orthonormalize(np.zeros((3, 3)))
    with pytest.raises(ValueError, match="quaternion"):
        rt.quat_to_dcm(np.zeros(4))


def test_euler_rates_body_rates_against_dcm_derivative():
    rng = np.random.default_rng(RNG_SEED + 5)
    h = 1e-6
    for e0, de in zip(_random_euler(rng, 30), rng.normal(size=(30, 3))):
        C = lambda t: rt.euler321_to_dcm(*(e0 + de * t))  # noqa: E731
        omega_num = rt.unskew(C(0).T @ (C(h) - C(-h)) / (2 * h), tol=1e-6)
        omega = rt.euler_rates_to_body_rates(e0[0], e0[1], de)
        np.testing.assert_allclose(omega, omega_num, atol=1e-8)
        np.testing.assert_allclose(rt.body_rates_to_euler_rates(e0[0], e0[1], omega), de, atol=1e-10)


def test_rotation_vector_maps_match_scipy():
    rng = np.random.default_rng(RNG_SEED + 6)
    for scale in (1e-9, 1e-5, 1e-2, 1.0, 3.0):
        for _ in range(30):
            v = rng.normal(size=3)
            v *= scale / np.linalg.norm(v) if scale < 3.0 else rng.uniform(0.0, math.pi) / np.linalg.norm(v)
            ref = Rotation.from_rotvec(v)
            C = rt.dcm_from_rotation_vector(v)
            # scipy's from_rotvec is an active rotation by v: the matrix exp(skew(v))
            np.testing.assert_allclose(C, ref.as_matrix(), atol=1e-15)
            np.testing.assert_allclose(rt.rotation_vector_from_dcm(C), v, atol=1e-12 * max(1.0, scale))
