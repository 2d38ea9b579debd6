"""The MAVLink gimbal manager client's core: what ``geo_pointer`` or the operator command,
as Gimbal Protocol v2 setpoints, and the gimbal's reported attitude back. Sans I/O, no
rclpy; the node is :mod:`.mavlink_gimbal_manager_node`.

Setpoints, in the earth frame (``YAW_IN_EARTH_FRAME`` with ``YAW_LOCK``, and roll and pitch
lock, as the protocol asks new implementations to say), addressed to ``target_system`` /
``target_component`` and sent ``send_as``:

* ``device``: ``GIMBAL_DEVICE_SET_ATTITUDE`` straight to a gimbal device;
* ``manager_attitude``: ``GIMBAL_MANAGER_SET_ATTITUDE`` to a gimbal manager (an autopilot),
  for ``gimbal_device_id`` (0: all its gimbals);
* ``manager_pitchyaw``: ``GIMBAL_MANAGER_SET_PITCHYAW``, the same as angles.

A direction (:meth:`GimbalManagerClient.point`: the LOS unit vector in NED, geo_pointer's
aim) becomes the attitude (roll 0, pitch = its elevation, yaw = its azimuth), rates NaN (not
given). A LOS rate (:meth:`~GimbalManagerClient.rate`: (q, r) about the sight's y and z
axes, the operator input's convention) becomes the Euler rates (θ̇, ψ̇) at the gimbal's newest
reported roll and pitch (:func:`gimbal_kinematics.maths.rotations.body_rates_to_euler_rates`, the
sight's roll rate taken as zero: a two-axis LOS command has none), attitude NaN; before any
report it cannot be converted and is counted (``rates_without_attitude``), not sent.

Reports. ``GIMBAL_DEVICE_ATTITUDE_STATUS`` from ``target_system`` and
``device_component_id`` (another sender is counted in ``other_reports``; a datagram that is
not wholly valid MAVLink in ``malformed``) gives :class:`Report`: the quaternion in the
earth frame when the flags say it is (``YAW_IN_EARTH_FRAME``, or neither frame flag with
``YAW_LOCK``), or from the vehicle frame through ``delta_yaw`` as the message defines
(q_earth = q_delta_yaw · q_vehicle); None when neither is known (``vehicle_frame_only``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gimbal_kinematics.maths.rotations import body_rates_to_euler_rates, quat_from_euler321, quat_mul, quat_to_euler321
from gimbal_kinematics.params.table import ParameterError
from pymavlink.dialects.v20 import common as mavlink

from .link import Codec, quat_wxyz, quat_xyzw, unit_quaternion
from .pointing import los_pitch_yaw

F = mavlink
SEND_AS = ("device", "manager_attitude", "manager_pitchyaw")
EARTH_LOCK = (F.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | F.GIMBAL_DEVICE_FLAGS_PITCH_LOCK | F.GIMBAL_DEVICE_FLAGS_YAW_LOCK
              | F.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME)  # same bits in GIMBAL_MANAGER_FLAGS
COUNTERS = ("datagrams", "malformed", "reports", "other_reports", "vehicle_frame_only", "setpoints_sent",
            "rates_without_attitude", "rejected_aims")
NAN = math.nan


@dataclass(frozen=True)
class ManagerParams:
    """Our ids, the gimbal's (its system, the component setpoints go to, the component that
    reports), how setpoints are sent, the manager's gimbal device id."""

    system_id: int = 1
    component_id: int = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER
    target_system: int = 1
    target_component: int = mavlink.MAV_COMP_ID_GIMBAL
    device_component_id: int = mavlink.MAV_COMP_ID_GIMBAL
    send_as: str = "device"
    gimbal_device_id: int = 0

    def __post_init__(self) -> None:
        for name in ("system_id", "component_id", "target_system", "target_component", "device_component_id"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 255:
                raise ValueError(f"{name} must be an integer within 1..255, got {v!r}")
        if self.send_as not in SEND_AS:
            raise ValueError(f"send_as must be one of {list(SEND_AS)}, got {self.send_as!r}")
        if isinstance(self.gimbal_device_id, bool) or not 0 <= self.gimbal_device_id <= 255:
            raise ValueError(f"gimbal_device_id must be within 0..255, got {self.gimbal_device_id!r}")

    @classmethod
    def from_values(cls, v: dict) -> ManagerParams:
        """From a ``mavlink_gimbal_manager`` node's values; :class:`ParameterError` names the
        parameter refused."""
        try:
            return cls(v["system_id"], v["component_id"], v["target_system"], v["target_component"],
                       v["device_component_id"], v["send_as"], v["gimbal_device_id"])
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc


@dataclass(frozen=True)
class Report:
    """One attitude status: the device's ``time_boot_ms``, its flags and failure flags, the
    attitude in the earth frame (x, y, z, w; None: unknown), the Euler rates (φ̇, θ̇, ψ̇)
    [rad/s] in the earth frame (NaN: unknown)."""

    time_boot_ms: int
    flags: int
    failure_flags: int
    quat_earth: tuple[float, float, float, float] | None
    euler_rates: tuple[float, float, float]


def earth_frame(flags: int) -> bool:
    """Whether a status with ``flags`` is in the earth frame (the message definition)."""
    if flags & F.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME:
        return True
    return not flags & F.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME and bool(flags & F.GIMBAL_DEVICE_FLAGS_YAW_LOCK)


class GimbalManagerClient:
    """Setpoints out, reports in (module docstring)."""

    def __init__(self, params: ManagerParams | None = None) -> None:
        self.params = params if params is not None else ManagerParams()
        self.codec = Codec(self.params.system_id, self.params.component_id)
        self.counts = dict.fromkeys(COUNTERS, 0)
        self.last_report: Report | None = None

    def heartbeat(self) -> bytes:
        return self.codec.pack(F.MAVLink_heartbeat_message(F.MAV_TYPE_ONBOARD_CONTROLLER, F.MAV_AUTOPILOT_INVALID,
                                                           0, 0, F.MAV_STATE_ACTIVE, 3))

    def point(self, los_n) -> bytes | None:
        """The setpoint pointing the LOS along ``los_n`` (NED, any length > 0); None
        (counted in ``rejected_aims``) for a zero or non-finite vector."""
        u = np.asarray(los_n, dtype=float)
        if u.shape != (3,) or not np.all(np.isfinite(u)) or float(np.linalg.norm(u)) < 1e-9:
            self.counts["rejected_aims"] += 1
            return None
        pitch, yaw = los_pitch_yaw(np.column_stack([u / np.linalg.norm(u), np.zeros(3), np.zeros(3)]))
        return self._setpoint(quat_from_euler321(0.0, pitch, yaw), (pitch, yaw), (NAN, NAN))

    def rate(self, q: float, r: float) -> bytes | None:
        """The setpoint turning the LOS at (q, r) [rad/s] (sight frame); None before the
        first report (counted)."""
        report = self.last_report
        if report is None or report.quat_earth is None:
            self.counts["rates_without_attitude"] += 1
            return None
        roll, pitch, _ = quat_to_euler321(np.array(report.quat_earth))
        _, pitch_rate, yaw_rate = body_rates_to_euler_rates(roll, pitch, np.array([0.0, q, r]))
        return self._setpoint(None, (NAN, NAN), (float(pitch_rate), float(yaw_rate)))

    def _setpoint(self, quat, angles: tuple[float, float], rates: tuple[float, float]) -> bytes:
        p = self.params
        q = [NAN] * 4 if quat is None else quat_wxyz(quat)
        if p.send_as == "device":
            msg = F.MAVLink_gimbal_device_set_attitude_message(p.target_system, p.target_component, EARTH_LOCK, q,
                                                               NAN, *rates)
        elif p.send_as == "manager_attitude":
            msg = F.MAVLink_gimbal_manager_set_attitude_message(p.target_system, p.target_component, EARTH_LOCK,
                                                                p.gimbal_device_id, q, NAN, *rates)
        else:
            msg = F.MAVLink_gimbal_manager_set_pitchyaw_message(p.target_system, p.target_component, EARTH_LOCK,
                                                                p.gimbal_device_id, *angles, *rates)
        self.counts["setpoints_sent"] += 1
        return self.codec.pack(msg)

    def receive(self, datagram: bytes) -> list[Report]:
        """The gimbal's reports in one datagram."""
        self.counts["datagrams"] += 1
        msgs = self.codec.parse(datagram)
        if msgs is None:
            self.counts["malformed"] += 1
            return []
        out = []
        for msg in msgs:
            if msg.get_type() != "GIMBAL_DEVICE_ATTITUDE_STATUS":
                continue
            if (msg.get_srcSystem(), msg.get_srcComponent()) != (self.params.target_system,
                                                                 self.params.device_component_id):
                self.counts["other_reports"] += 1
                continue
            report = self._report(msg)
            if report is not None:
                out.append(report)
                self.last_report = report
        return out

    def _report(self, msg) -> Report | None:
        q = unit_quaternion(msg.q)
        if q is None:
            self.counts["malformed"] += 1
            return None
        q = quat_xyzw(q)
        rates = (msg.angular_velocity_x, msg.angular_velocity_y, msg.angular_velocity_z)
        if not earth_frame(msg.flags):
            if math.isfinite(msg.delta_yaw):
                half = 0.5 * msg.delta_yaw
                q = quat_mul((0.0, 0.0, math.sin(half), math.cos(half)), q)
                rates = (rates[0], rates[1], rates[2] + msg.delta_yaw_velocity)  # NaN stays NaN
            else:
                self.counts["vehicle_frame_only"] += 1
                q, rates = None, (rates[0], rates[1], NAN)
        self.counts["reports"] += 1
        return Report(msg.time_boot_ms, msg.flags, msg.failure_flags, q, tuple(float(w) for w in rates))
