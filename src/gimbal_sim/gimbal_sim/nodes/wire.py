"""The serialisation of gimbal_sim's own nodes: pure functions from a core's output to the
messages' bytes (CDR), rclpy-free.

Each returns ``[(topic, type name, bytes), ...]`` in the order the node publishes them, with
the topic as the node declares its publisher (``~/x`` is relative to the node's name). The
node publishes the bytes (``publisher.publish(data)``); the no-ROS engine writes the same
bytes into its bag (:mod:`gimbal_sim.core.recording`). So the two can only differ where
their cores' numbers differ.
"""
from __future__ import annotations

import math

from gimbal_kinematics.maths.frames import BASE_FRAME, GIMBAL_FRAME, LGU1_FRAME, LGU2_FRAME, NAV_FRAME, PLATFORM_FRAME
from gimbal_kinematics.maths.rotations import euler321_to_quat, quat_canonical, quat_from_euler321
from gimbal_kinematics.ros.wire import (
    CLOCK, IMU, JOINT_STATE, NAVSAT_FIX, VECTOR3_STAMPED, ZERO_COV, clock_cdr, diag_cov, gimbal_gyro_covariance,
    imu_cdr, joint_state_cdr, navsat_fix_cdr, vector3_cdr,
)
from gimbal_kinematics.maths.units import DEG, UG

from ..world.sensor_suite import (
    DtgSample, EncoderSample, GimbalGyroSample, InsSample, LguSample, PlatformImuSample, ResolverSample,
    SensorSuiteConfig,
)
from ..world.sensors.free_gyro_sensor import FreeGyroSample
from ..world.vehicle import VehicleTruth

Messages = list[tuple[str, str, bytes]]

#: the plant -> its truth topics' prefix and frame
_PLANT = {"two_axis_gimbal": ("/truth/gimbal", GIMBAL_FRAME), "four_gimbal_platform": ("/truth/platform",
                                                                                         PLATFORM_FRAME)}


def truth_messages(t_ns: int, truth: VehicleTruth, plant: str, site=None) -> Messages:
    """``vehicle_dynamics``: the truth of one step; ``site`` (the profile's site: lat_rad,
    lon_deg, height_m) when the host's true position is due (then also its velocity)."""
    out = [("/truth/host/imu", IMU, imu_cdr(t_ns, BASE_FRAME, orientation=truth.quat_nb,
                                             angular_velocity=truth.omega_ib_b,
                                             linear_acceleration=truth.specific_force_b)),
           ("/truth/host/delta_angle", VECTOR3_STAMPED, vector3_cdr(t_ns, BASE_FRAME, truth.delta_angle_b))]
    if plant in _PLANT:
        prefix, frame = _PLANT[plant]
        out += [(f"{prefix}/joint_states", JOINT_STATE,
                 joint_state_cdr(t_ns, truth.joint_names, truth.joint_position, truth.joint_velocity,
                                 truth.joint_effort)),
                (f"{prefix}/imu", IMU, imu_cdr(t_ns, frame, orientation=truth.quat_nm, angular_velocity=truth.omega_im_m,
                                               linear_acceleration=truth.specific_force_m))]
    if site is not None:
        out += [("/truth/host/fix", NAVSAT_FIX, navsat_fix_cdr(t_ns, NAV_FRAME, site.lat_rad, math.radians(site.lon_deg),
                                                               site.height_m)),
                ("/truth/host/velocity", VECTOR3_STAMPED, vector3_cdr(t_ns, NAV_FRAME, (0.0, 0.0, 0.0)))]
    out.append(("/clock", CLOCK, clock_cdr(t_ns)))
    return out


def noise_covariances(c: SensorSuiteConfig) -> dict[str, tuple[float, ...]]:
    """Per-sample variances of the white noise each measurement carries (for the covariance
    fields; biases are not white and are not in them)."""
    arw = lambda deg_rt_h, rate_hz: (deg_rt_h * DEG / 60.0) ** 2 * rate_hz  # noqa: E731
    return {
        "ins_att": diag_cov([(c.ins.roll_pitch_rms_deg * DEG) ** 2] * 2 + [(c.ins.heading_rms_deg * DEG) ** 2]),
        "ins_rate": diag_cov([arw(c.ins.gyro.arw_deg_rt_h, c.ins_rate_hz)] * 3),
        # the roll axis x has no gyro: REP 145's large-variance marking of one axis
        "gyro": gimbal_gyro_covariance(*[arw(c.gimbal_gyro.arw_deg_rt_h, c.gimbal_gyro_rate_hz)] * 2),
        "lgu": diag_cov([arw(c.lgu1.arw_deg_rt_h, c.lgu_rate_hz)] * 3),
        "p_gyro": diag_cov([arw(c.platform_gyro.arw_deg_rt_h, c.platform_imu_rate_hz)] * 3),
        "p_accel": diag_cov([(c.platform_accel.noise_ug_rt_hz * UG) ** 2 * c.platform_imu_rate_hz] * 3),
        "fg_rate": diag_cov([arw(c.free_gyro.triad.arw_deg_rt_h, c.free_gyro_rate_hz)] * 3),
        # roll, pitch from the vertical reference; the heading is not measured: its variance
        # is that of a heading uniform on (−π, π], π²/3
        "fg_level": diag_cov([(c.free_gyro.level_noise_arcsec * DEG / 3600.0) ** 2] * 2 + [math.pi**2 / 3.0]),
    }


