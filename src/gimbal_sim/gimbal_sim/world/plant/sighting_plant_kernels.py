"""Compiled step of paper 1's gimbal on its moving host (numba ``njit``): one call per
simulation step does what :class:`.gimbal_simulator.GimbalSimulator` needs, from the
kernels that also serve everything else: the host sampled at t + dt/2 and t + dt
(:func:`.profile_kernels.sample`), the turret base of each
(:func:`gimbal_kinematics.gimbal.host_kernels.turret_base`) and one RK4 step of the rigid
body with the torque held (:func:`gimbal_kinematics.gimbal.gimbal_kernels.rk4_step`); the
inner gimbal's truth (:func:`inner_gimbal_truth`) for ``VehicleCore.truth``."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from gimbal_kinematics.gimbal.gimbal_kernels import rk4_step
from gimbal_kinematics.gimbal.host_kernels import turret_base
from gimbal_kinematics.maths.quat_kernels import quat_canonical, quat_mul

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


@njit(cache=True)
def inner_gimbal_truth(q_nb: tuple, pos: tuple, vel: tuple, omega_b: tuple, f_b: tuple) -> tuple:
    """(quat_nm, ω_im^m, f_m) of the inner gimbal from the host attitude quaternion q_nb
    (x, y, z, w), the joint angles/rates (ψt, ψm, θm) and the host's ω_ib^b and f_b.

    C_bm = rot3(ψt)ᵀ rot3(ψm)ᵀ rot2(θm)ᵀ is a turn of ψa = ψt + ψm about z and then θm about
    y, so q_nm = q_nb ⊗ q_z(ψa) ⊗ q_y(θm). The rate follows the chain
    (``sighting_chain.omega_m_m``): rotations about z commute with adding rates about z, so
    ω_a = rot3(ψa) ω_b + (ψ̇t + ψ̇m) e3 and ω_m = rot2(θm) ω_a + θ̇m e2; f_m = C_mb f_b.
    """
    psi_a = pos[0] + pos[1]
    theta = pos[2]
    ha, he = 0.5 * psi_a, 0.5 * theta
    sa2, se2 = math.sin(ha), math.sin(he)
    q_bm = (-sa2 * se2, math.cos(ha) * se2, sa2 * math.cos(he), math.cos(ha) * math.cos(he))
    quat_nm = quat_canonical(quat_mul(q_nb, q_bm))
    ca, sa = math.cos(psi_a), math.sin(psi_a)
    ce, se = math.cos(theta), math.sin(theta)
    w0, w1, w2 = omega_b
    u0 = ca * w0 + sa * w1
    u1 = -sa * w0 + ca * w1
    u2 = w2 + vel[0] + vel[1]
    omega_m = (ce * u0 - se * u2, u1 + vel[2], se * u0 + ce * u2)
    f0, f1, f2 = f_b
    g0 = ca * f0 + sa * f1
    g1 = -sa * f0 + ca * f1
    f_m = (ce * g0 - se * f2, g1, se * g0 + ce * f2)
    return quat_nm, omega_m, f_m
