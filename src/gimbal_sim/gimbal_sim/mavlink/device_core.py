"""The MAVLink gimbal device's core: Gimbal Protocol v2 on the device side, sans I/O (it
takes datagrams and attitude estimates, and returns datagrams and the LOS rate command).
No rclpy; the node is :mod:`.mavlink_gimbal_device_node`.

What the device is. The simulated two-axis gimbal of paper 1 on its turret: a pitch
(elevation) and a yaw (azimuth) axis, no roll axis, stabilised in inertial space by the
LOS-rate controller, continuous in azimuth. Its attitude is the gyro-bias EKF's estimate
Ĉ_nm (the device's own AHRS), its rates the gimbal gyro's, its angle to the vehicle the
encoders' (turret + gimbal azimuth). The capability flags say exactly that: pitch and yaw
axes, pitch lock (the rate loop holds the pitch inertially; there is no pitch follow), yaw
follow and yaw lock, infinite yaw, yaw in the earth frame.

Messages taken (each addressed to this system and component, or broadcast 0; any other
target is counted in ``wrong_target`` and ignored):

* ``GIMBAL_DEVICE_SET_ATTITUDE``: the setpoint of :mod:`.pointing`. The yaw frame comes
  from the flags as the message definition says (``YAW_IN_EARTH_FRAME``, else
  ``YAW_IN_VEHICLE_FRAME``, else ``YAW_LOCK`` means earth); both frame flags, ``RETRACT`` or
  ``NEUTRAL`` (not capabilities of this device), a quaternion that is finite but not unit, an
  infinite rate or one above ``max_rate``, or an earth-frame setpoint while the device cannot
  accept one (below) are refused and counted (``rejected_setpoints``). NaN means "ignore":
  a quaternion with a NaN component is ignored as a whole, each NaN rate on its own; the
  roll angle and rate are ignored (no roll axis). Setpoints take effect, in the order they
  came, at the next attitude estimate.
* ``AUTOPILOT_STATE_FOR_GIMBAL_DEVICE``: the vehicle attitude (its heading ψ_v is the
  vehicle frame's) and yaw rate (``angular_velocity_z``, the vehicle frame's feed-forward;
  NaN: none). A non-unit quaternion is counted (``rejected_autopilot_states``).
* ``COMMAND_LONG`` ``MAV_CMD_REQUEST_MESSAGE`` for ``GIMBAL_DEVICE_INFORMATION``: answered
  with it and an ACK; another message id gets ``MAV_RESULT_UNSUPPORTED``.

Earth frame. Yaw relative to North needs the autopilot: the device accepts earth-frame yaw
(flag ``ACCEPTS_YAW_IN_EARTH_FRAME``) only while the newest autopilot state is at most
``autopilot_timeout_s`` old (wall clock). When it goes stale, a yaw lock in force is
dropped: the yaw is held in the vehicle frame from then on (at the yaw it had, with its
rate), the status reports ``YAW_IN_VEHICLE_FRAME`` without ``YAW_LOCK`` and without
``ACCEPTS_YAW_IN_EARTH_FRAME``, ``delta_yaw`` becomes NaN, and ``earth_lock_drops`` counts
it. Without the autopilot the vehicle heading is the encoders': the LOS yaw less the turret
and gimbal azimuth angles (exact for a level vehicle); when the heading changes source, a
yaw held in the vehicle frame restarts where the sight points, so it does not jump. The lock comes back with a fresh
autopilot state while the last setpoint asked for it.

Malformed input: a datagram that is not wholly valid MAVLink (:class:`.link.Codec`) is
counted (``malformed``) and none of it is acted on.

Sent: ``HEARTBEAT`` (``MAV_TYPE_GIMBAL``) from :meth:`heartbeat`,
``GIMBAL_DEVICE_ATTITUDE_STATUS`` from :meth:`status` (the node calls it at
``status_rate_hz``), ``GIMBAL_DEVICE_INFORMATION`` on request. ``time_boot_ms`` is the
simulated time since the first attitude estimate (the device's clock is the simulation's).
The status quaternion is in the frame its flags name; angular velocities are Euler rates.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from gimbal_kinematics.maths.rotations import (
    body_rates_to_euler_rates, dcm_to_euler321, quat_from_euler321, quat_to_dcm,
)
from gimbal_kinematics.maths.units import DEG
from gimbal_kinematics.params.table import ParameterError
from pymavlink.dialects.v20 import common as mavlink

from .link import Codec, quat_wxyz, quat_xyzw, unit_quaternion
from .pointing import EARTH, VEHICLE, Pointing, Setpoint, los_pitch_yaw, wrap_pi

F = mavlink  # flag and enum constants
CAP_FLAGS = (F.GIMBAL_DEVICE_CAP_FLAGS_HAS_PITCH_AXIS | F.GIMBAL_DEVICE_CAP_FLAGS_HAS_PITCH_LOCK
             | F.GIMBAL_DEVICE_CAP_FLAGS_HAS_YAW_AXIS | F.GIMBAL_DEVICE_CAP_FLAGS_HAS_YAW_FOLLOW
             | F.GIMBAL_DEVICE_CAP_FLAGS_HAS_YAW_LOCK | F.GIMBAL_DEVICE_CAP_FLAGS_SUPPORTS_INFINITE_YAW
             | F.GIMBAL_DEVICE_CAP_FLAGS_SUPPORTS_YAW_IN_EARTH_FRAME)
UNSUPPORTED_FLAGS = F.GIMBAL_DEVICE_FLAGS_RETRACT | F.GIMBAL_DEVICE_FLAGS_NEUTRAL
BOTH_FRAMES = F.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME | F.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
COUNTERS = ("datagrams", "malformed", "wrong_target", "setpoints", "rejected_setpoints", "autopilot_states",
            "rejected_autopilot_states", "earth_lock_drops", "information_requests")
#: Setpoints kept between two estimates (a burst beyond it loses its oldest).
MAX_PENDING = 64
#: Slack on the setpoint rate limit, for a sender converting the same limit from degrees.
RATE_SLACK = 1e-6


@dataclass(frozen=True)
class DeviceParams:
    """Ids, the pointing loop (gain [1/s], rate limit [rad/s]), the pitch range [rad] the
    device points in (the two-axis chain is singular at ±90°), the autopilot timeout [s]."""

    system_id: int = 1
    component_id: int = mavlink.MAV_COMP_ID_GIMBAL
    gain_1_s: float = 2.0
    max_rate_rad_s: float = 8.0 * DEG
    pitch_min_rad: float = -85.0 * DEG
    pitch_max_rad: float = 85.0 * DEG
    autopilot_timeout_s: float = 1.0

    def __post_init__(self) -> None:
        for name in ("system_id", "component_id"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int) or not 1 <= v <= 255:
                raise ValueError(f"{name} must be an integer within 1..255, got {v!r}")
        for name in ("gain_1_s", "max_rate_rad_s", "autopilot_timeout_s"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0.0:
                raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
        if not -math.pi / 2 < self.pitch_min_rad < self.pitch_max_rad < math.pi / 2:
            raise ValueError(f"pitch_min_deg < pitch_max_deg, both within (-90, 90), got "
                             f"{math.degrees(self.pitch_min_rad)}, {math.degrees(self.pitch_max_rad)}")

    @classmethod
    def from_values(cls, v: dict) -> DeviceParams:
        """From a ``mavlink_gimbal_device`` node's values (degrees at the edge);
        :class:`ParameterError` names the parameter refused."""
        try:
            return cls(v["system_id"], v["component_id"], v["gain_1_s"], v["max_rate_deg_s"] * DEG,
                       v["pitch_min_deg"] * DEG, v["pitch_max_deg"] * DEG, v["autopilot_timeout_s"])
        except ValueError as exc:
            text = str(exc).replace("max_rate_rad_s", "max_rate_deg_s").replace("_rad ", "_deg ")
            raise ParameterError(f"parameter {text}") from exc


@dataclass
class AutopilotState:
    """The newest usable autopilot state: when (wall [s]), heading ψ_v [rad], yaw rate [rad/s]
    (NaN: not given)."""

    wall_s: float
    heading: float
    yaw_rate: float


class GimbalDevice:
    """Gimbal Protocol v2 device (module docstring)."""

    def __init__(self, params: DeviceParams | None = None) -> None:
        self.params = p = params if params is not None else DeviceParams()
        self.codec = Codec(p.system_id, p.component_id)
        self.pointing = Pointing(p.gain_1_s, p.max_rate_rad_s, p.pitch_min_rad, p.pitch_max_rad)
        self.counts = dict.fromkeys(COUNTERS, 0)
        self.requested = VEHICLE          # the yaw frame the last setpoint asked for
        self.autopilot: AutopilotState | None = None
        self._pending: deque[Setpoint] = deque(maxlen=MAX_PENDING)
        self._t0: float | None = None     # first estimate [s]
        self._t = 0.0                     # newest estimate [s]
        self._C_nm: np.ndarray | None = None
        self._rates_m: tuple[float, float, float] | None = None
        self._heading = 0.0
        self._earth_ok = False
        self._heading_from_autopilot = False  # the vehicle heading's source at the last step

    # ------------------------------------------------------------------ receiving
    def receive(self, datagram: bytes, wall_s: float) -> list[bytes]:
        """One UDP datagram received at ``wall_s`` [s]; returns the replies to send."""
        self.counts["datagrams"] += 1
        msgs = self.codec.parse(datagram)
        if msgs is None:
            self.counts["malformed"] += 1
            return []
        replies: list[bytes] = []
        for msg in msgs:
            kind = msg.get_type()
            handler = {"GIMBAL_DEVICE_SET_ATTITUDE": self._on_setpoint,
                       "AUTOPILOT_STATE_FOR_GIMBAL_DEVICE": self._on_autopilot,
                       "COMMAND_LONG": self._on_command}.get(kind)
            if handler is None:
                continue
            if not self._addressed_to_me(msg):
                self.counts["wrong_target"] += 1
                continue
            replies += handler(msg, wall_s)
        return replies

    def _addressed_to_me(self, msg) -> bool:
        """MAVLink routing: a target id of 0 is a broadcast."""
        return (msg.target_system in (0, self.params.system_id)
                and msg.target_component in (0, self.params.component_id))

    def _on_setpoint(self, msg, wall_s: float) -> list[bytes]:
        sp = self._setpoint(msg, wall_s)
        if sp is None:
            self.counts["rejected_setpoints"] += 1
        else:
            self._pending.append(sp)  # applied in order at the next estimate: NaN fields stay ignored
        return []

    def _setpoint(self, msg, wall_s: float) -> Setpoint | None:
        """The message's setpoint, or None when it must be refused (module docstring)."""
        flags = msg.flags
        if flags & UNSUPPORTED_FLAGS or flags & BOTH_FRAMES == BOTH_FRAMES:
            return None
        earth = bool(flags & F.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME or (
            not flags & BOTH_FRAMES and flags & F.GIMBAL_DEVICE_FLAGS_YAW_LOCK))
        if earth and not self.accepts_earth_frame(wall_s):
            return None
        pitch = yaw = None
        if all(math.isfinite(c) for c in msg.q):
            q = unit_quaternion(msg.q)
            if q is None:
                return None
            pitch, yaw = los_pitch_yaw(quat_to_dcm(np.array(quat_xyzw(q))))
        rates = []
        for w in (msg.angular_velocity_y, msg.angular_velocity_z):
            if math.isnan(w):
                rates.append(None)
            elif not math.isfinite(w) or abs(w) > self.params.max_rate_rad_s * (1.0 + RATE_SLACK):
                return None
            else:
                rates.append(float(w))
        return Setpoint(pitch, rates[0], yaw, rates[1], EARTH if earth else VEHICLE)

    def _on_autopilot(self, msg, wall_s: float) -> list[bytes]:
        q = unit_quaternion(msg.q)
        if q is None:
            self.counts["rejected_autopilot_states"] += 1
            return []
        _, _, heading = dcm_to_euler321(quat_to_dcm(np.array(quat_xyzw(q))))
        rate = float(msg.angular_velocity_z)
        self.autopilot = AutopilotState(wall_s, heading, rate if math.isfinite(rate) else math.nan)
        self.counts["autopilot_states"] += 1
        return []

    def _on_command(self, msg, wall_s: float) -> list[bytes]:
        if msg.command != F.MAV_CMD_REQUEST_MESSAGE:
            return []
        self.counts["information_requests"] += 1
        wanted = int(msg.param1) == F.MAVLINK_MSG_ID_GIMBAL_DEVICE_INFORMATION
        ack = F.MAVLink_command_ack_message(msg.command, F.MAV_RESULT_ACCEPTED if wanted else
                                           F.MAV_RESULT_UNSUPPORTED, 0, 0, msg.get_srcSystem(),
                                           msg.get_srcComponent())
        return [self.codec.pack(ack)] + ([self.information()] if wanted else [])

    def accepts_earth_frame(self, wall_s: float) -> bool:
        """Whether the autopilot's newest state is fresh enough for a yaw relative to North."""
        ap = self.autopilot
        return ap is not None and wall_s - ap.wall_s <= self.params.autopilot_timeout_s

    # ------------------------------------------------------------------ stepping
    def step(self, t: float, quat_nm, joint_azimuth: float, wall_s: float,
             rates_m: tuple[float, float, float] | None = None) -> tuple[float, float]:
        """One attitude estimate Ĉ_nm (quaternion x, y, z, w) at ``t`` [s] (the estimate's
        stamp), the encoders' azimuth of the sight relative to the vehicle (turret + gimbal)
        [rad], the gimbal gyro's body rates [rad/s] if known, at wall time ``wall_s`` [s] →
        the LOS rate command (q, r) [rad/s]."""
        C_nm = quat_to_dcm(np.asarray(quat_nm, dtype=float))
        self._t0 = t if self._t0 is None else self._t0
        self._t, self._C_nm, self._rates_m = t, C_nm, rates_m
        pitch_now, yaw_n = los_pitch_yaw(C_nm)
        self._earth_ok = self.accepts_earth_frame(wall_s)
        ap = self.autopilot
        if self._earth_ok:
            self._heading, heading_rate = ap.heading, (0.0 if math.isnan(ap.yaw_rate) else ap.yaw_rate)
        else:
            self._heading, heading_rate = wrap_pi(yaw_n - joint_azimuth), 0.0
        source_changed = self._earth_ok != self._heading_from_autopilot
        self._heading_from_autopilot = self._earth_ok
        while self._pending:
            sp = self._pending.popleft()
            if sp.frame == EARTH and not self._earth_ok:  # the autopilot went quiet since it came
                self.counts["rejected_setpoints"] += 1
            else:
                self.counts["setpoints"] += 1
                self.requested = sp.frame
                self.pointing.apply(sp, t, pitch_now, wrap_pi(yaw_n - self._offset(sp.frame)))
        frame = EARTH if self.requested == EARTH and self._earth_ok else VEHICLE
        if frame != self.pointing.frame or (frame == VEHICLE and source_changed):
            self.counts["earth_lock_drops"] += int(frame != self.pointing.frame and frame == VEHICLE)
            self.pointing.restart_yaw(frame, t, wrap_pi(yaw_n - self._offset(frame)))
        return self.pointing.step(t, C_nm, self._heading, heading_rate)

    def _offset(self, frame: str) -> float:
        return self._heading if frame == VEHICLE else 0.0

    # ------------------------------------------------------------------ sending
    def time_boot_ms(self) -> int:
        return 0 if self._t0 is None else int(round((self._t - self._t0) * 1000.0)) & 0xFFFFFFFF

    def heartbeat(self) -> bytes:
        state = F.MAV_STATE_STANDBY if self._C_nm is None else F.MAV_STATE_ACTIVE
        return self.codec.pack(F.MAVLink_heartbeat_message(F.MAV_TYPE_GIMBAL, F.MAV_AUTOPILOT_INVALID, 0, 0, state, 3))

    def information(self) -> bytes:
        p = self.params
        return self.codec.pack(F.MAVLink_gimbal_device_information_message(
            self.time_boot_ms(), b"gimbal-ros", b"two-axis sim (paper 1)", b"", 0, 0, 0, CAP_FLAGS & 0xFFFF, 0,
            math.nan, math.nan, p.pitch_min_rad, p.pitch_max_rad, -math.pi, math.pi, 0, CAP_FLAGS))

    def status_flags(self) -> int:
        """The flags of the mode in force (the status's)."""
        flags = F.GIMBAL_DEVICE_FLAGS_PITCH_LOCK
        if self.pointing.frame == EARTH:
            flags |= F.GIMBAL_DEVICE_FLAGS_YAW_LOCK | F.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
        else:
            flags |= F.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME
        if self._earth_ok:
            flags |= F.GIMBAL_DEVICE_FLAGS_ACCEPTS_YAW_IN_EARTH_FRAME
        return flags

    def status(self) -> bytes | None:
        """``GIMBAL_DEVICE_ATTITUDE_STATUS`` of the newest estimate (None before the first)."""
        if self._C_nm is None:
            return None
        roll, pitch, yaw_n = dcm_to_euler321(self._C_nm)
        vehicle = self.pointing.frame == VEHICLE
        yaw = wrap_pi(yaw_n - self._heading) if vehicle else yaw_n
        q = quat_wxyz(quat_from_euler321(roll, pitch, yaw))
        rates = [math.nan] * 3
        if self._rates_m is not None:  # the two-axis gyro measures q, r only: no roll rate
            rates = [math.nan, *(float(r) for r in body_rates_to_euler_rates(roll, pitch, np.array(self._rates_m))[1:])]
        ap = self.autopilot if self._earth_ok else None
        if vehicle:  # w_vehicle = w_earth - delta_yaw_velocity
            rates[2] = rates[2] - ap.yaw_rate if ap is not None else math.nan
        failure = F.GIMBAL_DEVICE_ERROR_FLAGS_AT_PITCH_LIMIT if self.pointing.pitch_clamped else 0
        return self.codec.pack(F.MAVLink_gimbal_device_attitude_status_message(
            0, 0, self.time_boot_ms(), self.status_flags(), q, *rates, failure,
            ap.heading if ap is not None else math.nan, ap.yaw_rate if ap is not None else math.nan, 0))