def sensor_messages(t_ns: int, s, cov: dict[str, tuple[float, ...]], free_gyro_velocity: bool = False) -> Messages:
    """``sensor_models``: one sample of the suite (``cov``: :func:`noise_covariances`;
    ``free_gyro_velocity``: the node's ``free_gyro_publish_velocity``)."""
    kind = type(s)
    if kind is GimbalGyroSample:
        return [("/gimbal/imu", IMU, imu_cdr(t_ns, GIMBAL_FRAME, angular_velocity=(0.0, s.q_m, s.r_m),
                                             angular_velocity_cov=cov["gyro"])),
                ("/truth/gimbal/gyro_bias", VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, (0.0, *s.true_bias)))]
    if kind is EncoderSample:
        return [("/gimbal/joint_states", JOINT_STATE, joint_state_cdr(t_ns, s.names, s.angles, s.rates))]
    if kind is InsSample:
        return [("/ins/imu", IMU, imu_cdr(t_ns, BASE_FRAME, orientation=quat_canonical(quat_from_euler321(*s.euler)),
                                          orientation_cov=cov["ins_att"], angular_velocity=s.omega_b,
                                          angular_velocity_cov=cov["ins_rate"])),
                ("/truth/ins/gyro_bias", VECTOR3_STAMPED, vector3_cdr(t_ns, BASE_FRAME, s.true_gyro_bias))]
    if kind is LguSample:
        # angular_velocity carries the increment over the sample interval divided by it
        return [("/ship/lgu1/imu", IMU, imu_cdr(t_ns, LGU1_FRAME, angular_velocity=[d / s.dt for d in s.dalpha1],
                                                angular_velocity_cov=cov["lgu"])),
                ("/ship/lgu2/imu", IMU, imu_cdr(t_ns, LGU2_FRAME, angular_velocity=[d / s.dt for d in s.dalpha2],
                                                angular_velocity_cov=cov["lgu"])),
                ("/truth/ship/flexure", VECTOR3_STAMPED, vector3_cdr(t_ns, LGU1_FRAME, s.flexure)),
                ("/truth/ship/flexure_quasi_static", VECTOR3_STAMPED,
                 vector3_cdr(t_ns, LGU1_FRAME, s.flexure_quasi_static))]
    if kind is ResolverSample:
        return [("/platform/resolvers", JOINT_STATE, joint_state_cdr(t_ns, s.names, s.angles, s.rates))]
    if kind is PlatformImuSample:
        return [("/platform/imu", IMU, imu_cdr(t_ns, PLATFORM_FRAME, angular_velocity=s.omega,
                                               angular_velocity_cov=cov["p_gyro"],
                                               linear_acceleration=s.specific_force,
                                               linear_acceleration_cov=cov["p_accel"])),
                ("/truth/platform/accel_bias", VECTOR3_STAMPED, vector3_cdr(t_ns, PLATFORM_FRAME, s.true_accel_bias)),
                ("/truth/platform/gyro_bias", VECTOR3_STAMPED, vector3_cdr(t_ns, PLATFORM_FRAME, s.true_gyro_bias))]
    if kind is DtgSample:
        return [("/platform/dtg_pickoffs", JOINT_STATE, joint_state_cdr(t_ns, s.names, s.angles))]
    if kind is FreeGyroSample:
        return _free_gyro_messages(t_ns, s, cov, free_gyro_velocity)
    raise TypeError(f"no serialisation for a {kind.__name__}")


def _free_gyro_messages(t_ns: int, s: FreeGyroSample, cov: dict, velocity: bool) -> Messages:
    out = [("/free_gyro/spin_axis_a", VECTOR3_STAMPED, vector3_cdr(t_ns, BASE_FRAME, s.spin_a_b)),
           ("/free_gyro/spin_axis_b", VECTOR3_STAMPED, vector3_cdr(t_ns, BASE_FRAME, s.spin_b_b)),
           # orientation = the vertical reference: roll and pitch, heading 0 (not measured)
           ("/free_gyro/imu", IMU, imu_cdr(t_ns, BASE_FRAME, orientation=euler321_to_quat(s.roll, s.pitch, 0.0),
                                           orientation_cov=cov["fg_level"], angular_velocity=s.omega_ib_b,
                                           angular_velocity_cov=cov["fg_rate"])),
           ("/truth/free_gyro/position", NAVSAT_FIX, navsat_fix_cdr(t_ns, BASE_FRAME, s.true_lat, s.true_lon, 0.0,
                                                                    ZERO_COV)),
           ("/truth/free_gyro/triad_bias", VECTOR3_STAMPED, vector3_cdr(t_ns, BASE_FRAME, s.true_triad_bias))]
    if velocity:
        out.append(("/free_gyro/velocity", VECTOR3_STAMPED, vector3_cdr(t_ns, BASE_FRAME, s.velocity_n)))
    return out


def operator_messages(t_ns: int, q: float, r: float, error: tuple[float, float, float]) -> Messages:
    """``operator``: its LOS rate command (0, q, r) [rad/s] and its true pointing error
    (ε, e_q, e_r) [rad] (NaN before it has a target)."""
    return [("/operator/los_rate", VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, (0.0, q, r))),
            ("~/pointing_error", VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, error))]
