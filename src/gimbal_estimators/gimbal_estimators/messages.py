"""Message conversion for gimbal_estimators (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from sensor_msgs.msg import Imu

from gimbal_sim.messages import (  # noqa: F401
    clock_msg, stamp_ns, step_of_stamp, step_stamp_ns, vec_of, vector3_msg,
)


def lgu_increment(msg: Imu, dt: float) -> tuple[float, float, float] | None:
    """Incremental angle Δα [rad] (3,) of an LGU message over its sample interval ``dt``
    [s]: the sensor publishes Δα/Δt in ``angular_velocity`` (README topic table), so this
    is exact for the interval the rate was formed over. None when the message marks its
    rates as not provided (REP 145: ``angular_velocity_covariance[0] == -1``). Non-finite
    values pass through; the filter core rejects and counts them."""
    if msg.angular_velocity_covariance[0] == -1.0:
        return None
    w = msg.angular_velocity
    return (w.x * dt, w.y * dt, w.z * dt)

