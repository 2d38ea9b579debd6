"""Message conversion for gimbal_sim: the only module that builds or reads ROS messages.

Time on topics is simulation time. Step k of a run at ``rate_hz`` is stamped
``round(k·1e9 / rate_hz)`` ns, and a receiver maps a stamp back to k the same way, so
stamps never accumulate floating-point error.

REP 145: a field a sensor does not provide at all has covariance element 0 set to -1, and
consumers (robot_localization, ...) then drop the whole field. A single unmeasured axis of a
provided field is marked the conventional way instead: value 0 with a very large variance on
its diagonal element (:data:`UNMEASURED_VARIANCE`). The two-axis gimbal gyro measures only q_m
and r_m: its message sets ``angular_velocity.x = 0`` and ``angular_velocity_covariance =
diag(UNMEASURED_VARIANCE, var_q, var_r)`` (:func:`gimbal_gyro_covariance`). Readers accept
the older forms too (:func:`gyro_qr_provided`): ``[0] = -1`` with ``[4]``, ``[8]`` > 0 (bags
recorded before the change) and an all-zero covariance ("unknown", a driver's default).
"""
from __future__ import annotations

import math
from typing import NamedTuple, Sequence

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3Stamped
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix, NavSatStatus

from gimbal_kinematics.maths.frames import GIMBAL_ENCODER_JOINTS, NAV_FRAME  # noqa: F401  (re-exported)
from gimbal_kinematics.timing.stamps import step_of_stamp, step_stamp_ns  # noqa: F401  (re-exported)

from . import cdr
# the serialized forms and the REP 145 constants (rclpy-free: the engine writes bags with them)
from .wire import (  # noqa: F401  (re-exported)
    NOT_PROVIDED, UNMEASURED_VARIANCE, ZERO_COV, clock_cdr, diag_cov, gimbal_gyro_covariance, imu_cdr, joint_state_cdr,
    navsat_fix_cdr, odometry_cdr, vector3_cdr,
)





def time_msg(stamp_ns: int) -> Time:
    return Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)


def stamp_ns(stamp: Time) -> int:
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def clock_msg(t_ns: int) -> Clock:
    return Clock(clock=time_msg(t_ns))


def gyro_qr_provided(cov: Sequence[float]) -> bool:
    """Whether an Imu's angular-velocity covariance (9 row-major) lets a reader use its y and
    z rates: the large-variance marking of an unmeasured x, the older ``[0] = -1`` form with
    ``[4]`` and ``[8]`` > 0 (bags recorded before the change), a driver's all-zero
    ("unknown") covariance, or any ordinary covariance. False only for ``[0] = -1`` without
    y and z variances: REP 145's "no angular velocity at all"."""
    return cov[0] != -1.0 or (cov[4] > 0.0 and cov[8] > 0.0)


def field_provided(cov: Sequence[float]) -> bool:
    """Whether an Imu field is provided at all (REP 145: element 0 of its covariance is not
    -1). An all-zero covariance is "unknown", still provided."""
    return cov[0] != -1.0


def imu_msg(t_ns: int, frame_id: str, *, orientation: Sequence[float] | None = None,
            orientation_cov: Sequence[float] = ZERO_COV, angular_velocity: Sequence[float] | None = None,
            angular_velocity_cov: Sequence[float] = ZERO_COV, linear_acceleration: Sequence[float] | None = None,
            linear_acceleration_cov: Sequence[float] = ZERO_COV) -> Imu:
    """An Imu message; a field given as ``None`` is marked not provided (REP 145)."""
    msg = Imu()
    msg.header.stamp = time_msg(t_ns)
    msg.header.frame_id = frame_id
    for name, axes, values, cov in (("orientation", "xyzw", orientation, orientation_cov),
                                    ("angular_velocity", "xyz", angular_velocity, angular_velocity_cov),
                                    ("linear_acceleration", "xyz", linear_acceleration, linear_acceleration_cov)):
        if values is None:
            setattr(msg, f"{name}_covariance", NOT_PROVIDED)
            continue
        field = getattr(msg, name)
        for axis, v in zip(axes, values, strict=True):
            setattr(field, axis, float(v))
        setattr(msg, f"{name}_covariance", tuple(float(v) for v in cov))
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


def quat_of(msg) -> tuple[float, float, float, float]:
    """(x, y, z, w) of an Imu's orientation (message object or :class:`ImuData`)."""
    o = msg.orientation
    return o if type(o) is tuple else (o.x, o.y, o.z, o.w)


def vec_of(v) -> tuple[float, float, float]:
    """(x, y, z) of a geometry_msgs Vector3 (or the tuple a decoded message holds)."""
    return v if type(v) is tuple else (v.x, v.y, v.z)


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


# ----------------------------------------------------------------------------------------
# Serialized (CDR) forms for the lockstep hot path: the same messages as above, built and
# read with one struct call instead of through message objects (:mod:`.cdr` says why).
# Publish the bytes with ``publisher.publish(data)``; take them with ``raw=True``.
# ----------------------------------------------------------------------------------------



class ImuData(NamedTuple):
    """A decoded sensor_msgs/Imu: stamp [ns], frame, and each field as a tuple."""

    stamp_ns: int
    frame_id: str
    orientation: tuple[float, float, float, float]
    orientation_covariance: tuple[float, ...]
    angular_velocity: tuple[float, float, float]
    angular_velocity_covariance: tuple[float, ...]
    linear_acceleration: tuple[float, float, float]
    linear_acceleration_covariance: tuple[float, ...]


class JointStateData(NamedTuple):
    stamp_ns: int
    frame_id: str
    name: tuple[str, ...]
    position: tuple[float, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]


class Vector3StampedData(NamedTuple):
    stamp_ns: int
    frame_id: str
    vector: tuple[float, float, float]


def imu_from_cdr(data: bytes) -> ImuData:
    """Decode a serialized Imu; raises :class:`.cdr.CdrError` on malformed bytes."""
    stamp, frame, v = cdr.read_header_doubles(data, 37)
    return ImuData(stamp, frame, v[0:4], v[4:13], v[13:16], v[16:25], v[25:28], v[28:37])


def joint_state_from_cdr(data: bytes) -> JointStateData:
    return JointStateData(*cdr.read_joint_state(data))


def vector3_stamped_from_cdr(data: bytes) -> Vector3StampedData:
    return Vector3StampedData(*cdr.read_header_doubles(data, 3))


def clock_from_cdr(data: bytes) -> int:
    """Stamp [ns] of a serialized rosgraph_msgs/Clock."""
    return cdr.read_stamp(data)
