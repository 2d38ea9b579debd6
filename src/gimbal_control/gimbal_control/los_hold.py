"""LOS hold: an outer angle loop on the bias EKF's attitude estimate (beyond paper 1).

Paper 1's rate loop nulls the *measured* inertial rate, so the LOS drifts by whatever
rate the gyro-bias estimate still gets wrong. The outer loop closes that gap: it holds the
LOS at its initial inertial direction u_i by commanding the inner rate loop

    q_md = k · atan2(−v_z, v_x),   r_md = k · atan2(v_y, v_x),   v = Ĉ_nmᵀ C_n(t)i u_i,

v being the target direction in the estimated m frame (FRD: +q pitches the LOS up, i.e.
towards −z; +r turns it right, towards +y). NED turns with the earth, so the inertial
target seen from NED at t is C_n(t)i u_i = exp(−[ω_ie^n ×] t) u_i (a fixed site).
k [1/s] is the loop's bandwidth; the command is limited to ``max_rate_deg_s``.

Capturing u_i. The first estimate (the EKF's alignment) is as wrong as one INS and encoder
sample (0.05° to 0.2°), the size of the whole error budget. So the loop waits
``capture_s`` while the rate loop alone holds the LOS and the EKF converges, and then
takes the estimated LOS carried back to t0 by the drift the rate loop let through since:
that drift is −∫(b − b̂_used) dt, and over a few seconds b is constant to well below the
estimate's error, so with the newest estimate b̂ it is D̂ = −(b̂ (t − t0) − ∫ b̂_used dt)
(q: elevation, about m-y; r: azimuth, about m-z). The LOS of t0, seen in the current m
frame, is then (1, −D̂_az, D̂_el) (small angles).

Pure Python; the estimate arrives at the EKF's update rate and the command is held
between updates.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

from gimbal_kinematics.maths.earth import earth_rate_n
from gimbal_kinematics.maths.rotations import quat_to_dcm
from gimbal_kinematics.maths.validate import nonneg_finite, positive
from gimbal_kinematics.params.table import ParameterError


def sight_frame_error(C_nm, u_n: Sequence[float]) -> tuple[float, float]:
    """Error angles (elevation, azimuth) [rad] of the direction ``u_n`` (NED) seen in the
    sight frame of C_nm: v = C_nmᵀ u, (atan2(−v_z, v_x), atan2(v_y, v_x)); k times them is
    the rate command (q, r) that turns the LOS (m-x) onto u (FRD: +q up, +r right)."""
    u = u_n
    v = [float(C_nm[0, j] * u[0] + C_nm[1, j] * u[1] + C_nm[2, j] * u[2]) for j in range(3)]
    return math.atan2(-v[2], v[0]), math.atan2(v[1], v[0])


@dataclass(frozen=True)
class LosHoldParams:
    """``gain_1_s`` k [1/s]; ``max_rate_deg_s`` command limit [°/s]; ``capture_s`` [s]
    time after the first estimate at which the target is captured (≥ 0); ``lat_deg`` site
    latitude [°] for the earth rate (``earth_rate`` False: NED is inertial)."""

    gain_1_s: float = 0.5
    max_rate_deg_s: float = 1.0
    capture_s: float = 5.0
    lat_deg: float = 0.0
    earth_rate: bool = True

    def __post_init__(self) -> None:
        for name in ("gain_1_s", "max_rate_deg_s"):
            positive(name, getattr(self, name))
        nonneg_finite("capture_s", self.capture_s)
        if not (isinstance(self.lat_deg, (int, float)) and math.isfinite(self.lat_deg) and abs(self.lat_deg) < 90.0):
            raise ValueError(f"lat_deg must be within (-90, 90), got {self.lat_deg!r}")

    @classmethod
    def from_values(cls, v: dict) -> LosHoldParams:
        """The outer loop's parameters from a ``los_rate_controller`` node's values (its
        ``hold_*``, ``lat_deg`` and ``earth_rate``); :class:`ParameterError` names the
        parameter refused."""
        try:
            return cls(gain_1_s=v["hold_gain_1_s"], max_rate_deg_s=v["hold_max_rate_deg_s"],
                       capture_s=v["hold_capture_s"], lat_deg=v["lat_deg"], earth_rate=v["earth_rate"])
        except ValueError as exc:
            raise ParameterError(f"parameter {exc}") from exc


class LosHold:
    """Outer LOS angle loop; :meth:`update` per attitude estimate returns (q_md, r_md) [rad/s]."""

    def __init__(self, params: LosHoldParams | None = None) -> None:
        self.params = params if params is not None else LosHoldParams()
        self._w = tuple(earth_rate_n(math.radians(self.params.lat_deg))) if self.params.earth_rate else (0.0, 0.0, 0.0)
        self.reset()

    def reset(self) -> None:
        """Forget the target; the next estimate captures it again."""
        self.target_i: tuple[float, float, float] | None = None
        self.t0: float | None = None        # first estimate [s]
        self.t_target: float | None = None  # when target_i was the LOS direction in n [s]
        self._t_last: float | None = None
        self._bias_used = (0.0, 0.0)      # (q, r) [rad/s] the rate loop used since _t_last
        self._bias_integral = [0.0, 0.0]  # ∫ b̂_used dt since t0 [rad]
        self.error: tuple[float, float] = (0.0, 0.0)
        self.command: tuple[float, float] = (0.0, 0.0)

    def _target_n(self, t: float) -> tuple[float, float, float]:
        """exp(−[ω×] (t − t0)) u_i (Rodrigues)."""
        u = self.target_i
        wx, wy, wz = self._w
        rate = math.sqrt(wx * wx + wy * wy + wz * wz)
        if rate == 0.0:
            return u
        kx, ky, kz = wx / rate, wy / rate, wz / rate
        a = -rate * (t - self.t_target)
        c, s = math.cos(a), math.sin(a)
        kxu = (ky * u[2] - kz * u[1], kz * u[0] - kx * u[2], kx * u[1] - ky * u[0])
        kdu = kx * u[0] + ky * u[1] + kz * u[2]
        return tuple(u[i] * c + kxu[i] * s + (kx, ky, kz)[i] * kdu * (1.0 - c) for i in range(3))

    def update(self, t: float, quat_nm: Sequence[float], bias_qr: Sequence[float] = (0.0, 0.0)) -> tuple[float, float]:
        """Attitude estimate Ĉ_nm (quaternion x, y, z, w) and the gyro-bias estimate (q, r)
        [rad/s] the rate loop uses from now on, stamped ``t`` [s] → rate command (q_md, r_md)."""
        t = float(t)
        C = quat_to_dcm(quat_nm)
        if self.t0 is None:
            self.t0 = t
        elif self.target_i is None:
            self._bias_integral[0] += self._bias_used[0] * (t - self._t_last)
            self._bias_integral[1] += self._bias_used[1] * (t - self._t_last)
        self._t_last = t
        self._bias_used = (float(bias_qr[0]), float(bias_qr[1]))
        if self.target_i is None:
            if t - self.t0 < self.params.capture_s:
                return self.command
            span = t - self.t0
            d_el = -(self._bias_used[0] * span - self._bias_integral[0])
            d_az = -(self._bias_used[1] * span - self._bias_integral[1])
            v0 = (1.0, -d_az, d_el)
            norm = math.sqrt(v0[0] ** 2 + v0[1] ** 2 + v0[2] ** 2)
            self.target_i = tuple(float(C[i, 0] * v0[0] + C[i, 1] * v0[1] + C[i, 2] * v0[2]) / norm for i in range(3))
            self.t_target = t
        self.error = sight_frame_error(C, self._target_n(t))
        k, lim = self.params.gain_1_s, math.radians(self.params.max_rate_deg_s)
        self.command = tuple(max(-lim, min(lim, k * e)) for e in self.error)  # type: ignore[assignment]
        return self.command
