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
one zeroes the command, counted (:mod:`gimbal_kinematics.ros.free_loop` says why and what else is counted, on
``/diagnostics``). The encoder angle is the newest sample's, not interpolated to the gyro
stamp: the filter's gate integrates the gyro between encoder stamps itself.
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import EagerStepGroups

from . import messages as m
from gimbal_kinematics.ros.free_loop import FreeLoop
from .encoder_fusion import EncoderFusionController, EncoderFusionParams
from .encoder_fusion_controller_params import DESCRIPTION, PARAMS

#: An incomplete step this many steps older than a complete one is given up.
_STALE_STEPS = 1000


class EncoderFusionControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("encoder_fusion_controller", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.enc_every = steps_per_sample(v, "encoder_rate_hz")
        self.base_every = steps_per_sample(v, "base_rate_hz")
        self.rate = v["sim_rate_hz"]
        self.core = EncoderFusionController(EncoderFusionParams.from_values(v))
        self.sync = EagerStepGroups(self._needs, _STALE_STEPS)
        self._omega_b: tuple[float, float, float] | None = None
        self._angles: tuple[float, float] | None = None
        self._kf_updates = 0
        self.held = 0  # steps whose command was held (bad or missing input)
        self.timing = timing = v["timing"]
        self.io = NodeIo(self)
        self.pub_cmd = self.io.advertise(JointState, "/gimbal/torque_cmd", timing)
        self.pub_feedback = self.io.advertise(Vector3Stamped, "~/feedback_velocity", timing)
        self.pub_correction = self.io.advertise(Vector3Stamped, "~/drift_correction", timing)
        on_input = self._on_input
        if timing == "free":
            p = self.core.params
            self.free = FreeLoop(self, self.io, "gyro", {"enc": v["max_input_age_s"], "base": v["max_input_age_s"]},
                                 1.0 / self.rate, p.clock_jump_s, v["diagnostics_period_s"])
            self._fed = {"enc": None, "base": None}  # stamps already given to the core
            on_input = self._on_free_input
        self.io.subscribe(Imu, "/gimbal/imu", lambda msg: on_input("gyro", msg), timing)
        self.io.subscribe(JointState, "/gimbal/joint_states", lambda msg: on_input("enc", msg), timing)
        self.io.subscribe(Imu, "/truth/host/imu", lambda msg: on_input("base", msg), timing)

    def _hold(self, k: int, why: str) -> None:
        self.held += 1
        self.get_logger().warning(f"step {k}: {why}; holding the last command ({self.held} held)",
                                  throttle_duration_sec=1.0)

    def _needs(self, step: int) -> tuple[str, ...]:
        """The inputs step ``step`` waits for: the gyro, and the encoders and base rates at
        the steps where they sample."""
        return (("gyro",) + (("enc",) if step % self.enc_every == 0 else ())
                + (("base",) if step % self.base_every == 0 else ()))

    def _on_input(self, kind: str, msg) -> None:
        k = m.step_of_stamp(m.stamp_ns(msg.header.stamp), self.rate)
        # A complete step runs at once: an older step still waiting for an input (lost, or a
        # stray message from another graph) must not stall the loop behind it. In lockstep the
        # steps complete in order anyway. Steps that stay incomplete are forgotten after a while.
        group = self.sync.add(kind, k, msg, self.get_logger())
        if group is not None:
            self._control(k, group)

    def _control(self, k: int, group: dict) -> None:
        t_ns = m.step_stamp_ns(k, self.rate)
        if "base" in group:
            self._omega_b = m.vec_of(group["base"].angular_velocity)
        if "enc" in group:
            readings = m.encoder_readings(group["enc"])
            self._angles = None if readings is None else (readings[0][1], readings[0][2])
        if self._omega_b is None or self._angles is None:
            self._hold(k, "encoder joints or base rates missing")
            tau = self.core.command
        else:
            gyro = group["gyro"].angular_velocity
            out = self.core.step(t_ns * 1e-9, self._omega_b, *self._angles, gyro.y, gyro.z)
            if out is None:
                self._hold(k, "input rejected (stamp out of order)")
                tau = self.core.command
            else:
                if out.held:
                    self._hold(k, "non-finite measurement")
                tau = (out.torque_azimuth, out.torque_elevation)
                self.pub_feedback.publish(m.gimbal_axes_msg(t_ns, out.velocity_q, out.velocity_r))
        self.pub_cmd.publish(m.torque_command_msg(t_ns, tau))
        updates = self.core.kf_q.updates
        if updates != self._kf_updates:
            self._kf_updates = updates
            self.pub_correction.publish(m.gimbal_axes_msg(t_ns, *self.core.corrections))


    # ------------------------------------------------------------------ free timing
    def _usable(self, kind: str, msg):
        """What the loop takes from a message, or None (counted) when it cannot be used."""
        count = self.free.count
        if kind == "enc":
            readings = m.encoder_readings(msg)
            if readings is None:
                count("rejected_joint_names", f"encoder message without the joints {m.GIMBAL_ENCODER_JOINTS}")
                return None
            value = (readings[0][1], readings[0][2])
        else:
            if not (m.gyro_qr_provided if kind == "gyro" else m.field_provided)(msg.angular_velocity_covariance):
                count("rejected_no_rates", f"{kind} angular velocity marked not provided; not fused")
                return None
            value = m.vec_of(msg.angular_velocity)
            if kind == "gyro":
                return value[1:]  # (q, r); NaN is the core's to reject (it holds the command)
        if not all(map(math.isfinite, value)):
            count("rejected_nonfinite", f"non-finite {kind} sample; not fused")
            return None
        return value

    def _on_free_input(self, kind: str, msg) -> None:
        value = self._usable(kind, msg)
        if value is None:
            return
        stamp = m.stamp_ns(msg.header.stamp)
        free, core = self.free, self.core
        step = free.gate.add(kind, stamp, (stamp, value))
        if step is None:
            return
        if not free.fresh(step, core.reset):
            tau = (0.0, 0.0)
            self._fed = {"enc": None, "base": None}
        else:
            if step.restarted:
                self._fed = {"enc": None, "base": None}
            for other, feed in (("base", core.on_base_rates), ("enc", lambda t, a: core.on_encoders(t, *a))):
                t_in, val = step.inputs[other]
                if self._fed[other] is None or t_in > self._fed[other]:
                    self._fed[other] = t_in
                    feed(free.seconds(t_in), val)
            out = core.on_gyro(step.t_ns * 1e-9, *value)
            if out is None or out.held:  # None: a stamp the core refused (counted there)
                if out is not None:
                    free.count("rejected_nonfinite", "non-finite gyro sample; holding the last command")
                tau = core.command
            else:
                tau = (out.torque_azimuth, out.torque_elevation)
                self.pub_feedback.publish(m.gimbal_axes_msg(stamp, out.velocity_q, out.velocity_r))
        self.pub_cmd.publish(m.torque_command_msg(stamp, tau))
        free.diagnostics(stamp, {"held_commands": core.held_commands, "core_rejected_nonfinite":
                                 core.rejected_nonfinite, "core_rejected_out_of_order": core.rejected_out_of_order,
                                 "resets": len(core.reset_reasons)})


def main(argv: list[str] | None = None) -> int:
    return run_node(EncoderFusionControllerNode, "encoder_fusion_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
