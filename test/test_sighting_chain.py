"""Paper 1 sighting chain against numerical derivatives of the DCM chain and scipy."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths import sighting_chain as sc
from gimbal_kinematics.maths.rotations import euler321_to_dcm, euler_rates_to_body_rates, unskew

RNG_SEED = 411


class RandomMotion:
    """Euler angles and joint angles as quadratics in time: exact rates and accelerations."""

    def __init__(self, rng):
        self.e0 = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), rng.uniform(-3, 3)])
        self.e1 = rng.normal(scale=0.5, size=3)
        self.e2 = rng.normal(scale=0.5, size=3)
        self.j0 = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-1.2, 1.2)])
        self.j1 = rng.normal(scale=1.0, size=3)
        self.j2 = rng.normal(scale=2.0, size=3)

    def euler(self, t):
        return self.e0 + self.e1 * t + 0.5 * self.e2 * t * t

    def joints(self, t):
        return self.j0 + self.j1 * t + 0.5 * self.j2 * t * t

    def joint_rates(self, t):
        return self.j1 + self.j2 * t

    def omega_b(self, t):
        e = self.euler(t)
        return euler_rates_to_body_rates(e[0], e[1], self.e1 + self.e2 * t)

    def alpha_b(self, t, h=1e-5):
        return (self.omega_b(t + h) - self.omega_b(t - h)) / (2 * h)

    def dcms(self, t):
        psi_t, psi_m, theta_m = self.joints(t)
        C_nb = euler321_to_dcm(*self.euler(t))
        C_nt = C_nb @ sc.dcm_bt(psi_t)
        C_na = C_nt @ sc.dcm_ta(psi_m)
        return C_nt, C_na, C_na @ sc.dcm_am(theta_m)

    def rates(self, t):
        return sc.chain_rates(self.omega_b(t), self.alpha_b(t), self.joints(t), self.joint_rates(t), self.j2)


def _omega_from_dcm(C_of_t, h=1e-6):
    # omega_x = C^T dC/dt for C mapping the moving frame to the (inertial) n frame
    return unskew(C_of_t(0.0).T @ (C_of_t(h) - C_of_t(-h)) / (2 * h), tol=1e-6)


def test_chain_dcms_match_scipy():
    rng = np.random.default_rng(RNG_SEED)
    for _ in range(50):
        roll, pitch, yaw = rng.uniform(-1, 1, 3)
        psi_t, psi_m, theta_m = rng.uniform(-3, 3, 3)
        # intrinsic rotations compose left to right: n -> b -> t -> a -> m
        joint_chain = Rotation.from_euler("z", psi_t) * Rotation.from_euler("z", psi_m) * Rotation.from_euler("y", theta_m)
        ref = Rotation.from_euler("ZYX", [yaw, pitch, roll]) * joint_chain
        np.testing.assert_allclose(sc.dcm_nm((roll, pitch, yaw), psi_t, psi_m, theta_m), ref.as_matrix(), atol=1e-13)
        np.testing.assert_allclose(
            sc.dcm_bm(psi_t, psi_m, theta_m), joint_chain.as_matrix(), atol=1e-13
        )


def test_every_angular_velocity_matches_dcm_derivative():
    rng = np.random.default_rng(RNG_SEED + 1)
    for _ in range(100):
        motion = RandomMotion(rng)
        rates = motion.rates(0.0)
        for k, omega in enumerate((rates.omega_t_t, rates.omega_a_a, rates.omega_m_m)):
            expected = _omega_from_dcm(lambda t, k=k: motion.dcms(t)[k])
            np.testing.assert_allclose(omega, expected, atol=1e-7, rtol=0)
        np.testing.assert_allclose(
            sc.omega_m_m(motion.omega_b(0.0), motion.joints(0.0), motion.joint_rates(0.0)),
            rates.omega_m_m, atol=1e-15,
        )


def test_every_angular_acceleration_matches_rate_derivative():
    # omega is validated against the DCM above; alpha must be its time derivative.
    rng = np.random.default_rng(RNG_SEED + 2)
    h = 1e-4
    for _ in range(50):
        motion = RandomMotion(rng)
        now, ahead, behind = motion.rates(0.0), motion.rates(h), motion.rates(-h)
        for w, a in (("omega_t_t", "alpha_t_t"), ("omega_a_a", "alpha_a_a"), ("omega_m_m", "alpha_m_m")):
            numeric = (getattr(ahead, w) - getattr(behind, w)) / (2 * h)
            np.testing.assert_allclose(getattr(now, a), numeric, atol=1e-6, rtol=0)


def test_roll_rate_reconstruction_round_trips():
    rng = np.random.default_rng(RNG_SEED + 3)
    for _ in range(500):
        omega_b = rng.normal(scale=0.5, size=3)
        joints = np.array([rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)])
        joint_rates = rng.normal(scale=1.0, size=3)
        p_m, q_m, r_m = sc.omega_m_m(omega_b, joints, joint_rates)
        p_rec, psi_m_dot = sc.reconstruct_roll_rate(omega_b, r_m, joints[0], joint_rates[0], joints[1], joints[2])
        assert abs(p_rec - p_m) < 1e-9
        assert abs(psi_m_dot - joint_rates[1]) < 1e-9


def test_task_to_joint_rates_realises_commanded_los_rate():
    rng = np.random.default_rng(RNG_SEED + 4)
    for _ in range(200):
        omega_b = rng.normal(scale=0.5, size=3)
        psi_t, psi_m, theta_m = rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-1.4, 1.4)
        psi_t_dot = rng.normal()
        q_md, r_md = rng.normal(scale=0.1, size=2)
        psi_m_dot, theta_m_dot = sc.task_to_joint_rates(q_md, r_md, omega_b, psi_t, psi_t_dot, psi_m, theta_m)
        _, q_m, r_m = sc.omega_m_m(omega_b, (psi_t, psi_m, theta_m), (psi_t_dot, psi_m_dot, theta_m_dot))
        assert abs(q_m - q_md) < 1e-12 and abs(r_m - r_md) < 1e-12


def test_los_azimuth_elevation_closed_form():
    az, el = sc.los_azimuth_elevation(sc.dcm_nm((0, 0, 0), 0.0, math.radians(30), math.radians(10)))
    assert math.isclose(az, math.radians(30), abs_tol=1e-15)
    assert math.isclose(el, math.radians(10), abs_tol=1e-15)  # NED z is down: +θm looks up
    rng = np.random.default_rng(RNG_SEED + 5)
    for _ in range(50):
        euler, joints = rng.uniform(-1, 1, 3), rng.uniform(-1.2, 1.2, 3)
        C_nm = sc.dcm_nm(euler, *joints)
        los = Rotation.from_matrix(C_nm).apply([1.0, 0.0, 0.0])
        np.testing.assert_allclose(sc.los_unit_vector_n(C_nm), los, atol=1e-14)
        az, el = sc.los_azimuth_elevation(C_nm)
        np.testing.assert_allclose([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), -math.sin(el)], los, atol=1e-14)


def test_elevation_at_ninety_degrees_is_refused():
    with pytest.raises(ValueError, match="±90°"):
        sc.reconstruct_roll_rate(np.zeros(3), 0.0, 0.0, 0.0, 0.0, math.pi / 2)
    with pytest.raises(ValueError, match="±90°"):
        sc.task_to_joint_rates(0.0, 0.0, np.zeros(3), 0.0, 0.0, 0.0, -math.pi / 2)
