"""Bags our writer produces, read back by libraries we did not write (rosbags, mcap),
and what survives truncation."""
from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import serialize_message
from rosbags.highlevel import AnyReader

from gimbal_kinematics.ros import messages as m
from gimbal_sim.bag.qos_yaml import qos_from_dict, qos_to_dict
from gimbal_sim.bag.reader import BagError, read_messages, recover, scan
from gimbal_sim.bag.schemas import SEPARATOR, ros2msg_schema
from gimbal_sim.bag.writer import BagWriter
from gimbal_kinematics.ros.qos import GRAPH_QOS

RATE = 100.0


def _messages(n: int):
    for k in range(n):
        t = m.step_stamp_ns(k, RATE)
        yield "/imu", "sensor_msgs/msg/Imu", m.imu_msg(t, "base_link_frd", orientation=(0.0, 0.0, math.sin(k), 1.0),
                                                        angular_velocity=(k * 0.1, -k, 0.5)), t
        # effort filled: rclpy's serialize_message pads a trailing empty sequence to 8 bytes,
        # which rosbags (strict to 3 bytes) rejects; messages off the wire carry no such padding
        yield "/joints", "sensor_msgs/msg/JointState", m.joint_state_msg(t, ["a", "b"], [k, 2.0 * k], [0.1, 0.2],
                                                                          [0.0, 1.0]), t
        yield "/clock", "rosgraph_msgs/msg/Clock", m.clock_msg(t), t


def write_bag(directory: Path, n: int, chunk_duration_ns: int = 10**9, compress: bool = True) -> list:
    writer = BagWriter(directory, chunk_duration_ns=chunk_duration_ns, compress=compress)
    written = []
    for topic, type_name, msg, t in _messages(n):
        writer.add_topic(topic, type_name, [qos_to_dict(GRAPH_QOS)])
        data = serialize_message(msg)  # rclpy leaves padding bytes uninitialised: keep these
        writer.write(topic, data, t)
        written.append((topic, t, msg, data))
    writer.close()
    return written


@pytest.mark.parametrize("compress", [True, False])
def test_rosbags_and_mcap_read_back_every_message(tmp_path, compress):
    written = write_bag(tmp_path / "bag", 200, compress=compress)
    with AnyReader([tmp_path / "bag"]) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == {"/imu": 200, "/joints": 200, "/clock": 200}
        got = [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    assert [(topic, t) for topic, t, _ in got] == [(topic, t) for topic, t, _, _ in written]
    for (topic, _, ours), (_, _, theirs, _) in zip(got, written):
        if topic == "/imu":
            assert (ours.angular_velocity.x, ours.orientation.z) == (theirs.angular_velocity.x, theirs.orientation.z)
        elif topic == "/joints":
            assert list(ours.position) == list(theirs.position) and list(ours.name) == list(theirs.name)
    with open(tmp_path / "bag" / "bag_0.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert {c.compression for c in summary.chunk_indexes} == {"zstd" if compress else ""}
        assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}
        for channel in summary.channels.values():
            qos = yaml.safe_load(channel.metadata["offered_qos_profiles"])
            assert qos[0]["reliability"] == "reliable" and qos[0]["durability"] == "transient_local"
        decoded = [(c.topic, msg.log_time, d) for _, c, msg, d in reader.iter_decoded_messages(log_time_order=True)]
    assert len(decoded) == len(written)
    assert decoded[-1][2].clock.nanosec == written[-1][2].clock.nanosec


def test_schema_layout_and_metadata(tmp_path):
    schema = ros2msg_schema("sensor_msgs/msg/Imu")
    assert schema.startswith("# This is a message to hold data from an IMU")
    assert f"\n{SEPARATOR}\nMSG: std_msgs/Header\n" in schema
    assert schema.count("MSG: ") == 4  # Header, Time, Quaternion, Vector3: each once
    write_bag(tmp_path / "bag", 10)
    meta = yaml.safe_load((tmp_path / "bag" / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap" and meta["ros_distro"] == "jazzy"
    assert meta["message_count"] == 30 and meta["relative_file_paths"] == ["bag_0.mcap"]
    assert meta["duration"]["nanoseconds"] == m.step_stamp_ns(9, RATE)
    qos = meta["topics_with_message_count"][0]["topic_metadata"]["offered_qos_profiles"][0]
    assert qos_from_dict(qos, GRAPH_QOS) == GRAPH_QOS


@pytest.mark.parametrize("compress", [True, False])
def test_truncated_bag_keeps_every_complete_chunk_and_recovers(tmp_path, compress):
    # 0.1 s chunks: 5 s of data (1500 messages) in ~50 chunks
    written = write_bag(tmp_path / "bag", 500, chunk_duration_ns=100_000_000, compress=compress)
    mcap = tmp_path / "bag" / "bag_0.mcap"
    data = mcap.read_bytes()
    with open(mcap, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    # cut in the middle of the chunk 60 % into the file (a cut between chunks, in the
    # message indexes that follow each, would leave no partial chunk to test)
    middle = chunks[len(chunks) * 6 // 10]
    cut = middle.chunk_start_offset + middle.chunk_length // 2
    complete = [c for c in chunks if c.chunk_start_offset + c.chunk_length <= cut]
    partial = [c for c in chunks if c.chunk_start_offset < cut < c.chunk_start_offset + c.chunk_length]
    assert len(complete) >= 10 and len(partial) == 1
    mcap.write_bytes(data[:cut])
    (tmp_path / "bag" / "metadata.yaml").unlink()  # as after a SIGKILL
    contents = scan(tmp_path / "bag")
    assert not contents.closed_cleanly and contents.error
    # the readable part is a prefix of what was written: all of every complete chunk, and
    # nothing of the cut one (the mcap library's own chunk index says where they end)
    messages, _ = read_messages(tmp_path / "bag")
    n = len(messages)
    assert [(x.topic, x.log_time_ns, x.data) for x in messages] == \
        [(topic, t, data) for topic, t, _, data in written[:n]]
    assert messages[-1].log_time_ns == max(c.message_end_time for c in complete)
    assert all(t < partial[0].message_start_time or (topic, t) in {(x.topic, x.log_time_ns) for x in messages}
               for topic, t, _, _ in written[:n])
    assert n < len(written) and written[n][1] >= partial[0].message_start_time
    out, _ = recover(tmp_path / "bag")
    assert out == tmp_path / "bag_recovered"
    with AnyReader([out]) as reader:
        assert sum(1 for _ in reader.messages()) == n
    assert scan(out).closed_cleanly
    with pytest.raises(BagError, match="already exists"):
        recover(tmp_path / "bag")


def test_not_a_bag_is_named(tmp_path):
    with pytest.raises(BagError, match="no such file"):
        scan(tmp_path / "missing")
    (tmp_path / "file.txt").write_text("x")
    with pytest.raises(BagError, match="not a bag .give a bag directory"):
        scan(tmp_path / "file.txt")
    (tmp_path / "empty").mkdir()
    with pytest.raises(BagError, match="not a bag"):
        scan(tmp_path / "empty")
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "junk_0.mcap").write_bytes(b"not an mcap file at all")
    contents = scan(tmp_path / "junk")
    assert not contents.closed_cleanly and "no MCAP magic" in contents.error


def test_writer_refuses_to_overwrite_a_bag(tmp_path):
    write_bag(tmp_path / "bag", 3)
    with pytest.raises(FileExistsError, match="already holds a bag"):
        BagWriter(tmp_path / "bag")
