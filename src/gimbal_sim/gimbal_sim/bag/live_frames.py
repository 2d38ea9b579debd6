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

``/live/los`` (``foxglove.SceneUpdate``, JSON): the line of sight, the m frame's x axis
(spec §2), as an arrow locked to the true inner gimbal and one to the EKF's, sent with the
chain topics that move them.
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
SCENE_TOPIC = "/live/los"
SCENE_SCHEMA_NAME = "foxglove.SceneUpdate"
SCENE_JSON_SCHEMA = json.dumps({"title": SCENE_SCHEMA_NAME, "type": "object",
                                "properties": {"deletions": {"type": "array"}, "entities": {"type": "array"}}})
LOS_LENGTH_M = 5.0
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


_LOS_FRAMES = {"/truth/gimbal/joint_states": (GIMBAL_FRAME, (0.1, 0.8, 0.2)),
               "/gyro_bias_ekf/attitude": ("ekf/" + GIMBAL_FRAME, (0.9, 0.5, 0.1))}


def los_scene(topic: str, stamp_ns: int) -> bytes | None:
    """The JSON SceneUpdate with the LOS arrow of the frame ``topic`` moves, or None."""
    if topic not in _LOS_FRAMES:
        return None
    frame, (r, g, b) = _LOS_FRAMES[topic]
    arrow = {"pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                      "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},  # along the frame's x: the LOS
             "shaft_length": 0.9 * LOS_LENGTH_M, "shaft_diameter": 0.02, "head_length": 0.1 * LOS_LENGTH_M,
             "head_diameter": 0.08, "color": {"r": r, "g": g, "b": b, "a": 1.0}}
    entity = {"timestamp": {"sec": stamp_ns // 1_000_000_000, "nsec": stamp_ns % 1_000_000_000},
              "frame_id": frame, "id": f"los:{frame}", "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": True,
              "metadata": [], "arrows": [arrow], "cubes": [], "spheres": [], "cylinders": [], "lines": [],
              "triangles": [], "texts": [], "models": []}
    return json.dumps({"deletions": [], "entities": [entity]}).encode()
