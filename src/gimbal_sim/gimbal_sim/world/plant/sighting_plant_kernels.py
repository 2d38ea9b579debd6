"""Compiled step of paper 1's gimbal on its moving host (numba ``njit``): one call per
simulation step does what :class:`.gimbal_simulator.GimbalSimulator` needs, from the
kernels that also serve everything else: the host sampled at t + dt/2 and t + dt
(:func:`.profile_kernels.sample`), the turret base of each
(:func:`gimbal_kinematics.gimbal.host_kernels.turret_base`) and one RK4 step of the rigid
body with the torque held (:func:`gimbal_kinematics.gimbal.gimbal_kernels.rk4_step`)."""
from __future__ import annotations

import numpy as np
from numba import njit

from gimbal_kinematics.gimbal.gimbal_kernels import rk4_step
from gimbal_kinematics.gimbal.host_kernels import turret_base

from .profile_kernels import sample


@njit(cache=True)
def gimbal_step(x: tuple, ta: float, te: float, base0: tuple, t_mid: float, t1: float, dt: float,
                lines: np.ndarray, terms: np.ndarray, starts: np.ndarray, g: float, wx: float, wy: float, wz: float,
                p: np.ndarray) -> tuple:
    """(x(t + dt), host fields at t1, base at t1) from x = (ψm, θm, ψ̇m, θ̇m) at t with the
    base ``base0`` of t, the torques (τ_a, τ_e) held (saturated by the RK4 kernel), the profile
    arrays, gravity g and ω_in^n = (wx, wy, wz)."""
    base_mid = turret_base(sample(lines, terms, starts, t_mid), g, wx, wy, wz)
    host1 = sample(lines, terms, starts, t1)
    base1 = turret_base(host1, g, wx, wy, wz)
    return rk4_step(x, ta, te, base0, base_mid, base1, dt, p), host1, base1
