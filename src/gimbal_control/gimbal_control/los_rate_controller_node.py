"""``los_rate_controller`` node: paper 1's LOS rate stabilization (dynamic inversion + PI).

Per lockstep step k it needs the gimbal gyro (``/gimbal/imu``) and the encoders
(``/gimbal/joint_states``) stamped k and, at the steps where the INS samples, the INS
(``/ins/imu``) stamped k; it then publishes the torque command stamped k on
``/gimbal/torque_cmd``. Waiting for exactly those inputs (never "the latest that happened
to arrive") keeps a run deterministic.

With ``feedback`` the gyro-bias estimate on ``bias_topic`` is subtracted from the gyro; the
EKF publishes one estimate per INS sample, stamped like it, so at INS steps the node also
waits for the estimate of step k, and between them uses the newest. ``mode: los_hold``
adds the outer LOS angle loop (:mod:`.los_hold`) on the EKF's attitude estimate
(``attitude_topic``, also waited for at INS steps); it implies bias feedback.

An operator slews the LOS with a rate command on ``operator_topic`` (Vector3Stamped, sight
frame, rad/s, y = q, z = r) or a joystick on ``joy_topic`` (sensor_msgs/Joy): the shaper
(:mod:`.operator_command`: rate and acceleration limits, dead-man ``operator_timeout_s``)
judges each command as it arrives and its shaped output is added to the stabilisation
reference at every step (:meth:`.los_rate_controller.LosRateController.reference`). Those
commands bypass the input policy: the shaper has its own stamp rule and timeout. Only a
lockstep graph with an ``operator`` node (``operator_rate_hz`` > 0) waits for its command
at the operator's steps, so the run is deterministic; nobody publishing leaves the loop's
data unchanged. Its counters are ``operator_*`` in /diagnostics.

That is ``timing: lockstep``, which the orchestrator sets. ``timing: free`` (the default,
for a driver or a bag) never waits: each gyro sample makes one command, stamped like it,
from the newest encoder and INS samples no older than ``max_input_age_s`` and the newest
estimates no older than ``max_estimate_age_s`` (:class:`gimbal_kinematics.sync.FreshInputs`;
dt from the stamps, time in int ns from the first stamp). A stale or missing measurement
(gyro, encoders, INS) *zeroes* the command: for a rate loop zero torque lets the gimbal
coast on its bearings, while holding a torque computed from angles that no longer hold can
drive it into a stop; paper 1 says nothing about lost inputs. Each such command is counted
(``stale_commands``), and when the inputs are fresh again the loop restarts (integrator
zeroed: the loop was open). A stale or missing *estimate* (bias, attitude) keeps the last
one taken (before the first: no correction, like the lockstep loop before the EKF's first
output) and is counted (``stale_estimate_steps``): the bias changes over hours, and zeroing
torque while an estimator starts would let the gimbal follow the vehicle. Jitter,
drops, duplicates and out-of-order stamps are counted; ``/diagnostics`` carries every
counter once per ``diagnostics_period_s`` of stamp time.

The node chooses its input policy once, in its constructor
(:mod:`gimbal_kinematics.control_policy`: :class:`~gimbal_kinematics.control_policy.LockstepControl`
or :class:`~gimbal_kinematics.control_policy.FreeControl`); each input is validated once, as
it arrives, and every step the policy releases runs the same ``_step``, whatever the timing.

Inputs that cannot be used are counted and never fused: a gyro message whose covariance
marks its angular velocity not provided (REP 145 ``[0] = -1`` without y, z variances; the
older -1-with-variances form and an all-zero "unknown" covariance are accepted), an INS
without angular velocity, encoders without the three gimbal joints, non-finite values.
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, Joy, JointState

from gimbal_kinematics.control_policy import ControlStep, FreeControl, LockstepControl, control_policy
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.input_kinds import InputKind
from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.diagnostics import advertise_diagnostics, health_msg
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read

from . import messages as m
from .los_hold import LosHold, LosHoldParams
from .los_rate_controller import LosRateController, LosRateControllerParams
from .los_rate_controller_params import DESCRIPTION, PARAMS
from .operator_command import OperatorCommand, OperatorCommandParams
from .wire import torque_command_messages

#: the node's own counters of inputs it could not use (/diagnostics, after the policy's)
COUNTERS = ("malformed", "rejected_no_rates", "rejected_nonfinite", "rejected_joint_names")
ESTIMATES = (InputKind.BIAS, InputKind.ATTITUDE)
ZERO = (0.0, 0.0)


class LosRateControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("los_rate_controller", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        timing = values["timing"]
        self.rate = rate = values["sim_rate_hz"]
        hold_mode = values["mode"] == "los_hold"
        params = LosRateControllerParams.from_values(values)
        self.operator = OperatorCommand(OperatorCommandParams.from_values(values))
        self.core = LosRateController(params, operator=self.operator)
        self.hold = LosHold(LosHoldParams.from_values(values)) if hold_mode else None
        self.counts = dict.fromkeys(COUNTERS, 0)
        self.io = NodeIo(self)
        self.pub = self.io.advertise_command(JointState, "/gimbal/torque_cmd", values)
        # taken serialized and decoded here (messages.*_from_cdr): no message objects per step
        imu, joints, vec = m.imu_from_cdr, m.joint_state_from_cdr, m.vector3_stamped_from_cdr
        inputs = [(InputKind.GYRO, Imu, "/gimbal/imu", imu),
                  (InputKind.ENCODERS, JointState, "/gimbal/joint_states", joints),
                  (InputKind.INS, Imu, "/ins/imu", imu)]
        if params.feedback:
            inputs.append((InputKind.BIAS, Vector3Stamped, values["bias_topic"], vec))
        if hold_mode:
            inputs.append((InputKind.ATTITUDE, Imu, values["attitude_topic"], imu))
        estimates = tuple(kind for kind, *_ in inputs if kind in ESTIMATES)
        ins_every = steps_per_sample(values, "ins_rate_hz")
        # an INS step also waits for the estimates in use
        ins_step_needs = (InputKind.GYRO, InputKind.ENCODERS, InputKind.INS) + estimates
        op_topic = values["operator_topic"]
        op_waited = bool(op_topic) and values["operator_rate_hz"] > 0.0
        # in lockstep a sampled operator command is one of the step's inputs; free, it is used as it arrives
        op_every = control_policy(timing, free=lambda: 0,
                                  lockstep=lambda: steps_per_sample(values, "operator_rate_hz") if op_waited else 0)
        if op_every:
            inputs.append((InputKind.OPERATOR, Vector3Stamped, op_topic, vec))

        def needs(k: int) -> tuple[str, ...]:
            base = ins_step_needs if k % ins_every == 0 else (InputKind.GYRO, InputKind.ENCODERS)
            return base + (InputKind.OPERATOR,) if op_every and k % op_every == 0 else base

        ages = {kind: values["max_estimate_age_s"] if kind in ESTIMATES else values["max_input_age_s"]
                for kind, *_ in inputs[1:] if kind != InputKind.OPERATOR}
        # the one choice of timing (module docstring); a step back of more than clock_jump_s is a bag loop
        self.policy = control_policy(
            timing,
            lockstep=lambda: LockstepControl(needs, rate, params.clock_jump_s, estimates=estimates,
                                             logger=self.get_logger()),
            free=lambda: FreeControl(InputKind.GYRO, ages, 1.0 / rate, params.clock_jump_s, held=estimates,
                                     on_arrival=(InputKind.ATTITUDE,) if hold_mode else (), warn=self._log))
        self.pub_diag = advertise_diagnostics(self.io, timing, self.policy)
        self.diag_period_ns = int(round(values["diagnostics_period_s"] * 1e9))
        self._next_diag_ns = 0
        self._ins_rates: tuple[float, float, float] | None = None
        for kind, msg_type, topic, decode in inputs:
            self.io.subscribe(msg_type, topic, lambda data, k=kind, d=decode: self._on_input(k, data, d), timing,
                              raw=True)
        if op_topic and not op_every:
            self.io.subscribe(Vector3Stamped, op_topic, self._on_operator, timing, raw=True)
        if values["joy_topic"]:
            self.io.subscribe(Joy, values["joy_topic"], self._on_joy, timing)

    @property
    def rejected(self) -> int:
        """Inputs the node could not use, over every counter."""
        return sum(self.counts.values())

    def _log(self, text: str) -> None:
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    def _count(self, counter: str, text: str) -> None:
        self.counts[counter] += 1
        self._log(f"{text} ({self.counts[counter]} {counter})")

    def _on_input(self, kind: str, data: bytes, decode) -> None:
        try:
            msg = decode(data)
        except CdrError as exc:
            self._count("malformed", f"malformed {kind} message ignored: {exc}")
            return
        for step in self.policy.add(kind, msg.stamp_ns, self._validate(kind, msg)):
            self._step(step)

    def _on_operator(self, data: bytes) -> None:
        """An operator rate command used as it arrives (the shaper judges and counts it)."""
        try:
            msg = m.vector3_stamped_from_cdr(data)
        except CdrError as exc:
            self._count("malformed", f"malformed operator command ignored: {exc}")
            return
        self.operator.set_rate(msg.stamp_ns, msg.vector[1], msg.vector[2])

    def _on_joy(self, msg: Joy) -> None:
        self.operator.set_joy(m.stamp_ns(msg.header.stamp), msg.axes)

    def _validate(self, kind: str, msg):
        """What the loop takes from an input message, or None (counted) when it cannot be used."""
        if kind == InputKind.OPERATOR:  # the operator's waited-for command: the shaper judges it
            return (msg.stamp_ns, msg.vector[1], msg.vector[2])
        if kind == InputKind.GYRO:
            if not m.gyro_qr_provided(msg.angular_velocity_covariance):
                self._count("rejected_no_rates", "gyro angular velocity marked not provided; not fused")
                return None
            return msg.angular_velocity[1:]  # (q, r); x, the roll axis, is not measured; NaN: the core holds
        if kind == InputKind.ENCODERS:
            readings = m.encoder_readings(msg)
            if readings is None:
                self._count("rejected_joint_names", f"encoder message without the joints {m.GIMBAL_ENCODER_JOINTS}")
                return None
            values = (*readings[0], *readings[1])
        elif kind == InputKind.INS:
            if not m.field_provided(msg.angular_velocity_covariance):
                self._count("rejected_no_rates", "INS angular velocity marked not provided; not fused")
                return None
            values = readings = msg.angular_velocity
        elif kind == InputKind.BIAS:
            values = readings = msg.vector
        else:  # InputKind.ATTITUDE
            if not m.field_provided(msg.orientation_covariance):
                self._count("rejected_no_rates", "attitude estimate marked not provided; not fused")
                return None
            values = readings = msg.orientation
        if not all(map(math.isfinite, values)):
            self._count("rejected_nonfinite", f"non-finite {kind} sample; not fused")
            return None
        return readings

    def _step(self, step: ControlStep) -> None:
        core, inputs = self.core, step.inputs
        for reason in step.resets:
            core.reset(reason)
        bias, att, op = inputs.get(InputKind.BIAS), inputs.get(InputKind.ATTITUDE), inputs.get(InputKind.OPERATOR)
        if op is not None:
            self.operator.set_rate(*op.value)
        if bias is not None:
            core.set_bias_estimate(bias.t, bias.value)
        if att is not None and self.hold is not None:  # the outer loop runs on each new attitude estimate
            core.set_rate_command(*self.hold.update(att.t, att.value, core.bias_estimate_qr))
        if not step.command:
            return
        if step.zero_command:
            tau = ZERO
        else:
            ins, gyro, enc = inputs.get(InputKind.INS), inputs.get(InputKind.GYRO), inputs.get(InputKind.ENCODERS)
            if ins is not None:
                self._ins_rates = ins.value
            if gyro is None or enc is None or self._ins_rates is None:
                self._log(f"step at {step.t:.6f} s: gyro, encoders or INS rates missing; holding the last command")
                tau = core.command
            else:
                before = core.rejected_inputs
                tau = core.step(step.t, gyro.value, enc.value[0], enc.value[1], self._ins_rates,
                                core.reference(step.stamp_ns))
                if core.rejected_inputs > before:
                    self._count("rejected_nonfinite", "non-finite gyro sample; holding the last command")
        for _, _, data in torque_command_messages(step.stamp_ns, tau):  # as the engine writes it
            self.pub.publish(data)
        if step.stamp_ns >= self._next_diag_ns:
            self._next_diag_ns = step.stamp_ns + self.diag_period_ns
            self.pub_diag.publish(self.health(step))

    def health(self, step: ControlStep):
        """The /diagnostics message (:mod:`gimbal_kinematics.ros.diagnostics`)."""
        core = self.core
        fields = {**self.policy.counters(), **self.counts, **self.io.counters(),
                  "saturated_steps": core.saturated_steps, "singular_steps": core.singular_steps,
                  "rejected_bias": core.rejected_bias, "resets": core.resets,
                  **{f"operator_{k}": n for k, n in self.operator.counters().items()}}
        return health_msg(step.stamp_ns, self.get_name(), fields, stale=step.zero_command)


def main(argv: list[str] | None = None) -> int:
    return run_node(LosRateControllerNode, "los_rate_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
