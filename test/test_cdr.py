"""Hand-written CDR encoders/decoders against rclpy's own (de)serialization."""
import math

import numpy as np
import pytest
from geometry_msgs.msg import Vector3Stamped
from rclpy.serialization import deserialize_message, serialize_message
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.ros import messages as m
from gimbal_kinematics.ros.cdr import CdrError

RNG = np.random.default_rng(11)
FRAMES = ["", "a", "ab", "abc", "abcd", "base_link_frd", "gimbal_inner_frd", "x" * 31]


@pytest.mark.parametrize("frame", FRAMES)
def test_imu_round_trips_through_rclpy(frame):
    t = int(RNG.integers(0, 10**12))
    cases = [dict(orientation=tuple(RNG.standard_normal(4)), orientation_cov=tuple(RNG.standard_normal(9)),
                  angular_velocity=tuple(RNG.standard_normal(3)), linear_acceleration=tuple(RNG.standard_normal(3))),
             dict(angular_velocity=(1.0, -2.0, math.inf), angular_velocity_cov=tuple(RNG.standard_normal(9))),
             dict()]
    for kw in cases:
        ours = m.imu_cdr(t, frame, **kw)
        theirs = serialize_message(m.imu_msg(t, frame, **kw))
        assert len(ours) == len(theirs)
        assert deserialize_message(ours, Imu) == m.imu_msg(t, frame, **kw)
        d = m.imu_from_cdr(theirs)
        msg = m.imu_msg(t, frame, **kw)
        assert (d.stamp_ns, d.frame_id) == (t, frame)
        assert d.orientation == m.quat_of(msg)
        assert d.angular_velocity == m.vec_of(msg.angular_velocity)
        assert d.linear_acceleration == m.vec_of(msg.linear_acceleration)
        assert d.angular_velocity_covariance == tuple(msg.angular_velocity_covariance)


@pytest.mark.parametrize("names,position,velocity,effort", [
    (("turret_azimuth", "gimbal_azimuth", "gimbal_elevation"), (1.0, 2.0, 3.0), (4.0, 5.0, 6.0), (7.0, 8.0, 9.0)),
    (("gimbal_azimuth", "gimbal_elevation"), (), (), (0.5, -0.25)),
    (("a",), (1.0,), (), ()), ((), (), (), ()), (("ab", "abcde"), (1.0, 2.0), (3.0, 4.0), ()),
])
def test_joint_state_round_trips_through_rclpy(names, position, velocity, effort):
    t = 1_234_567_891
    ours = m.joint_state_cdr(t, names, position, velocity, effort)
    msg = m.joint_state_msg(t, names, position, velocity, effort)
    assert deserialize_message(ours, JointState) == msg
    # rclpy's bytes may carry trailing slack after the last field; the decoder ignores it
    expected = (t, "", names, position, velocity, effort)
    assert m.joint_state_from_cdr(serialize_message(msg)) == expected
    assert m.joint_state_from_cdr(ours) == expected


@pytest.mark.parametrize("frame", FRAMES)
def test_vector3_and_clock_round_trip(frame):
    t, v = int(RNG.integers(0, 10**12)), tuple(RNG.standard_normal(3))
    ours = m.vector3_cdr(t, frame, v)
    assert len(ours) == len(serialize_message(m.vector3_msg(t, frame, v)))
    assert deserialize_message(ours, Vector3Stamped) == m.vector3_msg(t, frame, v)
    assert m.vector3_stamped_from_cdr(serialize_message(m.vector3_msg(t, frame, v))) == (t, frame, v)
    assert m.clock_cdr(t) == serialize_message(m.clock_msg(t))
    assert deserialize_message(m.clock_cdr(t), Clock).clock == m.time_msg(t)
    assert m.clock_from_cdr(serialize_message(m.clock_msg(t))) == t


@pytest.mark.parametrize("data", [b"", b"\x00\x01\x00\x00", b"\x01\x00\x00\x00" + bytes(60)])
def test_malformed_bytes_raise_cdr_error(data):
    with pytest.raises(CdrError):
        m.imu_from_cdr(data)
    with pytest.raises(CdrError):
        m.joint_state_from_cdr(data)


def test_truncated_imu_raises_cdr_error():
    with pytest.raises(CdrError):
        m.imu_from_cdr(serialize_message(m.imu_msg(5, "abc"))[:40])


def test_joint_states_of_the_same_names_and_other_lengths_decode_each_their_own():
    names = ("gimbal_azimuth", "gimbal_elevation")
    shapes = [((), (), (0.5, 0.25)), ((1.0,), (), (0.5, 0.25)), ((1.0, 2.0), (3.0, 4.0), ())]
    for _ in range(2):  # the second pass decodes from the cached shapes
        for k, (p, v, e) in enumerate(shapes):
            data = m.joint_state_cdr(1000 + k, names, p, v, e)
            assert m.joint_state_from_cdr(data) == (1000 + k, "", names, p, v, e)
            assert deserialize_message(data, JointState) == m.joint_state_msg(1000 + k, names, p, v, e)
    with pytest.raises(CdrError):
        m.joint_state_from_cdr(m.joint_state_cdr(7, names, (1.0,), (), (0.5, 0.25))[:-4])
