"""The gimbal device's pointing law: a Gimbal Protocol v2 attitude or rate setpoint turned
into the LOS-rate controller's operator input. Pure Python, no MAVLink, no rclpy.

Angles. The protocol's setpoint is a 3-2-1 attitude (roll, pitch, yaw) whose yaw is relative
to North (earth frame) or to the vehicle heading (vehicle frame: the earth frame turned by
the heading ψ_v), and whose pitch is relative to the horizon. A two-axis gimbal cannot roll
its sight, so only the LOS (the sight's x axis) is pointed: pitch θ and yaw ψ, per axis an
angle and/or a rate. Rates are Euler rates (θ̇, ψ̇), the way ArduPilot's AP_Mount and PX4
read ``angular_velocity_y`` and ``_z``.

Reference. Each axis follows θ_ref(t) = θ0 + θ̇ (t − t0) (likewise ψ): a setpoint with an
angle starts the ramp at that angle; a rate alone continues the running reference (from the
current attitude if the axis had none), so a rate held by repeated messages
integrates without drift; a missing (NaN) field leaves that part of the axis as it was.
When the yaw frame in force changes (earth-frame lock lost or regained), or the vehicle
heading behind the vehicle frame changes source, the yaw reference restarts at the current
yaw in the frame then in force, keeping its rate, so the sight does not jump.

Law. With the target direction u = (cos θ cos Ψ, cos θ sin Ψ, −sin θ) in NED, Ψ the
reference yaw plus ψ_v in the vehicle frame, the command is the reference's own inertial
rate resolved in the estimated sight frame (feed-forward: ψ̇_n about down, θ̇ about the
horizontal axis (−sin Ψ, cos Ψ, 0), ψ̇_n = ψ̇ + ψ̇_v in the vehicle frame) plus k times the
pointing error of :func:`gimbal_control.los_hold.sight_frame_error` (the LOS-hold loop's
law, which geo_pointer shares), limited per axis to ``max_rate`` (below the controller's
operator rate limit, which refuses more). It is a type-1 loop around the controller's
inertial rate loop: a ramp is tracked without lag, a step settles like e^(−k t) once the
error is under max_rate / k.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gimbal_control.los_hold import sight_frame_error

EARTH, VEHICLE = "earth", "vehicle"


def wrap_pi(angle: float) -> float:
    """``angle`` [rad] in [−π, π)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def los_pitch_yaw(C_nm: np.ndarray) -> tuple[float, float]:
    """Pitch above the horizon and yaw from North [rad] of the sight's x axis."""
    u = C_nm[:, 0]
    return math.atan2(-u[2], math.hypot(u[0], u[1])), math.atan2(u[1], u[0])


@dataclass
class AxisRef:
    """θ0 + rate (t − t0) [rad]."""

    angle: float
    rate: float = 0.0
    t0: float = 0.0

    def at(self, t: float) -> float:
        return self.angle + self.rate * (t - self.t0)


@dataclass(frozen=True)
class Setpoint:
    """One accepted setpoint: per axis an angle and a rate [rad, rad/s], None = ignore;
    ``frame``: the yaw frame (EARTH or VEHICLE)."""

    pitch: float | None
    pitch_rate: float | None
    yaw: float | None
    yaw_rate: float | None
    frame: str


class Pointing:
    """The law of the module docstring; :meth:`step` once per attitude estimate."""

    def __init__(self, gain_1_s: float, max_rate_rad_s: float, pitch_min: float, pitch_max: float) -> None:
        self.k, self.max_rate = gain_1_s, max_rate_rad_s
        self.pitch_min, self.pitch_max = pitch_min, pitch_max
        self.pitch: AxisRef | None = None
        self.yaw: AxisRef | None = None
        self.frame = VEHICLE
        self.pitch_clamped = False

    def apply(self, sp: Setpoint, t: float, pitch_now: float, yaw_now: float) -> None:
        """Take setpoint ``sp`` at time ``t`` [s]; ``pitch_now``, ``yaw_now``: the current
        LOS angles, the yaw in ``sp.frame`` [rad]."""
        self.pitch = self._axis(self.pitch, sp.pitch, sp.pitch_rate, t, pitch_now)
        if sp.frame != self.frame:
            self.frame, self.yaw = sp.frame, None
        self.yaw = self._axis(self.yaw, sp.yaw, sp.yaw_rate, t, yaw_now, wrap=True)

    @staticmethod
    def _axis(ref: AxisRef | None, angle: float | None, rate: float | None, t: float, now: float,
              wrap: bool = False) -> AxisRef:
        if angle is not None:
            return AxisRef(angle, 0.0 if rate is None else rate, t)
        if ref is None:
            ref = AxisRef(now, 0.0, t)
        if rate is None:
            return ref
        start = ref.at(t)
        return AxisRef(wrap_pi(start) if wrap else start, rate, t)

    def restart_yaw(self, frame: str, t: float, yaw_now: float) -> None:
        """The yaw frame in force becomes ``frame`` (or its heading reference changed): the
        yaw reference restarts at the current yaw ``yaw_now`` (in that frame) with its rate."""
        rate = self.yaw.rate if self.yaw is not None else 0.0
        self.frame, self.yaw = frame, AxisRef(yaw_now, rate, t)

    def step(self, t: float, C_nm: np.ndarray, heading: float, heading_rate: float) -> tuple[float, float]:
        """The LOS rate command (q, r) [rad/s] at ``t`` [s] for the estimated C_nm;
        ``heading``, ``heading_rate``: the vehicle's ψ_v [rad] and ψ̇_v [rad/s] (used in the
        vehicle frame only)."""
        pitch_now, yaw_n = los_pitch_yaw(C_nm)
        offset = heading if self.frame == VEHICLE else 0.0
        if self.pitch is None:
            self.pitch = AxisRef(pitch_now, 0.0, t)
        if self.yaw is None:
            self.yaw = AxisRef(wrap_pi(yaw_n - offset), 0.0, t)
        theta = self.pitch.at(t)
        self.pitch_clamped = not self.pitch_min <= theta <= self.pitch_max
        theta = min(self.pitch_max, max(self.pitch_min, theta))
        theta_rate = 0.0 if self.pitch_clamped else self.pitch.rate
        psi = self.yaw.at(t) + offset
        psi_rate = self.yaw.rate + (heading_rate if self.frame == VEHICLE else 0.0)
        c, s = math.cos(psi), math.sin(psi)
        u_n = (math.cos(theta) * c, math.cos(theta) * s, -math.sin(theta))
        w_n = np.array([-s * theta_rate, c * theta_rate, psi_rate])
        w_m = C_nm.T @ w_n
        err = sight_frame_error(C_nm, u_n)
        lim = self.max_rate
        return tuple(max(-lim, min(lim, float(ff) + self.k * e)) for ff, e in zip(w_m[1:], err))  # type: ignore
