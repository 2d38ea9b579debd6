"""Test bags of sensor_msgs/Imu written by the ``rosbags`` writer (a library we did not write),
from sample arrays made with numpy alone, for the ``gimbal-allan`` tests."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
IMU = TYPESTORE.types["sensor_msgs/msg/Imu"]
HEADER = TYPESTORE.types["std_msgs/msg/Header"]
TIME = TYPESTORE.types["builtin_interfaces/msg/Time"]
VECTOR3 = TYPESTORE.types["geometry_msgs/msg/Vector3"]
QUATERNION = TYPESTORE.types["geometry_msgs/msg/Quaternion"]
NOT_PROVIDED = np.array([-1.0] + [0.0] * 8)


def write_imu_bag(path: Path, stamps_ns: np.ndarray, gyro: np.ndarray, *, topic: str = "/imu",
                  gyro_cov: np.ndarray | None = None, accel: np.ndarray | None = None,
                  storage: str = "mcap", extra_topics: dict[str, str] | None = None, stamped: bool = True,
                  header_ns: np.ndarray | None = None) -> Path:
    """A rosbag2 bag at ``path`` with one Imu per stamp: angular_velocity = ``gyro`` (n, 3),
    its covariance ``gyro_cov`` (9,) (default all zeros: unknown), linear_acceleration =
    ``accel`` (n, 3) or not provided (covariance[0] = -1). ``extra_topics``: topic -> type of
    empty topics to add (e.g. one of the wrong type). ``stamped`` False leaves every header
    stamp at zero (a driver that does not stamp): only the log times carry the time;
    ``header_ns`` (n,) gives header stamps other than the log times ``stamps_ns``."""
    gyro_cov = np.zeros(9) if gyro_cov is None else np.asarray(gyro_cov, dtype=float)
    acc_cov = np.zeros(9) if accel is not None else NOT_PROVIDED
    plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
    with Writer(path, version=9, storage_plugin=plugin) as writer:
        conn = writer.add_connection(topic, IMU.__msgtype__, typestore=TYPESTORE)
        for name, msgtype in (extra_topics or {}).items():
            writer.add_connection(name, msgtype, typestore=TYPESTORE)
        zero = VECTOR3(x=0.0, y=0.0, z=0.0)
        quat = QUATERNION(x=0.0, y=0.0, z=0.0, w=1.0)
        for i, t in enumerate(np.asarray(stamps_ns, dtype=np.int64).tolist()):
            g = gyro[i]
            a = accel[i] if accel is not None else None
            h = (t if header_ns is None else int(header_ns[i])) if stamped else 0
            msg = IMU(header=HEADER(stamp=TIME(sec=h // 1_000_000_000, nanosec=h % 1_000_000_000), frame_id="imu"),
                      orientation=quat, orientation_covariance=NOT_PROVIDED,
                      angular_velocity=VECTOR3(x=float(g[0]), y=float(g[1]), z=float(g[2])),
                      angular_velocity_covariance=gyro_cov,
                      linear_acceleration=zero if a is None else VECTOR3(x=float(a[0]), y=float(a[1]), z=float(a[2])),
                      linear_acceleration_covariance=acc_cov)
            writer.write(conn, t, TYPESTORE.serialize_cdr(msg, IMU.__msgtype__))
    return path
