"""Compiled per-sample kernels of the four-gimbal platform's geometry (numba ``njit``).

Plain functions over floats and float64 arrays with no state; the vehicle core's truth of
each step calls :func:`platform_truth`, :mod:`.four_gimbal` calls :func:`dcm_bs`,
:func:`platform_rate_s` and :func:`inner_signals` (the closed forms are documented there);
the compiled platform chain calls :func:`outer_member_rates` (a moving base's rates into the
gimbal loops; :func:`.four_gimbal.outer_member_rates`, to the bit).
The matrix product C_ns = C_nb C_bs is summed in index order, so results may differ from
numpy's ``@`` in the last bit.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .rotation_kernels import dcm_to_quat, euler321_to_dcm


@njit(cache=True)
def dcm_bs(a: float, q: float, p: float, r: float) -> np.ndarray:
    """C_bs (platform to base) of the gimbal angles (θ_a, θ_q, θ_p, θ_r) [rad], (3, 3):
    C_pb = rot2(p) rot1(r) has rows m0 = (cp, sp sr, −sp cr), m1 = (0, cr, sr),
    m2 = (sp, −cp sr, cp cr); C_qb = rot1(q) C_pb has rows m0, n1, n2; C_sb = rot3(a) C_qb
    has rows k0, k1, n2; C_bs is its transpose."""
    ca, sa = math.cos(a), math.sin(a)
    cq, sq = math.cos(q), math.sin(q)
    cp, sp = math.cos(p), math.sin(p)
    cr, sr = math.cos(r), math.sin(r)
    n10, n11, n12 = sq * sp, cq * cr - sq * cp * sr, cq * sr + sq * cp * cr
    n20, n21, n22 = cq * sp, -sq * cr - cq * cp * sr, -sq * sr + cq * cp * cr
    m01, m02 = sp * sr, -sp * cr
    C = np.empty((3, 3))
    C[0, 0], C[0, 1], C[0, 2] = ca * cp + sa * n10, -sa * cp + ca * n10, n20
    C[1, 0], C[1, 1], C[1, 2] = ca * m01 + sa * n11, -sa * m01 + ca * n11, n21
    C[2, 0], C[2, 1], C[2, 2] = ca * m02 + sa * n12, -sa * m02 + ca * n12, n22
    return C


@njit(cache=True)
def platform_rate_s(omega_b: np.ndarray, angles: np.ndarray, rates: np.ndarray) -> tuple:
    """ω_s = C_sb ω_b + C_sr θ̇_r e1 + C_sp θ̇_p e2 + C_sq θ̇_q e1 + θ̇_a e3 [rad/s], as the
    outer-to-inner recursion of rotations about x (r), y (p), x (q), z (a)."""
    x, y, z = omega_b[0], omega_b[1], omega_b[2]
    c, s = math.cos(angles[3]), math.sin(angles[3])
    x, y, z = x, c * y + s * z, -s * y + c * z
    c, s = math.cos(angles[2]), math.sin(angles[2])
    x = x + rates[3]
    x, y, z = c * x - s * z, y, s * x + c * z
    c, s = math.cos(angles[1]), math.sin(angles[1])
    y = y + rates[2]
    x, y, z = x, c * y + s * z, -s * y + c * z
    c, s = math.cos(angles[0]), math.sin(angles[0])
    x = x + rates[1]
    x, y = c * x + s * y, -s * x + c * y
    return x, y, z + rates[0]


@njit(cache=True)
def platform_truth(euler: np.ndarray, angles: np.ndarray, rates: np.ndarray, omega_b: np.ndarray,
                   f_b: np.ndarray) -> tuple:
    """The stable element's truth: q_ns (x, y, z, w) of C_ns = C_nb C_bs, its inertial rate
    ω_s [rad/s] and specific force f_s = C_sb f_b [m/s²] (tuples), from the host's Euler
    angles, the gimbal angles/rates (a, q, p, r) and the host's ω_b, f_b."""
    C_bs = dcm_bs(angles[0], angles[1], angles[2], angles[3])
    C_nb = euler321_to_dcm(euler[0], euler[1], euler[2])
    C_ns = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            C_ns[i, j] = C_nb[i, 0] * C_bs[0, j] + C_nb[i, 1] * C_bs[1, j] + C_nb[i, 2] * C_bs[2, j]
    q = dcm_to_quat(C_ns)
    f = (C_bs[0, 0] * f_b[0] + C_bs[1, 0] * f_b[1] + C_bs[2, 0] * f_b[2],
         C_bs[0, 1] * f_b[0] + C_bs[1, 1] * f_b[1] + C_bs[2, 1] * f_b[2],
         C_bs[0, 2] * f_b[0] + C_bs[1, 2] * f_b[1] + C_bs[2, 2] * f_b[2])
    return (q[0], q[1], q[2], q[3]), platform_rate_s(omega_b, angles, rates), f


