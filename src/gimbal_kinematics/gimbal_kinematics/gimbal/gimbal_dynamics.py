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

from .gimbal_params import GimbalParams, inertia_matrix
from .turret_base import TurretBase


def _inertia_about_pivot(mass: float, inertia: tuple, cg: tuple) -> tuple[float, ...]:
    r = np.asarray(cg, dtype=float)
    j = inertia_matrix(inertia) + mass * (float(r @ r) * np.eye(3) - np.outer(r, r))
    return tuple(float(v) for v in (j[0, 0], j[1, 1], j[2, 2], j[0, 1], j[0, 2], j[1, 2]))


class TwoAxisGimbal:
    """Forward/inverse dynamics and RK4 step of the two-axis gimbal (module docstring).

    Stateless apart from the parameters: every method takes the state explicitly, so a
    controller can evaluate ``derivative`` at any point (e.g. at rest for linearisation).
    """

    def __init__(self, params: GimbalParams | None = None) -> None:
        self.params = params if params is not None else GimbalParams()
        p = self.params
        self._Ja = _inertia_about_pivot(p.outer_mass_kg, p.outer_inertia_kg_m2, p.outer_cg_m)
        self._Jm = _inertia_about_pivot(p.inner_mass_kg, p.inner_inertia_kg_m2, p.inner_cg_m)
        self._mra = tuple(p.outer_mass_kg * float(v) for v in p.outer_cg_m)
        self._mrm = tuple(p.inner_mass_kg * float(v) for v in p.inner_cg_m)
        self._ba = p.azimuth_friction_nm_s_rad
        self._be = p.elevation_friction_nm_s_rad
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
        maa, mae, mee = self._mass(math.cos(theta_m), math.sin(theta_m))
        return np.array([[maa, mae], [mae, mee]])

    def _mass(self, c: float, s: float) -> tuple[float, float, float]:
        xx, yy, zz, xy, xz, yz = self._Jm
        maa = self._Ja[2] + s * s * xx - 2.0 * s * c * xz + c * c * zz
        return maa, -s * xy + c * yz, yy

    def _bias(self, psi: float, c: float, s: float, psid: float, thd: float,
              base: TurretBase) -> tuple[float, float]:
        """Joint torques (h_a, h_e) needed for q̈ = 0, friction included.

        Hot path (four times per RK4 step): the pivot moments N = Ĵ α + ω × (Ĵ ω) + m r × f
        of the inner body (all three components) and of the outer body (its e3 component
        only) are written out in scalars.
        """
        wt1, wt2, wt3, at1, at2, at3, ft1, ft2, ft3 = base
        cp, sp = math.cos(psi), math.sin(psi)
        u1 = cp * wt1 + sp * wt2
        u2 = -sp * wt1 + cp * wt2
        wa3 = wt3 + psid
        aa1 = cp * at1 + sp * at2 + psid * u2
        aa2 = -sp * at1 + cp * at2 - psid * u1
        fa1 = cp * ft1 + sp * ft2
        fa2 = -sp * ft1 + cp * ft2
        wm1 = c * u1 - s * wa3
        wm3 = s * u1 + c * wa3
        # inner body m: ω, α, f in m
        w1, w2, w3 = wm1, u2 + thd, wm3
        a1, a2, a3 = c * aa1 - s * at3 - thd * wm3, aa2, s * aa1 + c * at3 + thd * wm1
        f1, f2, f3 = c * fa1 - s * ft3, fa2, s * fa1 + c * ft3
        xx, yy, zz, xy, xz, yz = self._Jm
        mx, my, mz = self._mrm
        h1 = xx * w1 + xy * w2 + xz * w3
        h2 = xy * w1 + yy * w2 + yz * w3
        h3 = xz * w1 + yz * w2 + zz * w3
        nm1 = xx * a1 + xy * a2 + xz * a3 + w2 * h3 - w3 * h2 + my * f3 - mz * f2
        nm2 = xy * a1 + yy * a2 + yz * a3 + w3 * h1 - w1 * h3 + mz * f1 - mx * f3
        nm3 = xz * a1 + yz * a2 + zz * a3 + w1 * h2 - w2 * h1 + mx * f2 - my * f1
        # outer body a: ω = (u1, u2, wa3), α = (aa1, aa2, at3), f = (fa1, fa2, ft3); e3 only
        xx, yy, zz, xy, xz, yz = self._Ja
        mx, my, _ = self._mra
        h1 = xx * u1 + xy * u2 + xz * wa3
        h2 = xy * u1 + yy * u2 + yz * wa3
        na3 = xz * aa1 + yz * aa2 + zz * at3 + u1 * h2 - u2 * h1 + mx * fa2 - my * fa1
        return na3 - s * nm1 + c * nm3 + self._ba * psid, nm2 + self._be * thd

    # ------------------------------------------------------------------ public dynamics
    def bias_torques(self, x: Sequence[float], base: TurretBase) -> tuple[float, float]:
        """h(x, base) [N·m]: Coriolis, centrifugal, base-motion, gravity and friction terms."""
        th = x[1]
        return self._bias(x[0], math.cos(th), math.sin(th), x[2], x[3], base)

    def inverse_dynamics(self, x: Sequence[float], qdd: Sequence[float], base: TurretBase) -> tuple[float, float]:
        """Joint torques (τ_a, τ_e) [N·m] that produce joint accelerations ``qdd`` [rad/s²]
        at state ``x`` on ``base`` (no saturation): τ = M q̈ + h."""
        c, s = math.cos(x[1]), math.sin(x[1])
        maa, mae, mee = self._mass(c, s)
        ha, he = self._bias(x[0], c, s, x[2], x[3], base)
        return maa * qdd[0] + mae * qdd[1] + ha, mae * qdd[0] + mee * qdd[1] + he

    def accelerations(self, x: Sequence[float], tau: Sequence[float], base: TurretBase) -> tuple[float, float]:
        """(ψ̈m, θ̈m) [rad/s²] for applied (already saturated) torques ``tau`` [N·m]."""
        psi, th, psid, thd = x
        c, s = math.cos(th), math.sin(th)
        maa, mae, mee = self._mass(c, s)
        ha, he = self._bias(psi, c, s, psid, thd, base)
        ra, re = tau[0] - ha, tau[1] - he
        inv_det = 1.0 / (maa * mee - mae * mae)
        return (mee * ra - mae * re) * inv_det, (maa * re - mae * ra) * inv_det

    def derivative(self, x: Sequence[float], tau: Sequence[float], base: TurretBase) -> tuple[float, float, float, float]:
        """Continuous-time ẋ = f(x, τ, base); ``tau`` is the commanded torque [N·m], clipped
        to the limits. Returns (ψ̇m, θ̇m, ψ̈m, θ̈m) as floats (``np.asarray`` for an array)."""
        qa, qe = self.accelerations(x, self.saturate(tau), base)
        return x[2], x[3], qa, qe

    def step(self, x: Sequence[float], tau: Sequence[float], base0: TurretBase, base_mid: TurretBase,
             base1: TurretBase, dt: float) -> tuple[float, float, float, float]:
        """One RK4 step of length ``dt`` [s] with the torque held (zero-order hold);
        ``base0``, ``base_mid``, ``base1`` are the base motion at t, t + dt/2, t + dt."""
        tau = self.saturate(tau)
        acc = self.accelerations
        x0, x1, x2, x3 = x
        h = 0.5 * dt
        a1, b1 = acc(x, tau, base0)
        y0, y1, y2, y3 = x0 + h * x2, x1 + h * x3, x2 + h * a1, x3 + h * b1
        a2, b2 = acc((y0, y1, y2, y3), tau, base_mid)
        z0, z1, z2, z3 = x0 + h * y2, x1 + h * y3, x2 + h * a2, x3 + h * b2
        a3, b3 = acc((z0, z1, z2, z3), tau, base_mid)
        v0, v1, v2, v3 = x0 + dt * z2, x1 + dt * z3, x2 + dt * a3, x3 + dt * b3
        a4, b4 = acc((v0, v1, v2, v3), tau, base1)
        w = dt / 6.0
        return (x0 + w * (x2 + 2.0 * y2 + 2.0 * z2 + v2), x1 + w * (x3 + 2.0 * y3 + 2.0 * z3 + v3),
                x2 + w * (a1 + 2.0 * a2 + 2.0 * a3 + a4), x3 + w * (b1 + 2.0 * b2 + 2.0 * b3 + b4))


def check_state(x: Sequence[float]) -> tuple[float, float, float, float]:
    arr = np.asarray(x, dtype=float)
    if arr.shape != (4,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"gimbal state must be 4 finite numbers (ψm, θm, ψ̇m, θ̇m), got {x}")
    return tuple(float(v) for v in arr)
