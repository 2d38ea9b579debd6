"""``gimbal-bag play`` says what it does: an unpaced replay into a best-effort
reader, which drops what it cannot keep up with as ROS does, is warned about and ``--pace``
named; a reliable reader is not warned about. The player and the readers share one rclpy
context in this process; the bag is written by the ``rosbags`` writer."""
from __future__ import annotations

import time

import pytest
import rclpy
from rclpy.context import Context
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu

from foreign_bags import synthetic_messages, write_rosbags
from gimbal_kinematics.ros.node_main import make_executor
from gimbal_sim.bag.player import BagPlayer, PlayOptions

MATCH_TIMEOUT_S = 30.0  # discovery on a loaded machine


@pytest.mark.parametrize("reliability, warned", [(ReliabilityPolicy.BEST_EFFORT, True),
                                                 (ReliabilityPolicy.RELIABLE, False)],
                         ids=["best_effort", "reliable"])
def test_unpaced_play_warns_of_a_best_effort_reader(reliability, warned, tmp_path, capfd):
    bag = write_rosbags(tmp_path / "bag", synthetic_messages(n_imu=20))
    context = Context()
    rclpy.init(context=context)
    try:
        player = BagPlayer(bag, PlayOptions(rate=0.0), context=context)
        reader = rclpy.create_node("reader", context=context)
        reader.create_subscription(Imu, "/imu", lambda _: None, QoSProfile(depth=10, reliability=reliability))
        executor = make_executor(context)
        executor.add_node(player)
        executor.add_node(reader)
        deadline = time.monotonic() + MATCH_TIMEOUT_S
        while (player.pubs["/imu"].get_subscription_count() < 1
               or not player.get_subscriptions_info_by_topic("/imu")) and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        player.wait_for_readers(executor)  # nothing awaited: returns at once, then checks the readers
        err = capfd.readouterr().err
        assert ("best effort" in err and "--pace" in err and "/imu" in err) == warned, err
    finally:
        executor.shutdown()
        rclpy.shutdown(context=context)
