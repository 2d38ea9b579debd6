"""vehicle_dynamics + sensor_models in lockstep against their cores.

A harness in the test process plays the controller: for each truth step k it publishes
a torque command stamped k (one of them NaN). The published truth and measurements must
equal what the cores produce in-process for the same commands (with the NaN command
replaced by the held one), and a second run with the same seed must publish byte-for-byte
the same messages.
"""
from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import Vector3Stamped
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_sim.nodes.sensor_models_node import truth_from_group
from gimbal_sim.world.sensor_suite import SensorSuite, SensorSuiteConfig
from gimbal_sim.world.vehicle import VehicleConfig, VehicleCore
from ros_harness import harness_node, node_processes, spin_until

pytestmark = pytest.mark.ros

RATE_HZ = 500.0
STEPS = 150
NAN_STEP = 40
SEED = 1234
SENSORS = ["ins", "gimbal_gyro", "encoders"]
RATES = {"ins_rate_hz": 100.0, "gimbal_gyro_rate_hz": 500.0, "encoder_rate_hz": 250.0}

TOPICS = {
    "/clock": Clock, "/truth/host/imu": Imu, "/truth/host/delta_angle": Vector3Stamped,
    "/truth/gimbal/joint_states": JointState, "/truth/gimbal/imu": Imu,
    "/ins/imu": Imu, "/gimbal/imu": Imu, "/gimbal/joint_states": JointState,
    "/truth/gimbal/gyro_bias": Vector3Stamped, "/truth/ins/gyro_bias": Vector3Stamped,
}


#: Messages each topic carries over the run (sensors publish at their own rates).
EXPECTED_COUNTS = {
    "/clock": STEPS + 1, "/truth/host/imu": STEPS + 1, "/truth/host/delta_angle": STEPS + 1,
    "/truth/gimbal/joint_states": STEPS + 1, "/truth/gimbal/imu": STEPS + 1,
    "/gimbal/imu": STEPS + 1, "/truth/gimbal/gyro_bias": STEPS + 1,
    "/gimbal/joint_states": STEPS // 2 + 1, "/ins/imu": STEPS // 5 + 1, "/truth/ins/gyro_bias": STEPS // 5 + 1,
}


def torque(k: int) -> tuple[float, float]:
    if k == NAN_STEP:
        return (math.nan, 0.1)
    return (0.3 * math.sin(k / 20.0), 0.2 * math.cos(k / 15.0))


def run_graph(env, tmp_path) -> dict[str, list]:
    """Run the two nodes plus the harness controller; return every message by topic."""
    domain = int(env["ROS_DOMAIN_ID"])
    vehicle = {"sim_rate_hz": RATE_HZ, "duration_s": STEPS / RATE_HZ, "controlled": True,
               "pace_topics": ["/sensor_models/progress"]}
    sensors = {"sim_rate_hz": RATE_HZ, "seed": SEED, "sensors": SENSORS, "wait_for_subscribers": 1, **RATES}
    received: dict[str, list] = {t: [] for t in TOPICS}
    with harness_node(domain) as (node, executor):
        cmd_pub = node.create_publisher(JointState, "/gimbal/torque_cmd", GRAPH_QOS)

        def on_message(topic, msg):
            received[topic].append(msg)
            if topic == "/truth/gimbal/joint_states":
                k = m.step_of_stamp(m.stamp_ns(msg.header.stamp), RATE_HZ)
                cmd_pub.publish(m.joint_state_msg(m.step_stamp_ns(k, RATE_HZ),
                                                  ["gimbal_azimuth", "gimbal_elevation"], effort=torque(k)))

        for topic, typ in TOPICS.items():
            node.create_subscription(typ, topic, lambda msg, t=topic: on_message(t, msg), GRAPH_QOS)
        with node_processes([("sensor_models", sensors), ("vehicle_dynamics", vehicle)], env, tmp_path) as procs:
            finished = spin_until(
                executor, lambda: all(len(received[t]) >= n for t, n in EXPECTED_COUNTS.items()), timeout_s=120.0)
            assert all(p.poll() is None for p in procs), "a node exited during the run"
        if not finished:
            missing = [k for k in range(STEPS + 1) if m.step_stamp_ns(k, RATE_HZ) not in
                       {m.stamp_ns(x.header.stamp) for x in received["/gimbal/imu"]}]
        assert finished, str({k: len(v) for k, v in received.items()}) + f" missing gimbal/imu steps {missing}"
        assert {t: len(received[t]) for t in TOPICS} == EXPECTED_COUNTS
    received["_vehicle_log"] = (tmp_path / "vehicle_dynamics.log").read_text()
    return received


