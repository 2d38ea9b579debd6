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

With ``modulation_next: true`` it publishes at each gyro step k, on ``~/modulation_next``, φz
and φ̇z of its next gyro step, stamped with that step: the schedule is a function of time,
so the value is known a step ahead, and a navigator on φz (``azimuth_source: servo``) groups it
with its accelerometer sample of that step in lockstep, without a cycle (the servo's step
waits for the navigator's command, which waits for φz). The navigator's first sample has
none, so the first gyro step waits for no command (the core uses its internal one, counted).

Bad input: a NaN/inf gyro sample (or resolvers at gimbal lock) holds the last command; a
NaN/inf or malformed resolver sample is ignored (the last angles are kept); both are counted
and warned about at most once a second. A stamp at or before the last step is rejected and
counted; one more than ``clock_jump_s`` back (a replayed bag looping) restarts the servo.

With ``command_source: navigator`` the servo follows the navigator's command rate ω_c^n
(``/platform_navigator/command_rate``, Vector3Stamped, rad/s NED; remap it for another
navigator), handed to :meth:`.platform_servo.PlatformServo.on_command_rate` before the gyro
sample of its step: in lockstep the step also waits for the command stamped k at each gyro
step (the navigator answers every accelerometer sample, so its IMU rate must be the servo's);
in free timing the newest command is used as it arrives, and the core falls back to its
internal command when it is older than ``command_max_age_s`` (counted).

With ``gyro_source: dtg`` the loops close on paper 3's two DTGs instead of the gyro triad
(:mod:`.dtg_servo`): the pickoff angles (``/platform/dtg_pickoffs``, JointState positions
[rad] of ``dtg_lower_x``, ``_y``, ``dtg_upper_x``, ``_y``) take the gyro sample's place in
every step and tick, and each step also publishes, before its voltages, the torquer currents
(x_s, y_s, z_s) [A] that precess the gyros at the command rate on ``~/torquer_current``
(a sensor_msgs/JointState: joints ``dtg_torquer_x``, ``_y``, ``_z``, the currents as
efforts; the type the toolkit already uses for per-axis actuator commands, as the voltages).
``sensor_models`` holds them over the next step of the gyros.

That is ``timing: lockstep`` (the orchestrator sets it). ``timing: free`` (the default, for a
driver or a bag) never waits: each platform gyro sample makes one command, stamped like it,
with the newest resolver sample no older than ``max_input_age_s``; a stale or missing one
zeroes the voltages, counted (:mod:`gimbal_kinematics.timing.control_policy` says why and what else is counted, on
``/diagnostics``).

The node chooses its input policy once, in its constructor
(:mod:`gimbal_kinematics.timing.control_policy`); each input is validated once, as it arrives, and
every step the policy releases runs the same ``_step``, whatever the timing.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.maths.outcome import Fed
from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.ros.diagnostics import health_msg
from gimbal_kinematics.ros.node_edge import NodeEdge
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.timing.control_policy import ControlStep, FreeControl, LockstepControl, control_policy

from . import messages as m
from .dtg_servo import platform_servo_core
from .platform_servo_params import DESCRIPTION, PARAMS
from .wire import modulation_next, pickoff_angles, platform_servo_messages

#: the node's own counters of inputs it could not use (/diagnostics, after the policy's)
COUNTERS = ("malformed", "rejected_no_rates", "rejected_nonfinite", "rejected_joint_names", "rejected_pickoff_names")
ZERO = (0.0, 0.0, 0.0, 0.0)
#: the navigator's command rate (command_source: navigator)
NAVIGATOR_TOPIC = "/platform_navigator/command_rate"
#: gyro_source -> the input the loops close on: (kind, type, topic)
GYRO_INPUTS = {"rate_triad": ("imu", Imu, "/platform/imu"), "dtg": ("dtg", JointState, "/platform/dtg_pickoffs")}


class PlatformServoNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("platform_servo", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        timing = values["timing"]
        self.rate = values["sim_rate_hz"]
        self.imu_every = steps_per_sample(values, "imu_rate_hz")
        self.res_every = steps_per_sample(values, "resolver_rate_hz")
        self.dtg = values["gyro_source"] == "dtg"
        self.core = platform_servo_core(values)
        self.gyro_input = GYRO_INPUTS[values["gyro_source"]]
        self.gyro = self.gyro_input[0]
        self.follows_navigator = values["command_source"] == "navigator"
        self.diag_every, self.mod_next = values["diagnostics_every_steps"], values["modulation_next"]
        self._ticks = 0
        self.edge = edge = NodeEdge(self, values, COUNTERS)
        edge.pubs["/platform/voltage_cmd"] = edge.io.advertise_command(JointState, "/platform/voltage_cmd", values)
        edge.advertise_all(((JointState, "~/control_error"), (JointState, "~/modulation"))
                           + (((JointState, "~/torquer_current"),) if self.dtg else ())
                           + (((JointState, "~/modulation_next"),) if self.mod_next else ()))
        # the one choice of timing (module docstring); steps without a gyro sample tick on /clock
        nav_age = {"nav": values["command_max_age_s"]} if self.follows_navigator else {}
        self.policy = control_policy(
            timing,
            lockstep=lambda: LockstepControl(self._needs, self.rate, values["clock_jump_s"],
                                             ticks=("clock",) if self.imu_every > 1 else (),
                                             logger=self.get_logger()),
            free=lambda: FreeControl(self.gyro, {"res": values["max_input_age_s"], **nav_age},
                                     1.0 / values["imu_rate_hz"], values["clock_jump_s"], held=tuple(nav_age),
                                     once=("res", *nav_age), warn=edge.warn))
        edge.advertise_diagnostics(self.policy)
        edge.subscribe_all((self.gyro_input, ("res", JointState, "/platform/resolvers"))
                           + ((("nav", Vector3Stamped, NAVIGATOR_TOPIC),) if self.follows_navigator else ())
                           + tuple((tick, Clock, "/clock") for tick in self.policy.ticks), self._on_input)

    def _needs(self, k: int) -> tuple[str, ...]:
        if k % self.imu_every == 0:  # the first step of a servo feeding the navigator has no command
            need = (self.gyro, "nav") if self.follows_navigator and (k or not self.mod_next) else (self.gyro,)
        else:
            need = ("clock",)
        return need + ("res",) if k % self.res_every == 0 else need

    def _on_input(self, kind: str, msg) -> None:
        stamp = msg.clock if kind == "clock" else msg.header.stamp
        for step in self.policy.add(kind, m.stamp_ns(stamp), self._validate(kind, msg)):
            self._step(step)

    def _validate(self, kind: str, msg):
        """What the servo takes from an input message, or None (counted) when it cannot be
        used; a non-finite value is the core's to reject (counted there)."""
        if kind == "res":
            angles = m.platform_joint_positions(msg)
            if angles is None:
                self.edge.reject("rejected_joint_names", "resolver message without the four platform joints ignored")
            return angles
        if kind == "imu":
            if not m.field_provided(msg.angular_velocity_covariance):
                return self.edge.reject("rejected_no_rates", "platform gyro angular velocity marked not provided; "
                                        "not fused")
            return m.vec_of(msg.angular_velocity)
        if kind == "dtg":
            angles = pickoff_angles(msg.name, msg.position)  # non-finite: the core's to count
            return angles if angles is not None else self.edge.reject(
                "rejected_pickoff_names", "pickoff message without the four DTG pickoff angles ignored")
        if kind == "nav":
            return m.vec_of(msg.vector)  # a non-finite rate is the core's to count
        return msg  # a clock tick

    def _step(self, step: ControlStep) -> None:
        core, inputs = self.core, step.inputs
        for reason in step.resets:
            core.reset(reason)
        out = None
        if step.zero_command:
            volts = ZERO
        else:
            res, gyro, nav = inputs.get("res"), inputs.get(self.gyro), inputs.get("nav")
            fed = ((core.on_resolvers(res.t, res.value) if res is not None else None),
                   (core.on_command_rate(nav.t, nav.value) if nav is not None else None),
                   (self._tick(step.t, gyro.value) if gyro is not None else None))
            out = None if fed[2] is None else fed[2].output
            volts = out.voltages if out is not None else core.command_voltages
            why = "; ".join(f.why for f in fed if f is not None and f.why is not None)
            if why:
                self.edge.warn(f"step at {step.t:.6f} s: {why} ({core.rejected_nonfinite} non-finite samples "
                               f"rejected, {core.held_commands} commands held, {core.rejected_gimbal_lock} at gimbal lock)")
        t_ns = step.stamp_ns
        if out is not None:
            self._ticks += 1
        due = out is not None and (self._ticks - 1) % self.diag_every == 0
        nxt = modulation_next(core, step.t, self.imu_every, self.rate) if self.mod_next else None
        # serialized by gimbal_control.wire (the engine writes the same bytes into its bag)
        self.edge.publish(platform_servo_messages(t_ns, volts, out if due else None,
                                                  core.torquer_current if self.dtg else None, nxt))
        self.edge.diagnostics(t_ns, lambda: self.health(step))

    def _tick(self, t: float, value) -> Fed:
        """The control tick on the step's gyro sample: the triad's rates, or the DTG pickoffs."""
        if not self.dtg:
            return self.core.on_gyro(t, value)
        out = self.core.on_pickoffs(t, value[:2], value[2:])
        return Fed(out is not None, output=out)

    def health(self, step: ControlStep):
        """The /diagnostics message (:mod:`gimbal_kinematics.ros.diagnostics`)."""
        core = self.core
        fields = {**self.policy.counters(), **self.edge.counters(),
                  "core_rejected_nonfinite": core.rejected_nonfinite, "held_commands": core.held_commands,
                  "rejected_gimbal_lock": core.rejected_gimbal_lock}
        return health_msg(step.stamp_ns, self.get_name(), fields, stale=step.zero_command)


def main(argv: list[str] | None = None) -> int:
    return run_node(PlatformServoNode, "platform_servo", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
