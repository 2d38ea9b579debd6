"""Message conversion for gimbal_control (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from sensor_msgs.msg import JointState

from gimbal_sim.messages import (  # noqa: F401
    encoder_readings, joint_state_msg, quat_of, stamp_ns, step_of_stamp, step_stamp_ns, vec_of,
)

GIMBAL_COMMAND_JOINTS = ("gimbal_azimuth", "gimbal_elevation")


def torque_command_msg(t_ns: int, tau: tuple[float, float]) -> JointState:
    return joint_state_msg(t_ns, GIMBAL_COMMAND_JOINTS, effort=tau)


# ---------------------------------------------------------------- paper 2 (encoder fusion)
from geometry_msgs.msg import Vector3Stamped  # noqa: E402  (imports kept with the functions using them)

from gimbal_sim.messages import vector3_msg  # noqa: E402

#: Frame of the two-axis gimbal gyro and of the per-axis (q_m, r_m) quantities.
GIMBAL_GYRO_FRAME = "gimbal_inner_frd"


def gimbal_axes_msg(t_ns: int, q: float, r: float) -> Vector3Stamped:
    """A per-axis quantity of the two gyro axes as (0, q, r) in the inner-gimbal frame
    (x, the roll axis the two-axis gyro does not measure, is 0)."""
    return vector3_msg(t_ns, GIMBAL_GYRO_FRAME, (0.0, q, r))
