"""``los_rate_controller`` node: paper 1's LOS rate stabilization (dynamic inversion + PI).

Per lockstep step k it needs the gimbal gyro (``/gimbal/imu``) and the encoders
(``/gimbal/joint_states``) stamped k and, at the steps where the INS samples, the INS
(``/ins/imu``) stamped k; it then publishes the torque command stamped k on
``/gimbal/torque_cmd``. Waiting for exactly those inputs (never "the latest that happened
to arrive") keeps a run deterministic. The gyro-bias estimate on ``bias_topic`` is
subtracted from the gyro when ``feedback`` is true.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from sensor_msgs.msg import Imu, JointState

from gimbal_sim.cdr import CdrError
from gimbal_sim.node_main import run_node
from gimbal_sim.qos import GRAPH_QOS
from gimbal_sim.ros_params import Param, ParameterError, declare_and_read

from . import messages as m
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
    Param("feedback", False, "subtract the gyro-bias estimate from the gyro rates"),
    Param("bias_topic", "/gyro_bias_ekf/bias", "gyro-bias estimate topic (geometry_msgs/Vector3Stamped) [rad/s]"),
    Param("anti_windup", "clamp", "integrator anti-windup", choices=("clamp", "conditional", "none")),
    Param("integrator_limit_factor", 4.0, "clamp bound of the integral term, in torque limits [-]", 1e-3, 1e3),
    Param("trim", True, "feed forward the gravity trim torque of the linearisation point"),
)


def core_params(v: dict) -> LosRateControllerParams:
    """The core's frozen parameters from the node's parameter values (raises naming the parameter)."""
    try:
        return LosRateControllerParams(
            rate_hz=v["sim_rate_hz"], omega_n_hz=v["omega_n_hz"], zeta=v["zeta"], feedback=v["feedback"],
            anti_windup=v["anti_windup"], integrator_limit_factor=v["integrator_limit_factor"], trim=v["trim"])
    except ValueError as exc:
        raise ParameterError(str(exc)) from exc


class LosRateControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("los_rate_controller", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.rate = v["sim_rate_hz"]
        ratio = self.rate / v["ins_rate_hz"]
        self.ins_every = int(round(ratio))
        if self.ins_every < 1 or abs(ratio - self.ins_every) > 1e-9 * ratio:
            raise ParameterError(f"parameter 'ins_rate_hz' = {v['ins_rate_hz']} Hz does not divide sim_rate_hz")
        self.core = LosRateController(core_params(v))
        self._pending: dict[int, dict[str, object]] = {}
        self._ins_rates: tuple[float, float, float] | None = None
        self.rejected = 0
        self.pub = self.create_publisher(JointState, "/gimbal/torque_cmd", GRAPH_QOS)
        # taken serialized and decoded here (messages.*_from_cdr): no message objects per step
        imu, joints = m.imu_from_cdr, m.joint_state_from_cdr
        self.create_subscription(Imu, "/gimbal/imu", lambda data: self._on_input("gyro", data, imu), GRAPH_QOS,
                                 raw=True)
        self.create_subscription(JointState, "/gimbal/joint_states",
                                 lambda data: self._on_input("enc", data, joints), GRAPH_QOS, raw=True)
        self.create_subscription(Imu, "/ins/imu", lambda data: self._on_input("ins", data, imu), GRAPH_QOS, raw=True)
        self.create_subscription(Vector3Stamped, v["bias_topic"], self._on_bias, GRAPH_QOS, raw=True)

    def _warn(self, text: str) -> None:
        self.rejected += 1
        self.get_logger().warning(f"{text} ({self.rejected} rejected)", throttle_duration_sec=1.0)

    def _on_bias(self, data: bytes) -> None:
        try:
            msg = m.vector3_stamped_from_cdr(data)
        except CdrError as exc:
            self._warn(f"malformed gyro-bias estimate ignored: {exc}")
            return
        if not self.core.set_bias_estimate(msg.stamp_ns * 1e-9, msg.vector):
            self._warn("non-finite gyro-bias estimate ignored")

    def _on_input(self, kind: str, data: bytes, decode) -> None:
        try:
            msg = decode(data)
        except CdrError as exc:
            self._warn(f"malformed {kind} message ignored: {exc}")
            return
        k = m.step_of_stamp(msg.stamp_ns, self.rate)
        self._pending.setdefault(k, {})[kind] = msg
        for step in sorted(self._pending):
            group = self._pending[step]
            if "gyro" not in group or "enc" not in group or (step % self.ins_every == 0 and "ins" not in group):
                break
            del self._pending[step]
            self._control(step, group)

    def _control(self, k: int, group: dict) -> None:
        if "ins" in group:
            self._ins_rates = group["ins"].angular_velocity
        readings = m.encoder_readings(group["enc"])
        if readings is None or self._ins_rates is None:
            self._warn(f"step {k}: encoder joints or INS rates missing; holding the last command")
            tau = self.core.command
        else:
            gyro = group["gyro"].angular_velocity
            before = self.core.rejected_inputs
            tau = self.core.step(k / self.rate, gyro[1:], readings[0], readings[1], self._ins_rates)
            if self.core.rejected_inputs > before:
                self._warn(f"step {k}: non-finite measurement; holding the last command")
        self.pub.publish(m.torque_command_cdr(m.step_stamp_ns(k, self.rate), tau))


def main(argv: list[str] | None = None) -> int:
    return run_node(LosRateControllerNode, "los_rate_controller", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
