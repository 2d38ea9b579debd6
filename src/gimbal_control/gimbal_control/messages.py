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
