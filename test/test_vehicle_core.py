"""VehicleCore truth against independent constructions (scipy Rotation, numerical
derivatives, closed forms)."""
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from gimbal_kinematics.maths.earth import earth_rate_n, normal_gravity
from gimbal_kinematics.maths.rotations import unskew
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore


def _R_nb(euler):
    return Rotation.from_euler("ZYX", [euler[2], euler[1], euler[0]])


def test_delta_angle_is_the_exact_inertial_body_rotation():
    cfg = VehicleConfig(profile="paper1_land_vehicle", profile_params={"lat_deg": 39.9},
                        plant="host_only", sim_rate_hz=2000.0, duration_s=1.0)
    core = VehicleCore(cfg)
    w_n = earth_rate_n(math.radians(39.9))
    previous = core.truth()
    for _ in range(50):
        core.step(())
        truth = core.truth()
        expected = (_R_nb(previous.euler).inv() * Rotation.from_rotvec(w_n * cfg.dt) * _R_nb(truth.euler)).as_rotvec()
        np.testing.assert_allclose(truth.delta_angle_b, expected, atol=1e-15)
        # and it is the integral of the inertial body rate up to the trapezoid error
        # dt^3 |w''| / 12; the structural modes dominate |w''| = sum A w^3 over the modes:
        # 0.01 deg at 101 rad/s and 1e-4 deg at 258 rad/s give 180 + 30 rad/s^3.
        w_ddot_bound = math.radians(0.01) * 101**3 + math.radians(1e-4) * 258**3 + 10.0
        trapezoid = 0.5 * (np.array(previous.omega_ib_b) + np.array(truth.omega_ib_b)) * cfg.dt
        assert np.max(np.abs(truth.delta_angle_b - trapezoid)) < 1.2 * cfg.dt**3 * w_ddot_bound / 12
        previous = truth


def test_gimbal_rate_is_the_derivative_of_the_published_attitude():
    cfg = VehicleConfig(sim_rate_hz=2000.0, duration_s=1.0, profile_params={"lat_deg": 45.0})
    core = VehicleCore(cfg)
    w_n = earth_rate_n(math.radians(45.0))
    truths = []
    for _ in range(400):
        truths.append(core.truth())
        core.step((0.05, -0.02))
    for k in range(100, 398, 37):
        C = lambda j: Rotation.from_quat(truths[j].quat_nm).as_matrix()  # noqa: E731
        omega_nm_m = unskew(C(k).T @ (C(k + 1) - C(k - 1)) / (2 * cfg.dt), tol=1e-3)
        omega_im_m = omega_nm_m + C(k).T @ w_n
        np.testing.assert_allclose(truths[k].omega_im_m, omega_im_m, atol=2e-5)
        # joints: positions and velocities agree with the DCM chain's encoder angles
        assert truths[k].joint_names == ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")


def test_specific_force_of_a_static_tilted_host_is_minus_gravity_in_body():
    cfg = VehicleConfig(profile="static", profile_params={"lat_deg": 30.0, "roll_deg": 3.0,
                                                          "pitch_deg": -2.0, "yaw_deg": 40.0},
                        plant="host_only", duration_s=1.0)
    truth = VehicleCore(cfg).truth()
    g = normal_gravity(math.radians(30.0))
    np.testing.assert_allclose(truth.specific_force_b, _R_nb(truth.euler).inv().apply([0, 0, -g]), atol=1e-12)


def _C_bs(joints):
    """Platform to base through the gimbal chain b → r (x) → p (y) → q (x) → s (z)."""
    a, q, p, r = joints
    return (Rotation.from_rotvec([r, 0, 0]) * Rotation.from_rotvec([0, p, 0]) * Rotation.from_rotvec([q, 0, 0])
            * Rotation.from_rotvec([0, 0, a]))


