"""Read-only views of serialized messages, decoded by ``struct`` without message objects.

A view has the field names of the message it stands for (``header.stamp.sec``,
``angular_velocity.y``, ``name``, ``position`` ...; arrays as tuples), so code written for
rclpy message objects reads it unchanged. Decoding a view is about twenty times cheaper
than rclpy's deserialisation into a message object: it is what lets a node take a bag
replayed at full speed (``raw=True`` subscriptions) and the reports read the 1 kHz
topics. A message the fast decoder does not recognise (:class:`.cdr.CdrError`) comes back
as the rclpy message object, so nothing is lost.
"""
from __future__ import annotations

from typing import Any, Callable, NamedTuple

from . import messages as msgs
from .cdr import CdrError


class Stamp(NamedTuple):
    sec: int
    nanosec: int


class Header(NamedTuple):
    stamp: Stamp
    frame_id: str


class Xyz(NamedTuple):
    x: float
    y: float
    z: float


class Xyzw(NamedTuple):
    x: float
    y: float
    z: float
    w: float


class ImuView(NamedTuple):
    """The fields of a sensor_msgs/Imu."""

    header: Header
    orientation: Xyzw
    orientation_covariance: tuple[float, ...]
    angular_velocity: Xyz
    angular_velocity_covariance: tuple[float, ...]
    linear_acceleration: Xyz
    linear_acceleration_covariance: tuple[float, ...]


class Vector3StampedView(NamedTuple):
    header: Header
    vector: Xyz


class JointStateView(NamedTuple):
    header: Header
    name: tuple[str, ...]
    position: tuple[float, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]


def _header(stamp_ns: int, frame_id: str) -> Header:
    return Header(Stamp(*divmod(stamp_ns, 1_000_000_000)), frame_id)


def imu_view(data: bytes) -> ImuView:
    """An :class:`ImuView` of serialized Imu bytes; raises :class:`.cdr.CdrError` if malformed."""
    d = msgs.imu_from_cdr(data)
    return ImuView(_header(d.stamp_ns, d.frame_id), Xyzw(*d.orientation), d.orientation_covariance,
                   Xyz(*d.angular_velocity), d.angular_velocity_covariance, Xyz(*d.linear_acceleration),
                   d.linear_acceleration_covariance)


def vector3_view(data: bytes) -> Vector3StampedView:
    d = msgs.vector3_stamped_from_cdr(data)
    return Vector3StampedView(_header(d.stamp_ns, d.frame_id), Xyz(*d.vector))


def joint_state_view(data: bytes) -> JointStateView:
    d = msgs.joint_state_from_cdr(data)
    return JointStateView(_header(d.stamp_ns, d.frame_id), d.name, d.position, d.velocity, d.effort)


#: ``pkg/msg/Name`` -> its view decoder.
VIEWS: dict[str, Callable[[bytes], Any]] = {"sensor_msgs/msg/Imu": imu_view,
                                            "geometry_msgs/msg/Vector3Stamped": vector3_view,
                                            "sensor_msgs/msg/JointState": joint_state_view}


def decoder(msg_class: type) -> Callable[[bytes], Any]:
    """A function of serialized bytes giving the view of ``msg_class`` (an rclpy message
    class with a view), or the deserialised message object when the view's decoder
    refuses the bytes; for a class without a view, always the message object."""
    from rclpy.serialization import deserialize_message

    module = msg_class.__module__.split(".")[0]
    view = VIEWS.get(f"{module}/msg/{msg_class.__name__}")

    def decode(data: bytes) -> Any:
        if view is not None:
            try:
                return view(data)
            except CdrError:
                pass
        return deserialize_message(data, msg_class)
    return decode
