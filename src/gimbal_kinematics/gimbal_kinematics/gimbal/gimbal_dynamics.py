"""Two-axis gimbal rigid-body dynamics on a moving turret (paper 1 §4), closed form + RK4.

Bodies: outer (azimuth) frame ``a`` on joint ψm about t-z, inner (elevation) frame ``m`` on
joint θm about a-y (docs/spec.md §2). The two joint axes intersect at the pivot P. State
``x = (ψm, θm, ψ̇m, θ̇m)`` [rad, rad/s]; input ``τ = (τ_a, τ_e)`` [N·m], saturated at the
torque limits; base motion is a :class:`.turret_base.TurretBase` (ω_t, α_t, f_t = a_P − g).

Newton–Euler about P. For a rigid body with mass m, CG offset r from P, inertia J about its
CG, inertial rate ω and acceleration α (all in the body frame), the moment that must act
on it about P is

    N = Ĵ α + ω × (Ĵ ω) + m r × f,     Ĵ = J + m (|r|² I − r rᵀ),

(Ĵ is the inertia about P; the ω × Ĵ ω form absorbs m r × (ω × (ω × r)).) The elevation
joint supplies the e2 component of the inner frame's N_m; the azimuth joint supplies the e3
component of N_a + C_am N_m, since the joint force acts at P and has no moment there:

    e2 · N_m             = τ_e − b_e θ̇m
    e3 · (N_a + C_am N_m) = τ_a − b_a ψ̇m

The rates come from the chain (``sighting_chain.chain_rates``), with u = rot3(ψm) ω_t:
ω_a = u + ψ̇m e3, α_a = rot3(ψm) α_t + ψ̈m e3 + u × ψ̇m e3, ω_m = rot2(θm) ω_a + θ̇m e2,
α_m = rot2(θm) α_a + θ̈m e2 + (rot2(θm) ω_a) × θ̇m e2. N is affine in (ψ̈m, θ̈m), so

    M(θm) q̈ + h(x, base) = τ,   with (c, s = cos θm, sin θm, Ĵ_m entries in m)
    M_ee = Ĵm_yy,  M_ae = −s Ĵm_xy + c Ĵm_yz,
    M_aa = Ĵa_zz + s² Ĵm_xx − 2 s c Ĵm_xz + c² Ĵm_zz,

and h is the joint torque needed with q̈ = 0 (friction included). The tests check M and h
against an independent Newton–Euler residual with explicit reaction forces, against
energy conservation and against dE/dt = τ·q̇ − friction power.

Integration: fixed-step RK4 with the torque held over the step (zero-order hold) and base
motion sampled at t, t + dt/2 and t + dt. No joint stops are modelled.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from . import gimbal_kernels as kernels
from .gimbal_params import GimbalParams, inertia_matrix
from .turret_base import TurretBase


def _inertia_about_pivot(mass: float, inertia: tuple, cg: tuple) -> tuple[float, ...]:
    r = np.asarray(cg, dtype=float)
    j = inertia_matrix(inertia) + mass * (float(r @ r) * np.eye(3) - np.outer(r, r))
    return tuple(float(v) for v in (j[0, 0], j[1, 1], j[2, 2], j[0, 1], j[0, 2], j[1, 2]))


class TwoAxisGimbal:
    """Forward/inverse dynamics and RK4 step of the two-axis gimbal (module docstring); the
    arithmetic is the compiled kernels' of :mod:`.gimbal_kernels`, over :attr:`kernel_params`.

    Stateless apart from the parameters: every method takes the state explicitly, so a
    controller can evaluate ``derivative`` at any point (e.g. at rest for linearisation).
    """

    def __init__(self, params: GimbalParams | None = None) -> None:
        self.params = params if params is not None else GimbalParams()
        p = self.params
        k = np.empty(kernels.N_PARAMS)
        k[kernels.P_JA:kernels.P_JA + 6] = _inertia_about_pivot(p.outer_mass_kg, p.outer_inertia_kg_m2, p.outer_cg_m)
        k[kernels.P_JM:kernels.P_JM + 6] = _inertia_about_pivot(p.inner_mass_kg, p.inner_inertia_kg_m2, p.inner_cg_m)
        k[kernels.P_MRA:kernels.P_MRA + 3] = [p.outer_mass_kg * float(v) for v in p.outer_cg_m]
        k[kernels.P_MRM:kernels.P_MRM + 3] = [p.inner_mass_kg * float(v) for v in p.inner_cg_m]
        k[kernels.P_BA], k[kernels.P_BE] = p.azimuth_friction_nm_s_rad, p.elevation_friction_nm_s_rad
        k[kernels.P_LIM_A], k[kernels.P_LIM_E] = p.azimuth_torque_limit_nm, p.elevation_torque_limit_nm
        self.kernel_params = k
        self._lim_a = p.azimuth_torque_limit_nm
        self._lim_e = p.elevation_torque_limit_nm

    # ------------------------------------------------------------------ building blocks
    def saturate(self, tau: Sequence[float]) -> tuple[float, float]:
        """Torque actually applied [N·m]: each command clipped to its limit."""
        ta, te = float(tau[0]), float(tau[1])
        la, le = self._lim_a, self._lim_e
        return (la if ta > la else -la if ta < -la else ta, le if te > le else -le if te < -le else te)

    def mass_matrix(self, theta_m: float) -> np.ndarray:
        """Joint-space mass matrix M(θm) [kg·m²], shape (2, 2), order (ψm, θm)."""
        maa, mae, mee = kernels.mass(math.cos(theta_m), math.sin(theta_m), self.kernel_params)
        return np.array([[maa, mae], [mae, mee]])

    # ------------------------------------------------------------------ public dynamics
    def bias_torques(self, x: Sequence[float], base: TurretBase) -> tuple[float, float]:
        """h(x, base) [N·m]: Coriolis, centrifugal, base-motion, gravity and friction terms."""
        th = float(x[1])
        return kernels.bias(float(x[0]), math.cos(th), math.sin(th), float(x[2]), float(x[3]), _base(base),
                            self.kernel_params)

    def inverse_dynamics(self, x: Sequence[float], qdd: Sequence[float], base: TurretBase) -> tuple[float, float]:
        """Joint torques (τ_a, τ_e) [N·m] that produce joint accelerations ``qdd`` [rad/s²]
        at state ``x`` on ``base`` (no saturation): τ = M q̈ + h."""
        return kernels.inverse_dynamics(float(x[0]), float(x[1]), float(x[2]), float(x[3]), float(qdd[0]),
                                        float(qdd[1]), _base(base), self.kernel_params)

    def accelerations(self, x: Sequence[float], tau: Sequence[float], base: TurretBase) -> tuple[float, float]:
        """(ψ̈m, θ̈m) [rad/s²] for applied (already saturated) torques ``tau`` [N·m]."""
        return kernels.accelerations(float(x[0]), float(x[1]), float(x[2]), float(x[3]), float(tau[0]),
                                     float(tau[1]), _base(base), self.kernel_params)

    def derivative(self, x: Sequence[float], tau: Sequence[float], base: TurretBase) -> tuple[float, float, float, float]:
        """Continuous-time ẋ = f(x, τ, base); ``tau`` is the commanded torque [N·m], clipped
        to the limits. Returns (ψ̇m, θ̇m, ψ̈m, θ̈m) as floats (``np.asarray`` for an array)."""
        qa, qe = self.accelerations(x, self.saturate(tau), base)
        return x[2], x[3], qa, qe

    def step(self, x: Sequence[float], tau: Sequence[float], base0: TurretBase, base_mid: TurretBase,
             base1: TurretBase, dt: float) -> tuple[float, float, float, float]:
        """One RK4 step of length ``dt`` [s] with the torque held (zero-order hold);
        ``base0``, ``base_mid``, ``base1`` are the base motion at t, t + dt/2, t + dt."""
        return kernels.rk4_step((float(x[0]), float(x[1]), float(x[2]), float(x[3])), float(tau[0]), float(tau[1]),
                                _base(base0), _base(base_mid), _base(base1), float(dt), self.kernel_params)


def _base(base: TurretBase) -> tuple[float, ...]:
    """The kernels' 9-tuple (ω_t, α_t, f_t) of a base, as floats."""
    return tuple(map(float, base))


def check_state(x: Sequence[float]) -> tuple[float, float, float, float]:
    arr = np.asarray(x, dtype=float)
    if arr.shape != (4,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"gimbal state must be 4 finite numbers (ψm, θm, ψ̇m, θ̇m), got {x}")
    return tuple(float(v) for v in arr)
