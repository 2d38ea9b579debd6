"""Bags written by libraries the project did not write: the ``rosbags`` writer (MCAP and
sqlite3, rosbag2 metadata) and the ``mcap`` library's writer with compressed chunks (a bare
``.mcap`` file, as non-rosbag2 tools write it). Messages are built and serialised by
rosbags' own type store, so nothing here goes through our CDR code.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
T = TYPESTORE.types
IMU = "sensor_msgs/msg/Imu"
JOINT_STATE = "sensor_msgs/msg/JointState"
#: An epoch start near 1.8e9 s, with a fraction a float of seconds cannot hold.
EPOCH_NS = 1_800_000_000_123_456_789
_INFINITE = QosTime(sec=0, nsec=0)
#: What ``ros2 bag record`` stores for a publisher with the ROS default QoS.
DEFAULT_QOS = Qos(history=QosHistory.KEEP_LAST, depth=10, reliability=QosReliability.RELIABLE,
                  durability=QosDurability.VOLATILE, deadline=_INFINITE, lifespan=_INFINITE,
                  liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=_INFINITE,
                  avoid_ros_namespace_conventions=False)


def stamp(t_ns: int):
    return T["builtin_interfaces/msg/Time"](sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)


def header(t_ns: int, frame: str):
    return T["std_msgs/msg/Header"](stamp=stamp(t_ns), frame_id=frame)


def imu_cdr(t_ns: int, gyro, quat=(0.0, 0.0, 0.0, 1.0), frame: str = "imu") -> bytes:
    """A sensor_msgs/Imu (CDR, serialised by rosbags) with ``gyro`` (3,) [rad/s] and ``quat`` (x, y, z, w)."""
    v3, q = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    msg = T[IMU](header=header(t_ns, frame), orientation=q(x=quat[0], y=quat[1], z=quat[2], w=quat[3]),
                 orientation_covariance=np.zeros(9), angular_velocity=v3(x=gyro[0], y=gyro[1], z=gyro[2]),
                 angular_velocity_covariance=np.zeros(9), linear_acceleration=v3(x=0.0, y=0.0, z=0.0),
                 linear_acceleration_covariance=np.array([-1.0] + [0.0] * 8))
    return bytes(TYPESTORE.serialize_cdr(msg, IMU))


def joint_state_cdr(t_ns: int, names: list[str], position, velocity) -> bytes:
    msg = T[JOINT_STATE](header=header(t_ns, ""), name=list(names), position=np.asarray(position, dtype=float),
                         velocity=np.asarray(velocity, dtype=float), effort=np.zeros(0))
    return bytes(TYPESTORE.serialize_cdr(msg, JOINT_STATE))


def synthetic_messages(n_imu: int = 200, rate_hz: float = 200.0, seed: int = 0) -> list[tuple[str, str, int, bytes]]:
    """(topic, type, log time [ns], CDR) of an Imu on ``/imu`` at ``rate_hz`` and a JointState
    on ``/joints`` at half that, stamped from :data:`EPOCH_NS`, in time order."""
    rng = np.random.default_rng(seed)
    period = int(round(1e9 / rate_hz))
    out = []
    for i in range(n_imu):
        t = EPOCH_NS + i * period
        out.append(("/imu", IMU, t, imu_cdr(t, rng.normal(size=3).tolist())))
        if i % 2 == 0:
            out.append(("/joints", JOINT_STATE, t, joint_state_cdr(t, ["a", "b"], rng.normal(size=2), [0.0, 0.0])))
    return out


def write_rosbags(path: Path, messages: list[tuple[str, str, int, bytes]], storage: str = "mcap",
                  qos: list[Qos] | None = None) -> Path:
    """A rosbag2 bag (metadata v9) by the rosbags writer; every topic offered with ``qos``
    (default: :data:`DEFAULT_QOS`, reliable volatile)."""
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conns = {}
        for topic, msgtype, _, _ in messages:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=TYPESTORE,
                                                     offered_qos_profiles=qos or [DEFAULT_QOS])
        for topic, _, t_ns, data in messages:
            writer.write(conns[topic], t_ns, data)
    return path


def write_compressed_mcap(path: Path, messages: list[tuple[str, str, int, bytes]], compression: str) -> Path:
    """A bare ``.mcap`` (ros2 profile, no metadata.yaml) by the mcap library, chunks
    compressed with ``compression`` ("zstd" or "lz4"), small chunks so there are many."""
    from mcap.writer import CompressionType, Writer as McapWriter

    kind = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4}[compression]
    with open(path, "wb") as f:
        writer = McapWriter(f, chunk_size=4096, compression=kind)
        writer.start(profile="ros2", library="test foreign_bags (mcap)")
        channels = {}
        for topic, msgtype, _, _ in messages:
            if topic not in channels:
                schema = writer.register_schema(msgtype, "ros2msg", TYPESTORE.generate_msgdef(msgtype)[0].encode())
                channels[topic] = writer.register_channel(topic, "cdr", schema)
        for seq, (topic, _, t_ns, data) in enumerate(messages):
            writer.add_message(channels[topic], log_time=t_ns, data=data, publish_time=t_ns, sequence=seq)
        writer.finish()
    return path
