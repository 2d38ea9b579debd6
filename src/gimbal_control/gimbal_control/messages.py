"""Message conversion for gimbal_control (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from sensor_msgs.msg import JointState

from gimbal_sim.messages import joint_state_msg, stamp_ns, step_of_stamp, step_stamp_ns, vec_of  # noqa: F401

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


# ---------------------------------------------------------------- paper 2 (encoder fusion)
from geometry_msgs.msg import Vector3Stamped  # noqa: E402  (imports kept with the functions using them)

from gimbal_sim.messages import vector3_msg  # noqa: E402

#: Frame of the two-axis gimbal gyro and of the per-axis (q_m, r_m) quantities.
GIMBAL_GYRO_FRAME = "gimbal_inner_frd"


def gimbal_axes_msg(t_ns: int, q: float, r: float) -> Vector3Stamped:
    """A per-axis quantity of the two gyro axes as (0, q, r) in the inner-gimbal frame
    (x, the roll axis the two-axis gyro does not measure, is 0)."""
    return vector3_msg(t_ns, GIMBAL_GYRO_FRAME, (0.0, q, r))
