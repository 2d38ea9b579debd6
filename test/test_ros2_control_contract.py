"""``vehicle_dynamics`` under ros2_control's joint-command contract (topic_based_ros2_control).

Run A: the paper 1 headline loop through the node graph (``los_rate_controller`` commanding
``/gimbal/torque_cmd``, the toolkit's own contract), recorded. Run B: the vehicle alone with
``command_interface: ros2_control``, driven by a plain rclpy publisher in this process that
does what TopicBasedSystem's read/write cycle does: it reads the joint states, then sends a
``sensor_msgs/JointState`` of the two joint names and their efforts (position and velocity
empty) on ``/robot_joint_commands``, reliable and volatile, stamped with its own wall clock
(no step). The efforts are run A's, read from A's bag with ``rosbags``. The two bags are
compared with the project's ``gimbal-bench compare`` logic (``bag.compare``, which reads them
with the ``mcap`` library): every truth topic identical, floats to the bit.

Run C: run A with the controller and the vehicle both in ros2_control's contract
(``command_interface: ros2_control`` on each): the same truth again, and the commands on
``/robot_joint_commands`` are A's on ``/gimbal/torque_cmd``.
"""
from __future__ import annotations

import subprocess
import time

import pytest
import yaml
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState

from conftest import VENV_BIN
from gimbal_kinematics.maths.frames import GIMBAL_COMMAND_JOINTS
from gimbal_kinematics.ros.qos import GRAPH_QOS
from gimbal_sim.bag.compare import compare_bags
from gimbal_sim.graph.scenario import builtin_scenarios
from ros_harness import harness_node, spin_until, start_refused

pytestmark = pytest.mark.ros

DURATION_S = 0.3  # 300 steps at 1 kHz
TRUTH = ("/clock", "/truth/gimbal/joint_states", "/truth/gimbal/imu", "/truth/host/imu", "/truth/host/delta_angle")
# topic_based_ros2_control's joint-command publisher: rclcpp::QoS(1), reliable, volatile
ROS2_CONTROL_PUB_QOS = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, reliability=ReliabilityPolicy.RELIABLE,
                                  durability=DurabilityPolicy.VOLATILE)


def _gimbal_run(spec, out, env, *extra) -> subprocess.Popen:
    return subprocess.Popen([str(VENV_BIN / "gimbal-run"), str(spec), "--duration", str(DURATION_S), "--out",
                             str(out), "--mode", "container", "--no-progress", *extra],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _finish(proc: subprocess.Popen) -> None:
    out, _ = proc.communicate(timeout=300)
    assert proc.returncode == 0, out


@pytest.fixture(scope="module")
def runs(module_ros_domain_env, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("ros2_control")
    headline = yaml.safe_load(builtin_scenarios()["sighting_land_vehicle"].read_text())
    for key in ("variants", "comparison"):  # the ekf_off case (the node's default), one run
        headline.pop(key)
    headline["report"] = "generic"  # the cheapest report: this test reads the bags
    spec_a = tmp / "a.yaml"
    spec_a.write_text(yaml.safe_dump(headline))
    bag_a = tmp / "a"
    _finish(_gimbal_run(spec_a, bag_a, module_ros_domain_env))
    with AnyReader([bag_a]) as reader:
        conns = [c for c in reader.connections if c.topic == "/gimbal/torque_cmd"]
        commands = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=conns)]
    torques = {msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec: (list(msg.name), tuple(msg.effort))
               for msg in commands}

    vehicle = headline["nodes"]["vehicle_dynamics"]
    vehicle["params"].update(command_interface="ros2_control")
    alone = {"name": "ros2_control_vehicle", "description": "the headline's vehicle driven through ros2_control's "
             "contract", "duration_s": headline["duration_s"], "sim_rate_hz": headline["sim_rate_hz"],
             "seed": headline["seed"], "record": list(TRUTH), "report": "generic",
             "nodes": {"vehicle_dynamics": vehicle}}
    spec_b = tmp / "b.yaml"
    spec_b.write_text(yaml.safe_dump(alone))
    with harness_node(int(module_ros_domain_env["ROS_DOMAIN_ID"]), "plain_ros2_control") as (node, executor):
        pub = node.create_publisher(JointState, "/robot_joint_commands", ROS2_CONTROL_PUB_QOS)
        seen: list[int] = []
        node.create_subscription(JointState, "/truth/gimbal/joint_states",
                                 lambda msg: seen.append(msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec),
                                 GRAPH_QOS)
        proc = _gimbal_run(spec_b, tmp / "b", module_ros_domain_env)
        try:
            sent = 0
            for stamp in sorted(torques):
                # read: the joint states of the step; write: that step's efforts, stamped with our own clock
                assert spin_until(executor, lambda: stamp in seen and pub.get_subscription_count() > 0, 120.0)
                names, effort = torques[stamp]
                msg = JointState(name=names, effort=list(effort))
                msg.header.stamp = node.get_clock().now().to_msg()
                pub.publish(msg)
                sent += 1
                if len(seen) > sent and seen[-1] >= max(torques):
                    break
            spin_until(executor, lambda: proc.poll() is not None, 120.0)
        finally:
            if proc.poll() is None:
                proc.kill()
        _finish(proc)
    bag_c = tmp / "c"
    _finish(_gimbal_run(spec_a, bag_c, module_ros_domain_env, "--set", "los_rate_controller.command_interface=ros2_control",
                        "--set", "vehicle_dynamics.command_interface=ros2_control"))
    return bag_a, tmp / "b", bag_c, torques


