"""The live view's relay without a run (no ROS graph, no node): each topic decimated by its
messages' stamps, and a failure inside the live view turning it off, logged once, instead of
stopping the recorder.

What the relay sends is read back through the Foxglove SDK's own MCAP sink on the relay's
context (what a connected client would get) with the ``mcap`` library's reader; messages are
serialised with rosbags, not with the project's code.
"""
from __future__ import annotations

import math
import socket

import foxglove
import pytest
from mcap.reader import make_reader
from rosbags.typesys import Stores, get_typestore

from gimbal_sim.bag.live import LiveGuard, LiveRelay

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
VECTOR = "geometry_msgs/msg/Vector3Stamped"
#: the EKF's bias: a live-view source, decoded for the ±3σ plot whether or not a client listens
BIAS = "/gyro_bias_ekf/bias"


def _vector_cdr(stamp_ns: int, x: float = 0.0) -> bytes:
    T = TYPESTORE.types
    msg = T["geometry_msgs/msg/Vector3Stamped"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000,
                                                                              nanosec=stamp_ns % 1_000_000_000),
                                        frame_id="gimbal"),
        vector=T["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=0.0))
    return bytes(TYPESTORE.serialize_cdr(msg, VECTOR))


def test_each_topic_is_decimated_by_stamp_to_its_rate(tmp_path):
    """1000 messages 3 ms apart on each topic. A topic at R Hz relays a message when its
    stamp is at least 1/R after the last relayed one: every m = ceil((1/R)/3 ms)-th message,
    ceil(1000/m) in all. Default 50 Hz (m = 7: 143), an override of 200 Hz (m = 2: 500),
    0 Hz: every message (1000)."""
    n, dt_ns = 1000, 3_000_000
    rates = {"/default": 50.0, "/fast": 200.0, "/every": 0.0}
    relay = LiveRelay("127.0.0.1", 0, 50.0, {"/fast": 200.0, "/every": 0.0})
    sink = foxglove.open_mcap(tmp_path / "relayed.mcap", context=relay.context)
    try:
        for topic in rates:
            relay.add_topic(topic, VECTOR)
        t0 = 1_700_000_000_000_000_000
        for k in range(n):
            for topic in rates:
                relay.publish(topic, _vector_cdr(t0 + k * dt_ns, float(k)), t0 + k * dt_ns)
    finally:
        sink.close()
        relay.close()
    relayed: dict[str, list[int]] = {topic: [] for topic in rates}
    with open(tmp_path / "relayed.mcap", "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            if channel.topic in relayed:
                relayed[channel.topic].append(message.log_time)
    for topic, rate in rates.items():
        stamps = relayed[topic]
        period_ns = 1e9 / rate if rate > 0 else 0.0
        every = max(1, math.ceil(period_ns / dt_ns))
        assert len(stamps) == math.ceil(n / every), (topic, len(stamps))
        assert stamps[0] == t0 and stamps == sorted(stamps)
        gaps = [b - a for a, b in zip(stamps, stamps[1:])]
        assert min(gaps) >= period_ns and max(gaps) == every * dt_ns, (topic, min(gaps), max(gaps))
    # the payload relayed is the message of that stamp, byte for byte
    with open(tmp_path / "relayed.mcap", "rb") as f:
        first = next(m for _, c, m in make_reader(f).iter_messages() if c.topic == "/default" and m.log_time > t0)
    assert first.data == _vector_cdr(first.log_time, float((first.log_time - t0) // dt_ns))


def test_an_error_in_the_live_view_is_logged_once_and_turns_it_off():
    """A bias message the relay cannot decode (its CDR cut short) makes ``LiveRelay.publish``
    raise; through the guard the recorder calls, that is one log line naming the error, the
    server closed and every later call a no-op: nothing reaches the caller."""
    bad = _vector_cdr(2_000_000_000)[:10]
    direct = LiveRelay("127.0.0.1", 0, 0.0, {})
    try:
        direct.add_topic(BIAS, VECTOR)
        with pytest.raises(Exception) as raised:
            direct.publish(BIAS, bad, 2_000_000_000)
    finally:
        direct.close()

    logs: list[str] = []
    guard = LiveGuard(LiveRelay("127.0.0.1", 0, 0.0, {}), logs.append)
    port = guard.port
    socket.create_connection(("127.0.0.1", port), timeout=2.0).close()  # listening
    guard.add_topic(BIAS, VECTOR)
    guard.publish(BIAS, _vector_cdr(1_000_000_000, 1e-5), 1_000_000_000)
    assert guard.on and logs == []
    guard.publish(BIAS, bad, 2_000_000_000)
    assert not guard.on
    assert len(logs) == 1 and type(raised.value).__name__ in logs[0] and str(port) in logs[0], logs
    assert "live view turned off" in logs[0]
    with pytest.raises(ConnectionRefusedError):
        socket.create_connection(("127.0.0.1", port), timeout=2.0)
    for k in range(3, 50):  # later messages, good or bad: nothing raised, nothing more logged
        guard.publish(BIAS, bad if k % 2 else _vector_cdr(k * 1_000_000_000), k * 1_000_000_000)
    guard.add_topic("/gimbal/imu", "sensor_msgs/msg/Imu")
    guard.close()
    assert len(logs) == 1
