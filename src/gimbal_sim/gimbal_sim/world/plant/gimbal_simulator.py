"""The two-axis gimbal of paper 1 on a host that follows a motion profile, stepped at a fixed
dt (the rigid-body model itself is :class:`gimbal_kinematics.gimbal.gimbal_dynamics.TwoAxisGimbal`)."""
from __future__ import annotations

import math
from collections.abc import Sequence

from gimbal_kinematics.gimbal.gimbal_dynamics import TwoAxisGimbal, check_state
from gimbal_kinematics.gimbal.gimbal_params import GimbalParams
from gimbal_kinematics.gimbal.host_state import HostState
from gimbal_kinematics.gimbal.turret_base import TurretBase, site_environment, turret_base_from_host

from .motion_profiles import SinusoidProfile
from .sighting_plant_kernels import gimbal_step


class GimbalSimulator:
    """The gimbal on a host that follows ``profile``, stepped at a fixed ``dt`` [s].

    ``earth_rate``: include the earth rate at the profile's site in the host's inertial
    rates (paper 1's gyros sense it); ``False`` treats NED as inertial. The host sample at
    the end of one step is reused as the start of the next.
    """

    def __init__(self, profile: SinusoidProfile, dt: float, params: GimbalParams | None = None,
                 x0: Sequence[float] = (0.0, 0.0, 0.0, 0.0), t0: float = 0.0,
                 earth_rate: bool = True) -> None:
        if not math.isfinite(dt) or dt <= 0.0:
            raise ValueError(f"dt must be > 0, got {dt}")
        if not math.isfinite(t0):
            raise ValueError(f"t0 must be finite, got {t0}")
        self.dynamics = TwoAxisGimbal(params)
        self.profile = profile
        self.dt = float(dt)
        self.env = site_environment(profile.site.lat_rad, profile.site.height_m, earth_rate)
        self._x = check_state(x0)
        self._step_index = 0
        self._t0 = float(t0)
        self._host = profile.sample(self._t0)
        self._base = self.base_from_host(self._host)
        self.applied_torque: tuple[float, float] = (0.0, 0.0)

    def base_from_host(self, host: HostState) -> TurretBase:
        """Turret base motion for a host sample, with this site's gravity and earth rate."""
        return turret_base_from_host(host, self.env.gravity_m_s2, self.env.omega_in_n)

    @property
    def t(self) -> float:
        """Simulation time [s]; counted in steps so it does not accumulate rounding."""
        return self._t0 + self._step_index * self.dt

    @property
    def x(self) -> tuple[float, float, float, float]:
        """State (ψm, θm, ψ̇m, θ̇m) [rad, rad/s]."""
        return self._x

    @property
    def host(self) -> HostState:
        """Host sample at the current time."""
        return self._host

    @property
    def base(self) -> TurretBase:
        """Turret base motion at the current time."""
        return self._base

    def step(self, tau: Sequence[float]) -> tuple[float, float, float, float]:
        """Advance one ``dt`` with commanded torques ``tau`` = (τ_a, τ_e) [N·m] held (one call of
        the compiled :func:`.sighting_plant_kernels.gimbal_step`)."""
        t = self.t
        lines, terms, starts = self.profile.packed
        wx, wy, wz = self.env.omega_in_n
        self.applied_torque = self.dynamics.saturate(tau)
        x, host1, base1 = gimbal_step(
            self._x, self.applied_torque[0], self.applied_torque[1], tuple(self._base), t + 0.5 * self.dt,
            self._t0 + (self._step_index + 1) * self.dt, self.dt, lines, terms, starts,
            float(self.env.gravity_m_s2), float(wx), float(wy), float(wz), self.dynamics.kernel_params)
        self._x = x
        self._step_index += 1
        self._host, self._base = HostState(*host1), TurretBase(*base1)
        return self._x
