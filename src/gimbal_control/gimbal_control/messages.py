"""Message conversion for gimbal_control (the package's one module that reads or builds
ROS messages). Stamps map to lockstep steps as in :mod:`gimbal_sim.messages`."""
from __future__ import annotations

from sensor_msgs.msg import JointState

from gimbal_sim.messages import joint_state_msg, stamp_ns, step_of_stamp, step_stamp_ns, vec_of  # noqa: F401
from gimbal_sim.vehicle import PLATFORM_JOINTS  # (a, q, p, r): the platform plant's joint names

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