@njit(cache=True)
def inner_signals(gx: float, gy: float, gz: float, theta_a: float, theta_q: float) -> tuple:
    """(Δθ_qm, Δθ_pm, Δθ_am) of a pickoff (or rate) vector g resolved in s (paper 3 eq. 1):
    v = C_qs g, Δθ_qm = v1, Δθ_pm = v2 / cos θ_q, Δθ_am = v3 + v2 tan θ_q. No lock check."""
    c, s = math.cos(theta_a), -math.sin(theta_a)
    cq = math.cos(theta_q)
    v1, v2, v3 = c * gx + s * gy, -s * gx + c * gy, gz
    return v1, v2 / cq, v3 + v2 * math.sin(theta_q) / cq


@njit(cache=True)
def servo_signals(d0: float, d1: float, d2: float, ex: float, ey: float, ez: float, theta_a: float,
                  theta_q: float, theta_p: float, lock_cos: float) -> tuple:
    """The platform servo's control signals of one tick: the pickoff δ and the rate error e
    resolved onto the inner-roll, pitch and azimuth axes (:func:`inner_signals`) and the
    outer-roll null Δθ_rm = θ_q / cos θ_p. Returns (ok, (q, p, a) of δ, (q, p, a) of e, Δθ_rm);
    ok is False within the lock margin (|cos θ_q| or |cos θ_p| < ``lock_cos``)."""
    cq, cp = math.cos(theta_q), math.cos(theta_p)
    if abs(cq) < lock_cos or abs(cp) < lock_cos:
        return False, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 0.0
    return (True, inner_signals(d0, d1, d2, theta_a, theta_q), inner_signals(ex, ey, ez, theta_a, theta_q),
            theta_q / cp)


@njit(cache=True)
def outer_member_rates(wx: float, wy: float, wz: float, q: float, p: float, r: float,
                       dq: float, dp: float, dr: float) -> tuple:
    """Inertial rate [rad/s] of each joint's outer member about that joint's axis (a, q, p, r)
    from the base rate ω_ib^b (wx, wy, wz), the angles θ_q, θ_p, θ_r and rates θ̇_q, θ̇_p,
    θ̇_r: :func:`.four_gimbal.outer_member_rates` in the same operation order (the base
    about b-x; rot1(θ_r), then θ̇_r about r-x and rot2(θ_p), the pitch gimbal about p-y;
    θ̇_p about p-y and rot1(θ_q), the inner-roll gimbal about q-x and about q-z)."""
    w_r = wx
    c, s = math.cos(r), math.sin(r)
    x, y, z = wx, c * wy + s * wz, -s * wy + c * wz
    w_p = y
    c, s = math.cos(p), math.sin(p)
    x, z = c * (x + dr) - s * z, s * (x + dr) + c * z
    w_q = x
    c, s = math.cos(q), math.sin(q)
    y, z = c * (y + dp) + s * z, -s * (y + dp) + c * z
    return z, w_q, w_p, w_r
