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
"""
from __future__ import annotations

import math
import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.params import Param, ParameterError, steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import StepGroups

from . import messages as m
from .los_hold import LosHold, LosHoldParams
from .los_rate_controller import LosRateController, LosRateControllerParams

DESCRIPTION = (
    "Paper 1 LOS rate stabilization controller: dynamic inversion of the linearized gimbal and a PI "
    "on the inertial LOS rate error (k_p = 2 zeta omega_n, k_i = omega_n^2), torque saturation with "
    "anti-windup, optional gyro-bias feedback. Publishes /gimbal/torque_cmd for each step."
)
PARAMS = (
    Param("sim_rate_hz", 1000.0, "lockstep rate [Hz]; the controller runs once per step", 1.0, 100000.0),
    Param("ins_rate_hz", 100.0, "INS output rate [Hz] (the controller waits for it at its steps)", 1e-3, 100000.0),
    Param("omega_n_hz", 25.0, "closed-loop natural frequency omega_n [Hz] (< sim_rate_hz / 4)", 1e-3, 25000.0),
    Param("zeta", 0.8, "damping ratio zeta [-]", 1e-3, 10.0),
    Param("feedback", False, "subtract the gyro-bias estimate from the gyro rates (waits for it at INS steps)"),
    Param("bias_topic", "/gyro_bias_ekf/bias", "gyro-bias estimate topic (geometry_msgs/Vector3Stamped) [rad/s]"),
    Param("mode", "rate", "rate: paper 1's LOS rate loop; los_hold: plus an outer loop holding the LOS at its "
          "initial inertial direction on the EKF attitude estimate (implies feedback)", choices=("rate", "los_hold")),
    Param("attitude_topic", "/gyro_bias_ekf/attitude", "EKF attitude estimate C(n,m) (sensor_msgs/Imu) for los_hold"),
    Param("hold_gain_1_s", 0.5, "los_hold outer-loop gain (bandwidth) [1/s]", 1e-6, 1e3),
    Param("hold_max_rate_deg_s", 1.0, "los_hold rate command limit [deg/s]", 1e-6, 1e3),
    Param("hold_capture_s", 5.0, "los_hold: capture the initial LOS this long after the first estimate [s]", 0.0, 1e4),
    Param("lat_deg", 0.0, "site latitude [deg] (earth rate of the los_hold inertial target)", -89.999, 89.999),
    Param("earth_rate", True, "los_hold: the inertial target turns with the earth as seen from NED"),
    Param("anti_windup", "clamp", "integrator anti-windup", choices=("clamp", "conditional", "none")),
    Param("integrator_limit_factor", 4.0, "clamp bound of the integral term, in torque limits [-]", 1e-3, 1e3),
    Param("trim", True, "feed forward the gravity trim torque of the linearisation point"),
)


def core_params(v: dict) -> LosRateControllerParams:
    """The core's frozen parameters from the node's values (``ParameterError`` names the
    culprit); ``mode: los_hold`` implies bias feedback."""
    try:
        return LosRateControllerParams(
            rate_hz=v["sim_rate_hz"], omega_n_hz=v["omega_n_hz"], zeta=v["zeta"],
            feedback=v["feedback"] or v["mode"] == "los_hold", anti_windup=v["anti_windup"],
            integrator_limit_factor=v["integrator_limit_factor"], trim=v["trim"])
    except ValueError as exc:
        raise ParameterError(f"parameter {exc}") from exc


def hold_params(v: dict) -> LosHoldParams:
    """The LOS-hold outer loop's parameters from the node's values."""
    try:
        return LosHoldParams(gain_1_s=v["hold_gain_1_s"], max_rate_deg_s=v["hold_max_rate_deg_s"],
                             capture_s=v["hold_capture_s"], lat_deg=v["lat_deg"], earth_rate=v["earth_rate"])
    except ValueError as exc:
        raise ParameterError(f"parameter {exc}") from exc


class LosRateControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("los_rate_controller", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.rate = v["sim_rate_hz"]
        self.ins_every = steps_per_sample(v, "ins_rate_hz")
        self.hold_mode = v["mode"] == "los_hold"
        params = core_params(v)
        self.feedback = params.feedback
        self.core = LosRateController(params)
        self.hold = LosHold(hold_params(v)) if self.hold_mode else None
        # What an INS step waits for besides the sensors.
        self._estimates = (("bias",) if self.feedback else ()) + (("att",) if self.hold_mode else ())
        self._ins_step_needs = ("gyro", "enc", "ins") + self._estimates
        # a step back of more than reset_backjump_s is a bag loop: start over (the core resets on the stamp)
        self.sync = StepGroups(self._needs, params.reset_backjump_s * self.rate)
        self._ins_rates: tuple[float, float, float] | None = None
        self.rejected = 0
        self.pub = self.create_publisher(JointState, "/gimbal/torque_cmd", GRAPH_QOS)
        # taken serialized and decoded here (messages.*_from_cdr): no message objects per step
        imu, joints, vec = m.imu_from_cdr, m.joint_state_from_cdr, m.vector3_stamped_from_cdr
        self.create_subscription(Imu, "/gimbal/imu", lambda data: self._on_input("gyro", data, imu), GRAPH_QOS,
                                 raw=True)
        self.create_subscription(JointState, "/gimbal/joint_states",
                                 lambda data: self._on_input("enc", data, joints), GRAPH_QOS, raw=True)
        self.create_subscription(Imu, "/ins/imu", lambda data: self._on_input("ins", data, imu), GRAPH_QOS, raw=True)
        if self.feedback:
            self.create_subscription(Vector3Stamped, v["bias_topic"], lambda data: self._on_input("bias", data, vec),
                                     GRAPH_QOS, raw=True)
        if self.hold_mode:
            self.create_subscription(Imu, v["attitude_topic"], lambda data: self._on_input("att", data, imu),
                                     GRAPH_QOS, raw=True)

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
            self._ins_rates = group["ins"].angular_velocity
        readings = m.encoder_readings(group["enc"])
        if readings is None or self._ins_rates is None:
            self._warn(f"step {k}: encoder joints or INS rates missing; holding the last command")
            tau = self.core.command
        else:
            gyro = group["gyro"].angular_velocity  # (x, y, z); x, the roll axis, is not measured
            before = self.core.rejected_inputs
            tau = self.core.step(k / self.rate, gyro[1:], readings[0], readings[1], self._ins_rates)
            if self.core.rejected_inputs > before:
                self._warn(f"step {k}: non-finite measurement; holding the last command")
        self.pub.publish(m.torque_command_cdr(m.step_stamp_ns(k, self.rate), tau))


def main(argv: list[str] | None = None) -> int:
    return run_node(LosRateControllerNode, "los_rate_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
