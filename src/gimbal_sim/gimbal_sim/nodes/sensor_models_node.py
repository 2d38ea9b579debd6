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

from gimbal_kinematics.maths.rotations import euler321_from_quat
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros import wire as w
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
from .wire import noise_covariances, sensor_messages
from ..world.sensor_suite import SensorSuite, SensorSuiteConfig
from ..world.vehicle import VehicleTruth

#: Truth topic -> message type; which ones a run needs follows from the enabled sensors.
TRUTH_TOPICS = {
    "/truth/host/imu": Imu,
    "/truth/host/delta_angle": Vector3Stamped,
    "/truth/gimbal/imu": Imu,
    "/truth/gimbal/joint_states": JointState,
    "/truth/platform/imu": Imu,
    "/truth/platform/joint_states": JointState,
}
_DECODERS = {Imu: m.imu_from_cdr, JointState: m.joint_state_from_cdr, Vector3Stamped: m.vector3_stamped_from_cdr}
NEEDS = {
    "ins": ("/truth/host/imu",),
    "gimbal_gyro": ("/truth/gimbal/imu",),
    "encoders": ("/truth/gimbal/joint_states",),
    "lgu": ("/truth/host/delta_angle",),
    "platform_imu": ("/truth/platform/imu",),
    "free_gyro": ("/truth/host/imu", "/truth/host/delta_angle"),
    "resolvers": ("/truth/platform/joint_states",),
    "dtg": ("/truth/platform/imu", "/truth/platform/joint_states"),
}

#: sensor -> the topics (and types) its samples are published on (:func:`.wire.sensor_messages`)
SENSOR_TOPICS = {
    "ins": (("/ins/imu", w.IMU), ("/truth/ins/gyro_bias", w.VECTOR3_STAMPED)),
    "gimbal_gyro": (("/gimbal/imu", w.IMU), ("/truth/gimbal/gyro_bias", w.VECTOR3_STAMPED)),
    "encoders": (("/gimbal/joint_states", w.JOINT_STATE),),
    "lgu": (("/ship/lgu1/imu", w.IMU), ("/ship/lgu2/imu", w.IMU), ("/truth/ship/flexure", w.VECTOR3_STAMPED),
            ("/truth/ship/flexure_quasi_static", w.VECTOR3_STAMPED)),
    "platform_imu": (("/platform/imu", w.IMU), ("/truth/platform/accel_bias", w.VECTOR3_STAMPED),
                     ("/truth/platform/gyro_bias", w.VECTOR3_STAMPED)),
    "free_gyro": (("/free_gyro/spin_axis_a", w.VECTOR3_STAMPED), ("/free_gyro/spin_axis_b", w.VECTOR3_STAMPED),
                  ("/free_gyro/imu", w.IMU), ("/truth/free_gyro/position", w.NAVSAT_FIX),
                  ("/truth/free_gyro/triad_bias", w.VECTOR3_STAMPED), ("/free_gyro/velocity", w.VECTOR3_STAMPED)),
    "resolvers": (("/platform/resolvers", w.JOINT_STATE),),
    "dtg": (("/platform/dtg_pickoffs", w.JOINT_STATE),),
}
_TYPES = {w.IMU: Imu, w.JOINT_STATE: JointState, w.VECTOR3_STAMPED: Vector3Stamped, w.NAVSAT_FIX: NavSatFix}


def truth_from_group(k: int, t: float, group: dict) -> VehicleTruth:
    """A :class:`VehicleTruth` holding what the subscribed truth topics carry."""
    host = group.get("/truth/host/imu")
    plant = group.get("/truth/gimbal/imu") or group.get("/truth/platform/imu")
    joints = group.get("/truth/gimbal/joint_states") or group.get("/truth/platform/joint_states")
    delta = group.get("/truth/host/delta_angle")
    return VehicleTruth(
        k=k, t=t,
        euler=euler321_from_quat(m.quat_of(host)) if host is not None else (0.0, 0.0, 0.0),
        quat_nb=m.quat_of(host) if host is not None else None,
        omega_ib_b=m.vec_of(host.angular_velocity) if host is not None else None,
        specific_force_b=m.vec_of(host.linear_acceleration) if host is not None else None,
        delta_angle_b=m.vec_of(delta.vector) if delta is not None else None,
        joint_names=tuple(joints.name) if joints is not None else (),
        joint_position=tuple(joints.position) if joints is not None else (),
        joint_velocity=tuple(joints.velocity) if joints is not None else (),
        joint_effort=tuple(joints.effort) if joints is not None else (),
        quat_nm=m.quat_of(plant) if plant is not None else None,
        omega_im_m=m.vec_of(plant.angular_velocity) if plant is not None else None,
        specific_force_m=m.vec_of(plant.linear_acceleration) if plant is not None else None,
    )


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
        self.pubs = {topic: self.create_publisher(_TYPES[type_name], topic, GRAPH_QOS)
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
            msg = _DECODERS[TRUTH_TOPICS[topic]](data)
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
