"""``sensor_models`` node: the :class:`.sensor_suite.SensorSuite` on the vehicle's truth.

It gathers the truth topics of each step (exact stamp match), runs the enabled sensors and
publishes their measurements stamped with the step's time. See the topic table in docs/interfaces.md.
"""
from __future__ import annotations

import math
import sys

from gimbal_kinematics.rotations import euler321_from_quat, euler321_to_quat, quat_canonical, quat_from_euler321
from gimbal_kinematics.frames import BASE_FRAME, GIMBAL_FRAME, LGU1_FRAME, LGU2_FRAME, PLATFORM_FRAME
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState, NavSatFix

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.cdr import CdrError
from gimbal_kinematics.ros.node_main import run_node
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_kinematics.ros.readiness import announce_when_connected
from gimbal_kinematics.params import topic_counts
from gimbal_kinematics.ros.params import declare_and_read
from gimbal_kinematics.sync import StampSync
from .sensor_models_params import DESCRIPTION, PARAMS
from ..world.sensor_suite import (
    EncoderSample, GimbalGyroSample, InsSample, LguSample, PlatformImuSample, ResolverSample, SensorSuite,
    SensorSuiteConfig,
)
from ..world.sensors.free_gyro_sensor import FreeGyroSample
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
}


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
        pub = lambda typ, topic: self.create_publisher(typ, topic, GRAPH_QOS)  # noqa: E731
        self.pubs = {}
        if "ins" in on:
            self.pubs["ins"] = (pub(Imu, "/ins/imu"), pub(Vector3Stamped, "/truth/ins/gyro_bias"))
        if "gimbal_gyro" in on:
            self.pubs["gimbal_gyro"] = (pub(Imu, "/gimbal/imu"), pub(Vector3Stamped, "/truth/gimbal/gyro_bias"))
        if "encoders" in on:
            self.pubs["encoders"] = (pub(JointState, "/gimbal/joint_states"),)
        if "lgu" in on:
            self.pubs["lgu"] = (pub(Imu, "/ship/lgu1/imu"), pub(Imu, "/ship/lgu2/imu"),
                                pub(Vector3Stamped, "/truth/ship/flexure"),
                                pub(Vector3Stamped, "/truth/ship/flexure_quasi_static"))
        if "platform_imu" in on:
            self.pubs["platform_imu"] = (pub(Imu, "/platform/imu"), pub(Vector3Stamped, "/truth/platform/accel_bias"),
                                         pub(Vector3Stamped, "/truth/platform/gyro_bias"))
        if "free_gyro" in on:
            self.pubs["free_gyro"] = (pub(Vector3Stamped, "/free_gyro/spin_axis_a"),
                                      pub(Vector3Stamped, "/free_gyro/spin_axis_b"), pub(Imu, "/free_gyro/imu"),
                                      pub(NavSatFix, "/truth/free_gyro/position"),
                                      pub(Vector3Stamped, "/truth/free_gyro/triad_bias"))
            if values["free_gyro_publish_velocity"]:
                self.pubs["free_gyro_velocity"] = (pub(Vector3Stamped, "/free_gyro/velocity"),)
        if "resolvers" in on:
            self.pubs["resolvers"] = (pub(JointState, "/platform/resolvers"),)
        self._noise_cov = self._white_noise_covariances()
        self.progress_every = values["progress_every_steps"]
        self.wait_for_subscribers = values["wait_for_subscribers"]
        self.pub_progress = self.create_publisher(Clock, "~/progress", GRAPH_QOS)
        outputs = [p for group in self.pubs.values() for p in group]
        counts = topic_counts(values["subscriber_counts"], "subscriber_counts", [p.topic_name for p in outputs])
        announce_when_connected(self, self.pub_progress, outputs=outputs, readers=self.wait_for_subscribers,
                                counts=counts)

    def _white_noise_covariances(self) -> dict:
        """Per-sample variances of the white noise each measurement carries (for the
        covariance fields; biases are not white and are not in them)."""
        c = self.config
        deg = math.pi / 180.0
        arw = lambda deg_rt_h, rate_hz: (deg_rt_h * deg / 60.0) ** 2 * rate_hz  # noqa: E731
        return {
            "ins_att": m.diag_cov([(c.ins.roll_pitch_rms_deg * deg) ** 2] * 2 + [(c.ins.heading_rms_deg * deg) ** 2]),
            "ins_rate": m.diag_cov([arw(c.ins.gyro.arw_deg_rt_h, c.ins_rate_hz)] * 3),
            # the roll axis x has no gyro: REP 145's large-variance marking of one axis
            "gyro": m.gimbal_gyro_covariance(*[arw(c.gimbal_gyro.arw_deg_rt_h, c.gimbal_gyro_rate_hz)] * 2),
            "lgu": m.diag_cov([arw(c.lgu1.arw_deg_rt_h, c.lgu_rate_hz)] * 3),
            "p_gyro": m.diag_cov([arw(c.platform_gyro.arw_deg_rt_h, c.platform_imu_rate_hz)] * 3),
            "p_accel": m.diag_cov([(c.platform_accel.noise_ug_rt_hz * 9.80665e-6) ** 2 * c.platform_imu_rate_hz] * 3),
            "fg_rate": m.diag_cov([arw(c.free_gyro.triad.arw_deg_rt_h, c.free_gyro_rate_hz)] * 3),
            # roll, pitch from the vertical reference; the heading is not measured: its variance
            # is that of a heading uniform on (−π, π], π²/3
            "fg_level": m.diag_cov([(c.free_gyro.level_noise_arcsec * deg / 3600.0) ** 2] * 2 + [math.pi**2 / 3.0]),
        }

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
        if group is None:
            return
        k = m.step_of_stamp(t_ns, self.rate)
        try:
            samples = self.suite.update(truth_from_group(k, k / self.rate, group))
        except ValueError as exc:
            self.rejected_truth += 1
            self.get_logger().warning(f"truth rejected: {exc} ({self.rejected_truth} rejected)",
                                      throttle_duration_sec=1.0)
            return
        for sample in samples:
            self._publish(t_ns, sample)
        if (k + 1) % self.progress_every == 0:
            self.pub_progress.publish(m.clock_cdr(m.step_stamp_ns(k + 1, self.rate)))

    def _publish(self, t_ns: int, s) -> None:
        # serialized by hand (messages.*_cdr): the same messages, without message objects
        cov = self._noise_cov
        if isinstance(s, GimbalGyroSample):
            imu, bias = self.pubs["gimbal_gyro"]
            imu.publish(m.imu_cdr(t_ns, GIMBAL_FRAME, angular_velocity=(0.0, s.q_m, s.r_m),
                                  angular_velocity_cov=cov["gyro"]))
            bias.publish(m.vector3_cdr(t_ns, GIMBAL_FRAME, (0.0, *s.true_bias)))
        elif isinstance(s, EncoderSample):
            self.pubs["encoders"][0].publish(m.joint_state_cdr(t_ns, s.names, s.angles, s.rates))
        elif isinstance(s, InsSample):
            imu, bias = self.pubs["ins"]
            imu.publish(m.imu_cdr(t_ns, BASE_FRAME, orientation=quat_canonical(quat_from_euler321(*s.euler)),
                                  orientation_cov=cov["ins_att"], angular_velocity=s.omega_b,
                                  angular_velocity_cov=cov["ins_rate"]))
            bias.publish(m.vector3_cdr(t_ns, BASE_FRAME, s.true_gyro_bias))
        elif isinstance(s, LguSample):
            lgu1, lgu2, flex, flex_qs = self.pubs["lgu"]
            # angular_velocity carries the increment over the sample interval divided by it
            lgu1.publish(m.imu_cdr(t_ns, LGU1_FRAME, angular_velocity=[d / s.dt for d in s.dalpha1],
                                   angular_velocity_cov=cov["lgu"]))
            lgu2.publish(m.imu_cdr(t_ns, LGU2_FRAME, angular_velocity=[d / s.dt for d in s.dalpha2],
                                   angular_velocity_cov=cov["lgu"]))
            flex.publish(m.vector3_cdr(t_ns, LGU1_FRAME, s.flexure))
            flex_qs.publish(m.vector3_cdr(t_ns, LGU1_FRAME, s.flexure_quasi_static))
        elif isinstance(s, ResolverSample):
            self.pubs["resolvers"][0].publish(m.joint_state_cdr(t_ns, s.names, s.angles, s.rates))
        elif isinstance(s, PlatformImuSample):
            imu, accel_bias, gyro_bias = self.pubs["platform_imu"]
            imu.publish(m.imu_cdr(t_ns, PLATFORM_FRAME, angular_velocity=s.omega, angular_velocity_cov=cov["p_gyro"],
                                  linear_acceleration=s.specific_force, linear_acceleration_cov=cov["p_accel"]))
            accel_bias.publish(m.vector3_cdr(t_ns, PLATFORM_FRAME, s.true_accel_bias))
            gyro_bias.publish(m.vector3_cdr(t_ns, PLATFORM_FRAME, s.true_gyro_bias))
        elif isinstance(s, FreeGyroSample):
            spin_a, spin_b, imu, position, bias = self.pubs["free_gyro"]
            spin_a.publish(m.vector3_msg(t_ns, BASE_FRAME, s.spin_a_b))
            spin_b.publish(m.vector3_msg(t_ns, BASE_FRAME, s.spin_b_b))
            # orientation = the vertical reference: roll and pitch, heading 0 (not measured)
            imu.publish(m.imu_msg(t_ns, BASE_FRAME, orientation=euler321_to_quat(s.roll, s.pitch, 0.0),
                                  orientation_cov=cov["fg_level"], angular_velocity=s.omega_ib_b,
                                  angular_velocity_cov=cov["fg_rate"]))
            position.publish(m.navsat_fix_msg(t_ns, BASE_FRAME, s.true_lat, s.true_lon, 0.0, m.ZERO_COV))
            bias.publish(m.vector3_msg(t_ns, BASE_FRAME, s.true_triad_bias))
            if "free_gyro_velocity" in self.pubs:
                self.pubs["free_gyro_velocity"][0].publish(m.vector3_msg(t_ns, BASE_FRAME, s.velocity_n))


def main(argv: list[str] | None = None) -> int:
    return run_node(SensorModelsNode, "sensor_models", DESCRIPTION, argv)


if __name__ == "__main__":
    sys.exit(main())