def test_platform_attitude_follows_its_gimbals():
    cfg = VehicleConfig(profile="static", profile_params={"lat_deg": 30.0, "yaw_deg": 25.0},
                        plant="four_gimbal_platform", initial_joints_deg=(10.0, 0.01, -0.02, 0.5), duration_s=1.0)
    core = VehicleCore(cfg)
    for _ in range(500):
        core.step((2.0, 0.0, 0.0, 0.0))
    truth = core.truth()
    assert truth.joint_position[0] > math.radians(10.0) and truth.joint_velocity[0] > 0.0  # the azimuth motor turned it
    C_ns = _R_nb(truth.euler) * _C_bs(truth.joint_position)
    g = normal_gravity(math.radians(30.0))
    np.testing.assert_allclose(truth.specific_force_m, C_ns.inv().apply([0, 0, -g]), atol=1e-12)
    np.testing.assert_allclose(Rotation.from_quat(truth.quat_nm).as_matrix(), C_ns.as_matrix(), atol=1e-12)
    # its torque is the motor's k_t times its current
    assert truth.joint_effort[0] == pytest.approx(0.21 * core._platform_x[0][2])


def test_platform_rate_is_the_derivative_of_its_attitude():
    """The platform gyros' truth is the inertial rate of the attitude the plant reports: a
    turning, tilted platform (azimuth 0.1 rad/s, pitch and outer roll moving) against the
    numerical derivative of C_is = C_in C_ns; and a tilt stays put in n while it turns."""
    lat = math.radians(30.0)
    cfg = VehicleConfig(profile="static", profile_params={"lat_deg": 30.0}, plant="four_gimbal_platform",
                        initial_joints_deg=(0.0, 0.0, 0.3, -0.2), duration_s=10.0)
    core = VehicleCore(cfg)
    w_n = earth_rate_n(lat)
    quats, rates = [], []
    for _ in range(3000):
        core.step((3.0, 0.0, 0.2, -0.3))
        truth = core.truth()
        # inertial attitude: NED turns at w_n relative to inertial space
        C_is = Rotation.from_rotvec(w_n * truth.t) * Rotation.from_quat(truth.quat_nm)
        quats.append(C_is)
        rates.append(truth.omega_im_m)
    dt = cfg.dt
    for k in range(1000, 2990, 97):
        rel = (quats[k - 1].inv() * quats[k + 1]).as_rotvec() / (2 * dt)
        np.testing.assert_allclose(rel, rates[k], atol=2e-6 * max(1.0, np.linalg.norm(rates[k])))
    assert abs(truth.joint_velocity[0]) > 0.05


def test_a_tilted_platform_turns_about_its_own_axis():
    """Only the azimuth motor drives: the platform's z axis (the azimuth gimbal axis) stays
    where the pitch and outer-roll gimbals tilted it, in n, while it turns through 90°."""
    cfg = VehicleConfig(profile="static", profile_params={"lat_deg": 30.0, "yaw_deg": 40.0},
                        plant="four_gimbal_platform", initial_joints_deg=(0.0, 0.0, 0.3, -0.2), duration_s=20.0)
    core = VehicleCore(cfg)
    axis0 = Rotation.from_quat(core.truth().quat_nm).apply([0.0, 0.0, 1.0])
    while core.truth().joint_position[0] < math.pi / 2:
        core.step((20.0, 0.0, 0.0, 0.0))
    truth = core.truth()
    np.testing.assert_allclose(Rotation.from_quat(truth.quat_nm).apply([0.0, 0.0, 1.0]), axis0, atol=1e-12)
    assert truth.joint_position[1:] == pytest.approx((0.0, math.radians(0.3), math.radians(-0.2)), abs=1e-15)


@pytest.mark.parametrize("kwargs,named", [
    ({"profile": "boat"}, "profile"), ({"plant": "tank"}, "plant"), ({"sim_rate_hz": 0.0}, "sim_rate_hz"),
    ({"duration_s": -1.0}, "duration_s"), ({"initial_joints_deg": (1.0,)}, "initial_joints_deg"),
])
def test_bad_config_names_the_field(kwargs, named):
    with pytest.raises(ValueError, match=named):
        VehicleConfig(**kwargs)
