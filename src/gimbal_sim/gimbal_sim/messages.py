"""Message conversion for gimbal_sim: the only module that builds or reads ROS messages.

Time on topics is simulation time. Step k of a run at ``rate_hz`` is stamped
``round(k·1e9 / rate_hz)`` ns, and a receiver maps a stamp back to k the same way, so
stamps never accumulate floating-point error.

REP 145: a field a sensor does not provide has covariance element 0 set to -1. The two-axis
gimbal gyro measures only q_m and r_m: its message sets ``angular_velocity.x = 0`` and
``angular_velocity_covariance[0] = -1`` while elements 4 and 8 carry the variances of y and z,
i.e. element 0 (the x-x variance) marks exactly the unmeasured roll axis.
"""
from __future__ import annotations

import math
from typing import Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix, NavSatStatus

#: Covariance marking a field as not provided (REP 145).
NOT_PROVIDED = (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
ZERO_COV = (0.0,) * 9

NAV_FRAME = "map_ned"


def step_stamp_ns(k: int, rate_hz: float) -> int:
    """Stamp [ns] of step ``k`` at ``rate_hz``."""
    return int(round(k * 1e9 / rate_hz))


def step_of_stamp(stamp_ns: int, rate_hz: float) -> int:
    """Step index of a stamp [ns] at ``rate_hz`` (inverse of :func:`step_stamp_ns`)."""
    return int(round(stamp_ns * rate_hz / 1e9))


def time_msg(stamp_ns: int) -> Time:
    return Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)


def stamp_ns(stamp: Time) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def clock_msg(t_ns: int) -> Clock:
    return Clock(clock=time_msg(t_ns))


def diag_cov(variances: Sequence[float]) -> tuple[float, ...]:
    """Row-major 3×3 covariance with ``variances`` on the diagonal."""
    a, b, c = variances
    return (a, 0.0, 0.0, 0.0, b, 0.0, 0.0, 0.0, c)


def imu_msg(t_ns: int, frame_id: str, *, orientation: Sequence[float] | None = None,
            orientation_cov: Sequence[float] = ZERO_COV, angular_velocity: Sequence[float] | None = None,
            angular_velocity_cov: Sequence[float] = ZERO_COV, linear_acceleration: Sequence[float] | None = None,
            linear_acceleration_cov: Sequence[float] = ZERO_COV) -> Imu:
    """An Imu message; a field given as ``None`` is marked not provided (REP 145)."""
    msg = Imu()
    msg.header.stamp = time_msg(t_ns)
    msg.header.frame_id = frame_id
    if orientation is None:
        msg.orientation_covariance = NOT_PROVIDED
    else:
        o = msg.orientation
        o.x, o.y, o.z, o.w = (float(v) for v in orientation)
        msg.orientation_covariance = tuple(float(v) for v in orientation_cov)
    if angular_velocity is None:
        msg.angular_velocity_covariance = NOT_PROVIDED
    else:
        w = msg.angular_velocity
        w.x, w.y, w.z = (float(v) for v in angular_velocity)
        msg.angular_velocity_covariance = tuple(float(v) for v in angular_velocity_cov)
    if linear_acceleration is None:
        msg.linear_acceleration_covariance = NOT_PROVIDED
    else:
        a = msg.linear_acceleration
        a.x, a.y, a.z = (float(v) for v in linear_acceleration)
        msg.linear_acceleration_covariance = tuple(float(v) for v in linear_acceleration_cov)
    return msg


def joint_state_msg(t_ns: int, names: Sequence[str], position: Sequence[float] = (),
                    velocity: Sequence[float] = (), effort: Sequence[float] = ()) -> JointState:
    msg = JointState()
    msg.header.stamp = time_msg(t_ns)
    msg.name = list(names)
    msg.position = [float(v) for v in position]
    msg.velocity = [float(v) for v in velocity]
    msg.effort = [float(v) for v in effort]
    return msg


def vector3_msg(t_ns: int, frame_id: str, vec: Sequence[float]) -> Vector3Stamped:
    msg = Vector3Stamped()
    msg.header.stamp = time_msg(t_ns)
    msg.header.frame_id = frame_id
    msg.vector.x, msg.vector.y, msg.vector.z = (float(v) for v in vec)
    return msg


def quat_of(msg: Imu) -> tuple[float, float, float, float]:
    o = msg.orientation
    return (o.x, o.y, o.z, o.w)


def vec_of(v) -> tuple[float, float, float]:
    """(x, y, z) of a geometry_msgs Vector3."""
    return (v.x, v.y, v.z)


GIMBAL_ENCODER_JOINTS = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")


def encoder_readings(msg: JointState) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """(angles, rates) in the order turret, gimbal azimuth, elevation; None when the
    message does not carry exactly those joints with positions and velocities."""
    names = list(msg.name)
    if sorted(names) != sorted(GIMBAL_ENCODER_JOINTS) or len(msg.position) != 3 or len(msg.velocity) != 3:
        return None
    idx = [names.index(j) for j in GIMBAL_ENCODER_JOINTS]
    return tuple(msg.position[i] for i in idx), tuple(msg.velocity[i] for i in idx)


def navsat_fix_msg(t_ns: int, frame_id: str, lat: float, lon: float, altitude_m: float,
                   covariance_enu_m2: Sequence[float] | None = None) -> NavSatFix:
    """A NavSatFix at geodetic ``lat``, ``lon`` [rad] (written in degrees, as the message
    wants) and ``altitude_m`` [m]. ``covariance_enu_m2``: 9 row-major ENU [m²]
    (``COVARIANCE_TYPE_KNOWN``); None: unknown. ``status.service`` is 0: not a GNSS."""
    msg = NavSatFix()
    msg.header.stamp = time_msg(t_ns)
    msg.header.frame_id = frame_id
    msg.status.status = NavSatStatus.STATUS_FIX
    msg.status.service = 0
    msg.latitude = math.degrees(lat)
    msg.longitude = math.degrees(lon)
    msg.altitude = float(altitude_m)
    if covariance_enu_m2 is None:
        msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_UNKNOWN
    else:
        msg.position_covariance = [float(v) for v in covariance_enu_m2]
        msg.position_covariance_type = NavSatFix.COVARIANCE_TYPE_KNOWN
    return msg
