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
from gimbal_kinematics.params import steps_per_sample
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import StepGroups

from . import messages as m
from .los_hold import LosHold, LosHoldParams
from .los_rate_controller import LosRateController, LosRateControllerParams
from .los_rate_controller_params import DESCRIPTION, PARAMS


class LosRateControllerNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("los_rate_controller", **node_kwargs)
        v = declare_and_read(self, PARAMS)
        self.rate = v["sim_rate_hz"]
        self.ins_every = steps_per_sample(v, "ins_rate_hz")
        self.hold_mode = v["mode"] == "los_hold"
        params = LosRateControllerParams.from_values(v)
        self.feedback = params.feedback
        self.core = LosRateController(params)
        self.hold = LosHold(LosHoldParams.from_values(v)) if self.hold_mode else None
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
