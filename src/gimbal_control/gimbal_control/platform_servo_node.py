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
from gimbal_kinematics.params import Param, ParameterError, steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read

from . import messages as m
from .platform_servo import FrictionModel, PlatformServo, PlatformServoParams, platform_pid_gains

DESCRIPTION = (
    "Paper 3 four-gimbal platform servo: four PID loops (azimuth, inner roll, pitch, outer roll) on the "
    "emulated gyro pickoffs resolved through the gimbal angles (eq. 1), outer roll holding the inner roll "
    "at null, bidirectional azimuth modulation at +-1.2 deg/s with the integrator preset at reversals. "
    "Publishes /platform/voltage_cmd for each step."
)
INF = float("inf")
#: A loop's triple pole must stay below the control rate / this (at 1 kHz: 25 Hz, where the
#: Table 1 loops keep 33° of phase margin; the 12 Hz default keeps 51°, test_platform_servo).
BANDWIDTH_RATE_DIVISOR = 40.0

PARAMS = (
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]; one command per step", 1.0, 100000.0),
    Param("imu_rate_hz", 1000.0, "platform gyro rate [Hz] = the control rate (paper 3: 1 kHz); divides sim_rate_hz",
          1e-3, 100000.0),
    Param("resolver_rate_hz", 1000.0, "gimbal resolver rate [Hz]; divides sim_rate_hz", 1e-3, 100000.0),
    Param("lat_deg", 45.0, "site latitude for the earth-rate part of the command [deg]", -89.999, 89.999),
    Param("rotation", "bidirectional", "azimuth modulation: bidirectional (out through sweep_deg and back) "
          "or off (hold phi_z = 0)", choices=("bidirectional", "off")),
    Param("rate_deg_s", 1.2, "modulation rate [deg/s] (paper 3: 1.2)", 1e-6, 1000.0),
    Param("sweep_deg", 360.0, "sweep of one leg between reversals [deg]", 1e-6, 1e6),
    Param("reversal_time_s", 0.0, "duration of a reversal ramp [s] (0: instantaneous)", 0.0, 1e6),
    Param("azimuth_bandwidth_hz", 12.0, "azimuth loop pole-placement bandwidth (triple pole) [Hz]", 1e-3, 10000.0),
    Param("level_bandwidth_hz", 12.0, "inner-roll and pitch loop bandwidth (triple pole) [Hz]", 1e-3, 10000.0),
    Param("outer_roll_bandwidth_hz", 4.0, "outer-roll null loop bandwidth (triple pole) [Hz]", 1e-3, 10000.0),
    Param("outer_roll_derivative_tau_s", 0.005, "low-pass time constant of the outer-roll D term [s]", 0.0, 10.0),
    Param("preset_integrator", True, "preset the azimuth integrator at each reversal (paper 3)"),
    Param("friction_coulomb_nm", 0.01, "azimuth bearing Coulomb friction for the preset [N*m]", 0.0, INF),
    Param("friction_viscous_nm_s_rad", 5e-4, "azimuth bearing viscous friction for the preset [N*m*s/rad]", 0.0, INF),
    Param("friction_smoothing_rad_s", 0.01, "rate scale of the Coulomb tanh for the preset [rad/s]", 1e-9, INF),
    Param("drift_deg_h", [0.0, 0.0, 0.0], "platform drift estimate (the negative of the gyro rate bias, as "
          "platform_alignment's ~/gyro_drift) subtracted from the command, platform x, y, z [deg/h]"),
    Param("max_gap_s", 0.05, "a longer gap between gyro samples restarts the pickoff integration [s]", 1e-6, INF),
    Param("backward_jump_s", 1.0, "a stamp this far before the last one restarts the servo (bag loop) [s]", 1e-6, INF),
    Param("diagnostics_every_steps", 1, "publish ~/control_error and ~/modulation every N control ticks", 1, 10**6),
)


def params_from_values(v: dict) -> PlatformServoParams:
    """The core's parameters from the node's values; raises naming the parameter."""
    control_hz = v["imu_rate_hz"]
    for name in ("azimuth_bandwidth_hz", "level_bandwidth_hz", "outer_roll_bandwidth_hz"):
        if v[name] > control_hz / BANDWIDTH_RATE_DIVISOR:
            raise ParameterError(f"parameter {name!r} = {v[name]} Hz is above imu_rate_hz/{BANDWIDTH_RATE_DIVISOR:g} "
                                 f"= {control_hz / BANDWIDTH_RATE_DIVISOR:g} Hz: the sampled loop loses its margin")
    if len(v["drift_deg_h"]) != 3:
        raise ParameterError(f"parameter 'drift_deg_h' needs 3 values (x, y, z), got {v['drift_deg_h']}")
    try:
        return PlatformServoParams(
            lat_deg=v["lat_deg"], rate_deg_s=v["rate_deg_s"], sweep_deg=v["sweep_deg"],
            reversal_time_s=v["reversal_time_s"], rotate=v["rotation"] == "bidirectional",
            azimuth_pid=platform_pid_gains("a", v["azimuth_bandwidth_hz"]),
            inner_roll_pid=platform_pid_gains("q", v["level_bandwidth_hz"]),
            pitch_pid=platform_pid_gains("p", v["level_bandwidth_hz"]),
            outer_roll_pid=platform_pid_gains("r", v["outer_roll_bandwidth_hz"], v["outer_roll_derivative_tau_s"]),
            preset_integrator=v["preset_integrator"],
            friction=FrictionModel(coulomb_nm=v["friction_coulomb_nm"],
                                   viscous_nm_s_rad=v["friction_viscous_nm_s_rad"],
                                   smoothing_rad_s=v["friction_smoothing_rad_s"]),
            drift_deg_h=tuple(v["drift_deg_h"]), max_gap_s=v["max_gap_s"], backward_jump_s=v["backward_jump_s"])
    except ValueError as exc:
        raise ParameterError(str(exc)) from exc


class PlatformServoNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("platform_servo", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.rate = v["sim_rate_hz"]
        self.imu_every = steps_per_sample(v, "imu_rate_hz")
        self.res_every = steps_per_sample(v, "resolver_rate_hz")
        self.core = PlatformServo(params_from_values(v))
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
