"""Real-time mode paces to the wall clock and holds the last command when one is late."""
from __future__ import annotations

import re

import pytest
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState
from geometry_msgs.msg import Vector3Stamped

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.qos import GRAPH_QOS
from ros_harness import harness_node, node_processes, spin_until

pytestmark = pytest.mark.ros
RATE_HZ, DURATION_S = 100.0, 0.6
STEPS = int(RATE_HZ * DURATION_S)


def test_realtime_mode_holds_late_commands(ros_domain_env, tmp_path):
    vehicle = {"mode": "realtime", "sim_rate_hz": RATE_HZ, "duration_s": DURATION_S, "controlled": True}
    clock_sent_ns = []  # the publisher's wall clock at publication: delivery delays under load do not shift it
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        cmd = node.create_publisher(JointState, "/gimbal/torque_cmd", GRAPH_QOS)

        def on_joints(msg):
            k = m.step_of_stamp(m.stamp_ns(msg.header.stamp), RATE_HZ)
            if k % 2 == 0:  # odd steps never get a command: they are late by construction
                cmd.publish(m.joint_state_msg(m.stamp_ns(msg.header.stamp), ["gimbal_azimuth", "gimbal_elevation"],
                                              effort=[0.01, 0.0]))

        node.create_subscription(Clock, "/clock", lambda msg, info: clock_sent_ns.append(info["source_timestamp"]),
                                 GRAPH_QOS)
        node.create_subscription(JointState, "/truth/gimbal/joint_states", on_joints, GRAPH_QOS)
        for topic, typ in (("/truth/host/imu", Imu), ("/truth/host/delta_angle", Vector3Stamped),
                           ("/truth/gimbal/imu", Imu)):
            node.create_subscription(typ, topic, lambda msg: None, GRAPH_QOS)
        with node_processes([("vehicle_dynamics", vehicle)], ros_domain_env, tmp_path):
            assert spin_until(executor, lambda: len(clock_sent_ns) > STEPS, timeout_s=60.0)
            spin_until(executor, lambda: "reached" in (tmp_path / "vehicle_dynamics.log").read_text(), 10.0)
    assert len(clock_sent_ns) == STEPS + 1
    # paced by a wall-clock timer: the run cannot be faster than real time (a timer may fire late, never early)
    assert (clock_sent_ns[-1] - clock_sent_ns[0]) * 1e-9 >= 0.9 * STEPS / RATE_HZ
    late = int(re.search(r"(\d+) late", (tmp_path / "vehicle_dynamics.log").read_text()).group(1))
    assert late >= STEPS // 2
