"""Views of serialized messages (gimbal_kinematics.ros.views) read the same fields as
rclpy's own deserialisation, on bytes serialised by rosbags (a library we did not write)."""
from __future__ import annotations

import numpy as np
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Imu, JointState

from foreign_bags import imu_cdr, joint_state_cdr
from gimbal_kinematics.ros.views import ImuView, JointStateView, decoder


def test_imu_and_joint_state_views_equal_rclpy_messages():
    t_ns = 1_800_000_000_123_456_789
    data = imu_cdr(t_ns, [1e-3, -2.5, 3.25], quat=(0.1, 0.2, 0.3, float(np.sqrt(1 - 0.14))), frame="gimbal")
    view, msg = decoder(Imu)(data), deserialize_message(data, Imu)
    assert isinstance(view, ImuView)
    assert (view.header.stamp.sec, view.header.stamp.nanosec, view.header.frame_id) == \
        (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id)
    for field in ("orientation", "angular_velocity", "linear_acceleration"):
        v, o = getattr(view, field), getattr(msg, field)
        assert [getattr(v, a) for a in v._fields] == [getattr(o, a) for a in v._fields]
    for field in ("orientation_covariance", "angular_velocity_covariance", "linear_acceleration_covariance"):
        assert list(getattr(view, field)) == list(getattr(msg, field))
    data = joint_state_cdr(t_ns, ["gimbal_outer", "gimbal_inner"], [0.5, -1.5], [2.0, 3.0])
    view, msg = decoder(JointState)(data), deserialize_message(data, JointState)
    assert isinstance(view, JointStateView)
    assert view.name == tuple(msg.name) and view.position == tuple(msg.position)
    assert view.velocity == tuple(msg.velocity) and view.effort == tuple(msg.effort)
    assert (view.header.stamp.sec, view.header.stamp.nanosec) == (msg.header.stamp.sec, msg.header.stamp.nanosec)


def test_bytes_the_view_refuses_come_back_as_the_message_object():
    """Big-endian CDR (legal, rare): the struct decoder refuses it, rclpy reads it."""
    from foreign_bags import IMU, T, TYPESTORE, header

    v3 = T["geometry_msgs/msg/Vector3"]
    msg = T[IMU](header=header(7, "x"), orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                 orientation_covariance=np.zeros(9), angular_velocity=v3(x=1.0, y=2.0, z=3.0),
                 angular_velocity_covariance=np.zeros(9), linear_acceleration=v3(x=0.0, y=0.0, z=0.0),
                 linear_acceleration_covariance=np.zeros(9))
    data = bytes(TYPESTORE.serialize_cdr(msg, IMU, little_endian=False))
    out = decoder(Imu)(data)
    assert isinstance(out, Imu)
    assert (out.header.stamp.nanosec, out.angular_velocity.y) == (7, 2.0)
