"""``platform_servo`` node: paper 3's four-gimbal platform servo (:mod:`.platform_servo`).

Per lockstep step k it needs the platform gyro triad (``/platform/imu``, angular_velocity)
and the gimbal resolvers (``/platform/resolvers``) stamped k, each at the steps where it
samples (and ``/clock`` stamped k when the gyro does not sample every step); it then
publishes the four gimbal motor voltages stamped k on ``/platform/voltage_cmd``, which
``vehicle_dynamics`` (``controlled: true``) waits for. Waiting for exactly the inputs of
step k keeps a run deterministic.

For the report it also publishes, every ``diagnostics_every_steps`` steps:

* ``~/control_error`` (JointState, platform joints): the eq. 1 control signals
  (Δθ_am, Δθ_qm, Δθ_pm, Δθ_rm) [rad] as positions — the gyro pickoff angles resolved onto
  the gimbal axes, the paper's "control error";
* ``~/modulation`` (JointState, joint ``modulation_angle``): the commanded modulation angle
  φz [rad] (about NED down, from the first tick) and its rate φ̇z [rad/s].

Bad input: a NaN/inf gyro sample (or resolvers at gimbal lock) holds the last command; a
NaN/inf or malformed resolver sample is ignored (the last angles are kept); both are counted
and warned about at most once a second. A stamp at or before the last step is rejected and
counted; one more than ``backward_jump_s`` back (a replayed bag looping) restarts the servo.
"""
from __future__ import annotations

import sys

from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.sync import StepGroups
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read

from . import messages as m
from .platform_servo import PlatformServo, PlatformServoParams
from .platform_servo_params import DESCRIPTION, PARAMS


class PlatformServoNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("platform_servo", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.rate = v["sim_rate_hz"]
        self.imu_every = steps_per_sample(v, "imu_rate_hz")
        self.res_every = steps_per_sample(v, "resolver_rate_hz")
        self.core = PlatformServo(PlatformServoParams.from_values(v))
        self.diag_every = v["diagnostics_every_steps"]
        self.sync = StepGroups(self._needs, v["backward_jump_s"] * self.rate)
        self._ticks = 0
        self.rejected_resolvers = 0
        self._seen = (0, 0, 0)  # core counters already warned about
        self.pub = self.create_publisher(JointState, "/platform/voltage_cmd", GRAPH_QOS)
        self.pub_error = self.create_publisher(JointState, "~/control_error", GRAPH_QOS)
        self.pub_mod = self.create_publisher(JointState, "~/modulation", GRAPH_QOS)
        self.create_subscription(Imu, "/platform/imu", lambda msg: self._on_input("imu", msg), GRAPH_QOS)
        self.create_subscription(JointState, "/platform/resolvers", lambda msg: self._on_input("res", msg), GRAPH_QOS)
        if self.imu_every > 1:  # steps without a gyro sample still need their (held) command
            self.create_subscription(Clock, "/clock", lambda msg: self._on_input("clock", msg), GRAPH_QOS)

    def _warn(self, text: str) -> None:
        self.get_logger().warning(text, throttle_duration_sec=1.0)

    def _needs(self, k: int) -> tuple[str, ...]:
        need = ("imu",) if k % self.imu_every == 0 else ("clock",)
        return need + ("res",) if k % self.res_every == 0 else need

    def _on_input(self, kind: str, msg) -> None:
        stamp = msg.clock if kind == "clock" else msg.header.stamp
        k = m.step_of_stamp(m.stamp_ns(stamp), self.rate)
        if kind == "clock" and kind not in self._needs(k):
            return  # a step with a gyro sample ticks on the gyro
        groups = self.sync.add(kind, k, msg, self.get_logger())
        for step, group in groups:
            self._control(step, group)

    def _control(self, k: int, group: dict) -> None:
        t = k / self.rate
        core = self.core
        if "res" in group:
            angles = m.platform_joint_positions(group["res"])
            if angles is None:
                self.rejected_resolvers += 1
                self._warn(f"step {k}: resolver message without the four platform joints ignored "
                           f"({self.rejected_resolvers} rejected)")
            else:
                core.on_resolvers(t, angles)
        out = None
        if "imu" in group:
            w = group["imu"].angular_velocity
            out = core.on_gyro(t, (w.x, w.y, w.z))
        seen = (core.rejected_nonfinite, core.held_commands, core.rejected_gimbal_lock)
        if seen != self._seen:
            self._seen = seen
            self._warn(f"step {k}: bad measurement; {core.rejected_nonfinite} non-finite samples rejected, "
                       f"{core.held_commands} commands held, {core.rejected_gimbal_lock} at gimbal lock")
        t_ns = m.step_stamp_ns(k, self.rate)
        volts = out.voltages if out is not None else core.command_voltages
        self.pub.publish(m.platform_voltage_msg(t_ns, volts))
        if out is not None:
            self._ticks += 1
            if (self._ticks - 1) % self.diag_every == 0:
                self.pub_error.publish(m.platform_control_error_msg(t_ns, out.control_signals))
                self.pub_mod.publish(m.modulation_msg(t_ns, out.phi_z, out.phi_z_rate))


def main(argv: list[str] | None = None) -> int:
    return run_node(PlatformServoNode, "platform_servo", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
