"""Message conversion for gimbal_control (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from sensor_msgs.msg import JointState

from gimbal_sim.messages import (  # noqa: F401
    encoder_readings, imu_from_cdr, joint_state_cdr, joint_state_from_cdr, joint_state_msg, quat_of, stamp_ns,
    step_of_stamp, step_stamp_ns, vec_of, vector3_stamped_from_cdr,
)
from gimbal_sim.vehicle import PLATFORM_JOINTS  # (a, q, p, r): the platform plant's joint names

GIMBAL_COMMAND_JOINTS = ("gimbal_azimuth", "gimbal_elevation")


def torque_command_msg(t_ns: int, tau: tuple[float, float]) -> JointState:
    return joint_state_msg(t_ns, GIMBAL_COMMAND_JOINTS, effort=tau)


def torque_command_cdr(t_ns: int, tau: tuple[float, float]) -> bytes:
    """:func:`torque_command_msg`, serialized."""
    return joint_state_cdr(t_ns, GIMBAL_COMMAND_JOINTS, effort=tau)


# ---------------------------------------------------------------- paper 2 (encoder fusion)
from geometry_msgs.msg import Vector3Stamped  # noqa: E402  (imports kept with the functions using them)

from gimbal_sim.messages import vector3_msg  # noqa: E402

#: Frame of the two-axis gimbal gyro and of the per-axis (q_m, r_m) quantities.
GIMBAL_GYRO_FRAME = "gimbal_inner_frd"


def gimbal_axes_msg(t_ns: int, q: float, r: float) -> Vector3Stamped:
    """A per-axis quantity of the two gyro axes as (0, q, r) in the inner-gimbal frame
    (x, the roll axis the two-axis gyro does not measure, is 0)."""
    return vector3_msg(t_ns, GIMBAL_GYRO_FRAME, (0.0, q, r))


# --- paper 3 four-gimbal platform servo ------------------------------------------------------

#: Name of the single joint of the servo's ``~/modulation`` message (commanded φz, φ̇z).
MODULATION_JOINT = "modulation_angle"


def platform_joint_positions(msg: JointState) -> tuple[float, float, float, float] | None:
    """Positions of the platform joints (θ_a, θ_q, θ_p, θ_r) [rad] in that order; None when
    the message does not carry exactly those joints with positions."""
    names = list(msg.name)
    if sorted(names) != sorted(PLATFORM_JOINTS) or len(msg.position) != 4:
        return None
    pos = msg.position
    return tuple(float(pos[names.index(j)]) for j in PLATFORM_JOINTS)  # type: ignore[return-value]


def platform_voltage_msg(t_ns: int, volts: tuple[float, ...]) -> JointState:
    """The gimbal motor voltages (a, q, p, r) [V] as effort of the platform joints."""
    return joint_state_msg(t_ns, PLATFORM_JOINTS, effort=volts)


def platform_control_error_msg(t_ns: int, signals: tuple[float, ...]) -> JointState:
    """Paper 3 eq. 1 control signals (Δθ_am, Δθ_qm, Δθ_pm, Δθ_rm) [rad] as positions."""
    return joint_state_msg(t_ns, PLATFORM_JOINTS, position=signals)


def modulation_msg(t_ns: int, phi_z: float, phi_z_rate: float) -> JointState:
    """Commanded modulation angle φz [rad] (about NED down, from the start) and rate [rad/s]."""
    return joint_state_msg(t_ns, (MODULATION_JOINT,), position=(phi_z,), velocity=(phi_z_rate,))
