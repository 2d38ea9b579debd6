"""The run's frames as ``foxglove.FrameTransforms`` (JSON) for the live view's 3D panel.

Each relayed message of a source topic becomes one FrameTransforms message at its own stamp.
Truth and estimate hang side by side from the navigation frame, the estimate's frames under
an ``ekf/`` or ``alignment/`` prefix:

* ``/truth/host/imu``: navigation ``map_ned`` → host body ``base_link_frd`` (C_nb);
* ``/truth/gimbal/joint_states`` (paper 1's sighting chain, spec §2): body → turret (ψt about
  z) → gimbal azimuth (ψm about z) → inner gimbal ``gimbal_inner_frd`` (θm about y);
* ``/truth/platform/joint_states`` (paper 3's four-gimbal platform,
  :mod:`gimbal_kinematics.maths.four_gimbal`): body → outer roll (θ_r about x) → pitch (θ_p about
  y) → inner roll (θ_q about x) → azimuth, the stable element ``platform_frd`` (θ_a about z);
* ``/ins/imu``: ``map_ned`` → ``ins/base_link_frd``, the INS's attitude;
* ``/gyro_bias_ekf/attitude``: ``map_ned`` → ``ekf/gimbal_inner_frd``, the EKF's C_nm;
* ``/platform_alignment/misalignment``: ``map_ned`` → ``alignment/platform_frd``, the platform
  the fine alignment estimates, C_ns = exp([φ̂×]) rot3(ψ)ᵀ: φ̂ is the estimated misalignment
  (NED, believed → true platform) and rot3(ψ)ᵀ the level frame the filter believes in, turned
  by ψ = θ_a + ``base_heading_deg`` (the ``platform_alignment`` node's, from the scenario). θ_a
  is the last relayed ``/truth/platform/joint_states`` sample's, carried to the stamp with its
  rate. The navigator (``platform_navigator``) publishes no attitude: its runs show the truth.

A transform's rotation is the child frame's orientation in its parent: the quaternion of
C_parent,child, (x, y, z, w) as on our messages. The intermediate gimbal frames have no ids
in :mod:`gimbal_kinematics.maths.frames` (no node writes them); they are named here, FRD like the
rest (REP 103/105 style: one ``*_frd`` id per body).
"""
from __future__ import annotations

import json
import math

from rclpy.serialization import deserialize_message
from geometry_msgs.msg import Vector3Stamped
from sensor_msgs.msg import Imu, JointState

from gimbal_kinematics.maths.frames import (BASE_FRAME, GIMBAL_ENCODER_JOINTS, GIMBAL_FRAME, NAV_FRAME, PLATFORM_FRAME,
                                      PLATFORM_JOINTS)
from gimbal_kinematics.maths.rotations import quat_from_rotation_vector, quat_mul

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
#: The four-gimbal platform's gimbals between the body and the stable element, outer to inner.
OUTER_ROLL_FRAME = "platform_outer_roll_frd"
PITCH_FRAME = "platform_pitch_frd"
INNER_ROLL_FRAME = "platform_inner_roll_frd"
EKF_GIMBAL_FRAME = "ekf/" + GIMBAL_FRAME
ALIGNMENT_PLATFORM_FRAME = "alignment/" + PLATFORM_FRAME
TRUTH_GIMBAL_JOINTS = "/truth/gimbal/joint_states"
TRUTH_PLATFORM_JOINTS = "/truth/platform/joint_states"
MISALIGNMENT = "/platform_alignment/misalignment"
EKF_ATTITUDE = "/gyro_bias_ekf/attitude"
_AXES = {"x": 0, "y": 1, "z": 2}


