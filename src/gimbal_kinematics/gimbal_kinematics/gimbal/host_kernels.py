"""Compiled per-sample kernel of the host's motion (numba ``njit``): a plain function over
floats, no state. :func:`.host_state.host_state_from_euler` and the motion profiles' sample
kernel both call :func:`host_fields`, so every host sample is computed by the same code."""
from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def host_fields(t: float, phi: float, theta: float, psi: float, dphi: float, dtheta: float, dpsi: float,
                ddphi: float, ddtheta: float, ddpsi: float, psi_t: float, psi_t_dot: float, psi_t_ddot: float,
                ax: float, ay: float, az: float) -> tuple:
    """The 22 fields of a :class:`.host_state.HostState`, in its order, from the 3-2-1 Euler
    angles and their first and second derivatives, the turret (ψt, ψ̇t, ψ̈t) and the pivot
    acceleration in b. Body rates ω_nb^b = E(φ, θ) ė::

        p = φ̇ − sθ ψ̇,   q = cφ θ̇ + sφ cθ ψ̇,   r = −sφ θ̇ + cφ cθ ψ̇

    and α_nb^b their time derivatives (each sine and cosine contributes its own rate term)."""
    cf, sf = math.cos(phi), math.sin(phi)
    ct, st = math.cos(theta), math.sin(theta)
    p = dphi - st * dpsi
    q = cf * dtheta + sf * ct * dpsi
    r = -sf * dtheta + cf * ct * dpsi
    p_dot = ddphi - ct * dtheta * dpsi - st * ddpsi
    q_dot = (
        -sf * dphi * dtheta + cf * ddtheta
        + (cf * dphi * ct - sf * st * dtheta) * dpsi + sf * ct * ddpsi
    )
    r_dot = (
        -cf * dphi * dtheta - sf * ddtheta
        - (sf * dphi * ct + cf * st * dtheta) * dpsi + cf * ct * ddpsi
    )
    return (t, phi, theta, psi, dphi, dtheta, dpsi, ddphi, ddtheta, ddpsi, p, q, r, p_dot, q_dot, r_dot,
            psi_t, psi_t_dot, psi_t_ddot, ax, ay, az)


@njit(cache=True)
def inertial_rates(p: float, q: float, r: float, p_dot: float, q_dot: float, r_dot: float, yaw: float,
                   x: float, y: float, z: float, cf: float, sf: float, ct: float, st: float) -> tuple:
    """(ω_ib^b, α_ib^b) [rad/s, rad/s²] from the host's ω_nb^b = (p, q, r), α_nb^b and the
    NED frame's constant inertial rate ω_in^n = (x, y, z), with cf, sf, ct, st the cos/sin
    of roll and pitch: ω_ib^b = ω_nb^b + C_bn ω_in^n, α_ib^b = α_nb^b − ω_nb^b × C_bn ω_in^n
    (C_bn = rot1(φ) rot2(θ) rot3(ψ)); with ω_in^n = 0 exactly ω_nb^b and α_nb^b."""
    if x == 0.0 and y == 0.0 and z == 0.0:
        return p, q, r, p_dot, q_dot, r_dot
    cy, sy = math.cos(yaw), math.sin(yaw)
    x1 = cy * x + sy * y
    y1 = -sy * x + cy * y
    e1 = ct * x1 - st * z
    z2 = st * x1 + ct * z
    e2, e3 = cf * y1 + sf * z2, -sf * y1 + cf * z2
    return (p + e1, q + e2, r + e3, p_dot - (q * e3 - r * e2), q_dot - (r * e1 - p * e3), r_dot - (p * e2 - q * e1))


@njit(cache=True)
def turret_base(host: tuple, g: float, wx: float, wy: float, wz: float) -> tuple:
    """The turret's base motion (ω_t, α_t, f_t) as 9 floats from a host sample's 22 fields
    (:func:`host_fields` order), gravity g [m/s²] and ω_in^n: the host's inertial rates
    turned by the turret angle ψt, plus ψ̇t, ψ̈t about z, and f_b = a_b − C_bn (0, 0, g)."""
    roll, pitch = host[1], host[2]
    cf, sf = math.cos(roll), math.sin(roll)
    ct, st = math.cos(pitch), math.sin(pitch)
    w1, w2, w3, a1, a2, a3 = inertial_rates(host[10], host[11], host[12], host[13], host[14], host[15], host[3],
                                            wx, wy, wz, cf, sf, ct, st)
    f1 = host[19] + g * st
    f2 = host[20] - g * sf * ct
    f3 = host[21] - g * cf * ct
    c, s = math.cos(host[16]), math.sin(host[16])
    d, dd = host[17], host[18]
    u1 = c * w1 + s * w2
    u2 = -s * w1 + c * w2
    return (u1, u2, w3 + d, c * a1 + s * a2 + d * u2, -s * a1 + c * a2 - d * u1, a3 + dd,
            c * f1 + s * f2, -s * f1 + c * f2, f3)
