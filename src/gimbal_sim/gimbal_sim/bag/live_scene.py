"""``/live/los`` (``foxglove.SceneUpdate``, JSON): the line of sight and the target, for the
live view's 3D panel.

* The LOS is the m frame's x axis (spec §2): an arrow locked to the true inner gimbal, sent
  with each relayed ``/truth/gimbal/joint_states``, and one locked to the EKF's, with each
  ``/gyro_bias_ekf/attitude``.
* The geo-pointing target (:attr:`SceneConfig.target_n`), in ``map_ned``: a sphere on the
  direction to it at the LOS arrow's length, so the arrow's tip shows the pointing error, a
  line to where it really is, and its range. Sent with the true LOS. The sight pivot's lever
  arm (metres) is not drawn at the target's kilometres.

What the live view knows of the run besides its messages is a :class:`SceneConfig`, handed
in by whoever builds the live view (:mod:`.scene_config`): this module knows no node or
parameter of the scenario.
* The simulated operator's target (``sighting_operator``: captured from the LOS, held fixed
  in inertial space, in no parameter): from ``/operator/pointing_error`` (ε, e_q, e_r), the
  direction it makes in the true inner gimbal's frame, u_m = (cos ε, sin ε e_r/ε, −sin ε e_q/ε)
  (the inverse of ``world.operator_model.sight_error``), a sphere locked to that frame.
"""
from __future__ import annotations

import json
import math

from geometry_msgs.msg import Vector3Stamped
from rclpy.serialization import deserialize_message

from gimbal_kinematics.maths.frames import GIMBAL_FRAME, NAV_FRAME

from .scene_config import SceneConfig
from .live_frames import EKF_ATTITUDE, EKF_GIMBAL_FRAME, TRUTH_GIMBAL_JOINTS, stamp_dict

SCENE_TOPIC = "/live/los"
SCENE_SCHEMA_NAME = "foxglove.SceneUpdate"
SCENE_JSON_SCHEMA = json.dumps({"title": SCENE_SCHEMA_NAME, "type": "object",
                                "properties": {"deletions": {"type": "array"}, "entities": {"type": "array"}}})
LOS_LENGTH_M = 5.0
TARGET_SPHERE_M = 0.3
OPERATOR_ERROR = "/operator/pointing_error"
_LOS_FRAMES = {TRUTH_GIMBAL_JOINTS: (GIMBAL_FRAME, (0.1, 0.8, 0.2)), EKF_ATTITUDE: (EKF_GIMBAL_FRAME, (0.9, 0.5, 0.1))}
_TARGET_COLOUR = {"r": 0.9, "g": 0.1, "b": 0.1, "a": 1.0}
_IDENTITY = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}


def _entity(stamp_ns: int, frame: str, ident: str, frame_locked: bool, **primitives) -> dict:
    entity = {"timestamp": stamp_dict(stamp_ns), "frame_id": frame, "id": ident, "lifetime": {"sec": 0, "nsec": 0},
              "frame_locked": frame_locked, "metadata": [], "arrows": [], "cubes": [], "spheres": [],
              "cylinders": [], "lines": [], "triangles": [], "texts": [], "models": []}
    entity.update(primitives)
    return entity


def _point(x: float, y: float, z: float) -> dict:
    return {"x": x, "y": y, "z": z}


def _sphere(x: float, y: float, z: float) -> dict:
    return {"pose": {"position": _point(x, y, z), "orientation": _IDENTITY["orientation"]},
            "size": _point(TARGET_SPHERE_M, TARGET_SPHERE_M, TARGET_SPHERE_M), "color": _TARGET_COLOUR}


def los_entity(stamp_ns: int, frame: str, rgb: tuple[float, float, float]) -> dict:
    r, g, b = rgb
    arrow = {"pose": _IDENTITY,  # along the frame's x: the LOS
             "shaft_length": 0.9 * LOS_LENGTH_M, "shaft_diameter": 0.02, "head_length": 0.1 * LOS_LENGTH_M,
             "head_diameter": 0.08, "color": {"r": r, "g": g, "b": b, "a": 1.0}}
    return _entity(stamp_ns, frame, f"los:{frame}", True, arrows=[arrow])


def geo_target_entity(stamp_ns: int, target_n: tuple[float, float, float]) -> dict:
    rng = math.sqrt(sum(c * c for c in target_n))
    x, y, z = (LOS_LENGTH_M * c / rng for c in target_n)
    line = {"type": 0, "pose": _IDENTITY, "thickness": 2.0, "scale_invariant": True,  # pixels
            "points": [_point(0.0, 0.0, 0.0), _point(*target_n)], "color": _TARGET_COLOUR, "colors": [],
            "indices": []}
    text = {"pose": {"position": _point(x, y, z - 2 * TARGET_SPHERE_M), "orientation": _IDENTITY["orientation"]},
            "billboard": True, "font_size": 12.0, "scale_invariant": True, "color": _TARGET_COLOUR,
            "text": f"target {rng / 1000.0:.2f} km"}
    return _entity(stamp_ns, NAV_FRAME, "target:geo", False, spheres=[_sphere(x, y, z)], lines=[line], texts=[text])


def operator_target_direction(eps: float, e_q: float, e_r: float) -> tuple[float, float, float] | None:
    """Unit direction in the sight frame m of the target an operator sees at the pointing
    error (ε, e_q, e_r) [rad]; None before the capture (NaN)."""
    if not all(math.isfinite(v) for v in (eps, e_q, e_r)):
        return None
    if eps == 0.0:
        return 1.0, 0.0, 0.0
    s = math.sin(eps) / eps
    return math.cos(eps), s * e_r, -s * e_q


class LiveScene:
    """The SceneUpdate a relayed message makes (module docstring)."""

    def __init__(self, config: SceneConfig = SceneConfig()) -> None:
        self.config = config

    def update(self, topic: str, data: bytes, stamp_ns: int) -> bytes | None:
        """The JSON SceneUpdate of a relayed message of ``topic``, or None."""
        entities = []
        if topic in _LOS_FRAMES:
            frame, rgb = _LOS_FRAMES[topic]
            entities.append(los_entity(stamp_ns, frame, rgb))
            if topic == TRUTH_GIMBAL_JOINTS and self.config.target_n is not None:
                entities.append(geo_target_entity(stamp_ns, self.config.target_n))
        elif topic == OPERATOR_ERROR:
            error = deserialize_message(data, Vector3Stamped).vector  # (ε, e_q, e_r)
            u = operator_target_direction(error.x, error.y, error.z)
            if u is not None:
                entities.append(_entity(stamp_ns, GIMBAL_FRAME, "target:operator", True,
                                        spheres=[_sphere(*(LOS_LENGTH_M * c for c in u))]))
        return json.dumps({"deletions": [], "entities": entities}).encode() if entities else None
