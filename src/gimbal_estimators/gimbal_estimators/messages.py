"""Message conversion for gimbal_estimators (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from sensor_msgs.msg import Imu, NavSatFix

from gimbal_kinematics.rotations import quat_to_euler321
from gimbal_sim.messages import (  # noqa: F401
    clock_msg, navsat_fix_msg, quat_of, stamp_ns, step_of_stamp, step_stamp_ns, vec_of, vector3_msg,
)

from .free_gyro_positioning import FreeGyroFix, navsat_covariance_enu

_NAN = float("nan")


def seconds_ns(t: float) -> int:
    """Stamp [ns] of a time ``t`` [s] that need not be a step time (e.g. a window's mean)."""
    return int(round(t * 1e9))


def level_of(msg: Imu) -> tuple[float, float]:
    """(roll, pitch) [rad] of a vertical-reference Imu orientation (its heading is ignored);
    NaN for an orientation that is not a finite non-zero quaternion (the core counts it)."""
    try:
        roll, pitch, _ = quat_to_euler321(quat_of(msg))
    except ValueError:
        return _NAN, _NAN
    return roll, pitch


def free_gyro_fix_msg(fix: FreeGyroFix, frame_id: str, height_m: float, height_sigma_m: float) -> NavSatFix:
    """``NavSatFix`` of a valid free-gyro fix stamped at the window's mean time: latitude and
    longitude, ``height_m`` as altitude (the free gyros do not observe it) and the ENU
    covariance = the fix's FDOP²σ² north/east block plus ``height_sigma_m``² vertically."""
    if not fix.valid:
        raise ValueError(f"no NavSatFix for a {fix.status} fix ({fix.reason})")
    cov = navsat_covariance_enu(fix.cov_ne_m, height_sigma_m**2)
    return navsat_fix_msg(seconds_ns(fix.t), frame_id, fix.lat, fix.lon, height_m, cov)