def expected_messages() -> dict[str, list]:
    """What the cores produce for the same commands, through the same message edge."""
    core = VehicleCore(VehicleConfig(sim_rate_hz=RATE_HZ, duration_s=STEPS / RATE_HZ))
    suite = SensorSuite(SensorSuiteConfig(sensors=tuple(SENSORS), sim_rate_hz=RATE_HZ, seed=SEED, **RATES))
    out = {"joints": [], "host": [], "gyro": [], "encoders": [], "ins": []}
    held = (0.0, 0.0)
    for k in range(STEPS + 1):
        truth = core.truth()
        t_ns = m.step_stamp_ns(k, RATE_HZ)
        host = m.imu_msg(t_ns, "base_link_frd", orientation=truth.quat_nb, angular_velocity=truth.omega_ib_b,
                         linear_acceleration=truth.specific_force_b)
        gimbal = m.imu_msg(t_ns, "gimbal_inner_frd", orientation=truth.quat_nm, angular_velocity=truth.omega_im_m,
                           linear_acceleration=truth.specific_force_m)
        joints = m.joint_state_msg(t_ns, truth.joint_names, truth.joint_position, truth.joint_velocity,
                                   truth.joint_effort)
        out["joints"].append(joints)
        out["host"].append(host)
        group = {"/truth/host/imu": host, "/truth/gimbal/imu": gimbal, "/truth/gimbal/joint_states": joints}
        for sample in suite.update(truth_from_group(k, k / RATE_HZ, group)):
            out[{"GimbalGyroSample": "gyro", "EncoderSample": "encoders", "InsSample": "ins"}[type(sample).__name__]].append(sample)
        if k < STEPS:
            tau = torque(k)
            held = tau if all(math.isfinite(v) for v in tau) else held
            core.step(held)
    return out


def test_lockstep_graph_equals_the_cores_and_repeats_exactly(ros_domain_env, tmp_path_factory):
    first = run_graph(ros_domain_env, tmp_path_factory.mktemp("run1"))
    expected = expected_messages()

    # truth: one message per step, in order, equal to the core's
    assert [m.stamp_ns(c.clock) for c in first["/clock"]] == [m.step_stamp_ns(k, RATE_HZ) for k in range(STEPS + 1)]
    for got, want in zip(first["/truth/gimbal/joint_states"], expected["joints"], strict=True):
        assert (list(got.position), list(got.velocity), list(got.effort)) == (
            list(want.position), list(want.velocity), list(want.effort))
    for got, want in zip(first["/truth/host/imu"], expected["host"], strict=True):
        assert serialize_message(got) == serialize_message(want)

    # measurements: each sensor at its own rate, equal to the suite's samples
    assert len(first["/gimbal/imu"]) == STEPS + 1 and len(first["/ins/imu"]) == STEPS // 5 + 1
    for got, want in zip(first["/gimbal/imu"], expected["gyro"], strict=True):
        assert (got.angular_velocity.y, got.angular_velocity.z) == (want.q_m, want.r_m)
        # the unmeasured roll axis: x = 0 with a very large variance (REP 145's per-axis form);
        # orientation is not provided at all ([0] = -1)
        assert got.angular_velocity.x == 0.0 and got.angular_velocity_covariance[0] == 1e6
        assert got.orientation_covariance[0] == -1.0
    for got, want in zip(first["/gimbal/joint_states"], expected["encoders"], strict=True):
        assert tuple(got.position) == want.angles and tuple(got.velocity) == want.rates
    for got, want in zip(first["/ins/imu"], expected["ins"], strict=True):
        assert (got.angular_velocity.x, got.angular_velocity.y, got.angular_velocity.z) == want.omega_b

    # the NaN command was never integrated: held, counted and warned about
    assert "non-finite effort" in first["_vehicle_log"]
    assert first["/truth/gimbal/joint_states"][NAN_STEP + 1].effort[1:] == pytest.approx(torque(NAN_STEP - 1))

    second = run_graph(ros_domain_env, tmp_path_factory.mktemp("run2"))
    for topic in TOPICS:
        assert [serialize_message(x) for x in first[topic]] == [serialize_message(x) for x in second[topic]], topic
