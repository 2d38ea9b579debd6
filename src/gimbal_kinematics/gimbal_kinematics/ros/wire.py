"""Serialized (CDR) forms of the messages the graph exchanges, without rclpy: what a node
publishes (``publisher.publish(data)``) and what the no-ROS engine writes into its bag are
the same bytes from the same functions. :mod:`.messages` re-exports them beside the message
objects; :mod:`.cdr` holds the layouts.

REP 145 (:mod:`.messages` says more): a field a sensor does not provide has covariance
element 0 set to -1 (:data:`NOT_PROVIDED`); one unmeasured axis of a provided field gets a
very large variance (:data:`UNMEASURED_VARIANCE`).
"""
from __future__ import annotations

import math
from typing import Sequence

from . import cdr

#: Type names as bags and ``ros2 topic`` spell them.
IMU = "sensor_msgs/msg/Imu"
JOINT_STATE = "sensor_msgs/msg/JointState"
VECTOR3_STAMPED = "geometry_msgs/msg/Vector3Stamped"
NAVSAT_FIX = "sensor_msgs/msg/NavSatFix"
CLOCK = "rosgraph_msgs/msg/Clock"
ODOMETRY = "nav_msgs/msg/Odometry"

#: Covariance marking a field as not provided (REP 145).
NOT_PROVIDED = (-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
ZERO_COV = (0.0,) * 9
#: Variance [rad²/s²] marking one unmeasured axis of a provided rate field (σ = 1000 rad/s,
#: ~160 turns/s: no gimbal turns that fast, so a consumer gives that axis no weight). Not
#: larger: a consumer that inverts the covariance then divides it by measured variances of
#: ~1e-7 rad²/s², and 1e6 / 1e-7 = 1e13 stays well inside double precision (1/eps = 4.5e15),
#: where 1e9 (also seen in drivers) would leave barely two digits.
UNMEASURED_VARIANCE = 1e6


def diag_cov(variances: Sequence[float]) -> tuple[float, ...]:
    """Row-major 3×3 covariance with ``variances`` on the diagonal."""
    a, b, c = variances
    return (a, 0.0, 0.0, 0.0, b, 0.0, 0.0, 0.0, c)


def gimbal_gyro_covariance(var_q: float, var_r: float) -> tuple[float, ...]:
    """Angular-velocity covariance of the two-axis gimbal gyro: the unmeasured roll axis x
    marked with :data:`UNMEASURED_VARIANCE`, the noise variances of q and r [rad²/s²] on
    elements 4 and 8 (module docstring)."""
    return diag_cov((UNMEASURED_VARIANCE, var_q, var_r))


# ----------------------------------------------------------------------------------------
# Built and read with one struct call instead of through message objects (:mod:`.cdr`
# says why).
# ----------------------------------------------------------------------------------------

_IDENTITY_QUAT = (0.0, 0.0, 0.0, 1.0)
_ZERO3 = (0.0, 0.0, 0.0)
#: sensor_msgs/NavSatStatus.STATUS_FIX, NavSatFix.COVARIANCE_TYPE_UNKNOWN / _KNOWN
_STATUS_FIX, _COV_UNKNOWN, _COV_KNOWN = 0, 0, 3


def imu_cdr(t_ns: int, frame_id: str, *, orientation: Sequence[float] | None = None,
            orientation_cov: Sequence[float] = ZERO_COV, angular_velocity: Sequence[float] | None = None,
            angular_velocity_cov: Sequence[float] = ZERO_COV, linear_acceleration: Sequence[float] | None = None,
            linear_acceleration_cov: Sequence[float] = ZERO_COV) -> bytes:
    """:func:`.messages.imu_msg`, serialized."""
    return cdr.imu_layout(frame_id).pack(
        t_ns // 1_000_000_000, t_ns % 1_000_000_000,
        *(_IDENTITY_QUAT if orientation is None else orientation),
        *(NOT_PROVIDED if orientation is None else orientation_cov),
        *(_ZERO3 if angular_velocity is None else angular_velocity),
        *(NOT_PROVIDED if angular_velocity is None else angular_velocity_cov),
        *(_ZERO3 if linear_acceleration is None else linear_acceleration),
        *(NOT_PROVIDED if linear_acceleration is None else linear_acceleration_cov))


def joint_state_cdr(t_ns: int, names: Sequence[str], position: Sequence[float] = (),
                    velocity: Sequence[float] = (), effort: Sequence[float] = ()) -> bytes:
    """:func:`.messages.joint_state_msg`, serialized."""
    layout = cdr.joint_state_layout("", tuple(names), len(position), len(velocity), len(effort))
    return layout.pack(t_ns // 1_000_000_000, t_ns % 1_000_000_000, *position, *velocity, *effort)


def vector3_cdr(t_ns: int, frame_id: str, vec: Sequence[float]) -> bytes:
    """:func:`.messages.vector3_msg`, serialized."""
    return cdr.vector3_stamped_layout(frame_id).pack(t_ns // 1_000_000_000, t_ns % 1_000_000_000, *vec)


def clock_cdr(t_ns: int) -> bytes:
    """:func:`.messages.clock_msg`, serialized."""
    return cdr.clock_layout().pack(t_ns // 1_000_000_000, t_ns % 1_000_000_000)


def odometry_cdr(t_ns: int, frame_id: str, child_frame_id: str, position: Sequence[float],
                 orientation: Sequence[float], pose_cov: Sequence[float], linear: Sequence[float],
                 angular: Sequence[float], twist_cov: Sequence[float]) -> bytes:
    """nav_msgs/Odometry, serialized: the pose (position, quaternion (x, y, z, w)) in
    ``frame_id``, the twist in ``child_frame_id``, each with its 6×6 row-major covariance
    (x, y, z, rotation about x, y, z)."""
    return cdr.odometry_layout(frame_id, child_frame_id).pack(
        t_ns // 1_000_000_000, t_ns % 1_000_000_000, *position, *orientation, *pose_cov, *linear, *angular,
        *twist_cov)


def navsat_fix_cdr(t_ns: int, frame_id: str, lat: float, lon: float, altitude_m: float,
                   covariance_enu_m2: Sequence[float] | None = None) -> bytes:
    """:func:`.messages.navsat_fix_msg`, serialized: ``lat``, ``lon`` [rad] written in degrees,
    status STATUS_FIX with service 0 (not a GNSS), the covariance KNOWN or (None) UNKNOWN."""
    known = covariance_enu_m2 is not None
    return cdr.navsat_fix_layout(frame_id).pack(
        t_ns // 1_000_000_000, t_ns % 1_000_000_000, _STATUS_FIX, 0, math.degrees(lat), math.degrees(lon),
        float(altitude_m), *((float(v) for v in covariance_enu_m2) if known else (0.0,) * 9),
        _COV_KNOWN if known else _COV_UNKNOWN)
