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
counted; one more than ``clock_jump_s`` back (a replayed bag looping) restarts the servo.

That is ``timing: lockstep`` (the orchestrator sets it). ``timing: free`` (the default, for a
driver or a bag) never waits: each platform gyro sample makes one command, stamped like it,
with the newest resolver sample no older than ``max_input_age_s``; a stale or missing one
zeroes the voltages, counted (:mod:`gimbal_kinematics.ros.free_loop` says why and what else is counted, on
``/diagnostics``).
"""
from __future__ import annotations

import sys

from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.sync import StepGroups
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.node_io import NodeIo
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read

from . import messages as m
from gimbal_kinematics.ros.free_loop import FreeLoop
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
        self.sync = StepGroups(self._needs, v["clock_jump_s"] * self.rate)
        self._ticks = 0
        self.rejected_resolvers = 0
        self._seen = (0, 0, 0)  # core counters already warned about
        self.timing = timing = v["timing"]
        self.io = NodeIo(self)
        self.pub = self.io.advertise(JointState, "/platform/voltage_cmd", timing)
        self.pub_error = self.io.advertise(JointState, "~/control_error", timing)
        self.pub_mod = self.io.advertise(JointState, "~/modulation", timing)
        on_input = self._on_input
        if timing == "free":
            self.free = FreeLoop(self, self.io, "imu", {"res": v["max_input_age_s"]}, 1.0 / v["imu_rate_hz"],
                                 v["clock_jump_s"], v["diagnostics_period_s"])
            self._fed_res: int | None = None
            on_input = self._on_free_input
        self.io.subscribe(Imu, "/platform/imu", lambda msg: on_input("imu", msg), timing)
        self.io.subscribe(JointState, "/platform/resolvers", lambda msg: on_input("res", msg), timing)
        if self.imu_every > 1 and timing == "lockstep":  # steps without a gyro sample still need their command
            self.io.subscribe(Clock, "/clock", lambda msg: self._on_input("clock", msg), timing)

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


    # ------------------------------------------------------------------ free timing
    def _on_free_input(self, kind: str, msg) -> None:
        free, core = self.free, self.core
        if kind == "res":
            value = m.platform_joint_positions(msg)
            if value is None:
                free.count("rejected_joint_names", "resolver message without the four platform joints")
                return
        else:
            if not m.field_provided(msg.angular_velocity_covariance):
                free.count("rejected_no_rates", "platform gyro angular velocity marked not provided; not fused")
                return
            value = m.vec_of(msg.angular_velocity)
        stamp = m.stamp_ns(msg.header.stamp)
        step = free.gate.add(kind, stamp, (stamp, value))
        if step is None:
            return
        out = None
        if not free.fresh(step, core.reset):
            volts = (0.0, 0.0, 0.0, 0.0)
            self._fed_res = None
        else:
            t_res, angles = step.inputs["res"]
            if step.restarted or self._fed_res is None or t_res > self._fed_res:
                self._fed_res = t_res
                core.on_resolvers(free.seconds(t_res), angles)  # the core counts a non-finite one
            out = core.on_gyro(step.t_ns * 1e-9, value)
            volts = out.voltages if out is not None else core.command_voltages
        self.pub.publish(m.platform_voltage_msg(stamp, volts))
        if out is not None:
            self._ticks += 1
            if (self._ticks - 1) % self.diag_every == 0:
                self.pub_error.publish(m.platform_control_error_msg(stamp, out.control_signals))
                self.pub_mod.publish(m.modulation_msg(stamp, out.phi_z, out.phi_z_rate))
        free.diagnostics(stamp, {"core_rejected_nonfinite": core.rejected_nonfinite, "held_commands":
                                 core.held_commands, "rejected_gimbal_lock": core.rejected_gimbal_lock})


def main(argv: list[str] | None = None) -> int:
    return run_node(PlatformServoNode, "platform_servo", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
