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
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import StepGroups

from . import messages as m
from gimbal_kinematics.ros.free_loop import FreeLoop
from .los_hold import LosHold, LosHoldParams
from .los_rate_controller import LosRateController, LosRateControllerParams
from .los_rate_controller_params import DESCRIPTION, PARAMS


class LosRateControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("los_rate_controller", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.timing = timing = v["timing"]
        self.rate = v["sim_rate_hz"]
        self.hold_mode = v["mode"] == "los_hold"
        params = LosRateControllerParams.from_values(v)
        self.feedback = params.feedback
        self.core = LosRateController(params)
        self.hold = LosHold(LosHoldParams.from_values(v)) if self.hold_mode else None
        self.rejected = 0
        self.io = NodeIo(self)
        self.pub = self.io.advertise(JointState, "/gimbal/torque_cmd", timing)
        # taken serialized and decoded here (messages.*_from_cdr): no message objects per step
        imu, joints, vec = m.imu_from_cdr, m.joint_state_from_cdr, m.vector3_stamped_from_cdr
        inputs = [("gyro", Imu, "/gimbal/imu", imu), ("enc", JointState, "/gimbal/joint_states", joints),
                  ("ins", Imu, "/ins/imu", imu)]
        if self.feedback:
            inputs.append(("bias", Vector3Stamped, v["bias_topic"], vec))
        if self.hold_mode:
            inputs.append(("att", Imu, v["attitude_topic"], imu))
        self.ins_every = steps_per_sample(v, "ins_rate_hz")
        if timing == "lockstep":
            # What an INS step waits for besides the sensors.
            self._estimates = (("bias",) if self.feedback else ()) + (("att",) if self.hold_mode else ())
            self._ins_step_needs = ("gyro", "enc", "ins") + self._estimates
            # a step back of more than clock_jump_s is a bag loop: start over (the core resets on the stamp)
            self.sync = StepGroups(self._needs, params.clock_jump_s * self.rate)
            self._ins_rates: tuple[float, float, float] | None = None
            on_input = self._on_input
        else:
            ages = {kind: v["max_estimate_age_s"] if kind in ("bias", "att") else v["max_input_age_s"]
                    for kind, *_ in inputs[1:]}
            self.free = FreeLoop(self, self.io, "gyro", ages, 1.0 / self.rate, params.clock_jump_s,
                                 v["diagnostics_period_s"], held=tuple(k for k in ("bias", "att") if k in ages))
            on_input = self._on_free_input
        for kind, msg_type, topic, decode in inputs:
            self.io.subscribe(msg_type, topic, lambda data, k=kind, d=decode: on_input(k, data, d), timing, raw=True)

    def _warn(self, text: str) -> None:
        self.rejected += 1
        self.get_logger().warning(f"{text} ({self.rejected} rejected)", throttle_duration_sec=1.0)

    def _use_estimates(self, group: dict) -> None:
        bias, att = group.get("bias"), group.get("att")
        if bias is not None and not self.core.set_bias_estimate(bias.stamp_ns * 1e-9, bias.vector):
            self._warn("non-finite gyro-bias estimate ignored")
        if att is not None and self.hold is not None:
            q = att.orientation
            if att.orientation_covariance[0] == -1.0 or not all(map(math.isfinite, q)):
                self._warn("attitude estimate not available; holding the LOS-hold rate command")
            else:
                self.core.set_rate_command(*self.hold.update(att.stamp_ns * 1e-9, q,
                                                             self.core.bias_estimate_qr))

    def _needs(self, step: int) -> tuple[str, ...]:
        """The inputs step ``step`` waits for: gyro and encoders, at INS steps also the INS
        and the estimates in use."""
        return self._ins_step_needs if step % self.ins_every == 0 else ("gyro", "enc")

    def _on_input(self, kind: str, data: bytes, decode) -> None:
        try:
            msg = decode(data)
        except CdrError as exc:
            self._warn(f"malformed {kind} message ignored: {exc}")
            return
        k = m.step_of_stamp(msg.stamp_ns, self.rate)
        if not self.sync.admit(kind, k):
            # Late or repeated input for a step already commanded: it cannot change that
            # command and must not block the steps after it.
            self._warn(f"{kind} input for step {k} after step {self.sync.last_step} was commanded; ignored")
            return
        if kind in ("bias", "att") and k % self.ins_every != 0:
            # An estimate off the INS steps (another estimator rate): use it as it comes.
            self._use_estimates({kind: msg})
            return
        for step, group in self.sync.add(kind, k, msg):
            self._control(step, group)

    def _control(self, k: int, group: dict) -> None:
        self._use_estimates(group)
        if "ins" in group:
            if m.field_provided(group["ins"].angular_velocity_covariance):
                self._ins_rates = group["ins"].angular_velocity
            else:
                self._warn(f"step {k}: INS angular velocity marked not provided; not used")
        readings = m.encoder_readings(group["enc"])
        if readings is None or self._ins_rates is None:
            self._warn(f"step {k}: encoder joints or INS rates missing; holding the last command")
            tau = self.core.command
        elif not m.gyro_qr_provided(group["gyro"].angular_velocity_covariance):
            self._warn(f"step {k}: gyro angular velocity marked not provided; holding the last command")
            tau = self.core.command
        else:
            gyro = group["gyro"].angular_velocity  # (x, y, z); x, the roll axis, is not measured
            before = self.core.rejected_inputs
            tau = self.core.step(k / self.rate, gyro[1:], readings[0], readings[1], self._ins_rates)
            if self.core.rejected_inputs > before:
                self._warn(f"step {k}: non-finite measurement; holding the last command")
        self.pub.publish(m.torque_command_cdr(m.step_stamp_ns(k, self.rate), tau))


    # ------------------------------------------------------------------ free timing
    def _usable(self, kind: str, msg):
        """What the loop takes from an input message, or None (counted) when it cannot be used."""
        if kind == "gyro":
            if not m.gyro_qr_provided(msg.angular_velocity_covariance):
                self.free.count("rejected_no_rates", "gyro angular velocity marked not provided; not fused")
                return None
            return msg.angular_velocity[1:]  # (q, r); x, the roll axis, is not measured
        if kind == "enc":
            readings = m.encoder_readings(msg)
            if readings is None:
                self.free.count("rejected_joint_names", f"encoder message without the joints {m.GIMBAL_ENCODER_JOINTS}")
                return None
            values = (*readings[0], *readings[1])
        elif kind == "ins":
            if not m.field_provided(msg.angular_velocity_covariance):
                self.free.count("rejected_no_rates", "INS angular velocity marked not provided; not fused")
                return None
            values = readings = msg.angular_velocity
        elif kind == "bias":
            values = readings = msg.vector
        else:  # att
            if not m.field_provided(msg.orientation_covariance):
                self.free.count("rejected_no_rates", "attitude estimate marked not provided; not fused")
                return None
            values = readings = msg.orientation
        if not all(map(math.isfinite, values)):
            self.free.count("rejected_nonfinite", f"non-finite {kind} sample; not fused")
            return None
        return readings

    def _on_free_input(self, kind: str, data: bytes, decode) -> None:
        try:
            msg = decode(data)
        except CdrError as exc:
            self.free.count("malformed", f"malformed {kind} message ignored: {exc}")
            return
        value = self._usable(kind, msg)
        if value is None:
            return
        free = self.free
        gate = free.gate
        accepted = gate.accepted[kind]
        step = gate.add(kind, msg.stamp_ns, (msg.stamp_ns, value))
        if kind == "att" and gate.accepted[kind] > accepted and self.hold is not None:
            # the outer loop runs on each new attitude estimate
            self.core.set_rate_command(*self.hold.update(free.seconds(msg.stamp_ns), value,
                                                         self.core.bias_estimate_qr))
        if step is None:
            return
        core = self.core
        if free.fresh(step, core.reset):
            (angles, rates), ins = step.inputs["enc"][1], step.inputs["ins"][1]
            bias = step.inputs.get("bias")
            if bias is not None and "bias" not in step.stale:  # a stale one is already the core's
                core.set_bias_estimate(free.seconds(bias[0]), bias[1])
            before = core.rejected_inputs
            tau = core.step(step.t_ns * 1e-9, value, angles, rates, ins)
            if core.rejected_inputs > before:
                free.count("rejected_nonfinite", "non-finite gyro sample; holding the last command")
        else:
            tau = (0.0, 0.0)
        self.pub.publish(m.torque_command_cdr(msg.stamp_ns, tau))
        free.diagnostics(msg.stamp_ns, {"saturated_steps": core.saturated_steps, "singular_steps": core.singular_steps,
                                        "rejected_bias": core.rejected_bias, "resets": core.resets})


def main(argv: list[str] | None = None) -> int:
    return run_node(LosRateControllerNode, "los_rate_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
