"""Message conversion for gimbal_control (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_kinematics.ros.messages`."""
from __future__ import annotations

from sensor_msgs.msg import JointState

from gimbal_kinematics.maths.frames import (  # noqa: F401  (MODULATION_JOINT: used by the servo node)
    GIMBAL_COMMAND_JOINTS, GIMBAL_ENCODER_JOINTS, GIMBAL_FRAME, MODULATION_JOINT, PLATFORM_JOINTS,
)
from gimbal_kinematics.ros.messages import (  # noqa: F401
    encoder_readings, field_provided, gyro_qr_provided, imu_from_cdr, joint_state_cdr, joint_state_from_cdr,
    joint_state_msg, quat_of, stamp_ns, step_of_stamp, step_stamp_ns, vec_of, vector3_msg, vector3_stamped_from_cdr,
)

from .wire import torque_command_cdr  # noqa: F401,E402  (re-exported; the serialized form is rclpy-free)


# --- paper 3 four-gimbal platform servo ------------------------------------------------------
def platform_joint_positions(msg: JointState) -> tuple[float, float, float, float] | None:
    """Positions of the platform joints (θ_a, θ_q, θ_p, θ_r) [rad] in that order; None when
    the message does not carry exactly those joints with positions."""
    names = list(msg.name)
    if sorted(names) != sorted(PLATFORM_JOINTS) or len(msg.position) != 4:
        return None
    pos = msg.position
    return tuple(float(pos[names.index(j)]) for j in PLATFORM_JOINTS)  # type: ignore[return-value]