def axis_quat(axis: str, angle: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of a rotation by ``angle`` about one axis of the parent."""
    q = [0.0, 0.0, 0.0, math.cos(angle / 2.0)]
    q[_AXES[axis]] = math.sin(angle / 2.0)
    return tuple(q)


def stamp_dict(stamp_ns: int) -> dict:
    return {"sec": stamp_ns // 1_000_000_000, "nsec": stamp_ns % 1_000_000_000}


def _transform(stamp_ns: int, parent: str, child: str, quat) -> dict:
    x, y, z, w = (float(v) for v in quat)
    return {"timestamp": stamp_dict(stamp_ns), "parent_frame_id": parent, "child_frame_id": child,
            "translation": {"x": 0.0, "y": 0.0, "z": 0.0}, "rotation": {"x": x, "y": y, "z": z, "w": w}}


def _attitude(parent: str, child: str):
    def source(stamp_ns: int, data: bytes) -> list[dict]:
        msg = deserialize_message(data, Imu)
        if msg.orientation_covariance[0] == -1.0:  # REP 145: no orientation on this message
            return []
        o = msg.orientation
        return [_transform(stamp_ns, parent, child, (o.x, o.y, o.z, o.w))]
    return source


def _chain(joints: tuple[str, ...], links: tuple[tuple[str, str, str], ...]):
    """A JointState's joints (in ``joints`` order) as the links (parent, child, axis)."""
    def source(stamp_ns: int, data: bytes) -> list[dict]:
        msg = deserialize_message(data, JointState)
        angle = dict(zip(msg.name, msg.position))
        if not set(joints) <= set(angle):
            return []
        return [_transform(stamp_ns, parent, child, axis_quat(axis, angle[joint]))
                for joint, (parent, child, axis) in zip(joints, links)]
    return source


_GIMBAL_CHAIN = _chain(GIMBAL_ENCODER_JOINTS, ((BASE_FRAME, TURRET_FRAME, "z"), (TURRET_FRAME, AZIMUTH_FRAME, "z"),
                                               (AZIMUTH_FRAME, GIMBAL_FRAME, "y")))
# PLATFORM_JOINTS are (a, q, p, r), inner to outer
_PLATFORM_CHAIN = _chain(PLATFORM_JOINTS, ((INNER_ROLL_FRAME, PLATFORM_FRAME, "z"), (PITCH_FRAME, INNER_ROLL_FRAME, "x"),
                                           (OUTER_ROLL_FRAME, PITCH_FRAME, "y"), (BASE_FRAME, OUTER_ROLL_FRAME, "x")))

_SOURCES = {
    "/truth/host/imu": _attitude(NAV_FRAME, BASE_FRAME),
    TRUTH_GIMBAL_JOINTS: _GIMBAL_CHAIN,
    TRUTH_PLATFORM_JOINTS: _PLATFORM_CHAIN,
    "/ins/imu": _attitude(NAV_FRAME, "ins/" + BASE_FRAME),
    EKF_ATTITUDE: _attitude(NAV_FRAME, EKF_GIMBAL_FRAME),
}
#: Every topic the frames are made from.
SOURCE_TOPICS = (*_SOURCES, MISALIGNMENT)


class LiveFrames:
    """FrameTransforms of relayed messages; keeps the platform azimuth that the alignment's
    estimate is resolved with. ``platform_heading_rad``: the alignment's ``base_heading_deg``."""

    def __init__(self, platform_heading_rad: float = 0.0) -> None:
        self.platform_heading = platform_heading_rad
        self._azimuth: tuple[int, float, float] | None = None  # (stamp ns, θ_a, rate) of the last sample

    def transforms(self, topic: str, data: bytes, stamp_ns: int) -> bytes | None:
        """The JSON FrameTransforms message a relayed message of ``topic`` makes, or None."""
        if topic == MISALIGNMENT:
            transforms = self._alignment(stamp_ns, data)
        elif topic in _SOURCES:
            transforms = _SOURCES[topic](stamp_ns, data)
            if topic == TRUTH_PLATFORM_JOINTS and transforms:
                self._keep_azimuth(stamp_ns, data)
        else:
            return None
        return json.dumps({"transforms": transforms}).encode() if transforms else None

    def _keep_azimuth(self, stamp_ns: int, data: bytes) -> None:
        msg = deserialize_message(data, JointState)
        i = list(msg.name).index(PLATFORM_JOINTS[0])
        rate = msg.velocity[i] if len(msg.velocity) == len(msg.name) else 0.0
        self._azimuth = (stamp_ns, msg.position[i], rate)

    def _alignment(self, stamp_ns: int, data: bytes) -> list[dict]:
        if self._azimuth is None:
            return []
        t_ns, theta_a, rate = self._azimuth
        phi = deserialize_message(data, Vector3Stamped).vector  # the estimated misalignment φ̂
        if not all(math.isfinite(c) for c in (phi.x, phi.y, phi.z)):
            return []
        psi = theta_a + rate * (stamp_ns - t_ns) * 1e-9 + self.platform_heading
        quat = quat_mul(quat_from_rotation_vector(phi.x, phi.y, phi.z), axis_quat("z", psi))
        return [_transform(stamp_ns, NAV_FRAME, ALIGNMENT_PLATFORM_FRAME, quat)]
