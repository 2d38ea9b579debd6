"""The serialisation of gimbal_control's nodes: pure functions from a core's output to the
messages' bytes (CDR), rclpy-free, which the node publishes and the no-ROS engine writes into
its bag. Each returns ``[(topic, type name, bytes), ...]`` in the node's publishing order,
the topic as the node declares it (``~/x`` relative to the node's name).
"""
from __future__ import annotations

from typing import Sequence

from gimbal_kinematics.maths.frames import (
    DTG_PICKOFF_JOINTS, DTG_TORQUER_JOINTS, GIMBAL_COMMAND_JOINTS, GIMBAL_FRAME, MODULATION_JOINT, NAV_FRAME,
    PLATFORM_JOINTS,
)
from gimbal_kinematics.ros.wire import JOINT_STATE, VECTOR3_STAMPED, joint_state_cdr, vector3_cdr
from gimbal_kinematics.timing.stamps import step_stamp_ns

Messages = list[tuple[str, str, bytes]]


def torque_command_cdr(t_ns: int, tau: tuple[float, float]) -> bytes:
    """The two-axis gimbal's torque command [N m] as a JointState's efforts."""
    return joint_state_cdr(t_ns, GIMBAL_COMMAND_JOINTS, effort=tau)


def torque_command_messages(t_ns: int, tau: tuple[float, float]) -> Messages:
    """``los_rate_controller``: the step's torque command."""
    return [("/gimbal/torque_cmd", JOINT_STATE, torque_command_cdr(t_ns, tau))]


def geo_pointer_messages(t_ns: int, operator_topic: str, command: tuple[float, float],
                         budget: Sequence[float] | None, aim: Sequence[float] | None = None) -> Messages:
    """``geo_pointer``: when it stepped, the LOS it steers to (unit vector, NED) on ``~/aim``;
    its LOS rate command (0, q, r) [rad/s] on ``operator_topic``; when it stepped, its pointing
    budget (1σ RMS, principal semi-axes) [rad] on ``~/budget``."""
    out = [] if aim is None else [("~/aim", VECTOR3_STAMPED, vector3_cdr(t_ns, NAV_FRAME, aim))]
    out.append((operator_topic, VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, (0.0, *command))))
    if budget is not None:
        out.append(("~/budget", VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, budget)))
    return out


def platform_servo_messages(t_ns: int, volts: Sequence[float], out=None,
                            torquer: Sequence[float] | None = None, modulation_next=None) -> Messages:
    """``platform_servo``: with ``gyro_source: dtg``, the step's torquer currents (x_s, y_s,
    z_s) [A] ``torquer`` as a JointState's efforts on ``~/torquer_current`` (first: the DTG
    pair's next step waits for them); the step's gimbal motor voltages (a, q, p, r) [V] on
    ``/platform/voltage_cmd``, and, with a servo tick's output ``out`` (when its report is
    due), the eq. 1 control signals [rad] on ``~/control_error`` and the modulation angle φz
    [rad] with its rate [rad/s] on ``~/modulation``; with ``modulation_next`` (stamp [ns] of the
    next gyro step, φz [rad], φ̇z [rad/s] there) that on ``~/modulation_next``, stamped with it."""
    msgs = [] if torquer is None else [("~/torquer_current", JOINT_STATE,
                                        joint_state_cdr(t_ns, DTG_TORQUER_JOINTS, effort=torquer))]
    msgs.append(("/platform/voltage_cmd", JOINT_STATE, joint_state_cdr(t_ns, PLATFORM_JOINTS, effort=volts)))
    if out is not None:
        msgs += [("~/control_error", JOINT_STATE, joint_state_cdr(t_ns, PLATFORM_JOINTS, position=out.control_signals)),
                 ("~/modulation", JOINT_STATE, joint_state_cdr(t_ns, (MODULATION_JOINT,), position=(out.phi_z,),
                                                               velocity=(out.phi_z_rate,)))]
    if modulation_next is not None:
        t_next, phi, rate = modulation_next
        msgs.append(("~/modulation_next", JOINT_STATE, joint_state_cdr(t_next, (MODULATION_JOINT,), position=(phi,),
                                                                       velocity=(rate,))))
    return msgs


def modulation_next(servo, t: float, every: int, rate_hz: float) -> tuple[int, float, float] | None:
    """What ``platform_servo``'s step at core time ``t`` = k / ``rate_hz`` puts on
    ``~/modulation_next`` (``modulation_next: true``): at a gyro step (k a multiple of
    ``every``) the (stamp [ns], φz [rad], φ̇z [rad/s]) of its next gyro step k + ``every``, from
    the schedule (:meth:`.platform_servo.PlatformServo.modulation_at`); None at other steps."""
    k = round(t * rate_hz)
    if k % every:
        return None
    return (step_stamp_ns(k + every, rate_hz), *servo.modulation_at((k + every) / rate_hz))


def encoder_fusion_messages(t_ns: int, tau: tuple[float, float], feedback: tuple[float, float] | None = None,
                            correction: tuple[float, float] | None = None) -> Messages:
    """``encoder_fusion_controller``: the fed-back velocity (q, r) [rad/s] of a step the loop
    closed, on ``~/feedback_velocity``; the step's torque command; the drift corrections
    (q, r) [rad/s] after a Kalman update, on ``~/drift_correction`` (both (0, q, r) in the
    inner-gimbal frame)."""
    out = [] if feedback is None else [("~/feedback_velocity", VECTOR3_STAMPED,
                                        vector3_cdr(t_ns, GIMBAL_FRAME, (0.0, *feedback)))]
    out += torque_command_messages(t_ns, tau)
    if correction is not None:
        out.append(("~/drift_correction", VECTOR3_STAMPED, vector3_cdr(t_ns, GIMBAL_FRAME, (0.0, *correction))))
    return out


def pickoff_angles(names: Sequence[str], positions: Sequence[float]) -> tuple[float, ...] | None:
    """The four DTG pickoff angles [rad] of a ``/platform/dtg_pickoffs`` JointState in
    :data:`DTG_PICKOFF_JOINTS`' order; None when a name is missing or the lengths differ."""
    names = list(names)
    if not all(j in names for j in DTG_PICKOFF_JOINTS) or len(positions) != len(names):
        return None
    return tuple(float(positions[names.index(j)]) for j in DTG_PICKOFF_JOINTS)
