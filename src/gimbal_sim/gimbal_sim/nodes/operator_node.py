"""``operator`` node: the simulated sight operator (:class:`..world.operator_model.SightOperator`, or the scripted step :class:`..world.operator_model.StepStick`)
on the true LOS.

At every ``rate_hz`` step it takes ``/truth/gimbal/imu`` (C(n,m)) stamped k, decides, and
publishes the LOS rate command stamped k on ``/operator/los_rate`` (Vector3Stamped, sight
frame, rad/s: x = 0, y = q, z = r), which ``los_rate_controller`` waits for at the same
steps (its ``operator_rate_hz``), and the true pointing error on ``~/pointing_error``
(x = ε, y = e_q, z = e_r [rad]; NaN before the capture). It sees the truth, so it lives in
gimbal_sim. Lockstep only: it steps on the truth's stamps.
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu

from gimbal_kinematics.params.table import steps_per_sample
from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.node_edge import publish_progress
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.timing.stamps import progress_stamp_ns

from ..world.operator_model import operator_core
from .operator_params import DESCRIPTION, PARAMS
from .wire import operator_messages

class OperatorNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("operator", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.core = operator_core(values)
        self.rate = values["sim_rate_hz"]
        self.every = steps_per_sample(values, "rate_hz")
        self.progress_every = values["progress_every_steps"]
        self.rejected_truth = 0
        self.sub = self.create_subscription(Imu, "/truth/gimbal/imu", self._on_truth, GRAPH_QOS, raw=True)
        self.pub_cmd = self.create_publisher(Vector3Stamped, "/operator/los_rate", GRAPH_QOS)
        self.pub_err = self.create_publisher(Vector3Stamped, "~/pointing_error", GRAPH_QOS)
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        announce_when_connected(self, self.pub_progress, inputs=[self.sub], outputs=[self.pub_cmd, self.pub_err],
                                readers=values["wait_for_subscribers"])

    def _on_truth(self, data: bytes) -> None:
        try:
            msg = m.imu_from_cdr(data)
        except CdrError as exc:
            self.rejected_truth += 1
            self.get_logger().warning(f"malformed truth: {exc} ({self.rejected_truth} rejected)",
                                      throttle_duration_sec=1.0)
            return
        k = m.step_of_stamp(msg.stamp_ns, self.rate)
        if k % self.every == 0:
            q, r = self.core.step(msg.stamp_ns, msg.orientation)
            for topic, _, data in operator_messages(msg.stamp_ns, q, r, self.core.pointing_error()):  # as the engine writes them
                (self.pub_cmd if topic == "/operator/los_rate" else self.pub_err).publish(data)
        publish_progress(self.pub_progress, progress_stamp_ns(msg.stamp_ns, self.rate, self.progress_every))


def main(argv: list[str] | None = None) -> int:
    return run_node(OperatorNode, "operator", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
