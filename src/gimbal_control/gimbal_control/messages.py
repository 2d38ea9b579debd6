"""Message conversion for gimbal_control (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from sensor_msgs.msg import JointState

from gimbal_sim.messages import (  # noqa: F401
    imu_from_cdr, joint_state_cdr, joint_state_from_cdr, joint_state_msg, stamp_ns, step_of_stamp, step_stamp_ns,
    vec_of, vector3_stamped_from_cdr,
)

GIMBAL_ENCODER_JOINTS = ("turret_azimuth", "gimbal_azimuth", "gimbal_elevation")
GIMBAL_COMMAND_JOINTS = ("gimbal_azimuth", "gimbal_elevation")


def encoder_readings(msg: JointState) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """(angles, rates) in the order turret, gimbal azimuth, elevation; None when the
    message does not carry exactly those joints with positions and velocities."""
    names = list(msg.name)
    if sorted(names) != sorted(GIMBAL_ENCODER_JOINTS) or len(msg.position) != 3 or len(msg.velocity) != 3:
        return None
    idx = [names.index(j) for j in GIMBAL_ENCODER_JOINTS]
    return tuple(msg.position[i] for i in idx), tuple(msg.velocity[i] for i in idx)


def torque_command_msg(t_ns: int, tau: tuple[float, float]) -> JointState:
    return joint_state_msg(t_ns, GIMBAL_COMMAND_JOINTS, effort=tau)


def torque_command_cdr(t_ns: int, tau: tuple[float, float]) -> bytes:
    """:func:`torque_command_msg`, serialized."""
    return joint_state_cdr(t_ns, GIMBAL_COMMAND_JOINTS, effort=tau)
