"""Compiled per-sample kernels of the two-axis gimbal's rigid-body dynamics (numba ``njit``).

A kernel is a plain function over floats, tuples of floats and float64 arrays, with no state
of its own. :class:`.gimbal_dynamics.TwoAxisGimbal` holds the parameter vector and calls
these; the plant (``vehicle_dynamics``' core, the engine's plant) and the controllers' inverse
dynamics therefore compute with the same code. The maths is the module docstring of
:mod:`.gimbal_dynamics`: M(θm) q̈ + h(x, base) = τ, RK4 with τ held and the base motion
sampled at t, t + dt/2, t + dt.

Parameter vector ``p`` (float64, :data:`N_PARAMS`): Ĵ_a (xx, yy, zz, xy, xz, yz) about the
pivot, Ĵ_m likewise, m_a r_a (3), m_m r_m (3), b_a, b_e [N·m·s/rad], τ limits (a, e) [N·m]
(offsets ``P_*``). A base is the 9-tuple (ω_t, α_t, f_t) of a
:class:`.turret_base.TurretBase`. The arithmetic keeps the order of the scalar Python it
replaced, so results agree to the last bits.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

P_JA, P_JM, P_MRA, P_MRM, P_BA, P_BE, P_LIM_A, P_LIM_E = 0, 6, 12, 15, 18, 19, 20, 21
N_PARAMS = 22


@njit(cache=True)
def saturate(ta: float, te: float, p: np.ndarray) -> tuple:
    """(τ_a, τ_e) clipped to their limits [N·m]."""
    la, le = p[P_LIM_A], p[P_LIM_E]
    return (la if ta > la else -la if ta < -la else ta, le if te > le else -le if te < -le else te)


@njit(cache=True)
def mass(c: float, s: float, p: np.ndarray) -> tuple:
    """(M_aa, M_ae, M_ee) of M(θm) at c, s = cos θm, sin θm."""
    xx, zz, xy, xz, yz, yy = p[P_JM], p[P_JM + 2], p[P_JM + 3], p[P_JM + 4], p[P_JM + 5], p[P_JM + 1]
    maa = p[P_JA + 2] + s * s * xx - 2.0 * s * c * xz + c * c * zz
    return maa, -s * xy + c * yz, yy


@njit(cache=True)
def bias(psi: float, c: float, s: float, psid: float, thd: float, base: tuple, p: np.ndarray) -> tuple:
    """Joint torques (h_a, h_e) for q̈ = 0, friction included: the pivot moments
    N = Ĵ α + ω × (Ĵ ω) + m r × f of the inner body (all of it) and the outer body (e3)."""
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
    w1, w2, w3 = wm1, u2 + thd, wm3
    a1, a2, a3 = c * aa1 - s * at3 - thd * wm3, aa2, s * aa1 + c * at3 + thd * wm1
    f1, f2, f3 = c * fa1 - s * ft3, fa2, s * fa1 + c * ft3
    xx, yy, zz, xy, xz, yz = p[P_JM], p[P_JM + 1], p[P_JM + 2], p[P_JM + 3], p[P_JM + 4], p[P_JM + 5]
    mx, my, mz = p[P_MRM], p[P_MRM + 1], p[P_MRM + 2]
    h1 = xx * w1 + xy * w2 + xz * w3
    h2 = xy * w1 + yy * w2 + yz * w3
    h3 = xz * w1 + yz * w2 + zz * w3
    nm1 = xx * a1 + xy * a2 + xz * a3 + w2 * h3 - w3 * h2 + my * f3 - mz * f2
    nm2 = xy * a1 + yy * a2 + yz * a3 + w3 * h1 - w1 * h3 + mz * f1 - mx * f3
    nm3 = xz * a1 + yz * a2 + zz * a3 + w1 * h2 - w2 * h1 + mx * f2 - my * f1
    xx, yy, zz, xy, xz, yz = p[P_JA], p[P_JA + 1], p[P_JA + 2], p[P_JA + 3], p[P_JA + 4], p[P_JA + 5]
    mx, my = p[P_MRA], p[P_MRA + 1]
    h1 = xx * u1 + xy * u2 + xz * wa3
    h2 = xy * u1 + yy * u2 + yz * wa3
    na3 = xz * aa1 + yz * aa2 + zz * at3 + u1 * h2 - u2 * h1 + mx * fa2 - my * fa1
    return na3 - s * nm1 + c * nm3 + p[P_BA] * psid, nm2 + p[P_BE] * thd


@njit(cache=True)
def mass_and_bias(psi: float, th: float, psid: float, thd: float, base: tuple, p: np.ndarray) -> tuple:
    """(M_aa, M_ae, M_ee, h_a, h_e): the mass matrix and the bias torques at the state."""
    c, s = math.cos(th), math.sin(th)
    maa, mae, mee = mass(c, s, p)
    ha, he = bias(psi, c, s, psid, thd, base, p)
    return maa, mae, mee, ha, he


@njit(cache=True)
def accelerations(psi: float, th: float, psid: float, thd: float, ta: float, te: float, base: tuple,
                  p: np.ndarray) -> tuple:
    """(ψ̈m, θ̈m) = M⁻¹ (τ − h) for applied (saturated) torques (τ_a, τ_e)."""
    maa, mae, mee, ha, he = mass_and_bias(psi, th, psid, thd, base, p)
    ra, re = ta - ha, te - he
    inv_det = 1.0 / (maa * mee - mae * mae)
    return (mee * ra - mae * re) * inv_det, (maa * re - mae * ra) * inv_det


@njit(cache=True)
def inverse_dynamics(psi: float, th: float, psid: float, thd: float, qdda: float, qdde: float, base: tuple,
                     p: np.ndarray) -> tuple:
    """τ = M q̈ + h (no saturation) [N·m]."""
    maa, mae, mee, ha, he = mass_and_bias(psi, th, psid, thd, base, p)
    return maa * qdda + mae * qdde + ha, mae * qdda + mee * qdde + he


@njit(cache=True)
def rk4_step(x: tuple, ta: float, te: float, base0: tuple, base_mid: tuple, base1: tuple, dt: float,
             p: np.ndarray) -> tuple:
    """x(t + dt) from x = (ψm, θm, ψ̇m, θ̇m) by one classical RK4 step, (τ_a, τ_e) saturated
    and held, the base at t, t + dt/2, t + dt."""
    ta, te = saturate(ta, te, p)
    x0, x1, x2, x3 = x
    h = 0.5 * dt
    a1, b1 = accelerations(x0, x1, x2, x3, ta, te, base0, p)
    y0, y1, y2, y3 = x0 + h * x2, x1 + h * x3, x2 + h * a1, x3 + h * b1
    a2, b2 = accelerations(y0, y1, y2, y3, ta, te, base_mid, p)
    z0, z1, z2, z3 = x0 + h * y2, x1 + h * y3, x2 + h * a2, x3 + h * b2
    a3, b3 = accelerations(z0, z1, z2, z3, ta, te, base_mid, p)
    v0, v1, v2, v3 = x0 + dt * z2, x1 + dt * z3, x2 + dt * a3, x3 + dt * b3
    a4, b4 = accelerations(v0, v1, v2, v3, ta, te, base1, p)
    w = dt / 6.0
    return (x0 + w * (x2 + 2.0 * y2 + 2.0 * z2 + v2), x1 + w * (x3 + 2.0 * y3 + 2.0 * z3 + v3),
            x2 + w * (a1 + 2.0 * a2 + 2.0 * a3 + a4), x3 + w * (b1 + 2.0 * b2 + 2.0 * b3 + b4))
