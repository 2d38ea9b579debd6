"""Replay and crash survival of recorded bags."""
from __future__ import annotations

import os
import signal
import subprocess
from pathlib import Path

import pytest
from rosbags.highlevel import AnyReader
from rosgraph_msgs.msg import Clock
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Imu, JointState

from conftest import VENV_BIN
from gimbal_kinematics.ros import messages as m
from gimbal_sim.bag.reader import read_messages, scan
from gimbal_kinematics.ros.qos import GRAPH_QOS
from ros_harness import harness_node, node_processes, spin_until

pytestmark = pytest.mark.ros
SENSOR_TOPICS = {"/gimbal/imu": Imu, "/gimbal/joint_states": JointState, "/ins/imu": Imu}


@pytest.fixture(scope="module")
def bag(module_ros_domain_env, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rec") / "run"
    result = subprocess.run([str(VENV_BIN / "gimbal-run"), "sim_open_loop", "--duration", "1.5", "--out", str(out),
                             "--mode", "container", "--no-progress"], env=module_ros_domain_env,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    # the run's page is the last thing gimbal-run prints, as after an interrupt (test_run_interrupt)
    assert result.stdout.rstrip().splitlines()[-1] == f"page: {out / 'report' / 'index.html'}", result.stdout
    return out


@pytest.mark.parametrize("rate", ["1", "0"])
def test_replay_delivers_every_sensor_message_in_order(bag, rate, ros_domain_env, tmp_path):
    # The graph records these topics transient-local, which the player offers with a bounded
    # history that never blocks: a reader that cannot report its progress (this one) and falls
    # that far behind on a loaded machine loses samples. Offered volatile, the player's KEEP_ALL
    # writer applies back-pressure instead, so the delivery is lossless whatever the load.
    overrides = tmp_path / "qos.yaml"
    overrides.write_text("".join(f"{t}: {{durability: volatile, history: keep_all}}\n" for t in SENSOR_TOPICS))
    recorded, _ = read_messages(bag, set(SENSOR_TOPICS))
    want = {t: [(x.log_time_ns, x.data) for x in recorded if x.topic == t] for t in SENSOR_TOPICS}
    got = {t: [] for t in SENSOR_TOPICS}
    keep_all = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        for topic, typ in SENSOR_TOPICS.items():
            node.create_subscription(typ, topic, lambda data, t=topic: got[t].append(data), keep_all, raw=True)
        play = subprocess.Popen([str(VENV_BIN / "gimbal-bag"), "play", str(bag), "--rate", rate,
                                 "--topics", *SENSOR_TOPICS, "--wait-for-subscribers", "1",
                                 "--qos-profile-overrides-path", str(overrides)],
                                env=ros_domain_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            assert spin_until(executor, lambda: all(len(got[t]) >= len(want[t]) for t in SENSOR_TOPICS), 120.0)
            out, err = play.communicate(timeout=60)
        finally:
            if play.poll() is None:
                play.kill()
                play.wait()
    assert play.returncode == 0, err
    for topic in SENSOR_TOPICS:
        assert got[topic] == [data for _, data in want[topic]], topic


def test_recorder_killed_mid_run_loses_at_most_a_second(ros_domain_env, tmp_path):
    out = tmp_path / "bag"
    rate = 1000.0
    # paced on the recorder too: unpaced, a loaded machine may drop /clock steps before the kill
    vehicle = {"sim_rate_hz": rate, "duration_s": 60.0, "pace_topics": ["/sensor_models/progress", "/bag_recorder/progress"]}
    sensors = {"sim_rate_hz": rate, "wait_for_subscribers": 1}
    recorder = {"output_dir": str(out), "sim_rate_hz": rate, "wait_for_nodes": ["vehicle_dynamics", "sensor_models"]}
    clock = []
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        node.create_subscription(Clock, "/clock", lambda msg: clock.append(m.stamp_ns(msg.clock)), GRAPH_QOS)
        with node_processes([("bag_recorder", recorder), ("sensor_models", sensors), ("vehicle_dynamics", vehicle)],
                            ros_domain_env, tmp_path) as (rec, _, _):
            assert spin_until(executor, lambda: clock and clock[-1] > 3e9, 120.0)
            os.kill(rec.pid, signal.SIGKILL)
            rec.wait()
            clock_at_kill = clock[-1]
    info = subprocess.run([str(VENV_BIN / "gimbal-bag"), "info", str(out)], capture_output=True, text=True, timeout=60)
    assert info.returncode == 1 and "Closed cleanly: NO" in info.stdout
    contents = scan(out)
    assert not contents.closed_cleanly and contents.message_count > 0
    # the complete chunks hold every step up to the last flush, on every topic
    messages, _ = read_messages(out)
    clock_steps = [x.log_time_ns for x in messages if x.topic == "/clock"]
    assert clock_steps == [m.step_stamp_ns(k, rate) for k in range(len(clock_steps))]
    assert clock_steps[-1] >= clock_at_kill - 1_000_000_000
    result = subprocess.run([str(VENV_BIN / "gimbal-bag"), "recover", str(out)], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    with AnyReader([tmp_path / "bag_recovered"]) as reader:
        assert reader.message_count == contents.message_count
        for connection, _, raw in reader.messages():
            reader.deserialize(raw, connection.msgtype)
