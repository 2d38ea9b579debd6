"""Scalar rotation fast paths against scipy's Rotation and the numpy forms."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths.rotations import (
    euler321_from_quat, euler321_to_dcm, quat_canonical, quat_conj, quat_from_euler321, quat_from_rotation_vector,
    quat_mul, quat_rotate, quat_to_euler321, rotation_vector_from_quat,
)

RNG = np.random.default_rng(7)


def _euler_samples(n=200):
    return np.column_stack([RNG.uniform(-math.pi, math.pi, n), RNG.uniform(-1.5, 1.5, n),
                            RNG.uniform(-math.pi, math.pi, n)])


def test_quat_from_euler321_is_the_dcm_of_the_euler_angles():
    for roll, pitch, yaw in _euler_samples():
        q = quat_from_euler321(roll, pitch, yaw)
        np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), euler321_to_dcm(roll, pitch, yaw), atol=1e-15)
        assert quat_canonical(q)[3] >= 0.0
        np.testing.assert_allclose(Rotation.from_quat(quat_canonical(q)).as_matrix(),
                                   euler321_to_dcm(roll, pitch, yaw), atol=1e-15)


def test_euler321_from_quat_inverts_it_and_matches_the_numpy_form():
    for roll, pitch, yaw in _euler_samples():
        q = np.array(quat_from_euler321(roll, pitch, yaw)) * RNG.uniform(0.5, 2.0)  # not normalised
        np.testing.assert_allclose(euler321_from_quat(tuple(q)), (roll, pitch, yaw), atol=1e-12)
        np.testing.assert_allclose(euler321_from_quat(tuple(q)), quat_to_euler321(q), atol=1e-14)


@pytest.mark.parametrize("q", [(0.0, 0.0, 0.0, 0.0), (math.nan, 0.0, 0.0, 1.0), (0.0, math.inf, 0.0, 1.0),
                               (0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5))])
def test_euler321_from_quat_refuses_what_quat_to_euler321_refuses(q):
    with pytest.raises(ValueError):
        quat_to_euler321(np.array(q))
    with pytest.raises(ValueError):
        euler321_from_quat(q)


def test_quat_mul_composes_like_the_matrices():
    for _ in range(100):
        a, b = Rotation.random(random_state=RNG), Rotation.random(random_state=RNG)
        q = quat_mul(tuple(a.as_quat()), tuple(b.as_quat()))
        np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), a.as_matrix() @ b.as_matrix(), atol=1e-15)
        np.testing.assert_allclose(Rotation.from_quat(quat_conj(q)).as_matrix(),
                                   (a.as_matrix() @ b.as_matrix()).T, atol=1e-15)
        v = tuple(RNG.standard_normal(3))
        np.testing.assert_allclose(quat_rotate(tuple(a.as_quat()), v), a.as_matrix() @ v, atol=1e-14)


@pytest.mark.parametrize("scale", [1e-12, 1e-5, 1e-3, 0.5, 3.0])
def test_rotation_vector_round_trip(scale):
    for _ in range(50):
        v = RNG.standard_normal(3)
        v = v / np.linalg.norm(v) * scale
        q = quat_from_rotation_vector(*v)
        np.testing.assert_allclose(q, Rotation.from_rotvec(v).as_quat(canonical=True), rtol=1e-14, atol=1e-17)
        np.testing.assert_allclose(rotation_vector_from_quat(*q), v, rtol=1e-12, atol=1e-20)
