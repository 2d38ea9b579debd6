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
checks each command's value as it arrives and its shaped output is added to the stabilisation
reference at every step (:meth:`.los_rate_controller.LosRateController.reference`). Their
stamps are judged by the node's command policy
(:class:`gimbal_kinematics.timing.control_policy.CommandStamps`: order, staleness, clock
jumps), which hands the shaper at each step the commands that step reached. Only a
lockstep graph with an ``operator`` node (``operator_rate_hz`` > 0) waits for its command
at the operator's steps, so the run is deterministic; nobody publishing leaves the loop's
data unchanged. Its counters are ``operator_*`` in /diagnostics.

That is ``timing: lockstep``, which the orchestrator sets. ``timing: free`` (the default,
for a driver or a bag) never waits: each gyro sample makes one command, stamped like it,
from the newest encoder and INS samples no older than ``max_input_age_s`` and the newest
estimates no older than ``max_estimate_age_s`` (:class:`gimbal_kinematics.timing.sync.FreshInputs`;
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
(:mod:`gimbal_kinematics.timing.control_policy`: :class:`~gimbal_kinematics.timing.control_policy.LockstepControl`
on the lockstep schedule of its inputs, a :class:`~gimbal_kinematics.timing.input_policy.SampleGrid`,
or :class:`~gimbal_kinematics.timing.control_policy.FreeControl`); each input is decoded and
validated once, as it arrives (:mod:`gimbal_kinematics.ros.node_edge`), and every step the
policy releases runs the same ``_step``, whatever the timing.

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

from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.input_kinds import InputKind
from gimbal_kinematics.ros.node_edge import NodeEdge
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.timing.control_policy import CommandStamps, ControlStep, FreeControl, LockstepControl, control_policy
from gimbal_kinematics.timing.input_policy import SampleGrid

from . import messages as m
from .los_hold import LosHold, LosHoldParams
from .los_rate_controller import LosRateController, LosRateControllerParams
from .los_rate_controller_params import CLOCK_JUMP_S, DESCRIPTION, PARAMS
from .operator_command import OperatorCommand, OperatorCommandParams
from .wire import torque_command_messages

COUNTERS = ("malformed", "rejected_no_rates", "rejected_nonfinite", "rejected_joint_names")
ESTIMATES = (InputKind.BIAS, InputKind.ATTITUDE)


class LosRateControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("los_rate_controller", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        timing, rate = values["timing"], values["sim_rate_hz"]
        params = LosRateControllerParams.from_values(values)
        self.operator = OperatorCommand(OperatorCommandParams.from_values(values))
        self.commands = CommandStamps(values["operator_timeout_s"], CLOCK_JUMP_S)  # the operator's stamp rule
        self.core = LosRateController(params, operator=self.operator)
        self.hold = LosHold(LosHoldParams.from_values(values)) if values["mode"] == "los_hold" else None
        self.edge = edge = NodeEdge(self, values, COUNTERS)
        self.pub = edge.pubs["/gimbal/torque_cmd"] = edge.io.advertise_command(JointState, "/gimbal/torque_cmd", values)
        inputs = [(InputKind.GYRO, Imu, "/gimbal/imu"), (InputKind.ENCODERS, JointState, "/gimbal/joint_states"),
                  (InputKind.INS, Imu, "/ins/imu")]
        if params.feedback:
            inputs.append((InputKind.BIAS, Vector3Stamped, values["bias_topic"]))
        if self.hold is not None:
            inputs.append((InputKind.ATTITUDE, Imu, values["attitude_topic"]))
        estimates = tuple(kind for kind, *_ in inputs if kind in ESTIMATES)
        op_topic = values["operator_topic"]
        # in lockstep a sampled operator command is one of the step's inputs; free, it is used as it arrives
        op_every = control_policy(timing, free=lambda: 0, lockstep=lambda: steps_per_sample(values, "operator_rate_hz")
                                  if op_topic and values["operator_rate_hz"] > 0.0 else 0)
        # lockstep: gyro and encoders every step, INS and estimates at its steps, the operator at its own
        ins_every = steps_per_sample(values, "ins_rate_hz")
        every = {InputKind.GYRO: 1, InputKind.ENCODERS: 1, **dict.fromkeys((InputKind.INS, *estimates), ins_every)}
        if op_every:
            inputs.append((InputKind.OPERATOR, Vector3Stamped, op_topic))
            every[InputKind.OPERATOR] = op_every
        grid = SampleGrid(every)
        ages = {kind: values["max_estimate_age_s"] if kind in ESTIMATES else values["max_input_age_s"]
                for kind, *_ in inputs[1:] if kind != InputKind.OPERATOR}
        # the one choice of timing (module docstring)
        self.policy = control_policy(
            timing,
            lockstep=lambda: LockstepControl(grid.needs, rate, CLOCK_JUMP_S, estimates=estimates,
                                             logger=self.get_logger()),
            free=lambda: FreeControl(InputKind.GYRO, ages, 1.0 / rate, CLOCK_JUMP_S, held=estimates,
                                     on_arrival=(InputKind.ATTITUDE,) if self.hold is not None else (), warn=edge.warn))
        edge.advertise_diagnostics(self.policy)
        self._ins_rates: tuple[float, float, float] | None = None
        edge.subscribe_all(inputs, self._on_input)
        stamp, rate_of, joy_of, add = m.stamp_ns, self.operator.check_rate, self.operator.check_joy, self.commands.add
        if op_topic and not op_every:  # used as it arrives: the shaper checks its value, the policy its stamp
            edge.subscribe(Vector3Stamped, op_topic, lambda v: add(stamp(v.header.stamp), rate_of(*v.vector[1:]).output))
        if values["joy_topic"]:
            edge.subscribe(Joy, values["joy_topic"], lambda joy: add(stamp(joy.header.stamp), joy_of(joy.axes).output))

    def _on_input(self, kind: str, msg) -> None:
        for step in self.policy.add(kind, m.stamp_ns(msg.header.stamp), self._validate(kind, msg)):
            self._step(step)

    def _validate(self, kind: str, msg):
        """What the loop takes from an input message, or None (counted) when it cannot be used."""
        if kind == InputKind.OPERATOR:  # the operator's waited-for command: the shaper and CommandStamps judge it
            return (m.stamp_ns(msg.header.stamp), msg.vector[1], msg.vector[2])
        if kind == InputKind.ENCODERS:
            readings = m.encoder_readings(msg)
            if readings is None:
                return self.edge.reject("rejected_joint_names", f"encoders without {m.GIMBAL_ENCODER_JOINTS}")
            values = (*readings[0], *readings[1])
        else:
            cov, readings = ((msg.orientation_covariance, msg.orientation) if kind == InputKind.ATTITUDE else
                             (None, msg.vector) if kind == InputKind.BIAS else
                             (msg.angular_velocity_covariance, msg.angular_velocity))
            provided = m.gyro_qr_provided if kind == InputKind.GYRO else m.field_provided
            if cov is not None and not provided(cov):
                return self.edge.reject("rejected_no_rates", f"{kind} marked not provided; not fused")
            if kind == InputKind.GYRO:
                return tuple(readings[1:])  # (q, r); x, the roll axis, is not measured; NaN: the core holds
            values = readings = tuple(readings)
        if not all(map(math.isfinite, values)):
            return self.edge.reject("rejected_nonfinite", f"non-finite {kind} sample; not fused")
        return readings

    def _step(self, step: ControlStep) -> None:
        core, inputs = self.core, step.inputs
        for reason in step.resets:
            core.reset(reason)
        bias, att, op = inputs.get(InputKind.BIAS), inputs.get(InputKind.ATTITUDE), inputs.get(InputKind.OPERATOR)
        if op is not None:
            self.commands.add(op.value[0], self.operator.check_rate(*op.value[1:]).output)
        if bias is not None:
            core.set_bias_estimate(bias.t, bias.value)
        if att is not None and self.hold is not None:  # the outer loop runs on each new attitude estimate
            core.set_rate_command(*self.hold.update(att.t, att.value, core.bias_estimate_qr))
        if not step.command:
            return
        if step.zero_command:
            tau = (0.0, 0.0)
        else:
            ins, gyro, enc = inputs.get(InputKind.INS), inputs.get(InputKind.GYRO), inputs.get(InputKind.ENCODERS)
            if ins is not None:
                self._ins_rates = ins.value
            if gyro is None or enc is None or self._ins_rates is None:
                self.edge.warn(f"step at {step.t:.6f} s: gyro, encoders or INS rates missing; holding the last command")
                tau = core.command
            else:
                fed = core.control(step.t, gyro.value, enc.value[0], enc.value[1], self._ins_rates,
                                   core.reference(self.commands.step(step.stamp_ns)))
                tau = fed.output
                if not fed.used:
                    self.edge.reject("rejected_nonfinite", "non-finite gyro sample; holding the last command")
        self.edge.publish(torque_command_messages(step.stamp_ns, tau))  # as the engine writes it
        self.edge.diagnostics(step.stamp_ns, lambda: self.health(step))

    def health(self, step: ControlStep):
        core = self.core  # /diagnostics: the policy's counters, the inputs', the loop's
        fields = {**self.policy.counters(), **self.edge.counters(), "saturated_steps": core.saturated_steps,
                  "singular_steps": core.singular_steps, "rejected_bias": core.rejected_bias, "resets": core.resets,
                  **self.operator.diagnostics(self.commands.counters())}
        return health_msg(step.stamp_ns, self.get_name(), fields, stale=step.zero_command)


def main(argv: list[str] | None = None) -> int:
    return run_node(LosRateControllerNode, "los_rate_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
