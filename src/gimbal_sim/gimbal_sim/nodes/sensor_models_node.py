"""``sensor_models`` node: the :class:`.sensor_suite.SensorSuite` on the vehicle's truth.

It gathers the truth topics of each step (exact stamp match), runs the enabled sensors and
publishes their measurements stamped with the step's time. See the topic table in docs/interfaces.md.

With ``dtg`` the step also needs the platform servo's torquer currents stamped one step
before (``dtg_torquer_topic``), the currents the torquing electronics held over the step
that ends here: a complete truth step waits for them, so a run is deterministic whatever
order the two topics arrive in.
"""
from __future__ import annotations

import sys

from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.node_edge import publish_progress
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.maths.frames import DTG_TORQUER_JOINTS
from gimbal_kinematics.timing.stamps import progress_stamp_ns, step_stamp_ns
from gimbal_kinematics.params.table import topic_counts
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.timing.sync import StampSync
from .sensor_models_params import DESCRIPTION, PARAMS
from .sensor_truth import DECODERS, NEEDS, SENSOR_TOPICS, TRUTH_TOPICS, TYPES, truth_from_group
from .wire import noise_covariances, sensor_messages
from ..world.sensor_suite import SensorSuite, SensorSuiteConfig

class SensorModelsNode(Node):
    def __init__(self, **node_kwargs) -> None:
        super().__init__("sensor_models", **node_kwargs)
        values = declare_and_read(self, PARAMS)
        self.config = SensorSuiteConfig.from_values(values)
        self.suite = SensorSuite(self.config)
        self.rate = self.config.sim_rate_hz
        topics = sorted({t for s in self.config.sensors for t in NEEDS[s]})
        self.sync = StampSync(topics)
        self.rejected_truth = 0
        # taken serialized and decoded here (messages.*_from_cdr): no message objects per step
        self.subs = [self.create_subscription(TRUTH_TOPICS[t], t, lambda data, t=t: self._on_truth(t, data), GRAPH_QOS,
                                              raw=True) for t in topics]
        on = set(self.config.sensors)
        # dtg: torquer currents by stamp, and the complete truth step (stamp, group) waiting for those of k - 1
        self.dtg = "dtg" in on
        self._currents: dict[int, tuple[float, float, float]] = {}
        self._waiting: tuple[int, dict] | None = None
        if self.dtg:
            self.subs.append(self.create_subscription(JointState, values["dtg_torquer_topic"], self._on_torquer,
                                                      GRAPH_QOS, raw=True))
        self.free_gyro_velocity = bool(values["free_gyro_publish_velocity"])
        self.pubs = {topic: self.create_publisher(TYPES[type_name], topic, GRAPH_QOS)
                     for sensor in SENSOR_TOPICS if sensor in on for topic, type_name in SENSOR_TOPICS[sensor]
                     if topic != "/free_gyro/velocity" or self.free_gyro_velocity}
        self._noise_cov = noise_covariances(self.config)
        self.progress_every = values["progress_every_steps"]
        self.wait_for_subscribers = values["wait_for_subscribers"]
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        outputs = list(self.pubs.values())
        counts = topic_counts(values["subscriber_counts"], "subscriber_counts", [p.topic_name for p in outputs])
        announce_when_connected(self, self.pub_progress, outputs=outputs, readers=self.wait_for_subscribers,
                                counts=counts)

    def _on_truth(self, topic: str, data: bytes) -> None:
        try:
            msg = DECODERS[TRUTH_TOPICS[topic]](data)
        except CdrError as exc:
            self.rejected_truth += 1
            self.get_logger().warning(f"malformed truth on {topic}: {exc} ({self.rejected_truth} rejected)",
                                      throttle_duration_sec=1.0)
            return
        t_ns = msg.stamp_ns
        group = self.sync.add(topic, t_ns, msg)
        if group is not None:
            self._step(t_ns, group)

    def _on_torquer(self, data: bytes) -> None:
        try:
            msg = m.joint_state_from_cdr(data)
        except CdrError as exc:
            msg = None
            why = str(exc)
        if msg is not None:
            currents = dict(zip(msg.name, msg.effort))
            why = "" if all(j in currents for j in DTG_TORQUER_JOINTS) else f"no efforts of {list(DTG_TORQUER_JOINTS)}"
        if why:
            self.rejected_truth += 1
            self.get_logger().warning(f"malformed torquer currents: {why} ({self.rejected_truth} rejected)",
                                      throttle_duration_sec=1.0)
            return
        for old in [s for s in self._currents if s < msg.stamp_ns]:  # a step takes the currents of the one before
            del self._currents[old]
        self._currents[msg.stamp_ns] = tuple(float(currents[j]) for j in DTG_TORQUER_JOINTS)
        if self._waiting is not None:
            t_ns, group = self._waiting
            self._waiting = None
            self._step(t_ns, group)

    def _step(self, t_ns: int, group: dict) -> None:
        """The sensors of the step stamped ``t_ns`` (its truth ``group``); with ``dtg``, kept
        until the torquer currents of the step before have come."""
        k = m.step_of_stamp(t_ns, self.rate)
        currents = None
        if self.dtg and k > 0:
            currents = self._currents.get(step_stamp_ns(k - 1, self.rate))
            if currents is None:
                self._waiting = (t_ns, group)
                return
        try:
            samples = self.suite.update(truth_from_group(k, k / self.rate, group), currents)
        except ValueError as exc:
            self.rejected_truth += 1
            self.get_logger().warning(f"truth rejected: {exc} ({self.rejected_truth} rejected)",
                                      throttle_duration_sec=1.0)
            return
        for sample in samples:
            # serialized by nodes.wire (the engine writes the same bytes into its bag)
            for topic, _, data in sensor_messages(t_ns, sample, self._noise_cov, self.free_gyro_velocity):
                self.pubs[topic].publish(data)
        publish_progress(self.pub_progress, progress_stamp_ns(t_ns, self.rate, self.progress_every))


def main(argv: list[str] | None = None) -> int:
    return run_node(SensorModelsNode, "sensor_models", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
