"""gimbal-bag and gimbal-report on bags other tools wrote: the rosbags writer's MCAP and
sqlite3 bags and the mcap library's chunk-compressed files, stamped at an epoch time.

What is read is checked against rosbags' own reader (``AnyReader``), a library we did not
write; what is played is checked by a plain rclpy subscriber of the test's own.
"""
from __future__ import annotations

import json
import subprocess
import time
from pathlib import Path

import pytest
import yaml
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from conftest import VENV_BIN
from foreign_bags import EPOCH_NS, synthetic_messages, write_compressed_mcap, write_rosbags
from gimbal_kinematics.ros import messages as m
from gimbal_sim.bag.player import PlayOptions
from gimbal_sim.bag.reader import read_messages
from ros_harness import harness_node, spin_until

MESSAGES = synthetic_messages()


@pytest.fixture(scope="module")
def bags(tmp_path_factory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("foreign")
    return {"mcap": write_rosbags(root / "rosbags_mcap", MESSAGES, "mcap"),
            "sqlite3": write_rosbags(root / "rosbags_db3", MESSAGES, "sqlite3"),
            "zstd": write_compressed_mcap(root / "zstd.mcap", MESSAGES, "zstd"),
            "lz4": write_compressed_mcap(root / "lz4.mcap", MESSAGES, "lz4")}


def _rosbags_view(path: Path) -> tuple[dict[str, tuple[str, int]], list[tuple[str, int, bytes]]]:
    """(topic -> (type, count), [(topic, log ns, bytes)] in log-time order) as rosbags reads it."""
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        topics = {c.topic: (c.msgtype, c.msgcount) for c in reader.connections}
        messages = [(c.topic, t, bytes(d)) for c, t, d in reader.messages()]
    return topics, messages


@pytest.mark.parametrize("kind", ["mcap", "sqlite3", "zstd", "lz4"])
def test_info_and_reader_agree_with_rosbags(bags, kind):
    bag = bags[kind]
    result = subprocess.run([str(VENV_BIN / "gimbal-bag"), "info", str(bag), "--json"], capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    info = json.loads(result.stdout)
    # rosbags reads a bare .mcap through its parent only with metadata: compare against the written list
    want_topics = {t: (ty, sum(1 for x in MESSAGES if x[0] == t)) for t, ty, _, _ in MESSAGES}
    if kind in ("mcap", "sqlite3"):
        topics, messages = _rosbags_view(bag)
        assert topics == want_topics
        assert messages == [(t, ns, d) for t, _, ns, d in MESSAGES]
    assert {t: (v["type"], v["count"]) for t, v in info["topics"].items()} == want_topics
    assert info["storage"] == ("sqlite3" if kind == "sqlite3" else "mcap")
    assert info["closed_cleanly"] is True
    assert info["start"] == EPOCH_NS and info["end"] == MESSAGES[-1][2]   # integer ns: nothing lost at 1.8e9 s
    if kind in ("zstd", "lz4"):
        assert info["compression"] == kind
    raw, contents = read_messages(bag)
    assert [(x.topic, x.log_time_ns, x.data) for x in raw] == [(t, ns, d) for t, _, ns, d in MESSAGES]
    assert {t: r.type_name for t, r in contents.topics.items()} == {t: ty for t, (ty, _) in want_topics.items()}


def test_text_info_names_the_sqlite3_topics(bags):
    result = subprocess.run([str(VENV_BIN / "gimbal-bag"), "info", str(bags["sqlite3"])], capture_output=True,
                            text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert "Storage:    sqlite3" in result.stdout
    assert "1800000000.123456789 s" in result.stdout
    for topic, msgtype in (("/imu", "sensor_msgs/msg/Imu"), ("/joints", "sensor_msgs/msg/JointState")):
        line = next(x for x in result.stdout.splitlines() if x.strip().startswith(topic + " "))
        assert msgtype in line and str(sum(1 for x in MESSAGES if x[0] == topic)) in line


def test_recover_refuses_sqlite3_and_a_sqlite3_bag_without_metadata_is_named(bags, tmp_path):
    result = subprocess.run([str(VENV_BIN / "gimbal-bag"), "recover", str(bags["sqlite3"]), "--out",
                             str(tmp_path / "out")], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and "sqlite3" in result.stderr and "reindex" in result.stderr
    assert not (tmp_path / "out").exists()
    killed = tmp_path / "killed"
    killed.mkdir()
    (killed / "killed_0.db3").write_bytes((bags["sqlite3"] / "rosbags_db3.db3").read_bytes())
    result = subprocess.run([str(VENV_BIN / "gimbal-bag"), "info", str(killed)], capture_output=True, text=True,
                            timeout=60)
    assert result.returncode == 2 and "without metadata.yaml" in result.stderr


def test_report_on_a_sqlite3_bag(bags, tmp_path):
    bag = tmp_path / "copy"
    bag.mkdir()
    for f in bags["sqlite3"].iterdir():
        (bag / f.name).write_bytes(f.read_bytes())
    result = subprocess.run([str(VENV_BIN / "gimbal-report"), str(bag)], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    metrics = json.loads((bag / "report" / "metrics.json").read_text())
    assert metrics["topics"]["/imu"] == {"type": "sensor_msgs/msg/Imu", "count": 200}
    assert metrics["closed_cleanly"] is True


# ---------------------------------------------------------------------------- play


def _play(bag: Path, env: dict, *args: str, stdin=subprocess.DEVNULL) -> subprocess.Popen:
    return subprocess.Popen([str(VENV_BIN / "gimbal-bag"), "play", str(bag), *args], env=env, stdin=stdin,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _finish(proc: subprocess.Popen) -> str:
    try:
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    return out


@pytest.mark.ros
@pytest.mark.parametrize("kind", ["mcap", "sqlite3"])
def test_play_offers_the_recorded_qos_to_a_default_qos_subscriber(bags, kind, ros_domain_env):
    """A reliable volatile subscriber (the ROS default) gets every message, bytes as
    written; the player's publisher offers what the bag recorded (reliable, volatile)."""
    want = {t: [d for tt, _, _, d in MESSAGES if tt == t] for t in ("/imu", "/joints")}
    got = {t: [] for t in want}
    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        node.create_subscription(Imu, "/imu", lambda d: got["/imu"].append(d), qos, raw=True)
        node.create_subscription(JointState, "/joints", lambda d: got["/joints"].append(d), qos, raw=True)
        play = _play(bags[kind], ros_domain_env, "--rate", "0", "--wait-for-subscribers", "1", "--start-paused",
                     stdin=subprocess.PIPE)
        assert spin_until(executor, lambda: node.get_publishers_info_by_topic("/imu"), 60.0)
        offered = node.get_publishers_info_by_topic("/imu")   # paused: the publisher is there to ask
        play.stdin.write("\n")
        play.stdin.flush()
        assert spin_until(executor, lambda: all(len(got[t]) >= len(want[t]) for t in want), 60.0)
        _finish(play)
    assert got == want
    assert [p.qos_profile.reliability for p in offered] == [ReliabilityPolicy.RELIABLE]


@pytest.mark.ros
def test_play_options(bags, ros_domain_env, tmp_path):
    """--start-paused waits for a newline; --exclude-topics, --playback-duration, --clock
    RATE_HZ and --qos-profile-overrides-path do what rosbag2's do."""
    overrides = tmp_path / "qos.yaml"
    overrides.write_text(yaml.safe_dump({"/imu": {"durability": "transient_local", "history": "keep_last",
                                                  "depth": 500}}))
    duration_ns = 300_000_000
    want = [d for t, _, ns, d in MESSAGES if t == "/imu" and ns <= EPOCH_NS + duration_ns]
    got, joints, clocks = [], [], []
    qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"])) as (node, executor):
        node.create_subscription(Imu, "/imu", got.append, qos, raw=True)
        node.create_subscription(JointState, "/joints", joints.append, 10, raw=True)
        node.create_subscription(Clock, "/clock", lambda msg: clocks.append(m.stamp_ns(msg.clock)),
                                 QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE))
        play = _play(bags["mcap"], ros_domain_env, "--rate", "1", "--start-paused", "--exclude-topics", "/joints",
                     "--playback-duration", "0.3", "--clock", "100", "--qos-profile-overrides-path", str(overrides),
                     "--wait-for-subscribers", "1", stdin=subprocess.PIPE)
        assert spin_until(executor, lambda: node.get_publishers_info_by_topic("/imu"), 60.0)
        offered = node.get_publishers_info_by_topic("/imu")
        joint_publishers = node.count_publishers("/joints")
        end = time.monotonic() + 1.0        # paused: nothing may come while we wait
        spin_until(executor, lambda: time.monotonic() > end, 5.0)
        assert got == [] and clocks == []
        play.stdin.write("\n")
        play.stdin.flush()
        assert spin_until(executor, lambda: len(got) >= len(want) and play.poll() is not None, 60.0)
        spin_until(executor, lambda: False, 0.3)
        _finish(play)
    assert [(p.qos_profile.reliability, p.qos_profile.durability) for p in offered] == \
        [(ReliabilityPolicy.RELIABLE, DurabilityPolicy.TRANSIENT_LOCAL)]
    assert got == want
    assert joints == [] and joint_publishers == 0
    # /clock on a 10 ms grid of bag time from the first message to the last one played
    last = max(ns for t, _, ns, _ in MESSAGES if t == "/imu" and ns <= EPOCH_NS + duration_ns)
    assert clocks == list(range(EPOCH_NS, last + 1, 10_000_000))


@pytest.mark.ros
def test_pace_starts_on_a_free_timing_readers_ready_and_again_for_a_second_player(bags, ros_domain_env):
    """--pace into a reader built like a free-timing node: best-effort inputs and a volatile
    ~/progress on which ``announce_when_connected`` says "ready" (step 0, i.e. epoch 0,
    1.8e9 s before the bag), then the newest /imu stamp it got. The player starts on "ready",
    takes it as "from the bag's start" (it used to wait forever for a reader 1.8e9 s behind),
    runs to its end and exits 0; a second player into the same reader gets its own "ready".

    What the reader gets is in bag order, without repeats. Best effort may still lose a sample
    on a loaded machine (the transport, not the player), so the test does not ask for every one.
    It asks for what pacing guarantees: the player publishes its last /imu message only once
    the reader's progress is within the pace window (``PlayOptions.pace_window_s``) of it, so
    the reader must have acknowledged an /imu stamp that close to the bag's end."""
    from gimbal_kinematics.ros.node_io import input_qos, output_qos
    from gimbal_kinematics.ros.readiness import announce_when_connected

    want = {t: [ns for tt, _, ns, _ in MESSAGES if tt == t] for t in ("/imu", "/joints")}
    got: dict[str, list[int]] = {t: [] for t in want}
    with harness_node(int(ros_domain_env["ROS_DOMAIN_ID"]), "free_reader") as (node, executor):
        progress = node.create_publisher(Clock, "~/progress", output_qos("free"))

        def on_imu(msg: Imu) -> None:
            got["/imu"].append(m.stamp_ns(msg.header.stamp))
            progress.publish(m.clock_msg(got["/imu"][-1]))

        inputs = [node.create_subscription(Imu, "/imu", on_imu, input_qos("free")),
                  node.create_subscription(JointState, "/joints",
                                           lambda msg: got["/joints"].append(m.stamp_ns(msg.header.stamp)),
                                           input_qos("free"))]
        announce_when_connected(node, progress, inputs=inputs)
        for _ in range(2):
            for stamps in got.values():
                stamps.clear()
            play = _play(bags["mcap"], ros_domain_env, "--rate", "0", "--pace", "/free_reader/progress",
                         "--wait-for-subscribers", "1")
            if not spin_until(executor, lambda: play.poll() is not None, 120.0):
                play.kill()  # its stderr (what it waits for) is in _finish's message
            _finish(play)
            spin_until(executor, lambda: all(len(got[t]) >= len(want[t]) for t in want), 2.0)  # the last in flight
            for topic, stamps in got.items():
                assert stamps == sorted(set(stamps)) and set(stamps) <= set(want[topic]), topic
            assert got["/joints"] and max(got["/imu"]) >= want["/imu"][-1] - int(PlayOptions.pace_window_s * 1e9)
            # that player has gone: the next one to match is a new progress reader
            assert spin_until(executor, lambda: progress.get_subscription_count() == 0, 60.0)


def test_bad_play_options_exit_2_naming_them(bags, tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"/imu": {"reliability": "sometimes"}}))
    for args, name in ((["--qos-profile-overrides-path", str(bad)], "--qos-profile-overrides-path"),
                       (["--exclude-topics", "/nope"], "--exclude-topics"),
                       (["--clock", "0"], "--clock")):
        result = subprocess.run([str(VENV_BIN / "gimbal-bag"), "play", str(bags["mcap"]), *args],
                                capture_output=True, text=True, timeout=60)
        assert result.returncode == 2, (args, result.stderr)
        assert name in result.stderr, (args, result.stderr)