def _same_truth(bag_a, bag_x) -> None:
    diff = compare_bags(bag_a, bag_x)
    for topic in TRUTH:
        t = diff.topics[topic]
        assert t.count_a == t.count_b >= DURATION_S * 1000, (topic, diff.lines())
        assert t.comparable and t.values_equal, (topic, diff.lines())
    return diff


def test_plain_joint_state_efforts_move_the_gimbal_as_the_controller_path_does(runs):
    bag_a, bag_b, _, torques = runs
    assert len(torques) >= DURATION_S * 1000 and {tuple(n) for n, _ in torques.values()} == {GIMBAL_COMMAND_JOINTS}
    assert max(abs(e) for _, effort in torques.values() for e in effort) > 0.1  # the loop does torque the gimbal
    _same_truth(bag_a, bag_b)


def test_the_controller_in_ros2_controls_form_drives_the_same_run(runs):
    bag_a, _, bag_c, _ = runs
    diff = _same_truth(bag_a, bag_c)
    assert "/gimbal/torque_cmd" not in {t for t, d in diff.topics.items() if d.count_b}
    a, c = (compare_bags(bag_a, bag_c).topics[t] for t in ("/gimbal/torque_cmd", "/robot_joint_commands"))
    assert a.count_a == c.count_b >= DURATION_S * 1000 and a.count_b == c.count_a == 0
    with AnyReader([bag_a]) as ra, AnyReader([bag_c]) as rc:
        def efforts(reader, topic):
            conns = [x for x in reader.connections if x.topic == topic]
            return [(m.header.stamp.sec, m.header.stamp.nanosec, list(m.name), list(m.effort)) for m in
                    (reader.deserialize(raw, x.msgtype) for x, _, raw in reader.messages(connections=conns))]
        assert efforts(ra, "/gimbal/torque_cmd") == efforts(rc, "/robot_joint_commands")


@pytest.mark.parametrize("exe", ["vehicle_dynamics", "los_rate_controller"])
def test_a_ros2_control_topic_that_names_no_topic_is_refused(exe, ros_domain_env):
    result = start_refused(exe, {"command_interface": "ros2_control", "ros2_control_topic": " "}, ros_domain_env)
    assert result.returncode == 2 and "ros2_control_topic" in result.stderr and "Traceback" not in result.stderr, \
        result.stderr
