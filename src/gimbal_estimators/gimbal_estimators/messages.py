"""Message conversion for gimbal_estimators (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_kinematics.ros.messages`."""
from __future__ import annotations

import math
from typing import Sequence

from geometry_msgs.msg import Vector3Stamped  # noqa: F401
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.maths.frames import GIMBAL_ENCODER_JOINTS, GIMBAL_FRAME, PLATFORM_FRAME  # noqa: F401
from gimbal_kinematics.maths.rotations import euler321_from_quat
from gimbal_kinematics.ros.messages import (  # noqa: F401
    NAV_FRAME, NOT_PROVIDED, clock_msg, encoder_readings, field_provided, gyro_qr_provided, imu_msg, navsat_fix_msg, quat_of,
    stamp_ns, step_of_stamp, step_stamp_ns, time_msg, vec_of, vector3_msg,
)

from .wire import NOT_ESTIMATED, enu_to_ned, north_only, planar, sigma_enu_to_ned  # noqa: F401  (re-exported)



def euler_of_imu(msg: Imu) -> tuple[float, float, float] | None:
    """(roll, pitch, yaw) [rad] of an Imu orientation; None when it is marked not provided
    (REP 145: covariance element 0 = -1); NaNs when it is not a valid quaternion, for the
    estimator to reject and count."""
    if msg.orientation_covariance[0] == -1.0:
        return None
    o = msg.orientation
    q = (o.x, o.y, o.z, o.w)
    if not (math.isfinite(sum(q)) and sum(v * v for v in q) > 0.0):
        return (math.nan, math.nan, math.nan)
    return euler321_from_quat(q)


def attitude_msg(t_ns: int, quat_nm: Sequence[float] | None, cov_n: Sequence[Sequence[float]] | None,
                 rate_m: Sequence[float] | None) -> Imu:
    """Estimated C(n,m) as an Imu message in the navigation frame: orientation (x, y, z, w)
    with the covariance [rad²] of the attitude error about the n axes; angular velocity the
    bias-corrected inertial rate of m [rad/s] (variance not stated: zeros); no linear
    acceleration. A field that is None is marked not provided."""
    cov = NOT_PROVIDED if cov_n is None else tuple(float(cov_n[i][j]) for i in range(3) for j in range(3))
    return imu_msg(t_ns, NAV_FRAME, orientation=quat_nm, orientation_cov=cov, angular_velocity=rate_m)


_NAN = float("nan")


def seconds_ns(t: float) -> int:
    """Stamp [ns] of a time ``t`` [s] that need not be a step time (e.g. a window's mean)."""
    return int(round(t * 1e9))


def level_of(msg: Imu) -> tuple[float, float]:
    """(roll, pitch) [rad] of a vertical-reference Imu orientation (its heading is ignored);
    NaN for an orientation that is not a finite non-zero quaternion (the core counts it)."""
    try:
        roll, pitch, _ = euler321_from_quat(quat_of(msg))
    except ValueError:
        return _NAN, _NAN
    return roll, pitch


def lgu_increment(msg: Imu, dt: float) -> tuple[float, float, float] | None:
    """Incremental angle Δα [rad] (3,) of an LGU message over its sample interval ``dt``
    [s]: the sensor publishes Δα/Δt in ``angular_velocity`` (docs/interfaces.md, topic table), so this
    is exact for the interval the rate was formed over. None when the message marks its
    rates as not provided (REP 145: ``angular_velocity_covariance[0] == -1``). Non-finite
    values pass through; the filter core rejects and counts them."""
    if msg.angular_velocity_covariance[0] == -1.0:
        return None
    w = msg.angular_velocity
    return (w.x * dt, w.y * dt, w.z * dt)


def joint_position_velocity(msg: JointState, name: str) -> tuple[float, float | None] | None:
    """(position, velocity or None) of joint ``name``; None when the message lacks it."""
    names = list(msg.name)
    if name not in names:
        return None
    i = names.index(name)
    if i >= len(msg.position):
        return None
    vel = float(msg.velocity[i]) if i < len(msg.velocity) else None
    return float(msg.position[i]), vel


# --- free timing: what a driver or another tool may send -----------------------------------
#: Input-check counters of the gyro-bias EKF node, by name; each counts messages or samples
#: that were not fused.
BAD_INPUT_KEYS = ("gyro_not_provided", "ins_rates_not_provided", "ins_attitude_not_provided",
                  "joint_names_missing")


def gyro_rates_provided(msg: Imu) -> bool:
    """Whether a two-axis gyro message carries its y, z rates (the three accepted forms of
    :func:`gimbal_kinematics.ros.messages.gyro_qr_provided`)."""
    return gyro_qr_provided(msg.angular_velocity_covariance)


def encoder_angles(msg: JointState) -> tuple[tuple[float, ...], tuple[float, ...] | None] | None:
    """(angles, rates or None) of the three gimbal joints in the order turret, gimbal
    azimuth, elevation, from a JointState that names them in any order among other joints
    (a driver's); rates are None when the message has no velocities. None when a joint is
    missing or has no position."""
    names = list(msg.name)
    try:
        idx = [names.index(j) for j in GIMBAL_ENCODER_JOINTS]
    except ValueError:
        return None
    if max(idx) >= len(msg.position):
        return None
    rates = tuple(msg.velocity[i] for i in idx) if len(msg.velocity) == len(names) else None
    return tuple(msg.position[i] for i in idx), rates
