"""The sighting chain as ``foxglove.FrameTransforms`` (JSON) for the live view's 3D panel.

Each relayed message of a chain topic becomes one FrameTransforms message at its own stamp,
so no state is kept across topics (their arrival order is not fixed):

* ``/truth/host/imu``: navigation ``map_ned`` → host body ``base_link_frd`` (its orientation, C_nb);
* ``/truth/gimbal/joint_states``: body → turret (ψt about z) → gimbal azimuth (ψm about z) →
  inner gimbal ``gimbal_inner_frd`` (θm about y), spec §2;
* ``/ins/imu``: ``map_ned`` → ``ins/base_link_frd``, the INS's attitude;
* ``/gyro_bias_ekf/attitude``: ``map_ned`` → ``ekf/gimbal_inner_frd``, the EKF's estimate C_nm.

A transform's rotation is the child frame's orientation in its parent: the quaternion of
C_parent,child, (x, y, z, w) as on our messages.
"""
from __future__ import annotations

import json
import math

from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.frames import BASE_FRAME, GIMBAL_ENCODER_JOINTS, GIMBAL_FRAME, NAV_FRAME

TOPIC = "/live/frames"
SCHEMA_NAME = "foxglove.FrameTransforms"
_VEC = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
JSON_SCHEMA = json.dumps({
    "title": SCHEMA_NAME, "type": "object",
    "properties": {"transforms": {"type": "array", "items": {
        "type": "object",
        "properties": {
            "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
            "parent_frame_id": {"type": "string"}, "child_frame_id": {"type": "string"},
            "translation": _VEC, "rotation": _QUAT}}}},
})
TURRET_FRAME = "turret_frd"
AZIMUTH_FRAME = "gimbal_azimuth_frd"
_AXES = {"z": 2, "y": 1}


def axis_quat(axis: str, angle: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``angle`` about one axis of the parent."""
    q = [0.0, 0.0, 0.0, math.cos(angle / 2.0)]
    q[_AXES[axis]] = math.sin(angle / 2.0)
    return tuple(q)


def _transform(stamp_ns: int, parent: str, child: str, quat) -> dict:
    x, y, z, w = (float(v) for v in quat)
    return {"timestamp": {"sec": stamp_ns // 1_000_000_000, "nsec": stamp_ns % 1_000_000_000},
            "parent_frame_id": parent, "child_frame_id": child,
            "translation": {"x": 0.0, "y": 0.0, "z": 0.0}, "rotation": {"x": x, "y": y, "z": z, "w": w}}


def _attitude(parent: str, child: str):
    def source(stamp_ns: int, data: bytes) -> list[dict]:
        msg = deserialize_message(data, Imu)
        if msg.orientation_covariance[0] == -1.0:  # REP 145: no orientation on this message
            return []
        o = msg.orientation
        return [_transform(stamp_ns, parent, child, (o.x, o.y, o.z, o.w))]
    return source


def _gimbal_chain(stamp_ns: int, data: bytes) -> list[dict]:
    msg = deserialize_message(data, JointState)
    angle = dict(zip(msg.name, msg.position))
    if not set(GIMBAL_ENCODER_JOINTS) <= set(angle):
        return []
    psi_t, psi_m, theta_m = (angle[n] for n in GIMBAL_ENCODER_JOINTS)
    return [_transform(stamp_ns, BASE_FRAME, TURRET_FRAME, axis_quat("z", psi_t)),
            _transform(stamp_ns, TURRET_FRAME, AZIMUTH_FRAME, axis_quat("z", psi_m)),
            _transform(stamp_ns, AZIMUTH_FRAME, GIMBAL_FRAME, axis_quat("y", theta_m))]


_SOURCES = {
    "/truth/host/imu": _attitude(NAV_FRAME, BASE_FRAME),
    "/truth/gimbal/joint_states": _gimbal_chain,
    "/ins/imu": _attitude(NAV_FRAME, "ins/" + BASE_FRAME),
    "/gyro_bias_ekf/attitude": _attitude(NAV_FRAME, "ekf/" + GIMBAL_FRAME),
}


def frame_transforms(topic: str, data: bytes, stamp_ns: int) -> bytes | None:
    """The JSON FrameTransforms message a relayed message of ``topic`` makes, or None."""
    source = _SOURCES.get(topic)
    if source is None:
        return None
    transforms = source(stamp_ns, data)
    return json.dumps({"transforms": transforms}).encode() if transforms else None
