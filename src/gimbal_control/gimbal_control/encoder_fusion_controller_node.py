"""``encoder_fusion_controller`` node: paper 2's two-axis PID stabilizer with encoder/gyro fusion.

A thin wrapper around :class:`.encoder_fusion.EncoderFusionController`. Per lockstep step k
it waits for exactly the inputs stamped k: the gimbal gyro (``/gimbal/imu``, q_m and r_m),
and at the steps where they sample, the encoders (``/gimbal/joint_states``) and the UAV
autopilot's body rates (``/truth/host/imu`` angular_velocity, remap it to your autopilot's
topic). It then publishes the torque command stamped k on ``/gimbal/torque_cmd``. Waiting
for exactly those inputs keeps a run deterministic.

Diagnostics (``geometry_msgs/Vector3Stamped``, (0, q, r) in ``gimbal_inner_frd``, rad/s):

* ``~/feedback_velocity``, stamped k every step: the velocity the PIDs feed back (encoder,
  raw gyro or fused, by ``mode``);
* ``~/drift_correction``, stamped at each filter update (``fused`` mode, every
  ``encoder_gate_s``): the accumulated drift correction E. It converges to −(gyro bias),
  which is how the bias leaves the feedback velocity.

Bad input: a NaN/inf measurement holds the last command (counted, warned at most once a
second); invalid modes, gains and rates are refused at startup naming the parameter.

That is ``timing: lockstep`` (the orchestrator sets it). ``timing: free`` (the default, for a
driver or a bag) never waits: each gyro sample makes one command, stamped like it, with the
newest encoder and base-rate samples no older than ``max_input_age_s``; a stale or missing
one zeroes the command, counted (:mod:`gimbal_kinematics.timing.control_policy` says why and what else is counted, on
``/diagnostics``). The encoder angle is the newest sample's, not interpolated to the gyro
stamp: the filter's gate integrates the gyro between encoder stamps itself.

The node chooses its input policy once, in its constructor
(:mod:`gimbal_kinematics.timing.control_policy`); each input is validated once, as it arrives, and
every step the policy releases runs the same ``_step``, whatever the timing. In lockstep
each step feeds the core the newest encoder and base-rate samples at the step's stamp; in
free timing each is fed once, at its own stamp.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.timing.control_policy import ControlStep, FreeControl, LockstepControl, control_policy
from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.ros.input_kinds import InputKind
from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.node_edge import NodeEdge
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read

from . import messages as m
from .encoder_fusion import EncoderFusionController, EncoderFusionParams
from .encoder_fusion_controller_params import DESCRIPTION, PARAMS
from .wire import encoder_fusion_messages

#: An incomplete step this many steps older than a complete one is given up.
_STALE_STEPS = 1000
#: the inputs besides the gyro, each sampled slower than it: the host's rates and the encoders
_SAMPLED = (InputKind.HOST, InputKind.ENCODERS)
#: the node's own counters of inputs it could not use (/diagnostics, after the policy's)
COUNTERS = ("malformed", "rejected_no_rates", "rejected_nonfinite", "rejected_joint_names")
ZERO = (0.0, 0.0)


class EncoderFusionControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("encoder_fusion_controller", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        timing = values["timing"]
        self.enc_every = steps_per_sample(values, "encoder_rate_hz")
        self.base_every = steps_per_sample(values, "base_rate_hz")
        self.rate = rate = values["sim_rate_hz"]
        self.core = EncoderFusionController(EncoderFusionParams.from_values(values))
        clock_jump_s = values["clock_jump_s"]
        self._kf_updates = 0
        self.held = 0  # steps whose command was held (bad or missing input)
        self.edge = edge = NodeEdge(self, values, COUNTERS)
        edge.pubs["/gimbal/torque_cmd"] = edge.io.advertise_command(JointState, "/gimbal/torque_cmd", values)
        edge.advertise_all(((Vector3Stamped, "~/feedback_velocity"), (Vector3Stamped, "~/drift_correction")))
        # the one choice of timing (module docstring). Lockstep: a complete step runs at once,
        # so an older step still waiting for a lost input cannot stall the loop behind it.
        max_age_s = values["max_input_age_s"]
        self.policy = control_policy(
            timing,
            lockstep=lambda: LockstepControl(self._needs, rate, clock_jump_s, eager_stale_steps=_STALE_STEPS,
                                             sample_hold=_SAMPLED, stamp_time=True, logger=self.get_logger()),
            free=lambda: FreeControl(InputKind.GYRO, {InputKind.ENCODERS: max_age_s, InputKind.HOST: max_age_s},
                                     1.0 / rate, clock_jump_s, once=_SAMPLED, finite=_SAMPLED,
                                     on_nonfinite=lambda kind: edge.reject("rejected_nonfinite",
                                                                           f"non-finite {kind} sample; not fused"),
                                     warn=edge.warn))
        edge.advertise_diagnostics(self.policy)
        edge.subscribe_all(((InputKind.GYRO, Imu, "/gimbal/imu"), (InputKind.HOST, Imu, "/truth/host/imu"),
                            (InputKind.ENCODERS, JointState, "/gimbal/joint_states")), self._on_input)

    def _hold(self, step: ControlStep, why: str) -> tuple[float, float]:
        self.held += 1
        self.edge.warn(f"step at {step.t:.6f} s: {why}; holding the last command ({self.held} held)")
        return self.core.command

    def _needs(self, step: int) -> tuple[str, ...]:
        """The inputs step ``step`` waits for: the gyro, and the encoders and base rates at
        the steps where they sample."""
        return ((InputKind.GYRO,) + ((InputKind.ENCODERS,) if step % self.enc_every == 0 else ())
                + ((InputKind.HOST,) if step % self.base_every == 0 else ()))

    def _on_input(self, kind: str, msg) -> None:
        for step in self.policy.add(kind, m.stamp_ns(msg.header.stamp), self._validate(kind, msg)):
            self._step(step)

    def _validate(self, kind: str, msg):
        """What the loop takes from a message, or None (counted) when it cannot be used; a
        gyro NaN is the core's to reject (it holds the command)."""
        if kind == InputKind.ENCODERS:
            readings = m.encoder_readings(msg)
            if readings is None:
                return self.edge.reject("rejected_joint_names", f"encoders without {m.GIMBAL_ENCODER_JOINTS}")
            return readings[0][1], readings[0][2]
        if not (m.gyro_qr_provided if kind == InputKind.GYRO else m.field_provided)(msg.angular_velocity_covariance):
            return self.edge.reject("rejected_no_rates", f"{kind} angular velocity marked not provided; not fused")
        w = msg.angular_velocity
        return (w.y, w.z) if kind == InputKind.GYRO else (w.x, w.y, w.z)  # gyro: (q, r)

    def _step(self, step: ControlStep) -> None:
        core, inputs = self.core, step.inputs
        for reason in step.resets:
            core.reset(reason)
        t_ns = step.stamp_ns
        feedback = None
        if step.zero_command:
            tau = ZERO
        elif None in inputs.values():
            tau = self._hold(step, "encoder joints or base rates missing")
        else:
            base, enc, gyro = inputs.get(InputKind.HOST), inputs.get(InputKind.ENCODERS), inputs[InputKind.GYRO].value
            out = core.tick(step.t, gyro[0], gyro[1], base, None if enc is None else (enc.t, *enc.value))
            if out is None:  # before the core has base rates and encoder angles
                tau = self._hold(step, "base rates or encoder angles not in yet")
            elif out.held:
                self.edge.reject("rejected_nonfinite", "non-finite measurement")
                tau = self._hold(step, "non-finite measurement")
            else:
                tau = (out.torque_azimuth, out.torque_elevation)
                feedback = (out.velocity_q, out.velocity_r)
        correction = None
        if self.core.kf_q.updates != self._kf_updates:
            self._kf_updates = self.core.kf_q.updates
            correction = self.core.corrections
        # serialized by gimbal_control.wire (the engine writes the same bytes into its bag)
        self.edge.publish(encoder_fusion_messages(t_ns, tau, feedback, correction))
        self.edge.diagnostics(t_ns, lambda: self.health(step))

    def health(self, step: ControlStep):
        """The /diagnostics message (:mod:`gimbal_kinematics.ros.diagnostics`)."""
        core = self.core
        fields = {**self.policy.counters(), **self.edge.counters(),
                  "held_commands": core.held_commands, "core_rejected_nonfinite": core.rejected_nonfinite,
                  "resets": len(core.reset_reasons)}
        return health_msg(step.stamp_ns, self.get_name(), fields, stale=step.zero_command)


def main(argv: list[str] | None = None) -> int:
    return run_node(EncoderFusionControllerNode, "encoder_fusion_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
