"""gimbal_kinematics.ros.node_io: the profiles of the two timings against rclpy's own
predefined profiles, delivery from publishers the project did not configure (a driver's
qos_profile_sensor_data, the ROS default), rclpy's standard QoS-override parameters, and
the incompatible-QoS event: logged once per topic, counted on every event."""
from __future__ import annotations

import pytest
from rclpy.parameter import Parameter
from rclpy.qos import (
    DurabilityPolicy, ReliabilityPolicy, qos_profile_sensor_data, qos_profile_system_default,
)
from std_msgs.msg import String

from gimbal_kinematics.ros.node_io import NodeIo, input_qos, output_qos
from gimbal_kinematics.ros.qos import GRAPH_QOS
from ros_harness import harness_node, spin_until

pytestmark = pytest.mark.ros


def test_profiles_follow_rep_2003_in_free_timing_and_stay_graph_qos_in_lockstep():
    assert input_qos("lockstep") is GRAPH_QOS and output_qos("lockstep") is GRAPH_QOS
    free_in, free_out = input_qos("free"), output_qos("free")
    assert free_in.reliability == qos_profile_sensor_data.reliability == ReliabilityPolicy.BEST_EFFORT
    assert free_in.durability == qos_profile_sensor_data.durability == DurabilityPolicy.VOLATILE
    assert free_out.reliability == ReliabilityPolicy.RELIABLE
    assert free_out.durability == DurabilityPolicy.VOLATILE and free_out.depth == 10
    with pytest.raises(ValueError, match="timing"):
        input_qos("realtime")


@pytest.mark.parametrize("publisher_qos", [qos_profile_sensor_data, 10], ids=["sensor_data", "default"])
def test_free_input_receives_from_a_driver_and_from_default_qos(ros_domain_env, publisher_qos):
    from gimbal_kinematics.ros.node_main import make_executor

    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, _):
        executor = make_executor(context=node.context)  # the executor every node spins on
        executor.add_node(node)
        got = []
        io = NodeIo(node)
        io.subscribe(String, "/t", lambda msg: got.append(msg.data), "free")
        pub = node.create_publisher(String, "/t", publisher_qos)
        ok = spin_until_n(executor, lambda: pub.get_subscription_count() >= 1, pub, got, 5)
        assert ok and got, "nothing delivered"
        assert io.incompatible_qos == 0
        executor.shutdown()


def spin_until_n(executor, matched, pub, got, n):
    import time

    deadline = time.monotonic() + 20.0
    while not matched() and time.monotonic() < deadline:
        executor.spin_until_future_complete(_never(), timeout_sec=0.05)
    for i in range(n):
        pub.publish(String(data=str(i)))
    while len(got) < n and time.monotonic() < deadline:
        executor.spin_until_future_complete(_never(), timeout_sec=0.05)
    return len(got) == n


def _never():
    from rclpy.task import Future

    return Future()


_TWO_DEFAULT_PUBLISHERS = """
import rclpy
from std_msgs.msg import String
rclpy.init()
node = rclpy.create_node("plain_publisher")
pubs = [node.create_publisher(String, "/lockstep_topic", 10) for _ in range(2)]
for _ in range(200):
    pubs[0].publish(String(data="x"))
    rclpy.spin_once(node, timeout_sec=0.1)
"""


def test_incompatible_qos_is_logged_once_per_topic_and_counted(ros_domain_env):
    """A lockstep (transient-local) subscription and two default-QoS (volatile) publishers
    of another process: no match; both are counted, the log names the topic, the policy and
    the parameter that fixes it, once. (Fast DDS reports no QoS events between participants
    of one process, hence the child process.)"""
    import subprocess
    import sys

    from gimbal_kinematics.ros.node_main import make_executor

    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, _):
        executor = make_executor(context=node.context)  # the executor every node spins on
        executor.add_node(node)
        io = NodeIo(node)
        logged = []
        real = node.get_logger()

        class Spy:
            def warning(self, text, **kw):
                logged.append(text)
                real.warning(text, **kw)

        node.get_logger = lambda: Spy()
        io.subscribe(String, "/lockstep_topic", lambda msg: None, "lockstep")
        proc = subprocess.Popen([sys.executable, "-c", _TWO_DEFAULT_PUBLISHERS], env=ros_domain_env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            ok = spin_until(_SpinAdapter(executor), lambda: io.incompatible_qos >= 2, 20.0)
        finally:
            from gimbal_sim.graph.orchestrator import stop_processes

            stop_processes([proc])
        assert ok, f"incompatible peers seen: {io.incompatible_qos}"
        assert io.incompatible_qos == 2
        assert len(logged) == 1, logged
        text = logged[0]
        assert "/lockstep_topic" in text and "DURABILITY" in text
        assert "qos_overrides./lockstep_topic.subscription.durability" in text
        executor.shutdown()


class _SpinAdapter:
    """spin_once for executors that only offer spin_until_future_complete (EventsExecutor)."""

    def __init__(self, executor) -> None:
        self.executor = executor

    def spin_once(self, timeout_sec: float) -> None:
        self.executor.spin_until_future_complete(_never(), timeout_sec=timeout_sec)


def test_standard_qos_override_parameters_apply(ros_domain_env):
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    context = Context()
    rclpy.init(context=context, domain_id=int(ros_domain_env["ROS_DOMAIN_ID"]))
    try:
        node = Node("qos_override_test", context=context, parameter_overrides=[
            Parameter("qos_overrides./in.subscription.reliability", value="reliable"),
            Parameter("qos_overrides./in.subscription.depth", value=7),
            Parameter("qos_overrides./out.publisher.durability", value="transient_local"),
        ])
        io = NodeIo(node)
        sub = io.subscribe(String, "/in", lambda msg: None, "free")
        pub = io.advertise(String, "/out", "free")
        assert sub.qos_profile.reliability == ReliabilityPolicy.RELIABLE and sub.qos_profile.depth == 7
        assert sub.qos_profile.durability == DurabilityPolicy.VOLATILE
        assert pub.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
        assert node.has_parameter("qos_overrides./in.subscription.history")
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
