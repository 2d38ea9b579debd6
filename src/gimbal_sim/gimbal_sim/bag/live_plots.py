"""Derived series for the live view's plots, which Foxglove's message paths cannot compute
(they have no arithmetic between fields or messages), as JSON channels with a ``header.stamp``
(``{sec, nsec}``, what the Plot panel's header-stamp time reads):

* ``/live/los_drift``: paper 1's LOS drift, the true inertial LOS's azimuth (cross-elevation)
  and elevation change from its first relayed direction [deg], as the sighting report
  computes it (:func:`gimbal_kinematics.maths.los.los_drift` of ``/truth/gimbal/imu``, taken to the
  inertial frame with the site's earth rate);
* ``/live/bias_bounds``: the EKF's bias estimate ± 3σ [rad/s] (``/gyro_bias_ekf/bias`` and
  ``bias_sigma`` of the same stamp).
"""
from __future__ import annotations

import json

import numpy as np
from geometry_msgs.msg import Vector3Stamped
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import Imu

from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.los import inertial_los, los_drift, los_from_quat

from .live_frames import stamp_dict

DRIFT_TOPIC = "/live/los_drift"
BOUNDS_TOPIC = "/live/bias_bounds"
TRUTH_LOS = "/truth/gimbal/imu"
EKF_BIAS = "/gyro_bias_ekf/bias"
EKF_SIGMA = "/gyro_bias_ekf/bias_sigma"
SOURCE_TOPICS = (TRUTH_LOS, EKF_BIAS, EKF_SIGMA)
BOUND_SIGMAS = 3.0
_STAMP = {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}}
_HEADER = {"type": "object", "properties": {"stamp": _STAMP, "frame_id": {"type": "string"}}}
_VEC = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
SCHEMAS = {
    DRIFT_TOPIC: ("gimbal.LosDrift", json.dumps({
        "title": "gimbal.LosDrift", "type": "object",
        "properties": {"header": _HEADER, "azimuth_deg": {"type": "number"}, "elevation_deg": {"type": "number"}}})),
    BOUNDS_TOPIC: ("gimbal.BiasBounds", json.dumps({
        "title": "gimbal.BiasBounds", "type": "object",
        "properties": {"header": _HEADER, "upper": _VEC, "lower": _VEC}})),
}


def _header(stamp_ns: int, frame: str = "") -> dict:
    return {"stamp": stamp_dict(stamp_ns), "frame_id": frame}


class LivePlots:
    """The derived series of relayed messages; ``omega_in_n``: the site's ω_in^n [rad/s] (3,)."""

    def __init__(self, omega_in_n=(0.0, 0.0, 0.0)) -> None:
        self.omega_in_n = np.asarray(omega_in_n, dtype=float)
        self._los0: tuple[int, np.ndarray] | None = None  # (stamp ns, LOS in n) of the first sample
        self._bias: dict[str, tuple[int, tuple[float, float, float], str]] = {}  # topic -> last (stamp, vector, frame)

    @classmethod
    def at_site(cls, lat_rad: float, earth_rate: bool) -> LivePlots:
        return cls(earth_rate_n(lat_rad) if earth_rate else np.zeros(3))

    def update(self, topic: str, data: bytes, stamp_ns: int) -> tuple[str, bytes] | None:
        """(channel, JSON message) a relayed message of ``topic`` makes, or None."""
        if topic == TRUTH_LOS:
            return self._drift(stamp_ns, data)
        if topic in (EKF_BIAS, EKF_SIGMA):
            msg = deserialize_message(data, Vector3Stamped)
            bias = msg.vector  # the estimate or its σ
            self._bias[topic] = (stamp_ns, (bias.x, bias.y, bias.z), msg.header.frame_id)
            return self._bounds()
        return None

    def _drift(self, stamp_ns: int, data: bytes) -> tuple[str, bytes] | None:
        msg = deserialize_message(data, Imu)
        o = msg.orientation
        los = los_from_quat(np.array([o.x, o.y, o.z, o.w]))[0]
        if not np.all(np.isfinite(los)):
            return None
        if self._los0 is None:
            self._los0 = (stamp_ns, los)
        t0, los0 = self._los0
        pair = inertial_los(np.vstack([los0, los]), np.array([0.0, (stamp_ns - t0) * 1e-9]), self.omega_in_n)
        az, el = np.degrees(los_drift(pair)[1])
        return DRIFT_TOPIC, json.dumps({"header": _header(stamp_ns), "azimuth_deg": float(az),
                                        "elevation_deg": float(el)}).encode()

    def _bounds(self) -> tuple[str, bytes] | None:
        if len(self._bias) < 2 or self._bias[EKF_BIAS][0] != self._bias[EKF_SIGMA][0]:
            return None
        stamp_ns, bias, frame = self._bias[EKF_BIAS]
        sigma = self._bias[EKF_SIGMA][1]
        bound = {sign: {k: b + s * BOUND_SIGMAS * sd for k, b, sd in zip("xyz", bias, sigma)}
                 for sign, s in (("upper", 1.0), ("lower", -1.0))}
        return BOUNDS_TOPIC, json.dumps({"header": _header(stamp_ns, frame), **bound}).encode()
