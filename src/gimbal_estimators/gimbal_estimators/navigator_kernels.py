"""Compiled per-sample kernels of the platform navigator (numba ``njit``): plain functions
of floats. :class:`.platform_navigator.PlatformNavigator` holds the state (L, λ, h, v_NED,
δa) and calls :func:`integrate` and :func:`command_rate`; the WGS-84 radii and gravity are
:mod:`gimbal_kinematics.earth_kernels`'. The maths is the navigator's module docstring:

    v_N⁺ = v_N + Δt (f_N − (w_E v_D − w_D v_E)),   v_E⁺ = v_E + Δt (f_E − (w_D v_N − w_N v_D)),
    w = 2 ω_ie^n + ω_en^n,   v_U⁺ = v_U + Δt (a_U − k2 e − δa),   δa⁺ = δa + Δt k3 e,
    h⁺ = h + Δt (½(v_U⁺ + v_U) − k1 e),   L⁺ = L + Δt ½(v_N + v_N⁺)/R_M,
    λ⁺ = λ + Δt ½(v_E + v_E⁺)/(R_N cos L)   (wrapped to (−π, π]),   e = h − h_ref
"""
from __future__ import annotations

import math

from numba import njit

from gimbal_kinematics.earth_kernels import meridian_radius, normal_gravity, prime_vertical_radius
from gimbal_kinematics.wgs84 import OMEGA_IE


@njit(cache=True)
def integrate(lat: float, lon: float, hgt: float, vn: float, ve: float, vd: float, da: float, dt: float,
              f_n: float, f_e: float, f_d: float, k1: float, k2: float, k3: float, h_ref: float) -> tuple:
    """(L, λ, h, v_N, v_E, v_D, δa) after one interval ``dt`` with the specific force
    (f_N, f_E, f_D) [m/s²] (module docstring)."""
    cl, sl = math.cos(lat), math.sin(lat)
    rm = meridian_radius(lat) + hgt
    rn = prime_vertical_radius(lat) + hgt
    wx = 2.0 * OMEGA_IE * cl + ve / rn
    wy = -vn / rm
    wz = -2.0 * OMEGA_IE * sl - ve * sl / (cl * rn)
    vn1 = vn + dt * (f_n - (wy * vd - wz * ve))
    ve1 = ve + dt * (f_e - (wz * vn - wx * vd))
    err = hgt - h_ref
    a_up = -(f_d + normal_gravity(lat, hgt) - (wx * ve - wy * vn))
    vu1 = -vd + dt * (a_up - k2 * err - da)
    da1 = da + dt * k3 * err
    hgt1 = hgt + dt * (0.5 * (vu1 - vd) - k1 * err)
    lat1 = lat + dt * 0.5 * (vn + vn1) / rm
    lon1 = _remainder_tau(lon + dt * 0.5 * (ve + ve1) / (rn * cl))
    return lat1, lon1, hgt1, vn1, ve1, -vu1, da1


@njit(cache=True)
def _remainder_tau(x: float) -> float:
    """IEEE remainder of x by 2π (Python's ``math.remainder(x, math.tau)``): x − n 2π with n
    the nearest integer to x / 2π, ties to even."""
    tau = 2.0 * math.pi
    n = x / tau
    r = math.floor(n)
    f = n - r
    if f > 0.5 or (f == 0.5 and r % 2.0 != 0.0):
        r += 1.0
    return x - r * tau


@njit(cache=True)
def command_rate(lat: float, hgt: float, vn: float, ve: float, c: float, s: float, north_drift: float,
                 ex: float, ey: float, ez: float) -> tuple:
    """ω_c^n = ω_ie^n + ω_en^n − ε̂^n [rad/s], the drift estimate ε̂_s resolved through the
    azimuth (c, s = cos ψ̂, sin ψ̂) plus the north drift estimate."""
    cl, sl = math.cos(lat), math.sin(lat)
    rm = meridian_radius(lat) + hgt
    rn = prime_vertical_radius(lat) + hgt
    wn = OMEGA_IE * cl + ve / rn - (north_drift + c * ex - s * ey)
    we = -vn / rm - (s * ex + c * ey)
    wd = -OMEGA_IE * sl - ve * sl / (cl * rn) - ez
    return wn, we, wd
