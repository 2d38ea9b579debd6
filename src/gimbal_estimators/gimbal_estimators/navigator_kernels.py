"""Compiled per-sample kernels of the platform navigator (numba ``njit``): plain functions
of floats. :class:`.platform_navigator.PlatformNavigator` holds the state (L, λ, h, v_NED,
δa, ...) in a vector and calls :func:`navigator_step` per sample, which calls
:func:`integrate` and :func:`command_rate` (the compiled engine calls it too); the WGS-84 radii and gravity are
:mod:`gimbal_kinematics.maths.earth_kernels`'. The maths is the navigator's module docstring:

    v_N⁺ = v_N + Δt (f_N − (w_E v_D − w_D v_E)),   v_E⁺ = v_E + Δt (f_E − (w_D v_N − w_N v_D)),
    w = 2 ω_ie^n + ω_en^n,   v_U⁺ = v_U + Δt (a_U − k2 e − δa),   δa⁺ = δa + Δt k3 e,
    h⁺ = h + Δt (½(v_U⁺ + v_U) − k1 e),   L⁺ = L + Δt ½(v_N + v_N⁺)/R_M,
    λ⁺ = λ + Δt ½(v_E + v_E⁺)/(R_N cos L)   (wrapped to (−π, π]),   e = h − h_ref
"""
from __future__ import annotations

import math

from numba import njit

from gimbal_kinematics.maths.earth_kernels import meridian_radius, normal_gravity, prime_vertical_radius
from gimbal_kinematics.maths.wgs84 import OMEGA_IE


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


# -- one navigator sample over state and parameter vectors --------------------------------------
(N_LAT, N_LON, N_H, N_VN, N_VE, N_VD, N_DA, N_PSI_LAST, N_ACCEPTED, N_CMD_N, N_CMD_E, N_CMD_D, N_PSI,
 N_TORQUING) = range(14)
N_STATE = 14
(Q_BIAS_X, Q_BIAS_Y, Q_BIAS_Z, Q_HEADING, Q_TORQUE_OUT_S, Q_K1, Q_K2, Q_K3, Q_H_REF, Q_NORTH_DRIFT, Q_EX, Q_EY,
 Q_EZ, Q_TORQUE_N, Q_TORQUE_E, Q_TORQUE_D) = range(16)
N_PARAMS = 16


@njit(cache=True)
def navigator_step(s, q, first: bool, dt: float, elapsed: float, fx: float, fy: float, fz: float,
                   theta: float) -> None:
    """One accepted sample: the specific force f_s [m/s²] less the hand-off bias, resolved
    through ψ̂ = θ + heading, integrated over the ``dt`` [s] since the last sample (none on
    the ``first``; :func:`integrate`), and the command rate ω_c^n (:func:`command_rate`,
    with ε̂_s resolved at ψ̂ + ½ Δψ̂, plus the torquing pulse while the ``elapsed`` time since
    the first sample is under T) into ``s[N_CMD_N:N_CMD_D+1]``. The state ``s``
    (:data:`N_STATE`) and parameters ``q`` (:data:`N_PARAMS`) are what
    :class:`.platform_navigator.PlatformNavigator` holds; the caller keeps the stamps (integer
    ns, exact also for epoch stamps) and passes their differences in seconds."""
    s[N_ACCEPTED] += 1.0
    fx, fy, fz = fx - q[Q_BIAS_X], fy - q[Q_BIAS_Y], fz - q[Q_BIAS_Z]
    psi = theta + q[Q_HEADING]
    c, sn = math.cos(psi), math.sin(psi)
    psi_c = psi
    if not first:
        (s[N_LAT], s[N_LON], s[N_H], s[N_VN], s[N_VE], s[N_VD], s[N_DA]) = integrate(
            s[N_LAT], s[N_LON], s[N_H], s[N_VN], s[N_VE], s[N_VD], s[N_DA], dt, c * fx - sn * fy, sn * fx + c * fy,
            fz, q[Q_K1], q[Q_K2], q[Q_K3], q[Q_H_REF])
        psi_c += 0.5 * _remainder_tau(psi - s[N_PSI_LAST])
    s[N_PSI_LAST] = psi
    torquing = elapsed < q[Q_TORQUE_OUT_S]
    wn, we, wd = command_rate(s[N_LAT], s[N_H], s[N_VN], s[N_VE], math.cos(psi_c), math.sin(psi_c),
                              q[Q_NORTH_DRIFT], q[Q_EX], q[Q_EY], q[Q_EZ])
    if torquing:
        wn, we, wd = wn + q[Q_TORQUE_N], we + q[Q_TORQUE_E], wd + q[Q_TORQUE_D]
    s[N_CMD_N], s[N_CMD_E], s[N_CMD_D] = wn, we, wd
    s[N_PSI], s[N_TORQUING] = psi, 1.0 if torquing else 0.0
